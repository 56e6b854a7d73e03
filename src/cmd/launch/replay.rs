//! The identity of a run (launch, arguments, seed), written into a recorded bag and read back
//! when the bag is replayed.

use crate::report::Reporter;
use anyhow::{Context, Result};
use nrslam_runtime::bag;
use nrslam_runtime::launch::Launch;
use std::path::PathBuf;

/// The identity (launch, arguments, seed) of a recorded run, from its bag's `custom_data`.
pub(super) struct RecordedRun {
    launch: String,
    arguments: std::collections::BTreeMap<String, serde_json::Value>,
    seed: u64,
}

impl RecordedRun {
    /// The recorded run's summary is reproduced: it names the recorded launch, not the replay.
    pub(super) fn apply(&self, summary: &mut crate::report::Summary) {
        summary.launch = self.launch.clone();
        summary.arguments = self.arguments.clone();
        summary.seed = self.seed;
    }
}

/// `custom_data` identifying the run of `launch` with `seed`.
pub(super) fn run_identity(
    launch: &Launch,
    seed: u64,
) -> Result<std::collections::BTreeMap<String, String>> {
    let summary =
        Reporter::default().summary(&launch.arguments, seed, &launch.path.display().to_string());
    Ok(std::collections::BTreeMap::from([
        (bag::RUN_LAUNCH_KEY.to_owned(), summary.launch),
        (
            bag::RUN_ARGUMENTS_KEY.to_owned(),
            serde_json::to_string(&summary.arguments)?,
        ),
        (bag::RUN_SEED_KEY.to_owned(), seed.to_string()),
    ]))
}

/// For a launch that replays a bag (a node of kind `bag`): the bag and its recorded run.
pub(super) fn replayed_run(launch: &Launch) -> Result<Option<(PathBuf, RecordedRun)>> {
    let Some(decl) = launch.nodes.iter().find(|n| n.kind == "bag") else {
        return Ok(None);
    };
    let Some(path) = decl.params.get("path").and_then(|p| p.as_str()) else {
        return Ok(None);
    };
    let recover = decl
        .params
        .get("recover")
        .and_then(|r| r.as_bool())
        .unwrap_or(false);
    let dir = PathBuf::from(path);
    let custom = bag::custom_data(&dir, recover)?;
    let identity = match (
        custom.get(bag::RUN_LAUNCH_KEY),
        custom.get(bag::RUN_ARGUMENTS_KEY),
        custom.get(bag::RUN_SEED_KEY),
    ) {
        (Some(launch), Some(arguments), Some(seed)) => RecordedRun {
            launch: launch.clone(),
            arguments: serde_json::from_str(arguments).with_context(|| {
                format!("{}: custom_data {}", dir.display(), bag::RUN_ARGUMENTS_KEY)
            })?,
            seed: seed
                .parse()
                .with_context(|| format!("{}: custom_data {}", dir.display(), bag::RUN_SEED_KEY))?,
        },
        // A bag recorded from a live graph does not know its run: the replay names itself.
        _ => return Ok(None),
    };
    Ok(Some((dir, identity)))
}
