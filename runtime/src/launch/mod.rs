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

#[derive(Debug, Deserialize)]
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

/// A node of the graph.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodeDecl {
    /// Instance name, unique in the launch.
    pub name: String,
    /// Which node: `radar`, `association`, `mapper`, `segmenter`, `evaluator`.
    pub kind: String,
    /// Parameters of the node kind (its `Params` fields).
    #[serde(default)]
    pub params: toml::Table,
    /// Run the node only when each named argument has one of the listed values, e.g.
    /// `when = { fidelity = ["spectral", "waveform"] }` (as ROS 2 launch's `IfCondition`).
    #[serde(default)]
    pub when: std::collections::BTreeMap<String, Vec<String>>,
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
}

fn default_respawn_delay_s() -> f64 {
    1.0
}

fn default_max_restarts() -> u32 {
    3
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLaunch {
    launch: Option<Header>,
    #[serde(default)]
    arguments: BTreeMap<String, Argument>,
    #[serde(default)]
    node: Vec<NodeDecl>,
}

/// A launch file with its arguments applied.
#[derive(Debug, Clone)]
pub struct Launch {
    /// The file it came from.
    pub path: PathBuf,
    /// Folder of the file: relative paths in parameters resolve against it.
    pub base_dir: PathBuf,
    /// What it runs.
    pub description: String,
    /// Mode the file asks for.
    pub mode: Mode,
    /// Declared arguments.
    pub declared: BTreeMap<String, Argument>,
    /// Every argument's effective value (defaults overridden by `name:=value`), as typed: a
    /// `path = true` argument's command-line value before it is made absolute, so that a run's
    /// record does not depend on the directory it was started from.
    pub arguments: BTreeMap<String, toml::Value>,
    /// The nodes, parameters substituted.
    pub nodes: Vec<NodeDecl>,
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
}

/// Splits `name:=value`.
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

/// Deepest chain of arguments whose values name other arguments (`a` = "$(var b)", `b` =
/// "$(var c)", ...) that is expanded.
pub const MAX_SUBSTITUTION_DEPTH: usize = 32;

/// Longest string a substitution may produce, in bytes: with references nested, each level can
/// double the text (`a` = "$(var b)$(var b)"), so without a bound 32 levels would ask for 4 GiB.
pub const MAX_SUBSTITUTED_BYTES: usize = 1 << 20;

/// Why a `$(var ...)` could not be expanded.
#[derive(Debug, Clone, PartialEq)]
enum SubstitutionError {
    Undeclared(String),
    Unterminated(String),
    /// The arguments of the cycle, the first repeated at the end.
    Cycle(Vec<String>),
    /// The chain that went past [`MAX_SUBSTITUTION_DEPTH`].
    TooDeep(Vec<String>),
    TooLong,
}

impl std::fmt::Display for SubstitutionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Undeclared(name) => write!(f, "uses undeclared argument {name:?}"),
            Self::Unterminated(text) => write!(f, "unterminated $(var ...) in {text:?}"),
            Self::Cycle(chain) => write!(f, "substitution cycle: {}", chain.join(" -> ")),
            Self::TooDeep(chain) => write!(
                f,
                "substitution nested deeper than {MAX_SUBSTITUTION_DEPTH} arguments: {} -> ...",
                chain.join(" -> ")
            ),
            Self::TooLong => write!(
                f,
                "substitution makes a string longer than {MAX_SUBSTITUTED_BYTES} bytes"
            ),
        }
    }
}

/// `text` with every `$(var NAME)` replaced by the text of `lookup(NAME)`, left to right; the
/// replacements are not scanned again (they come already expanded).
fn expand_text(
    text: &str,
    mut lookup: impl FnMut(&str) -> Result<toml::Value, SubstitutionError>,
) -> Result<String, SubstitutionError> {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find("$(var ") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 6..];
        let end = after
            .find(')')
            .ok_or_else(|| SubstitutionError::Unterminated(text.to_owned()))?;
        match lookup(after[..end].trim())? {
            toml::Value::String(s) => out.push_str(&s),
            other => out.push_str(&other.to_string()),
        }
        if out.len() > MAX_SUBSTITUTED_BYTES {
            return Err(SubstitutionError::TooLong);
        }
        rest = &after[end + 1..];
    }
    out.push_str(rest);
    if out.len() > MAX_SUBSTITUTED_BYTES {
        return Err(SubstitutionError::TooLong);
    }
    Ok(out)
}

/// Every argument's value with the `$(var ...)` in string values expanded (an argument may name
/// others, e.g. `out_dir` = "runs/$(var label)"). Each argument is expanded once (memoised), a
/// cycle is reported with its arguments, and depth and length are bounded
/// ([`MAX_SUBSTITUTION_DEPTH`], [`MAX_SUBSTITUTED_BYTES`]). `Err` names the argument.
fn expand_arguments(
    arguments: &BTreeMap<String, toml::Value>,
) -> Result<BTreeMap<String, toml::Value>, (String, SubstitutionError)> {
    fn expand(
        name: &str,
        arguments: &BTreeMap<String, toml::Value>,
        done: &mut BTreeMap<String, toml::Value>,
        stack: &mut Vec<String>,
    ) -> Result<toml::Value, SubstitutionError> {
        if let Some(value) = done.get(name) {
            return Ok(value.clone());
        }
        if let Some(at) = stack.iter().position(|n| n == name) {
            let mut chain = stack[at..].to_vec();
            chain.push(name.to_owned());
            return Err(SubstitutionError::Cycle(chain));
        }
        if stack.len() >= MAX_SUBSTITUTION_DEPTH {
            return Err(SubstitutionError::TooDeep(stack.clone()));
        }
        let value = arguments
            .get(name)
            .ok_or_else(|| SubstitutionError::Undeclared(name.to_owned()))?;
        let expanded = match value {
            toml::Value::String(text) if text.contains("$(var ") => {
                stack.push(name.to_owned());
                let text = expand_text(text, |inner| expand(inner, arguments, done, stack));
                stack.pop();
                toml::Value::String(text?)
            }
            other => other.clone(),
        };
        done.insert(name.to_owned(), expanded.clone());
        Ok(expanded)
    }
    let mut done = BTreeMap::new();
    for name in arguments.keys() {
        let mut stack = Vec::new();
        expand(name, arguments, &mut done, &mut stack).map_err(|e| (name.clone(), e))?;
    }
    Ok(done)
}

/// Substitutes the (already expanded) `arguments` into a node parameter.
fn substitute(
    value: &mut toml::Value,
    arguments: &BTreeMap<String, toml::Value>,
    path: &Path,
    node: &str,
) -> Result<(), LaunchError> {
    let error = |e: SubstitutionError| LaunchError::Node {
        path: path.to_owned(),
        node: node.to_owned(),
        problem: e.to_string(),
    };
    let lookup = |name: &str| {
        arguments
            .get(name)
            .cloned()
            .ok_or_else(|| SubstitutionError::Undeclared(name.to_owned()))
    };
    match value {
        toml::Value::String(text) => {
            if let Some(name) = text
                .strip_prefix("$(var ")
                .and_then(|t| t.strip_suffix(')'))
            {
                if !name.contains("$(") && !name.contains(')') {
                    *value = lookup(name.trim()).map_err(error)?;
                    return Ok(());
                }
            }
            if text.contains("$(var ") {
                *text = expand_text(text, lookup).map_err(error)?;
            }
            Ok(())
        }
        toml::Value::Array(items) => items
            .iter_mut()
            .try_for_each(|v| substitute(v, arguments, path, node)),
        toml::Value::Table(table) => table
            .iter_mut()
            .try_for_each(|(_, v)| substitute(v, arguments, path, node)),
        _ => Ok(()),
    }
}

impl Launch {
    /// Reads `path` and applies `overrides` (`name:=value` strings).
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
    pub fn parse_in(
        path: &Path,
        text: &str,
        overrides: &[String],
        cwd: Option<&Path>,
    ) -> Result<Launch, LaunchError> {
        let raw: RawLaunch = toml::from_str(text).map_err(|e| LaunchError::Parse {
            path: path.to_owned(),
            message: e.message().to_owned() + &location(text, e.span()),
        })?;
        let header = raw.launch.unwrap_or(Header {
            description: String::new(),
            mode: Mode::default(),
        });
        for (name, argument) in &raw.arguments {
            if argument.path && !argument.default.is_str() {
                return Err(LaunchError::Argument {
                    path: path.to_owned(),
                    name: name.clone(),
                    problem: format!(
                        "path = true needs a string default, got {}",
                        type_name(&argument.default)
                    ),
                });
            }
        }
        let mut arguments: BTreeMap<String, toml::Value> = raw
            .arguments
            .iter()
            .map(|(name, argument)| (name.clone(), argument.default.clone()))
            .collect();
        // What the node parameters receive: `arguments` with relative command-line paths made
        // absolute against the current directory.
        let mut resolved = arguments.clone();
        for text in overrides {
            let (name, value) = parse_assignment(text).ok_or_else(|| LaunchError::Argument {
                path: path.to_owned(),
                name: text.clone(),
                problem: "expected name:=value".into(),
            })?;
            let declared = raw
                .arguments
                .get(&name)
                .ok_or_else(|| LaunchError::Argument {
                    path: path.to_owned(),
                    name: name.clone(),
                    problem: format!(
                        "not declared (declared: {})",
                        if raw.arguments.is_empty() {
                            "none".to_owned()
                        } else {
                            raw.arguments.keys().cloned().collect::<Vec<_>>().join(", ")
                        }
                    ),
                })?;
            let typed =
                typed_like(&declared.default, &value).ok_or_else(|| LaunchError::Argument {
                    path: path.to_owned(),
                    name: name.clone(),
                    problem: format!("{value:?} is not {}", type_name(&declared.default)),
                })?;
            let effective = match &typed {
                toml::Value::String(text) if declared.path && !text.is_empty() => {
                    let given = Path::new(text);
                    if given.is_absolute() {
                        typed.clone()
                    } else {
                        let cwd = cwd.ok_or_else(|| LaunchError::Argument {
                            path: path.to_owned(),
                            name: name.clone(),
                            problem: format!(
                                "{text:?} is relative and the current directory is unknown; \
                                 give an absolute path"
                            ),
                        })?;
                        toml::Value::String(cwd.join(given).display().to_string())
                    }
                }
                _ => typed.clone(),
            };
            resolved.insert(name.clone(), effective);
            arguments.insert(name, typed);
        }
        let mut nodes = raw.node;
        if nodes.is_empty() {
            return Err(LaunchError::Parse {
                path: path.to_owned(),
                message: "no [[node]] declared".into(),
            });
        }
        for (index, node) in nodes.iter().enumerate() {
            if nodes[..index].iter().any(|other| other.name == node.name) {
                return Err(LaunchError::Node {
                    path: path.to_owned(),
                    node: node.name.clone(),
                    problem: "name used twice".into(),
                });
            }
        }
        for node in &nodes {
            if !(node.respawn_delay_s.is_finite() && (0.0..=3600.0).contains(&node.respawn_delay_s))
                || node.max_restarts > 1000
            {
                return Err(LaunchError::Node {
                    path: path.to_owned(),
                    node: node.name.clone(),
                    problem: format!(
                        "respawn_delay_s = {} and max_restarts = {} (allowed: 0 to 3600 s, 0 to 1000)",
                        node.respawn_delay_s, node.max_restarts
                    ),
                });
            }
            for (argument, allowed) in &node.when {
                if !arguments.contains_key(argument) {
                    return Err(LaunchError::Node {
                        path: path.to_owned(),
                        node: node.name.clone(),
                        problem: format!("`when` names undeclared argument {argument:?}"),
                    });
                }
                if allowed.is_empty() {
                    return Err(LaunchError::Node {
                        path: path.to_owned(),
                        node: node.name.clone(),
                        problem: format!("`when.{argument}` lists no value"),
                    });
                }
            }
        }
        nodes.retain(|node| {
            node.when.iter().all(|(argument, allowed)| {
                let value = match &arguments[argument] {
                    toml::Value::String(text) => text.clone(),
                    other => other.to_string(),
                };
                allowed.contains(&value)
            })
        });
        let resolved =
            expand_arguments(&resolved).map_err(|(name, problem)| LaunchError::Argument {
                path: path.to_owned(),
                name,
                problem: problem.to_string(),
            })?;
        for node in &mut nodes {
            let name = node.name.clone();
            for (_, value) in node.params.iter_mut() {
                substitute(value, &resolved, path, &name)?;
            }
        }
        let base_dir = path.parent().map(Path::to_owned).unwrap_or_default();
        Ok(Launch {
            path: path.to_owned(),
            base_dir: if base_dir.as_os_str().is_empty() {
                PathBuf::from(".")
            } else {
                base_dir
            },
            description: header.description,
            mode: header.mode,
            declared: raw.arguments,
            arguments,
            nodes,
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

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = r#"
[launch]
description = "test"
[arguments.angle_std_deg]
default = 1.0
[arguments.label]
default = "run"
[[node]]
name = "radar"
kind = "radar"
[node.params]
angle_std_deg = "$(var angle_std_deg)"
name = "x-$(var label)-y"
"#;

    fn load(overrides: &[&str]) -> Result<Launch, LaunchError> {
        let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
        Launch::parse(Path::new("launch/test.toml"), FILE, &overrides)
    }

    #[test]
    fn defaults_and_overrides_are_substituted_with_their_types() {
        let launch = load(&[]).unwrap();
        assert_eq!(
            launch.nodes[0].params["angle_std_deg"],
            toml::Value::Float(1.0)
        );
        assert_eq!(
            launch.nodes[0].params["name"],
            toml::Value::String("x-run-y".into())
        );
        let launch = load(&["angle_std_deg:=5", "label:=b"]).unwrap();
        assert_eq!(
            launch.nodes[0].params["angle_std_deg"],
            toml::Value::Float(5.0)
        );
        assert_eq!(
            launch.nodes[0].params["name"],
            toml::Value::String("x-b-y".into())
        );
        assert_eq!(launch.base_dir, Path::new("launch"));
    }

    #[test]
    fn bad_arguments_name_the_file_and_the_argument() {
        let error = load(&["angle_std_deg:=abc"]).unwrap_err().to_string();
        assert!(
            error.contains("launch/test.toml")
                && error.contains("angle_std_deg")
                && error.contains("number"),
            "{error}"
        );
        let error = load(&["nope:=1"]).unwrap_err().to_string();
        assert!(
            error.contains("nope") && error.contains("angle_std_deg, label"),
            "{error}"
        );
        let error = load(&["angle_std_deg=1"]).unwrap_err().to_string();
        assert!(error.contains("name:=value"), "{error}");
        assert!(load(&["angle_std_deg:=inf"]).is_err());
    }

    #[test]
    fn path_arguments_resolve_command_line_values_against_the_current_directory() {
        let text = r#"
[arguments.scene]
default = "../config/hall.toml"
path = true
[arguments.label]
default = "out/x.toml"
[[node]]
name = "radar"
kind = "radar"
[node.params]
scene = "$(var scene)"
label = "$(var label)"
"#;
        let cwd = Path::new("/home/user/work");
        let parse = |overrides: &[&str]| {
            let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
            Launch::parse_in(Path::new("launch/l.toml"), text, &overrides, Some(cwd))
        };
        let param =
            |launch: &Launch, key: &str| launch.nodes[0].params[key].as_str().unwrap().to_owned();
        // The default is written in the file: it stays relative, for the launch file's folder.
        let launch = parse(&[]).unwrap();
        assert_eq!(param(&launch, "scene"), "../config/hall.toml");
        assert_eq!(launch.base_dir, Path::new("launch"));
        // Typed on the command line: against the current directory; the record keeps the text.
        let launch = parse(&["scene:=out/s1.toml", "label:=out/y.toml"]).unwrap();
        assert_eq!(param(&launch, "scene"), "/home/user/work/out/s1.toml");
        assert_eq!(launch.arguments["scene"].as_str(), Some("out/s1.toml"));
        // Only `path = true` arguments are paths.
        assert_eq!(param(&launch, "label"), "out/y.toml");
        let launch = parse(&["scene:=/data/s2.toml"]).unwrap();
        assert_eq!(param(&launch, "scene"), "/data/s2.toml");
        // No current directory: a relative path is an error naming the argument, not a guess.
        let error = Launch::parse_in(
            Path::new("l.toml"),
            text,
            &["scene:=s.toml".to_owned()],
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(
            error.contains("argument scene") && error.contains("absolute"),
            "{error}"
        );
        // A path argument needs a string default.
        let bad = text.replace("default = \"../config/hall.toml\"", "default = 3");
        let error = Launch::parse_in(Path::new("l.toml"), &bad, &[], Some(cwd))
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("argument scene") && error.contains("string"),
            "{error}"
        );
    }

    #[test]
    fn when_conditions_select_nodes_by_argument_value() {
        let text = r#"
[arguments.fidelity]
default = "spectral"
[[node]]
name = "radar"
kind = "radar"
[[node]]
name = "estimator"
kind = "estimator"
when = { fidelity = ["spectral", "waveform"] }
"#;
        let names = |overrides: &[&str]| {
            let overrides: Vec<String> = overrides.iter().map(|s| s.to_string()).collect();
            Launch::parse(Path::new("l.toml"), text, &overrides)
                .unwrap()
                .nodes
                .into_iter()
                .map(|n| n.name)
                .collect::<Vec<_>>()
        };
        assert_eq!(names(&[]), ["radar", "estimator"]);
        assert_eq!(names(&["fidelity:=waveform"]), ["radar", "estimator"]);
        assert_eq!(names(&["fidelity:=ideal"]), ["radar"]);
        let bad = text.replace("when = { fidelity", "when = { fidel");
        let error = Launch::parse(Path::new("l.toml"), &bad, &[])
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("node estimator") && error.contains("fidel"),
            "{error}"
        );
    }

    fn substitution(arguments: &[(&str, &str)], param: &str) -> Result<Launch, LaunchError> {
        let mut text = String::new();
        for (name, default) in arguments {
            text.push_str(&format!("[arguments.{name}]\ndefault = {default:?}\n"));
        }
        text.push_str(&format!(
            "[[node]]\nname = \"n\"\nkind = \"k\"\n[node.params]\nx = {param:?}\n"
        ));
        Launch::parse(Path::new("s.toml"), &text, &[])
    }

    #[test]
    fn arguments_may_name_other_arguments() {
        let launch = substitution(
            &[
                ("label", "b"),
                ("out", "runs/$(var label)/x"),
                ("n", "$(var out)"),
            ],
            "$(var n)-$(var label)",
        )
        .unwrap();
        assert_eq!(launch.nodes[0].params["x"].as_str(), Some("runs/b/x-b"));
        // The record keeps the values as typed.
        assert_eq!(
            launch.arguments["out"].as_str(),
            Some("runs/$(var label)/x")
        );
        // A whole-value reference to a string argument that names another.
        let launch = substitution(&[("a", "$(var b)"), ("b", "z")], "$(var a)").unwrap();
        assert_eq!(launch.nodes[0].params["x"].as_str(), Some("z"));
    }

    #[test]
    fn substitution_cycles_are_reported_with_their_arguments() {
        let error = substitution(&[("a", "$(var b)"), ("b", "x$(var a)")], "$(var a)")
            .unwrap_err()
            .to_string();
        assert!(
            error.starts_with("s.toml: argument a: ")
                && error.contains("substitution cycle: a -> b -> a"),
            "{error}"
        );
        let error = substitution(&[("a", "$(var a)")], "y")
            .unwrap_err()
            .to_string();
        assert!(error.contains("substitution cycle: a -> a"), "{error}");
        // A cycle entered through the command line is caught too.
        let text = "[arguments.a]\ndefault = \"1\"\n[arguments.b]\ndefault = \"$(var a)\"\n\
                    [[node]]\nname = \"n\"\nkind = \"k\"\n[node.params]\nx = \"$(var b)\"\n";
        let error = Launch::parse(Path::new("s.toml"), text, &["a:=-$(var b)-".to_owned()])
            .unwrap_err()
            .to_string();
        assert!(error.contains("substitution cycle: a -> b -> a"), "{error}");
    }

    #[test]
    fn substitution_depth_and_length_are_bounded() {
        // A chain longer than the depth bound.
        let names: Vec<String> = (0..=MAX_SUBSTITUTION_DEPTH + 1)
            .map(|i| format!("a{i:02}"))
            .collect();
        let defaults: Vec<String> = (0..names.len())
            .map(|i| match names.get(i + 1) {
                Some(next) => format!("$(var {next})"),
                None => "end".to_owned(),
            })
            .collect();
        let arguments: Vec<(&str, &str)> = names
            .iter()
            .zip(&defaults)
            .map(|(n, d)| (n.as_str(), d.as_str()))
            .collect();
        let error = substitution(&arguments, "$(var a00)")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains(&format!("deeper than {MAX_SUBSTITUTION_DEPTH}")),
            "{error}"
        );
        // A chain within the bound expands.
        let short = &arguments[arguments.len() - MAX_SUBSTITUTION_DEPTH..];
        let launch = substitution(short, &format!("$(var {})", short[0].0)).unwrap();
        assert_eq!(launch.nodes[0].params["x"].as_str(), Some("end"));
        // Doubling at each of 30 levels would make 2^30 copies: refused, quickly.
        let names: Vec<String> = (0..30).map(|i| format!("d{i:02}")).collect();
        let defaults: Vec<String> = (0..30)
            .map(|i| match names.get(i + 1) {
                Some(next) => format!("$(var {next})$(var {next})"),
                None => "xxxxxxxx".to_owned(),
            })
            .collect();
        let arguments: Vec<(&str, &str)> = names
            .iter()
            .zip(&defaults)
            .map(|(n, d)| (n.as_str(), d.as_str()))
            .collect();
        let started = std::time::Instant::now();
        let error = substitution(&arguments, "$(var d00)")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains(&format!("longer than {MAX_SUBSTITUTED_BYTES} bytes")),
            "{error}"
        );
        assert!(started.elapsed().as_secs_f64() < 5.0);
        // An unterminated reference in an argument's value names the argument.
        let error = substitution(&[("a", "$(var b")], "y")
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("argument a") && error.contains("unterminated"),
            "{error}"
        );
    }

    #[test]
    fn respawn_is_declared_per_node_and_its_bounds_are_checked() {
        let text = "[[node]]\nname=\"a\"\nkind=\"mapper\"\nrespawn = true\nrespawn_delay_s = 0.5\n";
        let launch = Launch::parse(Path::new("f.toml"), text, &[]).unwrap();
        let node = &launch.nodes[0];
        assert!(node.respawn);
        assert_eq!((node.respawn_delay_s, node.max_restarts), (0.5, 3));
        let plain = Launch::parse(
            Path::new("f.toml"),
            "[[node]]\nname=\"a\"\nkind=\"b\"\n",
            &[],
        )
        .unwrap();
        assert!(!plain.nodes[0].respawn);
        for bad in [
            "respawn_delay_s = -1.0",
            "respawn_delay_s = 1e19",
            "max_restarts = 5000",
        ] {
            let error = Launch::parse(
                Path::new("f.toml"),
                &format!("[[node]]\nname=\"a\"\nkind=\"b\"\n{bad}\n"),
                &[],
            )
            .unwrap_err()
            .to_string();
            assert!(
                error.contains("node a") && error.contains("allowed: 0 to 3600 s"),
                "{bad}: {error}"
            );
        }
    }

    #[test]
    fn unknown_fields_and_duplicates_are_refused_with_a_line() {
        let error = Launch::parse(
            Path::new("f.toml"),
            "[launch]\nmode = \"in-process\"\nspeed = 3\n[[node]]\nname=\"a\"\nkind=\"b\"\n",
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(
            error.starts_with("f.toml:") && error.contains("speed") && error.contains("line 3"),
            "{error}"
        );
        let error = Launch::parse(
            Path::new("f.toml"),
            "[[node]]\nname=\"a\"\nkind=\"b\"\n[[node]]\nname=\"a\"\nkind=\"c\"\n",
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(
            error.contains("node a") && error.contains("twice"),
            "{error}"
        );
        let error = Launch::parse(
            Path::new("f.toml"),
            "[[node]]\nname=\"a\"\nkind=\"b\"\n[node.params]\nx=\"$(var y)\"\n",
            &[],
        )
        .unwrap_err()
        .to_string();
        assert!(error.contains("undeclared argument \"y\""), "{error}");
    }
}
