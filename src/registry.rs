//! Node kinds the CLI can build, by the name a launch file gives them.

use nrslam_runtime::{parse_params, Node, NodeContext, NodeError, ParamsError};
use std::collections::BTreeMap;

/// Why a node could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// No such kind.
    #[error("unknown node kind {0:?} (known: radar, estimator, association, mapper, segmenter, shapes, evaluator, fusion, sensor_adapter, viz, bag)")]
    UnknownKind(String),
    /// Bad parameters.
    #[error(transparent)]
    Params(#[from] ParamsError),
    /// The node refused to start.
    #[error(transparent)]
    Node(#[from] NodeError),
    /// A `bag` node's bag could not be read.
    #[error(transparent)]
    Bag(#[from] nrslam_runtime::bag::BagError),
    /// The node's namespace or remap does not fit it.
    #[error(transparent)]
    Remap(#[from] nrslam_runtime::remap::RemapError),
}

macro_rules! build_kind {
    ($crate_name:ident, $table:expr, $ctx:expr) => {{
        let params: $crate_name::Params = parse_params($table)?;
        params.validate().map_err(ParamsError::from)?;
        $crate_name::build(params, $ctx)?
    }};
}

/// Builds a node of `kind` from its parameter table, under `ctx.namespace` and with `remap`
/// (its own topic names → absolute ones): the one place a node of a launch (in-process, a node
/// process, a replay's rebuilt back end) is built, so each applies namespaces alike. Without a
/// namespace or remap the node is the kind's own, unwrapped.
pub fn build_node(
    kind: &str,
    table: toml::Table,
    ctx: &NodeContext,
    remap: &BTreeMap<String, String>,
) -> Result<Box<dyn Node>, BuildError> {
    let node = build(kind, table, ctx)?;
    Ok(nrslam_runtime::remap::wrap(node, &ctx.namespace, remap)?)
}

/// Builds a node of `kind` from its parameter table, with the catalogue's topic names.
fn build(kind: &str, table: toml::Table, ctx: &NodeContext) -> Result<Box<dyn Node>, BuildError> {
    Ok(match kind {
        "radar" => build_kind!(nrslam_radar, table, ctx),
        "association" => build_kind!(nrslam_association, table, ctx),
        "mapper" => build_kind!(nrslam_mapper, table, ctx),
        "segmenter" => build_kind!(nrslam_segmenter, table, ctx),
        "shapes" => build_kind!(nrslam_shapes, table, ctx),
        "evaluator" => build_kind!(nrslam_evaluator, table, ctx),
        "fusion" => build_kind!(nrslam_fusion, table, ctx),
        "estimator" => build_kind!(nrslam_estimator, table, ctx),
        "sensor_adapter" => build_kind!(nrslam_sensor_adapter, table, ctx),
        "viz" => build_kind!(nrslam_viz, table, ctx),
        "bag" => {
            let mut table = table;
            let remap = bag_remap(table.remove("remap"))?;
            let params: nrslam_runtime::bag::SourceParams = parse_params(table)?;
            let source = Box::new(nrslam_runtime::bag::BagSource::new(&params)?);
            if remap.is_empty() {
                source
            } else {
                Box::new(
                    nrslam_sensor_adapter::RemapOutputs::new(source, &remap)
                        .map_err(ParamsError::from)?,
                )
            }
        }
        other => return Err(BuildError::UnknownKind(other.to_owned())),
    })
}

/// A `bag` node's `remap = { "/from" = "/to", ... }` (outputs renamed, see
/// [`nrslam_sensor_adapter::remap`]), as (from, to) pairs; none if absent.
fn bag_remap(value: Option<toml::Value>) -> Result<Vec<(String, String)>, ParamsError> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    let bad = || {
        ParamsError::Parse(
            "remap: expected a table of topic names, e.g. remap = { \"/slam/pose\" = \"/ground_truth/pose\" }"
                .into(),
        )
    };
    let table = value.as_table().ok_or_else(bad)?;
    table
        .iter()
        .map(|(from, to)| Ok((from.clone(), to.as_str().ok_or_else(bad)?.to_owned())))
        .collect()
}

/// Frames the radar of a launch will produce, for the progress bar (None if unknown).
pub fn expected_frames(kind: &str, table: &toml::Table, ctx: &NodeContext) -> Option<u64> {
    if kind != "radar" {
        return None;
    }
    let params: nrslam_radar::Params = parse_params(table.clone()).ok()?;
    let scene = nrslam_radar::scene::Scene::load(&params.scene_path(&ctx.base_dir)).ok()?;
    let all = scene.trajectory.frame_count() as u64;
    Some(if params.frames == 0 {
        all
    } else {
        all.min(params.frames as u64)
    })
}
