//! Launch files: the graph to run, as TOML, with arguments set on the command line as
//! `name:=value` (as ROS 2 launch does).
//!
//! ```toml
//! [launch]
//! description = "Fig. 3 of the paper"
//! mode = "in-process"                    # or "processes"
//!
//! [arguments.angle_std_deg]
//! default = 1.0
//! description = "angle error std Δθ (deg)"
//!
//! [arguments.scene]
//! default = "../config/hall.toml"          # written in the file: against the file's folder
//! description = "scene file"
//! path = true                              # scene:=out/s1.toml: against the current directory
//!
//! [[node]]
//! name = "radar"
//! kind = "radar"
//! [node.params]
//! angle_std_deg = "$(var angle_std_deg)"   # whole value: takes the argument's type
//! scene = "$(var scene)"                  # relative paths: against the launch file's folder
//! ```
//!
//! A string that is exactly `$(var NAME)` becomes the argument's typed value; `$(var NAME)` inside a
//! longer string is replaced by its text. Every error names the file, the field and what is allowed.
//!
//! An argument's own (string) value may name other arguments (`out = "runs/$(var label)"`); they
//! are expanded first, each once. A cycle (`a = "$(var b)"`, `b = "$(var a)"`) is refused as
//! `argument a: substitution cycle: a -> b -> a`, and the expansion is bounded in depth
//! ([`MAX_SUBSTITUTION_DEPTH`]) and in length ([`MAX_SUBSTITUTED_BYTES`]), so no launch file or
//! `name:=value` can make it loop or blow up.
//!
//! Paths: a relative path in a node's parameters resolves against the launch file's folder, so
//! the file works from any directory. An argument declared `path = true` is a file path typed by
//! the user: a relative value given on the command line (`scene:=out/s1.toml`) is made absolute
//! against the current directory, as a shell user expects; its default, written in the file,
//! stays relative and so resolves against the file's folder like every other path there.
//! [`Launch::arguments`] keeps the values as typed (what a run's summary records), the node
//! parameters get the resolved ones.
//!
//! Includes and overrides (docs/launch.md has the full format): `[[include]] file = "x.toml"`
//! adds another launch file's nodes, passing it arguments (its arguments the includer does not
//! set become the includer's), with `[include.params.NODE]` changing its nodes' parameters and
//! `drop` removing nodes; `node.param:=value` on the command line sets one node parameter.
//!
//! Namespaces (several agents running the same nodes): `[[node]] namespace = "agv1"` puts every
//! topic of the node under `/agv1` and names it `agv1/NAME`; `remap = { "/from" = "/to" }` gives
//! one of its topics an absolute name instead ([`crate::remap::Remapped`] applies both when the
//! node is built). `[[include]] namespace = "..."` puts an included file's nodes (and its
//! `[[external]]` topics) under a namespace, nested includes composing outer first, and `repeat
//! = N` (0 to [`MAX_INCLUDE_REPEAT`]) includes it N times, `$(index)` in the include's
//! `namespace`, `arguments` and `params` being the copy's number from 1.
//!
//! `[[external]] topic = "/odom"` (with an optional `when`, as a node's) declares a topic fed
//! from outside the launch: it counts as published when the wiring is checked
//! ([`crate::wiring::check_wiring`]).

mod file;
mod include;
mod overrides;
mod substitute;
#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_include;
#[cfg(test)]
mod tests_namespace;
#[cfg(test)]
mod tests_support;

pub use include::{MAX_INCLUDE_DEPTH, MAX_INCLUDE_REPEAT};
pub use overrides::{parse_param_assignment, ParamAssignment};
pub use substitute::{MAX_SUBSTITUTED_BYTES, MAX_SUBSTITUTION_DEPTH};

use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How the nodes of a launch are run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "kebab-case")]
pub enum Mode {
    /// All nodes composed in one process, wired directly (zenoh only to mirror topics outside).
    #[default]
    InProcess,
    /// One OS process per node, talking over zenoh.
    Processes,
}

impl std::str::FromStr for Mode {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "in-process" => Ok(Mode::InProcess),
            "processes" => Ok(Mode::Processes),
            other => Err(format!(
                "unknown mode {other:?} (allowed: in-process, processes)"
            )),
        }
    }
}

/// `[launch]`: what the file runs and how. Only the top file's counts; an included file's is
/// read (and checked) but not used.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct Header {
    #[serde(default)]
    description: String,
    #[serde(default)]
    mode: Mode,
}

/// A declared argument.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Argument {
    /// Default value; its type (float, integer, boolean, string) is the argument's type.
    pub default: toml::Value,
    /// What it sets, with its unit.
    #[serde(default)]
    pub description: String,
    /// The argument is a file path (string default): a relative value given on the command line
    /// resolves against the current directory, the default against the launch file's folder.
    #[serde(default)]
    pub path: bool,
}

/// `[[external]]`: a topic the launch's nodes take from outside it (a ROS 2 publisher, `nrslam
/// run`, `nrslam bag play`): it counts as published for the wiring check, and an in-process
/// launch feeds it from its zenoh session.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ExternalDecl {
    /// Topic name, e.g. `/odom` (a catalogue topic; checked with the wiring).
    pub topic: String,
    /// Declared only when each named argument has one of the listed values, as a node's `when`.
    #[serde(default)]
    pub when: BTreeMap<String, Vec<String>>,
}

/// A node of the graph.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeDecl {
    /// Instance name, unique in the launch. As written in a file, a plain name (`radar`); once
    /// the launch is expanded, a node under a namespace is named `<namespace>/<name>`
    /// (`agv1/radar`): the name logs, errors, `NAME.param:=value` and `[include.params.NAME]` use.
    pub name: String,
    /// The namespace the node runs in (`agv1`; empty: none): each of its topics that is not
    /// remapped becomes `/<namespace><topic>` (`/agv1/odom`), and its random streams are its own
    /// (`NodeContext::seed_for`). Once the launch is expanded, the full namespace: the including
    /// files' namespaces first (`site/agv1`).
    #[serde(default)]
    pub namespace: String,
    /// Topics renamed: the node's own topic name (`/ground_truth/targets`) → the absolute name it
    /// takes instead of its namespaced one, as ROS 2's `--remap from:=to`. Checked against the
    /// node's topics when it is built ([`crate::remap::Remapped`]).
    #[serde(default)]
    pub remap: BTreeMap<String, String>,
    /// Which node: `radar`, `association`, `mapper`, `segmenter`, `evaluator`.
    pub kind: String,
    /// Parameters of the node kind (its `Params` fields).
    #[serde(default)]
    pub params: toml::Table,
    /// Run the node only when each named argument has one of the listed values, e.g.
    /// `when = { fidelity = ["spectral", "waveform"] }` (as ROS 2 launch's `IfCondition`).
    #[serde(default)]
    pub when: BTreeMap<String, Vec<String>>,
    /// In a processes-mode launch: start the node's process again when it dies (ROS 2 launch's
    /// `respawn`). Only for nodes with inputs: a source would start its stream over.
    #[serde(default)]
    pub respawn: bool,
    /// Seconds to wait before a respawn, 0–3600.
    #[serde(default = "default_respawn_delay_s")]
    pub respawn_delay_s: f64,
    /// Respawns allowed before a death stops the graph, 0–1000.
    #[serde(default = "default_max_restarts")]
    pub max_restarts: u32,
    /// In a processes-mode launch, what the node's death does once it is not (or no more)
    /// respawned: `"stop"` the graph (the default), or `"continue"` without it, the launcher
    /// ending its output streams for it so that the nodes downstream finish what they have (an
    /// agent of a cooperative run that is switched off). An `[[include]]`'s `on_exit` sets it
    /// for every node the include adds.
    #[serde(default)]
    pub on_exit: crate::supervisor::OnExit,
    /// The launch file that declares the node (for an included node, the included file).
    #[serde(skip)]
    pub file: PathBuf,
    /// Folder that relative paths in its parameters resolve against: `file`'s folder.
    #[serde(skip)]
    pub base_dir: PathBuf,
    /// What changed its parameters after `file` set them, in order: an including file's
    /// `[include.params.NAME]`, a command-line `NAME.param:=value`.
    #[serde(skip)]
    pub set_by: Vec<String>,
}

impl NodeDecl {
    /// The name as its file wrote it: [`NodeDecl::name`] without the namespace in front.
    pub fn local_name(&self) -> &str {
        self.name
            .strip_prefix(&self.namespace)
            .and_then(|rest| rest.strip_prefix('/'))
            .filter(|_| !self.namespace.is_empty())
            .unwrap_or(&self.name)
    }

    /// `node NAME`, with where it was declared when that is not `top` (the launch file run) and
    /// what changed its parameters: for errors about its parameters.
    pub fn describe(&self, top: &Path) -> String {
        let mut notes = Vec::new();
        if self.file != top && !self.file.as_os_str().is_empty() {
            notes.push(format!("declared in {}", self.file.display()));
        }
        if !self.set_by.is_empty() {
            notes.push(format!("parameters set by {}", self.set_by.join(", ")));
        }
        if notes.is_empty() {
            format!("node {}", self.name)
        } else {
            format!("node {} ({})", self.name, notes.join("; "))
        }
    }
}

fn default_respawn_delay_s() -> f64 {
    1.0
}

fn default_max_restarts() -> u32 {
    3
}

/// A launch file with its arguments applied.
#[derive(Debug, Clone)]
pub struct Launch {
    /// The file it came from.
    pub path: PathBuf,
    /// Folder of the file: relative paths in its own nodes' parameters resolve against it (an
    /// included node's resolve against [`NodeDecl::base_dir`]).
    pub base_dir: PathBuf,
    /// What it runs.
    pub description: String,
    /// Mode the file asks for.
    pub mode: Mode,
    /// Arguments settable on the command line: the file's own and those of included files it
    /// does not set (re-exported).
    pub declared: BTreeMap<String, Argument>,
    /// Every settable argument's effective value (defaults overridden by `name:=value`), as
    /// typed: a `path = true` argument's command-line value before it is made absolute, so that
    /// a run's record does not depend on the directory it was started from. Each command-line
    /// node-parameter override is recorded too, as `node.param` (the run depends on it).
    pub arguments: BTreeMap<String, toml::Value>,
    /// The nodes, parameters substituted: included files' nodes first, in include order, then
    /// the file's own.
    pub nodes: Vec<NodeDecl>,
    /// Topics fed from outside the launch (`[[external]]` whose `when` holds, included files'
    /// too), each once.
    pub externals: Vec<String>,
}

/// Why a launch file could not be used. The message names the file and the field.
#[derive(Debug, thiserror::Error)]
pub enum LaunchError {
    /// The file could not be read.
    #[error("{path}: cannot read: {source}")]
    Read {
        /// File.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The file is not valid TOML or has an unknown or mistyped field.
    #[error("{path}: {message}")]
    Parse {
        /// File.
        path: PathBuf,
        /// What the parser said, with line and field.
        message: String,
    },
    /// An argument problem (unknown name, wrong type, malformed `name:=value`).
    #[error("{path}: argument {name}: {problem}")]
    Argument {
        /// File.
        path: PathBuf,
        /// Argument name or the malformed text.
        name: String,
        /// What is wrong and what is allowed.
        problem: String,
    },
    /// A node declaration problem.
    #[error("{path}: node {node}: {problem}")]
    Node {
        /// File.
        path: PathBuf,
        /// Node instance name.
        node: String,
        /// What is wrong.
        problem: String,
    },
    /// An `[[include]]` problem: its file, its arguments, the nodes it names, a cycle.
    #[error("{path}: include {file}: {problem}")]
    Include {
        /// The including file.
        path: PathBuf,
        /// The `file` of the include, as written.
        file: String,
        /// What is wrong.
        problem: String,
    },
    /// An error inside an included file, with the include that brought it in.
    #[error("{path}: include {file}: {source}")]
    Included {
        /// The including file.
        path: PathBuf,
        /// The `file` of the include, as written.
        file: String,
        /// The included file's error (naming that file).
        source: Box<LaunchError>,
    },
    /// An `[[external]]` declaration problem.
    #[error("{path}: external {topic}: {problem}")]
    External {
        /// File.
        path: PathBuf,
        /// The topic as written.
        topic: String,
        /// What is wrong.
        problem: String,
    },
    /// A command-line `node.param:=value` that cannot be applied.
    #[error("{path}: {assignment}: {problem}")]
    Override {
        /// The launch file run.
        path: PathBuf,
        /// The assignment as typed.
        assignment: String,
        /// What is wrong.
        problem: String,
    },
}

/// Splits `name:=value` (a launch argument: letters, digits, `_`).
pub fn parse_assignment(text: &str) -> Option<(String, String)> {
    let (name, value) = text.split_once(":=")?;
    let name = name.trim();
    (!name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'))
        .then(|| (name.to_owned(), value.to_owned()))
}

fn type_name(value: &toml::Value) -> &'static str {
    match value {
        toml::Value::Float(_) => "a number",
        toml::Value::Integer(_) => "an integer",
        toml::Value::Boolean(_) => "true or false",
        toml::Value::String(_) => "a string",
        _ => "a value of the default's type",
    }
}

/// Parses `text` as a value of the same type as `default`.
fn typed_like(default: &toml::Value, text: &str) -> Option<toml::Value> {
    match default {
        toml::Value::Float(_) => text
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite())
            .map(toml::Value::Float),
        toml::Value::Integer(_) => text.trim().parse::<i64>().ok().map(toml::Value::Integer),
        toml::Value::Boolean(_) => text.trim().parse::<bool>().ok().map(toml::Value::Boolean),
        toml::Value::String(_) => Some(toml::Value::String(text.to_owned())),
        _ => None,
    }
}

impl Launch {
    /// Reads `path` and applies `overrides` (`name:=value` arguments, `node.param:=value` node
    /// parameters).
    pub fn load(path: &Path, overrides: &[String]) -> Result<Launch, LaunchError> {
        let text = std::fs::read_to_string(path).map_err(|source| LaunchError::Read {
            path: path.to_owned(),
            source,
        })?;
        Self::parse(path, &text, overrides)
    }

    /// Parses launch `text` as if read from `path`; relative command-line values of `path = true`
    /// arguments resolve against the process's current directory.
    pub fn parse(path: &Path, text: &str, overrides: &[String]) -> Result<Launch, LaunchError> {
        let cwd = std::env::current_dir().ok();
        Self::parse_in(path, text, overrides, cwd.as_deref())
    }

    /// As [`Launch::parse`], with the directory that relative command-line values of
    /// `path = true` arguments resolve against given (`None`: unknown, an error if one is needed).
    /// Included files are read from disk, relative to `path`'s folder.
    pub fn parse_in(
        path: &Path,
        text: &str,
        overrides: &[String],
        cwd: Option<&Path>,
    ) -> Result<Launch, LaunchError> {
        let mut given = BTreeMap::new();
        let mut params = Vec::new();
        for assignment in overrides {
            if let Some(param) = parse_param_assignment(assignment) {
                params.push(param);
            } else if let Some((name, value)) = parse_assignment(assignment) {
                given.insert(name, file::Given::command_line(value));
            } else {
                return Err(LaunchError::Argument {
                    path: path.to_owned(),
                    name: assignment.clone(),
                    problem: "expected name:=value (a launch argument) or node.param:=value \
                              (a node parameter)"
                        .into(),
                });
            }
        }
        let expanded = file::expand_file(&file::Ctx { cwd }, path, text, &given, &[])?;
        if let Some(name) = given.keys().find(|n| !expanded.consumed.contains(*n)) {
            let declared: Vec<&str> = expanded.exported.keys().map(String::as_str).collect();
            return Err(LaunchError::Argument {
                path: path.to_owned(),
                name: name.clone(),
                problem: format!(
                    "not declared (declared: {})",
                    if declared.is_empty() {
                        "none".to_owned()
                    } else {
                        declared.join(", ")
                    }
                ),
            });
        }
        if expanded.nodes.is_empty() {
            return Err(LaunchError::Parse {
                path: path.to_owned(),
                message: "no node runs with these arguments (every node's or include's `when` \
                          is false)"
                    .into(),
            });
        }
        let mut nodes = expanded.nodes;
        let mut arguments: BTreeMap<String, toml::Value> = expanded
            .exported
            .iter()
            .map(|(name, e)| (name.clone(), e.value.clone()))
            .collect();
        for param in &params {
            overrides::apply(path, &mut nodes, &expanded.declared_nodes, param)?;
            arguments.insert(param.key(), param.value.clone());
        }
        Ok(Launch {
            path: path.to_owned(),
            base_dir: file::folder_of(path),
            description: expanded.header.description,
            mode: expanded.header.mode,
            declared: expanded
                .exported
                .into_iter()
                .map(|(name, e)| (name, e.argument))
                .collect(),
            arguments,
            nodes,
            externals: expanded.externals,
        })
    }
}

fn location(text: &str, span: Option<std::ops::Range<usize>>) -> String {
    span.map(|span| {
        let line = text[..span.start.min(text.len())].matches('\n').count() + 1;
        format!(" (line {line})")
    })
    .unwrap_or_default()
}
