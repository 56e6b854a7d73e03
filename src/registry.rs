//! Node kinds the CLI can build, by the name a launch file gives them.

use nrslam_runtime::{parse_params, Node, NodeContext, NodeError, ParamsError};

/// Why a node could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    /// No such kind.
    #[error("unknown node kind {0:?} (known: radar, estimator, association, mapper, segmenter, evaluator, bag)")]
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
}

macro_rules! build_kind {
    ($crate_name:ident, $table:expr, $ctx:expr) => {{
        let params: $crate_name::Params = parse_params($table)?;
        params.validate().map_err(ParamsError::from)?;
        $crate_name::build(params, $ctx)?
    }};
}

/// Builds a node of `kind` from its parameter table.
pub fn build(
    kind: &str,
    table: toml::Table,
    ctx: &NodeContext,
) -> Result<Box<dyn Node>, BuildError> {
    Ok(match kind {
        "radar" => build_kind!(nrslam_radar, table, ctx),
        "association" => build_kind!(nrslam_association, table, ctx),
        "mapper" => build_kind!(nrslam_mapper, table, ctx),
        "segmenter" => build_kind!(nrslam_segmenter, table, ctx),
        "evaluator" => build_kind!(nrslam_evaluator, table, ctx),
        "estimator" => build_kind!(nrslam_estimator, table, ctx),
        "bag" => {
            let params: nrslam_runtime::bag::SourceParams = parse_params(table)?;
            Box::new(nrslam_runtime::bag::BagSource::new(&params)?)
        }
        other => return Err(BuildError::UnknownKind(other.to_owned())),
    })
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
