//! One launch file expanded: its arguments valued (from what its includer or the command line
//! gives, else their defaults), its nodes selected by `when` and substituted, its includes
//! expanded in turn ([`super::include`]).

use super::include::{self, IncludeDecl};
use super::substitute::{expand_arguments, substitute};
use super::{
    location, type_name, typed_like, Argument, ExternalDecl, Header, LaunchError, NodeDecl,
};
use serde::Deserialize;
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// What does not change while a launch is expanded.
pub(super) struct Ctx<'a> {
    /// Directory relative command-line paths resolve against (`None`: unknown).
    pub cwd: Option<&'a Path>,
}

/// A value given to an argument from outside its file.
#[derive(Debug, Clone)]
pub(super) enum GivenValue {
    /// Typed on the command line: parsed as the argument's type.
    Text(String),
    /// Passed by an including file: already typed there.
    Value(toml::Value),
}

/// A value given to an argument from outside its file, with where it came from.
#[derive(Debug, Clone)]
pub(super) struct Given {
    pub value: GivenValue,
    /// Folder a relative path in `value` was written against; `None`: the command line (the
    /// current directory).
    pub written_in: Option<PathBuf>,
    /// The giver declared the value a path (`path = true`).
    pub is_path: bool,
}

impl Given {
    /// `name:=value` typed on the command line.
    pub fn command_line(text: String) -> Given {
        Given {
            value: GivenValue::Text(text),
            written_in: None,
            is_path: false,
        }
    }
}

/// An argument settable from above: declared by the file (or one it includes) and not set by
/// its includer.
#[derive(Debug, Clone)]
pub(super) struct Exported {
    pub argument: Argument,
    /// Its value as typed (the command line's, else the default).
    pub value: toml::Value,
    /// The file that declares it.
    pub file: PathBuf,
}

/// A launch file expanded.
pub(super) struct Expanded {
    pub header: Header,
    /// The nodes that run, parameters substituted.
    pub nodes: Vec<NodeDecl>,
    /// Every node name declared, running or not (what an includer may name).
    pub declared_nodes: Vec<String>,
    pub exported: BTreeMap<String, Exported>,
    /// Names of the given values that an argument of this file or of one it includes took.
    pub consumed: BTreeSet<String>,
    /// Topics fed from outside whose `when` holds: included files' first, then the file's own,
    /// each once.
    pub externals: Vec<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLaunch {
    launch: Option<Header>,
    #[serde(default)]
    arguments: BTreeMap<String, Argument>,
    #[serde(default)]
    node: Vec<NodeDecl>,
    #[serde(default)]
    include: Vec<IncludeDecl>,
    #[serde(default)]
    external: Vec<ExternalDecl>,
}

/// The folder of `path`, `.` for a bare file name.
pub(super) fn folder_of(path: &Path) -> PathBuf {
    match path.parent() {
        Some(dir) if !dir.as_os_str().is_empty() => dir.to_owned(),
        _ => PathBuf::from("."),
    }
}

/// The file's own arguments: (as typed, for the record; resolved, for substitution).
struct Valued {
    arguments: BTreeMap<String, toml::Value>,
    resolved: BTreeMap<String, toml::Value>,
    exported: BTreeMap<String, Exported>,
    consumed: BTreeSet<String>,
}

/// Expands launch `text`, read from `path`, with `given` values for its arguments; `chain` is
/// the files that include it, outermost first.
pub(super) fn expand_file(
    ctx: &Ctx,
    path: &Path,
    text: &str,
    given: &BTreeMap<String, Given>,
    chain: &[PathBuf],
) -> Result<Expanded, LaunchError> {
    let raw: RawLaunch = toml::from_str(text).map_err(|e| LaunchError::Parse {
        path: path.to_owned(),
        message: e.message().to_owned() + &location(text, e.span()),
    })?;
    if raw.node.is_empty() && raw.include.is_empty() && raw.external.is_empty() {
        return Err(LaunchError::Parse {
            path: path.to_owned(),
            message: "no [[node]], [[include]] or [[external]] declared".into(),
        });
    }
    let dir = folder_of(path);
    let valued = value_arguments(ctx, path, &dir, &raw.arguments, given)?;
    let resolved =
        expand_arguments(&valued.resolved).map_err(|(name, problem)| LaunchError::Argument {
            path: path.to_owned(),
            name,
            problem: problem.to_string(),
        })?;
    let own = own_nodes(path, &dir, raw.node, &valued.arguments, &resolved)?;
    let own_externals = own_externals(path, &raw.external, &valued.arguments)?;
    let mut externals: Vec<String> = Vec::new();
    let mut declared_nodes: Vec<String> = own.declared.clone();
    let mut nodes = Vec::new();
    let mut exported = valued.exported;
    let mut consumed = valued.consumed;
    let mut chain = chain.to_vec();
    chain.push(path.to_owned());
    let includer = include::Includer {
        path,
        dir: &dir,
        declared: &raw.arguments,
        arguments: &valued.arguments,
        resolved: &resolved,
        given,
        chain: &chain,
    };
    for decl in &raw.include {
        // Nodes of earlier copies of this include (`repeat`), to say why a name clashes.
        let mut this_include: Vec<String> = Vec::new();
        for included in include::expand(ctx, &includer, decl)? {
            consumed.extend(included.consumed);
            externals.extend(included.externals);
            for (name, argument) in included.exported {
                include::merge_exported(path, &decl.file, &mut exported, name, argument)?;
            }
            for node in &included.nodes {
                let clash = |n: &NodeDecl| n.name == node.name;
                if own.nodes.iter().any(clash) || nodes.iter().any(clash) {
                    let here = if own.nodes.iter().any(clash) {
                        "in this file as well"
                    } else if this_include.contains(&node.name) {
                        "by another copy of this include (with `repeat`, put `$(index)` in \
                         its `namespace`, e.g. namespace = \"agv$(index)\")"
                    } else {
                        "by another include as well"
                    };
                    return Err(LaunchError::Include {
                        path: path.to_owned(),
                        file: decl.file.clone(),
                        problem: format!(
                            "node {} is declared {here} (node names are unique in a launch); to \
                             replace the included one, list it in this include's `drop`",
                            node.name
                        ),
                    });
                }
            }
            for name in included.declared_nodes {
                if !declared_nodes.contains(&name) {
                    declared_nodes.push(name);
                }
            }
            this_include.extend(included.nodes.iter().map(|n| n.name.clone()));
            nodes.extend(included.nodes);
        }
    }
    nodes.extend(own.nodes);
    externals.extend(own_externals);
    let mut seen = BTreeSet::new();
    externals.retain(|topic| seen.insert(topic.clone()));
    Ok(Expanded {
        header: raw.launch.unwrap_or_default(),
        nodes,
        declared_nodes,
        exported,
        consumed,
        externals,
    })
}

/// The file's `[[external]]` topics whose `when` holds (each `when` checked as a node's is).
fn own_externals(
    path: &Path,
    externals: &[ExternalDecl],
    arguments: &BTreeMap<String, toml::Value>,
) -> Result<Vec<String>, LaunchError> {
    let mut out = Vec::new();
    for external in externals {
        let error = |problem: String| LaunchError::External {
            path: path.to_owned(),
            topic: external.topic.clone(),
            problem,
        };
        if !external.topic.starts_with('/') || external.topic.len() < 2 {
            return Err(error(
                "`topic` must be a topic name starting with '/', e.g. \"/odom\"".into(),
            ));
        }
        check_when(&external.when, arguments).map_err(error)?;
        if when_holds(&external.when, arguments) {
            out.push(external.topic.clone());
        }
    }
    Ok(out)
}

/// Values the file's declared arguments from `given`, else their defaults.
fn value_arguments(
    ctx: &Ctx,
    path: &Path,
    dir: &Path,
    declared: &BTreeMap<String, Argument>,
    given: &BTreeMap<String, Given>,
) -> Result<Valued, LaunchError> {
    let error = |name: &str, problem: String| LaunchError::Argument {
        path: path.to_owned(),
        name: name.to_owned(),
        problem,
    };
    let mut valued = Valued {
        arguments: BTreeMap::new(),
        resolved: BTreeMap::new(),
        exported: BTreeMap::new(),
        consumed: BTreeSet::new(),
    };
    for (name, argument) in declared {
        if argument.path && !argument.default.is_str() {
            return Err(error(
                name,
                format!(
                    "path = true needs a string default, got {}",
                    type_name(&argument.default)
                ),
            ));
        }
        let (typed, resolved, export) = match given.get(name) {
            None => (argument.default.clone(), argument.default.clone(), true),
            Some(given) => {
                valued.consumed.insert(name.clone());
                let typed = match &given.value {
                    GivenValue::Text(text) => {
                        typed_like(&argument.default, text).ok_or_else(|| {
                            error(
                                name,
                                format!("{text:?} is not {}", type_name(&argument.default)),
                            )
                        })?
                    }
                    GivenValue::Value(value) => {
                        coerce(&argument.default, value).ok_or_else(|| {
                            error(
                                name,
                                format!(
                                    "the including file passes {value}, which is not {}",
                                    type_name(&argument.default)
                                ),
                            )
                        })?
                    }
                };
                let resolved = if argument.path || given.is_path {
                    rebase(ctx, dir, given, &typed).map_err(|problem| error(name, problem))?
                } else {
                    typed.clone()
                };
                let export = matches!(given.value, GivenValue::Text(_));
                (typed, resolved, export)
            }
        };
        if export {
            valued.exported.insert(
                name.clone(),
                Exported {
                    argument: argument.clone(),
                    value: typed.clone(),
                    file: path.to_owned(),
                },
            );
        }
        valued.arguments.insert(name.clone(), typed);
        valued.resolved.insert(name.clone(), resolved);
    }
    Ok(valued)
}

/// `value` as a value of `default`'s type: the same type, an integer for a float, or a string
/// that parses as the type (what `$(var ...)` inside a longer string makes).
fn coerce(default: &toml::Value, value: &toml::Value) -> Option<toml::Value> {
    use toml::Value as V;
    match (default, value) {
        (V::Float(_), V::Integer(i)) => Some(V::Float(*i as f64)),
        (V::String(_), V::String(_)) => Some(value.clone()),
        (V::String(_), V::Float(_) | V::Integer(_) | V::Boolean(_)) => {
            Some(V::String(value.to_string()))
        }
        (_, V::String(text)) => typed_like(default, text),
        _ if std::mem::discriminant(default) == std::mem::discriminant(value) => {
            Some(value.clone())
        }
        _ => None,
    }
}

/// A path value given to an argument of the file in `dir`, made to resolve from `dir`: one typed
/// on the command line against the current directory, one written in another file against that
/// file's folder (absolute, unless the folders are the same).
fn rebase(
    ctx: &Ctx,
    dir: &Path,
    given: &Given,
    value: &toml::Value,
) -> Result<toml::Value, String> {
    let toml::Value::String(text) = value else {
        return Ok(value.clone());
    };
    let relative = Path::new(text);
    if text.is_empty() || relative.is_absolute() {
        return Ok(value.clone());
    }
    let base = match &given.written_in {
        Some(written_in) if same_dir(written_in, dir) => return Ok(value.clone()),
        Some(written_in) => written_in.join(relative),
        None => relative.to_owned(),
    };
    if base.is_absolute() {
        return Ok(toml::Value::String(base.display().to_string()));
    }
    let cwd = ctx.cwd.ok_or_else(|| {
        format!("{text:?} is relative and the current directory is unknown; give an absolute path")
    })?;
    Ok(toml::Value::String(cwd.join(base).display().to_string()))
}

/// Whether two folders are the same (as written, or on disk).
fn same_dir(a: &Path, b: &Path) -> bool {
    a == b
        || matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(a), Ok(b)) if a == b
        )
}

/// The file's own nodes: checked, selected by `when`, substituted.
struct OwnNodes {
    nodes: Vec<NodeDecl>,
    declared: Vec<String>,
}

fn own_nodes(
    path: &Path,
    dir: &Path,
    mut nodes: Vec<NodeDecl>,
    arguments: &BTreeMap<String, toml::Value>,
    resolved: &BTreeMap<String, toml::Value>,
) -> Result<OwnNodes, LaunchError> {
    let error = |node: &NodeDecl, problem: String| LaunchError::Node {
        path: path.to_owned(),
        node: node.name.clone(),
        problem,
    };
    for (index, node) in nodes.iter().enumerate() {
        if node.name.contains('/') {
            return Err(error(
                node,
                "a node name has no '/': to run it under a namespace, set `namespace`".into(),
            ));
        }
        // As written: two nodes of one name are told apart only by their namespaces.
        if nodes[..index]
            .iter()
            .any(|other| other.name == node.name && other.namespace == node.namespace)
        {
            return Err(error(node, "name used twice".into()));
        }
        if !(node.respawn_delay_s.is_finite() && (0.0..=3600.0).contains(&node.respawn_delay_s))
            || node.max_restarts > 1000
        {
            return Err(error(
                node,
                format!(
                    "respawn_delay_s = {} and max_restarts = {} (allowed: 0 to 3600 s, 0 to 1000)",
                    node.respawn_delay_s, node.max_restarts
                ),
            ));
        }
        check_when(&node.when, arguments).map_err(|problem| error(node, problem))?;
    }
    // Every declared node's full name (what an includer may name), so namespaces are
    // substituted whether the node runs or not.
    for node in &mut nodes {
        namespace_node(node, resolved).map_err(|problem| error(node, problem))?;
    }
    let twice = nodes
        .iter()
        .enumerate()
        .find(|(index, node)| nodes[..*index].iter().any(|other| other.name == node.name));
    if let Some((_, node)) = twice {
        return Err(error(
            node,
            "name used twice (after substituting the namespaces)".into(),
        ));
    }
    let declared = nodes.iter().map(|n| n.name.clone()).collect();
    nodes.retain(|node| when_holds(&node.when, arguments));
    for node in &mut nodes {
        for (_, value) in node.params.iter_mut() {
            substitute(value, resolved).map_err(|e| LaunchError::Node {
                path: path.to_owned(),
                node: node.name.clone(),
                problem: e.to_string(),
            })?;
        }
        for (from, to) in node.remap.iter_mut() {
            let mut value = toml::Value::String(std::mem::take(to));
            substitute(&mut value, resolved).map_err(|e| LaunchError::Node {
                path: path.to_owned(),
                node: node.name.clone(),
                problem: format!("remap.{from:?}: {e}"),
            })?;
            *to = match value {
                toml::Value::String(text) => text,
                other => other.to_string(),
            };
        }
        check_remap(node).map_err(|problem| error(node, problem))?;
        node.file = path.to_owned();
        node.base_dir = dir.to_owned();
    }
    Ok(OwnNodes { nodes, declared })
}

/// Substitutes `$(var ...)` in the node's `namespace`, checks it, and names the node
/// `<namespace>/<name>` when it has one.
fn namespace_node(
    node: &mut NodeDecl,
    resolved: &BTreeMap<String, toml::Value>,
) -> Result<(), String> {
    if node.namespace.is_empty() {
        return Ok(());
    }
    let mut value = toml::Value::String(std::mem::take(&mut node.namespace));
    substitute(&mut value, resolved).map_err(|e| format!("namespace: {e}"))?;
    let namespace = match value {
        toml::Value::String(text) => text,
        other => other.to_string(),
    };
    if let Some(problem) = nrslam_msgs::topics::namespace_problem(&namespace) {
        return Err(format!("namespace {problem}"));
    }
    node.name = join_namespace(&namespace, &node.name);
    node.namespace = namespace;
    Ok(())
}

/// `name` under `namespace` (`agv1`, `radar` → `agv1/radar`; a namespace `site` in front of
/// `agv1` → `site/agv1`); `name` itself when the namespace is empty.
pub(super) fn join_namespace(namespace: &str, name: &str) -> String {
    match (namespace.is_empty(), name.is_empty()) {
        (true, _) => name.to_owned(),
        (false, true) => namespace.to_owned(),
        (false, false) => format!("{namespace}/{name}"),
    }
}

/// Checks what can be checked of a node's `remap` before it is built: keys are topic names,
/// values absolute names of catalogue topics (under a namespace or not). Whether each key is one
/// of the node's topics is known once it is built ([`crate::remap::Remapped`]).
fn check_remap(node: &NodeDecl) -> Result<(), String> {
    for (from, to) in &node.remap {
        if !from.starts_with('/') {
            return Err(format!(
                "remap.{from:?}: a key is one of the node's own topics, e.g. \"/odom\""
            ));
        }
        if let Some(problem) = crate::remap::target_problem(to) {
            return Err(format!("remap.{from:?} = {to:?}: {problem}"));
        }
    }
    Ok(())
}

/// Checks that a `when` condition names declared arguments and lists values.
pub(super) fn check_when(
    when: &BTreeMap<String, Vec<String>>,
    arguments: &BTreeMap<String, toml::Value>,
) -> Result<(), String> {
    for (argument, allowed) in when {
        if !arguments.contains_key(argument) {
            return Err(format!("`when` names undeclared argument {argument:?}"));
        }
        if allowed.is_empty() {
            return Err(format!("`when.{argument}` lists no value"));
        }
    }
    Ok(())
}

/// Whether each argument a (checked) `when` names has one of its listed values.
pub(super) fn when_holds(
    when: &BTreeMap<String, Vec<String>>,
    arguments: &BTreeMap<String, toml::Value>,
) -> bool {
    when.iter().all(|(argument, allowed)| {
        let value = match &arguments[argument] {
            toml::Value::String(text) => text.clone(),
            other => other.to_string(),
        };
        allowed.contains(&value)
    })
}
