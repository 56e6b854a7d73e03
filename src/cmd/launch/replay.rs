//! Recording a run so that it replays, and replaying it.
//!
//! `launch --record DIR` writes into the bag's `custom_data` (rosbag2 `metadata.yaml`, repeated
//! in the MCAP file's `nrslam` metadata record) the run's identity (launch file, arguments, seed,
//! nrslam version) and its **resolved launch**: every node that ran, with its kind and its
//! parameters after argument substitution, includes and command-line overrides. A launch whose
//! `bag` node sets `rebuild_recorded_back_end` (`launch/replay.toml`) keeps that bag node and
//! replaces its other nodes by the recorded back end: every recorded node that publishes none of
//! the topics the bag plays (those come from the bag) and is not a source. The back end then sees
//! the recorded streams in the recorded order and computes the recorded bytes.
//!
//! A bag without that record (written by rosbags, the mcap tools, `nrslam bag record`, or an
//! nrslam older than the record) replays into the launch file's own back end, with one warning.
//! `node.param:=value` still changes a rebuilt node; the summary then lists each parameter that
//! differs from the recording.

use super::LaunchArgs;
use crate::registry;
use crate::report::{Reporter, Summary};
use anyhow::{anyhow, bail, Context, Result};
use nrslam_runtime::bag;
use nrslam_runtime::launch::{parse_param_assignment, Launch, NodeDecl};
use nrslam_runtime::NodeContext;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Node kinds that only produce data (the simulator, a bag player): a replay never rebuilds them,
/// the bag plays what they published.
const SOURCE_KINDS: [&str; 2] = ["radar", "bag"];

/// Replay arguments that choose the bag, not the back end: the only `name:=value` arguments a
/// replay of a bag with a launch record takes.
const BAG_ARGUMENTS: [&str; 2] = ["bag", "recover"];

/// One node of a recorded run, as `nrslam.nodes` stores it. `name` is the full name
/// (`agv1/radar` under namespace `agv1`); `namespace` and `remap` are written only when set, so
/// that the record of a run without namespaces is what it always was.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RecordedNode {
    name: String,
    kind: String,
    #[serde(default, skip_serializing_if = "String::is_empty")]
    namespace: String,
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    remap: BTreeMap<String, String>,
    #[serde(default)]
    params: toml::Table,
}

impl RecordedNode {
    /// The record of `decl`, as it ran.
    fn of(decl: &NodeDecl) -> Self {
        Self {
            name: decl.name.clone(),
            kind: decl.kind.clone(),
            namespace: decl.namespace.clone(),
            remap: decl.remap.clone(),
            params: decl.params.clone(),
        }
    }

    /// The node as a launch file's `[[node]]` declares it: its name without the namespace
    /// (the launch puts it back in front).
    fn as_declared(&self) -> Self {
        let local = self
            .name
            .strip_prefix(&self.namespace)
            .and_then(|rest| rest.strip_prefix('/'))
            .filter(|_| !self.namespace.is_empty())
            .unwrap_or(&self.name);
        Self {
            name: local.to_owned(),
            ..self.clone()
        }
    }
}

/// The TOML document of `nrslam.nodes`.
#[derive(Debug, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct RecordedNodes {
    node: Vec<RecordedNode>,
}

/// A recorded run, from its bag's `custom_data`.
pub(super) struct RecordedRun {
    launch: String,
    arguments: BTreeMap<String, serde_json::Value>,
    seed: u64,
    nodes: Vec<RecordedNode>,
}

/// What a replay reproduces and how it departs from the recording.
pub(super) struct Replay {
    /// The bag replayed.
    pub bag: PathBuf,
    /// The recorded run, when the bag carries its record.
    recorded: Option<RecordedRun>,
    /// The seed the replay's nodes are built with.
    pub seed: u64,
    /// Each parameter (`node.key`, or `seed`) set otherwise than in the recording.
    differences: BTreeMap<String, serde_json::Value>,
}

impl Replay {
    /// A replayed recording's summary names the recorded run (launch, arguments, seed), so that it
    /// is the recorded run's byte for byte, plus what the replay changed.
    pub(super) fn apply(&self, summary: &mut Summary) {
        if let Some(run) = &self.recorded {
            summary.launch = run.launch.clone();
            summary.arguments = run.arguments.clone();
            summary.seed = run.seed;
        }
        summary.differs_from_recording = self.differences.clone();
    }
}

/// `custom_data` identifying the run of `launch` with `seed` and recording its resolved launch.
pub(super) fn run_identity(launch: &Launch, seed: u64) -> Result<BTreeMap<String, String>> {
    let summary =
        Reporter::default().summary(&launch.arguments, seed, &launch.path.display().to_string());
    let nodes = RecordedNodes {
        node: launch.nodes.iter().map(RecordedNode::of).collect(),
    };
    Ok(BTreeMap::from([
        (bag::RUN_LAUNCH_KEY.to_owned(), summary.launch),
        (
            bag::RUN_ARGUMENTS_KEY.to_owned(),
            serde_json::to_string(&summary.arguments)?,
        ),
        (bag::RUN_SEED_KEY.to_owned(), seed.to_string()),
        (
            bag::RUN_VERSION_KEY.to_owned(),
            env!("CARGO_PKG_VERSION").to_owned(),
        ),
        (
            bag::RUN_NODES_KEY.to_owned(),
            toml::to_string(&nodes).context("the launch record")?,
        ),
    ]))
}

/// The recorded run in a bag's `custom_data`; `None` without a launch record.
fn recorded_run(
    dir: &std::path::Path,
    custom: &BTreeMap<String, String>,
) -> Result<Option<RecordedRun>> {
    let key_error = |key: &str| format!("{}: custom_data {key}", dir.display());
    let (Some(launch), Some(arguments), Some(seed), Some(nodes)) = (
        custom.get(bag::RUN_LAUNCH_KEY),
        custom.get(bag::RUN_ARGUMENTS_KEY),
        custom.get(bag::RUN_SEED_KEY),
        custom.get(bag::RUN_NODES_KEY),
    ) else {
        return Ok(None);
    };
    let nodes: RecordedNodes = toml::from_str(nodes)
        .map_err(|e| anyhow!("{}: {}", key_error(bag::RUN_NODES_KEY), e.message()))?;
    Ok(Some(RecordedRun {
        launch: launch.clone(),
        arguments: serde_json::from_str(arguments)
            .with_context(|| key_error(bag::RUN_ARGUMENTS_KEY))?,
        seed: seed.parse().with_context(|| key_error(bag::RUN_SEED_KEY))?,
        nodes: nodes.node,
    }))
}

/// The replaying bag node of `launch`: one of kind `bag` with `rebuild_recorded_back_end`.
fn replaying_bag(launch: &Launch) -> Option<&NodeDecl> {
    launch.nodes.iter().find(|n| {
        n.kind == "bag"
            && n.params
                .get("rebuild_recorded_back_end")
                .and_then(toml::Value::as_bool)
                .unwrap_or(false)
    })
}

/// For a launch that replays a recorded run (see the module docs): the launch to run, with the
/// recorded back end behind its bag node, and what the replay reproduces. Other launches are
/// returned unchanged.
pub(super) fn prepare(launch: Launch, args: &LaunchArgs) -> Result<(Launch, Option<Replay>)> {
    let Some(bag_node) = replaying_bag(&launch) else {
        check_bag_folders(&launch)?;
        return Ok((launch, None));
    };
    let path = bag_node
        .params
        .get("path")
        .and_then(|p| p.as_str())
        .unwrap_or("");
    if path.is_empty() {
        bail!(
            "{}: no bag folder given: name the recorded bag with bag:=DIR",
            launch.path.display()
        );
    }
    let dir = PathBuf::from(path);
    let recover = bag_node
        .params
        .get("recover")
        .and_then(toml::Value::as_bool)
        .unwrap_or(false);
    let custom = bag::custom_data(&dir, recover)?;
    let Some(recorded) = recorded_run(&dir, &custom)? else {
        let back_end: Vec<&str> = launch
            .nodes
            .iter()
            .filter(|n| n.kind != "bag")
            .map(|n| n.name.as_str())
            .collect();
        eprintln!(
            "warning: {}: no nrslam launch record in this bag (written by another tool, by `nrslam \
             bag record` or by an older nrslam): replaying into {}'s default back end ({}), \
             seed {}",
            dir.display(),
            launch.path.display(),
            back_end.join(", "),
            args.seed()
        );
        let replay = Replay {
            bag: dir,
            recorded: None,
            seed: args.seed(),
            differences: BTreeMap::new(),
        };
        return Ok((launch, Some(replay)));
    };
    let given: Vec<&String> = args
        .assignments
        .iter()
        .filter(|a| parse_param_assignment(a).is_none())
        .filter(|a| {
            let name = a.split_once(":=").map_or(a.as_str(), |(n, _)| n.trim());
            !BAG_ARGUMENTS.contains(&name)
        })
        .collect();
    if let Some(first) = given.first() {
        bail!(
            "{first}: {} carries its recorded launch, whose back end the replay rebuilds; change \
             a node's parameter instead (node.param:=value, e.g. \
             association.loop_closure.min_inlier_ratio:=0.5; the recorded nodes: {})",
            dir.display(),
            recorded
                .nodes
                .iter()
                .map(|n| n.name.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    let seed = args.seed.unwrap_or(recorded.seed);
    // The bag plays the launch's topics that it holds (all it holds when none are listed): a
    // recording without ground truth (a real sensor's) replays too.
    let in_bag = bag_topics(&dir, recover)?;
    let listed: Vec<String> = bag_node
        .params
        .get("topics")
        .and_then(toml::Value::as_array)
        .map(|topics| {
            topics
                .iter()
                .filter_map(|t| t.as_str().map(str::to_owned))
                .collect()
        })
        .unwrap_or_default();
    let played = played_topics(&listed, &in_bag);
    let back_end = recorded_back_end(&launch, &listed, &played, &recorded, seed)?;
    let text = replay_launch_text(&launch, bag_node, &played, &back_end)?;
    let params: Vec<String> = args
        .assignments
        .iter()
        .filter(|a| parse_param_assignment(a).is_some())
        .cloned()
        .collect();
    let rebuilt = Launch::parse(&launch.path, &text, &params)?;
    let mut differences = BTreeMap::new();
    for node in &back_end {
        let Some(decl) = rebuilt.nodes.iter().find(|d| d.name == node.name) else {
            continue;
        };
        differ(&node.name, &node.params, &decl.params, &mut differences);
    }
    if seed != recorded.seed {
        differences.insert(
            "seed".to_owned(),
            serde_json::json!({ "recorded": recorded.seed, "replay": seed }),
        );
    }
    for (key, change) in &differences {
        eprintln!(
            "replaying with {key} = {} (recorded: {})",
            change["replay"], change["recorded"]
        );
    }
    let replay = Replay {
        bag: dir,
        recorded: Some(recorded),
        seed,
        differences,
    };
    Ok((rebuilt, Some(replay)))
}

/// Refuses a launch with a `bag` node given no folder, naming the launch's path arguments left
/// empty (`launch/multi-session.toml`'s `first` and `second`), before any bag is opened.
fn check_bag_folders(launch: &Launch) -> Result<()> {
    let Some(node) = launch.nodes.iter().find(|n| {
        n.kind == "bag" && n.params.get("path").and_then(toml::Value::as_str) == Some("")
    }) else {
        return Ok(());
    };
    let mut empty: Vec<&String> = launch
        .declared
        .iter()
        .filter(|(name, argument)| {
            argument.path && launch.arguments.get(*name).and_then(toml::Value::as_str) == Some("")
        })
        .map(|(name, _)| name)
        .collect();
    // An argument named as the node (multi-session.toml's `first` feeds node agv1/first) is the
    // one; otherwise every empty path argument may be.
    let local = node.name.rsplit('/').next().unwrap_or(&node.name);
    if empty.iter().any(|name| name.as_str() == local) {
        empty.retain(|name| name.as_str() == local);
    }
    let empty: Vec<String> = empty.iter().map(|name| format!("{name}:=DIR")).collect();
    if empty.is_empty() {
        bail!(
            "{}: node {} has no bag folder (its path is empty)",
            launch.path.display(),
            node.name
        );
    }
    bail!(
        "{}: node {} has no bag folder: give {}",
        launch.path.display(),
        node.name,
        empty.join(" and ")
    )
}

/// What the bag node plays: every topic of the bag when none are `listed`, else each listed
/// topic the bag holds followed by its copies under namespaces in the bag (`/odom`, then
/// `/agv1/odom`, `/agv2/odom`): a recording of several agents replays their streams as the
/// single-agent list names them.
fn played_topics(listed: &[String], in_bag: &[String]) -> Vec<String> {
    if listed.is_empty() {
        return in_bag.to_vec();
    }
    let mut played = Vec::new();
    for topic in listed {
        if in_bag.contains(topic) {
            played.push(topic.clone());
        }
        let mut namespaced: Vec<&String> = in_bag
            .iter()
            .filter(|t| {
                nrslam_msgs::topics::split_namespace(t).is_some_and(|(_, s)| s.name == topic)
            })
            .collect();
        namespaced.sort();
        played.extend(namespaced.into_iter().cloned());
    }
    played
}

/// Whether `topic` (perhaps under a namespace) is one of the `listed` topics of the bag node.
fn is_listed(listed: &[String], topic: &str) -> bool {
    let base = nrslam_msgs::topics::base_name(topic).unwrap_or(topic);
    listed.iter().any(|l| l == base)
}

/// The topics a bag holds.
fn bag_topics(dir: &std::path::Path, recover: bool) -> Result<Vec<String>> {
    let topics = crate::cmd::bag::open_bag(dir, recover)?.known_topics()?;
    Ok(topics.into_iter().map(|t| t.name).collect())
}

/// The recorded nodes the replay rebuilds: neither a source nor a publisher of a topic the bag
/// node plays (`played`, those of `listed` the bag holds). A rebuilt node that needs a listed
/// topic the bag does not hold is refused by name: the recording left it out.
fn recorded_back_end(
    launch: &Launch,
    listed: &[String],
    played: &[String],
    recorded: &RecordedRun,
    seed: u64,
) -> Result<Vec<RecordedNode>> {
    let mut back_end = Vec::new();
    for node in &recorded.nodes {
        if SOURCE_KINDS.contains(&node.kind.as_str()) {
            continue;
        }
        let ctx = NodeContext {
            name: node.name.clone(),
            seed,
            base_dir: launch.base_dir.clone(),
            namespace: node.namespace.clone(),
        };
        let built = registry::build_node(&node.kind, node.params.clone(), &ctx, &node.remap)
            .map_err(|e| {
                anyhow!(
                    "recorded node {} ({}) cannot be rebuilt by this nrslam: {e}",
                    node.name,
                    node.kind
                )
            })?;
        if built
            .outputs()
            .iter()
            .any(|t| played.iter().any(|p| p == t))
        {
            continue;
        }
        let missing = built
            .inputs()
            .into_iter()
            .find(|t| is_listed(listed, t) && !played.iter().any(|p| p == t));
        if let Some(topic) = missing {
            bail!(
                "the bag holds no {topic}, which the recorded node {} ({}) needs: record it too \
                 (launch --record without --record-topics records every topic)",
                node.name,
                node.kind
            );
        }
        back_end.push(node.clone());
    }
    if back_end.is_empty() {
        bail!(
            "the recorded launch has no back end to replay (each of its nodes publishes what the \
             bag plays: {})",
            played.join(", ")
        );
    }
    Ok(back_end)
}

/// The replay's launch as TOML: the bag node, playing `played`, followed by the recorded back end.
fn replay_launch_text(
    launch: &Launch,
    bag_node: &NodeDecl,
    played: &[String],
    back_end: &[RecordedNode],
) -> Result<String> {
    let mut bag_params = bag_node.params.clone();
    bag_params.insert(
        "topics".into(),
        toml::Value::Array(played.iter().cloned().map(toml::Value::String).collect()),
    );
    let mut nodes = vec![RecordedNode {
        params: bag_params,
        ..RecordedNode::of(bag_node)
    }
    .as_declared()];
    nodes.extend(back_end.iter().map(RecordedNode::as_declared));
    let mut text = format!(
        "[launch]\ndescription = {}\nmode = \"in-process\"\n\n",
        toml::Value::String(format!(
            "{} (the back end recorded in the bag)",
            launch.description
        ))
    );
    text.push_str(&toml::to_string(&RecordedNodes { node: nodes })?);
    Ok(text)
}

/// Adds to `out` every leaf of `replay` that differs from `recorded` (or is absent from it), under
/// `prefix.key.key`.
fn differ(
    prefix: &str,
    recorded: &toml::Table,
    replay: &toml::Table,
    out: &mut BTreeMap<String, serde_json::Value>,
) {
    for (key, value) in replay {
        let name = format!("{prefix}.{key}");
        match (recorded.get(key), value) {
            (Some(toml::Value::Table(before)), toml::Value::Table(after)) => {
                differ(&name, before, after, out)
            }
            (Some(before), after) if before == after => {}
            (before, after) => {
                let json = |v: &toml::Value| serde_json::to_value(v).unwrap_or_default();
                out.insert(
                    name,
                    serde_json::json!({
                        "recorded": before.map(json),
                        "replay": json(after),
                    }),
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differ_names_each_changed_leaf_and_nothing_else() {
        let recorded: toml::Table = toml::from_str(
            "robust_scale_m = 0.5\n[loop_closure]\nmin_inlier_ratio = 0.4\ninlier_distance_m = 1.0\n",
        )
        .unwrap();
        let mut replay = recorded.clone();
        let mut out = BTreeMap::new();
        differ("association", &recorded, &replay, &mut out);
        assert!(out.is_empty(), "{out:?}");
        replay["loop_closure"]
            .as_table_mut()
            .unwrap()
            .insert("min_inlier_ratio".into(), toml::Value::Float(0.5));
        replay.insert("scan_matching".into(), toml::Value::Boolean(false));
        differ("association", &recorded, &replay, &mut out);
        assert_eq!(
            out,
            BTreeMap::from([
                (
                    "association.loop_closure.min_inlier_ratio".to_owned(),
                    serde_json::json!({"recorded": 0.4, "replay": 0.5})
                ),
                (
                    "association.scan_matching".to_owned(),
                    serde_json::json!({"recorded": null, "replay": false})
                ),
            ])
        );
    }

    #[test]
    fn a_listed_topic_plays_with_its_copies_under_namespaces() {
        let names = |list: &[&str]| list.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        let in_bag = names(&["/a2/odom", "/clock", "/a1/odom", "/a1/clock", "/metrics"]);
        assert_eq!(
            played_topics(&names(&["/odom", "/clock"]), &in_bag),
            names(&["/a1/odom", "/a2/odom", "/clock", "/a1/clock"])
        );
        assert_eq!(played_topics(&[], &in_bag), in_bag);
        assert!(is_listed(&names(&["/odom"]), "/a3/odom"));
        assert!(!is_listed(&names(&["/odom"]), "/a3/clock"));
    }

    #[test]
    fn a_namespaced_node_is_recorded_in_full_and_declared_by_its_own_name() {
        let node = RecordedNode {
            name: "site/agv1/radar".into(),
            kind: "radar".into(),
            namespace: "site/agv1".into(),
            remap: BTreeMap::from([(
                "/ground_truth/targets".to_owned(),
                "/ground_truth/targets".to_owned(),
            )]),
            params: toml::Table::new(),
        };
        let text = toml::to_string(&RecordedNodes {
            node: vec![node.clone()],
        })
        .unwrap();
        let back: RecordedNodes = toml::from_str(&text).unwrap();
        assert_eq!(back.node[0], node);
        let declared = node.as_declared();
        assert_eq!(declared.name, "radar");
        assert_eq!(declared.namespace, "site/agv1");
        // Re-read as a launch file, it is the recorded node again.
        let launch = Launch::parse(
            std::path::Path::new("replay.toml"),
            &toml::to_string(&RecordedNodes {
                node: vec![declared],
            })
            .unwrap(),
            &[],
        )
        .unwrap();
        let decl = &launch.nodes[0];
        assert_eq!(RecordedNode::of(decl), node);
    }

    #[test]
    fn the_node_record_round_trips_every_value_type() {
        let params: toml::Table = toml::from_str(
            "a = 1\nb = 1.0\nc = -0.0\nd = 1e-300\ne = inf\nf = \"x\"\ng = [1, 2]\n[h]\ni = true\n",
        )
        .unwrap();
        let nodes = RecordedNodes {
            node: vec![RecordedNode {
                name: "n".into(),
                kind: "k".into(),
                namespace: String::new(),
                remap: BTreeMap::new(),
                params: params.clone(),
            }],
        };
        let text = toml::to_string(&nodes).unwrap();
        // Without namespace or remap the record is what it was before they existed.
        assert!(
            text.starts_with("[[node]]\nname = \"n\"\nkind = \"k\"\n\n[node.params]\n"),
            "{text}"
        );
        let back: RecordedNodes = toml::from_str(&text).unwrap();
        assert_eq!(back.node[0].params, params);
        assert!(back.node[0].params["c"]
            .as_float()
            .unwrap()
            .is_sign_negative());
        assert!(back.node[0].params["a"].is_integer() && back.node[0].params["b"].is_float());
    }
}
