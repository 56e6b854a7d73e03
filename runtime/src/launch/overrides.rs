//! Command-line node-parameter overrides, `node.param:=value` (nested: `node.table.key:=value`),
//! so that a variant of a launch file is one word on the command line. The value is read as a
//! TOML value (`0.3`, `true`, `"x"`, `[1, 2]`); anything that is not one is taken as a string
//! (`radar.fidelity:=spectral`). The node's own parameter checks (unknown fields, ranges) still
//! apply when it is built, and their errors name the override.

use super::{LaunchError, NodeDecl};
use std::path::Path;

/// One `node.param:=value`.
#[derive(Debug, Clone, PartialEq)]
pub struct ParamAssignment {
    /// The assignment as typed.
    pub text: String,
    /// Node instance name.
    pub node: String,
    /// Key path inside the node's parameters (at least one key).
    pub keys: Vec<String>,
    /// The value.
    pub value: toml::Value,
}

impl ParamAssignment {
    /// `node.key.key`: how the run's record names it.
    pub fn key(&self) -> String {
        format!("{}.{}", self.node, self.keys.join("."))
    }
}

fn is_name(text: &str) -> bool {
    !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

/// Parses `node.param:=value` (`None` when `text` is not of that form: no `:=`, no `.` before
/// it, or a part that is not letters, digits, `_` and `-`). A node under a namespace is named
/// with it, `agv2/radar.snr_db:=3`: its name's parts are separated by `/`.
pub fn parse_param_assignment(text: &str) -> Option<ParamAssignment> {
    let (name, value) = text.split_once(":=")?;
    let mut parts = name.trim().split('.');
    let node = parts.next()?.to_owned();
    let keys: Vec<String> = parts.map(str::to_owned).collect();
    if keys.is_empty() || !node.split('/').all(is_name) || !keys.iter().all(|k| is_name(k)) {
        return None;
    }
    Some(ParamAssignment {
        text: text.to_owned(),
        node,
        keys,
        value: parse_value(value),
    })
}

/// `text` as a TOML value, else as a string.
fn parse_value(text: &str) -> toml::Value {
    match toml::from_str::<toml::Table>(&format!("value = {text}")) {
        Ok(mut table) if table.len() == 1 => table
            .remove("value")
            .unwrap_or_else(|| toml::Value::String(text.to_owned())),
        _ => toml::Value::String(text.to_owned()),
    }
}

/// Sets `assignment` in its node of `nodes` (those that run; `declared` are all the launch's).
pub(super) fn apply(
    path: &Path,
    nodes: &mut [NodeDecl],
    declared: &[String],
    assignment: &ParamAssignment,
) -> Result<(), LaunchError> {
    let error = |problem: String| LaunchError::Override {
        path: path.to_owned(),
        assignment: assignment.text.clone(),
        problem,
    };
    let running: Vec<String> = nodes.iter().map(|n| n.name.clone()).collect();
    let Some(node) = nodes.iter_mut().find(|n| n.name == assignment.node) else {
        return Err(error(if declared.contains(&assignment.node) {
            format!(
                "node {} does not run with these arguments (its `when` condition is false)",
                assignment.node
            )
        } else {
            format!(
                "no node {} in this launch (nodes: {})",
                assignment.node,
                running.join(", ")
            )
        }));
    };
    let (last, tables) = assignment
        .keys
        .split_last()
        .ok_or_else(|| error("no parameter named".into()))?;
    let mut table = &mut node.params;
    for (depth, key) in tables.iter().enumerate() {
        let entry = table
            .entry(key.clone())
            .or_insert_with(|| toml::Value::Table(toml::Table::new()));
        table = match entry {
            toml::Value::Table(inner) => inner,
            other => {
                return Err(error(format!(
                    "{}.{} is {}, not a table",
                    assignment.node,
                    assignment.keys[..=depth].join("."),
                    other.type_str()
                )))
            }
        };
    }
    table.insert(last.clone(), assignment.value.clone());
    node.set_by
        .push(format!("the command line ({})", assignment.text));
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn assignments_are_split_and_their_values_typed_as_toml() {
        let a = parse_param_assignment("association.scan_matching:=false").unwrap();
        assert_eq!(
            (a.node.as_str(), a.keys.as_slice()),
            ("association", &["scan_matching".to_owned()][..])
        );
        assert_eq!(a.value, toml::Value::Boolean(false));
        assert_eq!(a.key(), "association.scan_matching");
        let a = parse_param_assignment("estimator.estimator.dynamic_range_db:=12.5").unwrap();
        assert_eq!(a.keys, ["estimator", "dynamic_range_db"]);
        assert_eq!(a.value, toml::Value::Float(12.5));
        assert_eq!(
            parse_param_assignment("m.n:=3").unwrap().value,
            toml::Value::Integer(3)
        );
        assert_eq!(
            parse_param_assignment("r.fidelity:=spectral")
                .unwrap()
                .value,
            toml::Value::String("spectral".into())
        );
        assert_eq!(
            parse_param_assignment("r.f:=\"x y\"").unwrap().value,
            toml::Value::String("x y".into())
        );
        assert_eq!(
            parse_param_assignment("r.faults.drop_frames:=[3, 4]")
                .unwrap()
                .value,
            toml::Value::Array(vec![toml::Value::Integer(3), toml::Value::Integer(4)])
        );
        // A value that smuggles a second key is one string, not two settings.
        assert_eq!(
            parse_param_assignment("r.f:=1\nother = 2").unwrap().value,
            toml::Value::String("1\nother = 2".into())
        );
        let a = parse_param_assignment("agv2/radar.snr_db:=3").unwrap();
        assert_eq!(
            (a.node.as_str(), a.key()),
            ("agv2/radar", "agv2/radar.snr_db".into())
        );
        assert_eq!(
            parse_param_assignment("site/agv2/radar.faults.drop_frames:=[1]")
                .unwrap()
                .node,
            "site/agv2/radar"
        );
        for bad in [
            "plain:=1",
            "a.:=1",
            ".b:=1",
            "a..b:=1",
            "a.b c:=1",
            "a.b=1",
            "/radar.x:=1",
            "agv2/.x:=1",
            "agv2//radar.x:=1",
            "a.b/c:=1",
        ] {
            assert_eq!(parse_param_assignment(bad), None, "{bad}");
        }
    }
}
