//! `[[include]]`: another launch file's nodes added to the graph, so a variant of a launch file
//! is the few lines that differ, not a copy that drifts.
//!
//! An included file's argument takes, in order: the value of the include's `arguments` table
//! (which may use the includer's `$(var ...)`); else the includer's argument of the same name
//! (ROS 2 launch's scoping: an included file sees its includer's configuration); else it becomes
//! an argument of the includer (re-exported: settable as `name:=value` on the command line and
//! recorded with the run). `[include.params.NODE]` is merged over that node's parameters (tables
//! key by key, other values replaced) and `drop` removes nodes, e.g. to declare a replacement.
//! Relative paths in an included file keep resolving against its own folder; a relative path
//! passed into it from a file in another folder is made absolute first.

use super::file::{
    check_when, expand_file, join_namespace, when_holds, Ctx, Expanded, Exported, Given, GivenValue,
};
use super::substitute::{substitute, whole_reference};
use super::{Argument, LaunchError};
use serde::Deserialize;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Deepest chain of includes: the file run includes one (depth 1), which includes another
/// (depth 2), and so on up to this.
pub const MAX_INCLUDE_DEPTH: usize = 8;

/// Most copies one `[[include]]` may make with `repeat`: enough for a fleet of agents, few enough
/// that a typo cannot build a graph of thousands of nodes.
pub const MAX_INCLUDE_REPEAT: i64 = 64;

/// What `$(index)` stands for in a copy made by `repeat`.
const INDEX: &str = "$(index)";

/// One `[[include]]`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct IncludeDecl {
    /// The launch file, relative to the including file's folder.
    pub file: String,
    /// Namespace prefixed to every included node's (nested includes compose, outer first).
    #[serde(default)]
    namespace: String,
    /// Include the file this many times (0 to [`MAX_INCLUDE_REPEAT`]; an integer or a
    /// `"$(var NAME)"`); in copy i (from 1), `$(index)` is i in `namespace`, `arguments` and
    /// `params`.
    #[serde(default)]
    pub repeat: Option<toml::Value>,
    /// With `repeat`: leave out the first this many copies (0 to [`MAX_INCLUDE_REPEAT`]; an
    /// integer or a `"$(var NAME)"`), the others keeping their index (`repeat = 3`, `skip_first =
    /// 1`: copies 2 and 3), so that two includes can split one numbering (agv1 with one set of
    /// parameters, agv2 ... agvN with another).
    #[serde(default)]
    skip_first: Option<toml::Value>,
    /// Include only when each named argument (of the includer) has one of the listed values.
    #[serde(default)]
    when: BTreeMap<String, Vec<String>>,
    /// Values for the included file's arguments.
    #[serde(default)]
    arguments: toml::Table,
    /// Per included node: parameters merged over the included file's.
    #[serde(default)]
    params: BTreeMap<String, toml::Table>,
    /// Included nodes not to run.
    #[serde(default)]
    drop: Vec<String>,
    /// `on_exit` of every node the include adds (nested includes' too), e.g. `"continue"` for
    /// an agent's chain, which the graph survives losing ([`super::NodeDecl::on_exit`]).
    #[serde(default)]
    on_exit: Option<crate::supervisor::OnExit>,
    /// Included nodes that are restarted when they die (processes mode): `respawn = true` on
    /// each, e.g. an agent's SLAM, whose restart the fusion node follows. A source cannot be
    /// named (restarted, it would start its stream over; the wiring check refuses it).
    #[serde(default)]
    respawn: Vec<String>,
}

/// The including file, as far as its includes need it.
pub(super) struct Includer<'a> {
    pub path: &'a Path,
    pub dir: &'a Path,
    pub declared: &'a BTreeMap<String, Argument>,
    /// Its arguments as typed (what `when` compares).
    pub arguments: &'a BTreeMap<String, toml::Value>,
    /// Its arguments resolved and expanded (what is substituted and passed down).
    pub resolved: &'a BTreeMap<String, toml::Value>,
    /// What it was given (passed on to its includes for arguments it does not declare).
    pub given: &'a BTreeMap<String, Given>,
    /// The files from the one run down to this one.
    pub chain: &'a [PathBuf],
}

/// Expands `decl` of `includer`: one expansion per copy (one without `repeat`), none when its
/// `when` does not hold.
pub(super) fn expand(
    ctx: &Ctx,
    includer: &Includer,
    decl: &IncludeDecl,
) -> Result<Vec<Expanded>, LaunchError> {
    let error = |problem: String| LaunchError::Include {
        path: includer.path.to_owned(),
        file: decl.file.clone(),
        problem,
    };
    check_when(&decl.when, includer.arguments).map_err(error)?;
    if decl.file.trim().is_empty() {
        return Err(error("`file` is empty".into()));
    }
    let path = includer.dir.join(&decl.file);
    if !when_holds(&decl.when, includer.arguments) {
        // Not included with these arguments; a missing file is still reported now.
        return match path.is_file() {
            true => Ok(Vec::new()),
            false => Err(error(format!("no such file {}", path.display()))),
        };
    }
    check_chain(includer.chain, &path).map_err(error)?;
    let text = std::fs::read_to_string(&path)
        .map_err(|e| error(format!("cannot read {}: {e}", path.display())))?;
    let copies: Vec<Option<i64>> = match &decl.repeat {
        None => {
            if decl.skip_first.is_some() {
                return Err(error(
                    "skip_first: leaves out copies of an include with `repeat`, and this one \
                     has none"
                        .into(),
                ));
            }
            check_no_index(decl).map_err(error)?;
            vec![None]
        }
        Some(repeat) => {
            let count = repeat_count("repeat", repeat, includer.resolved).map_err(error)?;
            let skipped = match &decl.skip_first {
                Some(skip) => repeat_count("skip_first", skip, includer.resolved).map_err(error)?,
                None => 0,
            };
            // Skipping as many copies as there are, or more, leaves none.
            (skipped + 1..=count).map(Some).collect()
        }
    };
    copies
        .into_iter()
        .map(|index| match index {
            None => expand_copy(ctx, includer, decl, &path, &text, decl.file.clone()),
            Some(index) => expand_copy(
                ctx,
                includer,
                &decl.with_index(index),
                &path,
                &text,
                format!("{} (copy {index})", decl.file),
            ),
        })
        .collect()
}

/// The number of copies `repeat` (or `skip_first`, the `field`) asks for: an integer, or a string
/// (`"$(var NAME)"`) that substitutes to one, from 0 to [`MAX_INCLUDE_REPEAT`].
fn repeat_count(
    field: &str,
    repeat: &toml::Value,
    resolved: &BTreeMap<String, toml::Value>,
) -> Result<i64, String> {
    let allowed =
        format!("allowed: an integer from 0 to {MAX_INCLUDE_REPEAT}, or \"$(var NAME)\" of one");
    let mut value = repeat.clone();
    substitute(&mut value, resolved).map_err(|e| format!("{field}: {e}"))?;
    // What the user wrote, and what it became when that was a `$(var ...)`.
    let shown = if value == *repeat {
        value.to_string()
    } else {
        format!("{repeat} (= {value})")
    };
    let count = match &value {
        toml::Value::Integer(count) => *count,
        toml::Value::String(text) => text
            .trim()
            .parse::<i64>()
            .map_err(|_| format!("{field}: {shown} is not an integer ({allowed})"))?,
        _ => return Err(format!("{field}: {shown} is not an integer ({allowed})")),
    };
    if !(0..=MAX_INCLUDE_REPEAT).contains(&count) {
        return Err(format!("{field}: {shown} is out of range ({allowed})"));
    }
    Ok(count)
}

/// Refuses `$(index)` in an include without `repeat`: it stands for nothing there.
fn check_no_index(decl: &IncludeDecl) -> Result<(), String> {
    let problem = |field: String| {
        Err(format!(
            "{field}: {INDEX} is the copy number of an include with `repeat`, and this one has none"
        ))
    };
    if decl.namespace.contains(INDEX) {
        return problem("namespace".into());
    }
    if let Some(name) = decl
        .arguments
        .iter()
        .find(|(_, v)| mentions_index(v))
        .map(|(n, _)| n)
    {
        return problem(format!("arguments.{name}"));
    }
    if let Some(node) = decl
        .params
        .iter()
        .find(|(_, t)| t.values().any(mentions_index))
        .map(|(n, _)| n)
    {
        return problem(format!("params.{node}"));
    }
    Ok(())
}

fn mentions_index(value: &toml::Value) -> bool {
    match value {
        toml::Value::String(text) => text.contains(INDEX),
        toml::Value::Array(items) => items.iter().any(mentions_index),
        toml::Value::Table(table) => table.values().any(mentions_index),
        _ => false,
    }
}

/// `value` with `$(index)` replaced by `index`: a string that is exactly `$(index)` becomes the
/// integer, as a whole `$(var ...)` takes its argument's type.
fn replace_index(value: &mut toml::Value, index: i64) {
    match value {
        toml::Value::String(text) if text == INDEX => *value = toml::Value::Integer(index),
        toml::Value::String(text) => *text = text.replace(INDEX, &index.to_string()),
        toml::Value::Array(items) => items.iter_mut().for_each(|v| replace_index(v, index)),
        toml::Value::Table(table) => table.iter_mut().for_each(|(_, v)| replace_index(v, index)),
        _ => {}
    }
}

impl IncludeDecl {
    /// Copy `index` of a repeated include: `$(index)` replaced in its namespace, arguments and
    /// parameters.
    fn with_index(&self, index: i64) -> IncludeDecl {
        let mut copy = self.clone();
        copy.namespace = copy.namespace.replace(INDEX, &index.to_string());
        copy.arguments
            .iter_mut()
            .for_each(|(_, v)| replace_index(v, index));
        for table in copy.params.values_mut() {
            table.iter_mut().for_each(|(_, v)| replace_index(v, index));
        }
        copy
    }
}

/// The include's `namespace`, `$(var ...)` substituted and checked.
fn include_namespace(
    decl: &IncludeDecl,
    resolved: &BTreeMap<String, toml::Value>,
) -> Result<String, String> {
    if decl.namespace.is_empty() {
        return Ok(String::new());
    }
    let mut value = toml::Value::String(decl.namespace.clone());
    substitute(&mut value, resolved).map_err(|e| format!("namespace: {e}"))?;
    let namespace = match value {
        toml::Value::String(text) => text,
        other => other.to_string(),
    };
    match nrslam_msgs::topics::namespace_problem(&namespace) {
        Some(problem) => Err(format!("namespace {problem}")),
        None => Ok(namespace),
    }
}

/// Puts everything the included file declared under `namespace`: its nodes (their namespaces
/// and names, e.g. `radar` → `agv1/radar`) and its `[[external]]` topics (`/odom` →
/// `/agv1/odom`, the topic its namespaced nodes subscribe to).
fn put_under(expanded: &mut Expanded, namespace: &str) {
    if namespace.is_empty() {
        return;
    }
    for node in &mut expanded.nodes {
        node.namespace = join_namespace(namespace, &node.namespace);
        node.name = join_namespace(namespace, &node.name);
    }
    for name in &mut expanded.declared_nodes {
        *name = join_namespace(namespace, name);
    }
    for topic in &mut expanded.externals {
        *topic = nrslam_msgs::topics::namespaced(namespace, topic);
    }
}

/// Expands one copy of an include (`label`: its `file`, with the copy number for a repeat).
fn expand_copy(
    ctx: &Ctx,
    includer: &Includer,
    decl: &IncludeDecl,
    path: &Path,
    text: &str,
    label: String,
) -> Result<Expanded, LaunchError> {
    let error = |problem: String| LaunchError::Include {
        path: includer.path.to_owned(),
        file: label.clone(),
        problem,
    };
    let namespace = include_namespace(decl, includer.resolved).map_err(error)?;
    let given = given_to(includer, decl).map_err(error)?;
    let mut expanded = expand_file(ctx, path, text, &given, includer.chain).map_err(|source| {
        LaunchError::Included {
            path: includer.path.to_owned(),
            file: label.clone(),
            source: Box::new(source),
        }
    })?;
    if let Some(name) = decl
        .arguments
        .keys()
        .find(|n| !expanded.consumed.contains(*n))
    {
        let mut names: Vec<&str> = expanded
            .exported
            .keys()
            .chain(&expanded.consumed)
            .map(String::as_str)
            .collect();
        names.sort_unstable();
        names.dedup();
        return Err(error(format!(
            "arguments.{name}: {} declares no such argument (its arguments: {})",
            path.display(),
            list(&names)
        )));
    }
    // Upwards, what was consumed of what the includer passed on from its own givers.
    expanded.consumed.retain(|name| {
        !includer.declared.contains_key(name)
            && !decl.arguments.contains_key(name)
            && includer.given.contains_key(name)
    });
    let nodes = expanded.declared_nodes.clone();
    let unknown = |what: &str, node: &str| {
        error(format!(
            "{what}: {} declares no node {node} (its nodes: {})",
            path.display(),
            list(&nodes)
        ))
    };
    for node in &decl.drop {
        if !nodes.contains(node) {
            return Err(unknown("drop", node));
        }
    }
    expanded.nodes.retain(|n| !decl.drop.contains(&n.name));
    expanded.declared_nodes.retain(|n| !decl.drop.contains(n));
    // `respawn` and `params` change nodes the include adds: each must be one it keeps.
    let kept = |what: &str, node: &String| {
        if !nodes.contains(node) {
            return Err(unknown(what, node));
        }
        if decl.drop.contains(node) {
            return Err(error(format!("{what}: {node} is in this include's `drop`")));
        }
        Ok(())
    };
    for node in &decl.respawn {
        kept("respawn", node)?;
    }
    for (node, params) in &decl.params {
        kept(&format!("params.{node}"), node)?;
        let mut params = toml::Value::Table(params.clone());
        substitute(&mut params, includer.resolved)
            .map_err(|e| error(format!("params.{node}: {e}")))?;
        // A node its own `when` leaves out is not running: nothing to change.
        if let (Some(target), toml::Value::Table(params)) =
            (expanded.nodes.iter_mut().find(|n| n.name == *node), &params)
        {
            merge(&mut target.params, params);
            target.set_by.push(format!(
                "{} [include.params.{node}]",
                includer.path.display()
            ));
        }
    }
    for node in &mut expanded.nodes {
        if let Some(on_exit) = decl.on_exit {
            node.on_exit = on_exit;
        }
        node.respawn |= decl.respawn.contains(&node.name);
    }
    // `drop` and `params` name the nodes as the included file knows them; then the namespace.
    put_under(&mut expanded, &namespace);
    Ok(expanded)
}

/// Refuses `path` when it is already in `chain` (a cycle) or `chain` is already
/// [`MAX_INCLUDE_DEPTH`] includes deep.
fn check_chain(chain: &[PathBuf], path: &Path) -> Result<(), String> {
    let identity = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_owned());
    let show = |files: &[PathBuf]| {
        files
            .iter()
            .chain([&path.to_owned()])
            .map(|p| p.display().to_string())
            .collect::<Vec<_>>()
            .join(" -> ")
    };
    let me = identity(path);
    if let Some(at) = chain.iter().position(|p| identity(p) == me) {
        return Err(format!("include cycle: {}", show(&chain[at..])));
    }
    if chain.len() > MAX_INCLUDE_DEPTH {
        return Err(format!(
            "includes nested deeper than {MAX_INCLUDE_DEPTH}: {}",
            show(chain)
        ));
    }
    Ok(())
}

/// What the included file is given: what the includer was given for arguments it does not
/// declare, the includer's own arguments by name, and the include's `arguments`.
fn given_to(includer: &Includer, decl: &IncludeDecl) -> Result<BTreeMap<String, Given>, String> {
    let mut given: BTreeMap<String, Given> = includer
        .given
        .iter()
        .filter(|(name, _)| !includer.declared.contains_key(*name))
        .map(|(name, given)| (name.clone(), given.clone()))
        .collect();
    for (name, argument) in includer.declared {
        given.insert(
            name.clone(),
            Given {
                value: GivenValue::Value(includer.resolved[name].clone()),
                written_in: Some(includer.dir.to_owned()),
                is_path: argument.path,
            },
        );
    }
    for (name, value) in &decl.arguments {
        let mut value = value.clone();
        // `$(var scene)` of a path argument passes a path, to be resolved where it was written.
        let is_path = value
            .as_str()
            .and_then(whole_reference)
            .and_then(|n| includer.declared.get(n))
            .is_some_and(|a| a.path);
        substitute(&mut value, includer.resolved).map_err(|e| format!("arguments.{name}: {e}"))?;
        given.insert(
            name.clone(),
            Given {
                value: GivenValue::Value(value),
                written_in: Some(includer.dir.to_owned()),
                is_path,
            },
        );
    }
    Ok(given)
}

/// Merges `over` into `base`: tables key by key, anything else replaced.
pub(super) fn merge(base: &mut toml::Table, over: &toml::Table) {
    for (key, value) in over {
        match (base.get_mut(key), value) {
            (Some(toml::Value::Table(inner)), toml::Value::Table(over)) => merge(inner, over),
            _ => {
                base.insert(key.clone(), value.clone());
            }
        }
    }
}

/// Adds an included file's settable argument to the includer's; two includes re-exporting one
/// name must agree on its value (else which one the record shows would be a guess).
pub(super) fn merge_exported(
    path: &Path,
    file: &str,
    exported: &mut BTreeMap<String, Exported>,
    name: String,
    argument: Exported,
) -> Result<(), LaunchError> {
    match exported.get(&name) {
        None => {
            exported.insert(name, argument);
            Ok(())
        }
        Some(first) if first.value == argument.value => Ok(()),
        Some(first) => Err(LaunchError::Include {
            path: path.to_owned(),
            file: file.to_owned(),
            problem: format!(
                "argument {name} is declared by {} (default {}) and by {} (default {}); declare \
                 it in {} to give both one value",
                first.file.display(),
                first.value,
                argument.file.display(),
                argument.value,
                path.display()
            ),
        }),
    }
}

fn list<S: AsRef<str>>(names: &[S]) -> String {
    if names.is_empty() {
        return "none".into();
    }
    names
        .iter()
        .map(AsRef::as_ref)
        .collect::<Vec<_>>()
        .join(", ")
}
