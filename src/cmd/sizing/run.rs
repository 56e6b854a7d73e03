//! Running the trials: every configuration's launches loaded and built up front (a bad
//! configuration fails before any time is spent), then rounds. Each round gives every
//! undecided configuration the trials up to its next look; all of them run in parallel, and a
//! configuration's file is rewritten as soon as its batch is complete.

use super::requirement::Requirement;
use super::sequential::{decide, Status};
use super::space::Config;
use super::store::Store;
use super::trial::summarise;
use crate::cmd::launch::build_all;
use crate::cmd::montecarlo::run_trial;
use anyhow::{bail, Context, Result};
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_runtime::launch::Launch;
use rayon::prelude::*;
use std::path::Path;
use std::sync::Mutex;

/// One configuration to simulate: its launches (one per scene) and its trials so far.
pub struct Job<'a> {
    pub config: &'a Config,
    pub launches: Vec<Launch>,
    pub trials: Vec<[f64; 5]>,
}

/// Loads and builds `config`'s launch once per scene.
pub fn load(
    requirement: &Requirement,
    config: &Config,
    scenes: &[Option<std::path::PathBuf>],
) -> Result<Vec<Launch>> {
    scenes
        .iter()
        .map(|scene| {
            let mut assignments = config.assignments(requirement.scene.frames);
            if let Some(scene) = scene {
                assignments.push(format!("scene:={}", scene.display()));
            }
            let launch = Launch::load(&requirement.scene.launch, &assignments)
                .with_context(|| format!("configuration {}", config.id()))?;
            build_all(&launch, requirement.trials.seed)
                .with_context(|| format!("configuration {}", config.id()))?;
            Ok(launch)
        })
        .collect()
}

/// Runs every job's trials until each is decided or at its budget, keeping them in `store`.
pub fn run(
    requirement: &Requirement,
    store: &Store,
    jobs: &mut [Job<'_>],
    threads: Option<usize>,
) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads.unwrap_or(0))
        .build()
        .context("starting worker threads")?;
    let bar = ProgressBar::new(jobs.len() as u64);
    bar.set_style(
        ProgressStyle::with_template(
            "{bar:40} {pos}/{len} configurations decided  {elapsed_precise}  {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let mut trials_run = 0u64;
    loop {
        let decided = jobs
            .iter()
            .filter(|j| next_count(requirement, j).is_none())
            .count();
        bar.set_position(decided as u64);
        // (job, first trial, trials wanted) for every job with a look due.
        let due: Vec<(usize, usize, usize)> = jobs
            .iter()
            .enumerate()
            .filter_map(|(i, j)| {
                next_count(requirement, j).map(|n| (i, j.trials.len(), n as usize))
            })
            .collect();
        if due.is_empty() {
            break;
        }
        let work: Vec<(usize, usize)> = due
            .iter()
            .flat_map(|&(i, from, to)| (from..to).map(move |t| (i, t)))
            .collect();
        bar.set_message(format!(
            "{trials_run} trials run, {} in this round over {} configurations",
            work.len(),
            due.len()
        ));
        // Each job's batch as it fills: slot t − from holds trial t's summary.
        let batches: Vec<Mutex<Vec<Option<[f64; 5]>>>> = jobs
            .iter()
            .enumerate()
            .map(|(i, _)| {
                let size = due.iter().find(|d| d.0 == i).map_or(0, |d| d.2 - d.1);
                Mutex::new(vec![None; size])
            })
            .collect();
        let jobs_ref = &*jobs;
        pool.install(|| {
            work.par_iter().try_for_each(|&(i, t)| -> Result<()> {
                let job = &jobs_ref[i];
                let launch = &job.launches[t % job.launches.len()];
                let seed = nrslam_runtime::seed::trial(requirement.trials.seed, t as u64);
                let rows = run_trial(launch, seed)
                    .with_context(|| format!("configuration {}, trial {t}", job.config.id()))?;
                let summary = summarise(&rows);
                if summary.iter().any(|v| !v.is_finite()) {
                    bail!(
                        "configuration {}, trial {t}: no frame was evaluated (frames:={} in \
                         the requirement's scene table?)",
                        job.config.id(),
                        requirement.scene.frames
                    );
                }
                let from = job.trials.len();
                let mut batch = batches[i].lock().unwrap_or_else(|e| e.into_inner());
                batch[t - from] = Some(summary);
                if batch.iter().all(Option::is_some) {
                    let mut all = job.trials.clone();
                    all.extend(batch.iter().flatten());
                    store.save(&job.config.id(), &all)?;
                }
                Ok(())
            })
        })?;
        trials_run += work.len() as u64;
        for (i, batch) in batches.into_iter().enumerate() {
            let batch = batch.into_inner().unwrap_or_else(|e| e.into_inner());
            jobs[i].trials.extend(batch.into_iter().flatten());
        }
    }
    bar.finish_and_clear();
    Ok(())
}

/// The trial count of `job`'s next look, or `None` once it is decided or at its budget.
pub fn next_count(requirement: &Requirement, job: &Job<'_>) -> Option<u32> {
    let decision = decide(&requirement.requirements, &requirement.trials, &job.trials);
    if decision.status == Status::Undecided {
        decision.more_due
    } else {
        None
    }
}

/// The scene files of the study: the requirement's file, or its random family written under
/// `dir/scenes/`, or `[None]`: the launch's own scene.
pub fn scenes(requirement: &Requirement, dir: &Path) -> Result<Vec<Option<std::path::PathBuf>>> {
    use nrslam_radar::random_scene::{self, RandomSceneParams};
    if let Some(file) = &requirement.scene.file {
        return Ok(vec![Some(file.clone())]);
    }
    let Some(random) = &requirement.scene.random else {
        return Ok(vec![None]);
    };
    let folder = dir.join("scenes");
    std::fs::create_dir_all(&folder)
        .with_context(|| format!("cannot create {}", folder.display()))?;
    (0..random.count as u64)
        .map(|j| {
            let seed = random.seed.wrapping_add(j);
            let spec = random_scene::generate(&RandomSceneParams::default(), seed)
                .with_context(|| format!("random scene for seed {seed}"))?;
            let header = format!(
                "A random scene of a sizing study: nrslam scene --random --seed {seed} writes \
                 the same.\n"
            );
            let text = random_scene::to_toml(&spec, &header)?;
            let path = folder.join(format!("scene-{seed}.toml"));
            super::store::write_atomically(&path, text.as_bytes())?;
            Ok(Some(path))
        })
        .collect()
}

/// The fewest targets of any scene of the study (the screen's all-missed ET-GOPSA).
pub fn fewest_targets(
    requirement: &Requirement,
    scenes: &[Option<std::path::PathBuf>],
) -> Result<usize> {
    let mut fewest = usize::MAX;
    for scene in scenes {
        let path = match scene {
            Some(path) => path.clone(),
            None => launch_scene(requirement)?,
        };
        let loaded = nrslam_radar::scene::Scene::load(&path)
            .map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        fewest = fewest.min(loaded.targets.len());
    }
    Ok(fewest)
}

/// The scene file the launch runs by default: its radar node's `scene` parameter.
fn launch_scene(requirement: &Requirement) -> Result<std::path::PathBuf> {
    let launch = Launch::load(&requirement.scene.launch, &[])?;
    let radar = launch
        .nodes
        .iter()
        .find(|n| n.kind == "radar")
        .with_context(|| format!("{}: no radar node", launch.path.display()))?;
    let scene = radar
        .params
        .get("scene")
        .and_then(|v| v.as_str())
        .with_context(|| {
            format!(
                "{}: the radar node has no scene parameter; name a scene file in the \
                 requirement's [scene] table",
                launch.path.display()
            )
        })?;
    Ok(radar.base_dir.join(scene))
}
