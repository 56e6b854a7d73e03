//! The Slurm scripts of scripts/cluster on a real one-node Slurm cluster
//! (`scripts/cluster/local-slurm.sh start`): a study submitted as a job array with its dependent
//! final job gives byte for byte the files one unsharded run writes, and a request no node can
//! hold is refused before anything is submitted (docs/cluster.md).
//!
//! It needs root on Linux, with Slurm installed or apt-get to install it (the script installs
//! and starts the daemons). Where it cannot run, it passes saying so on stderr ("slurm test
//! skipped: ..."; `cargo test -- --nocapture` shows it). `NRSLAM_SLURM_TEST=skip` skips it
//! anywhere; `NRSLAM_SLURM_TEST=require` turns a skip into a failure, for CI.

mod common;
use common::*;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::{Mutex, MutexGuard, OnceLock};
use std::time::{Duration, Instant};

/// How long a submitted study may take, queueing included.
const TIMEOUT: Duration = Duration::from_secs(600);

fn script(name: &str) -> PathBuf {
    root().join("scripts/cluster").join(name)
}

/// Why this machine cannot run the test, if it cannot.
fn cannot_run() -> Option<String> {
    if std::env::var("NRSLAM_SLURM_TEST").as_deref() == Ok("skip") {
        return Some("NRSLAM_SLURM_TEST=skip".into());
    }
    if !cfg!(target_os = "linux") {
        return Some("not Linux".into());
    }
    let uid = Command::new("id")
        .arg("-u")
        .output()
        .map(|o| text(&o.stdout));
    if uid.as_deref().ok().map(str::trim) != Some("0") {
        return Some("not root (local-slurm.sh installs packages and starts daemons)".into());
    }
    let on_path = |tool: &str| {
        Command::new("sh")
            .args(["-c", &format!("command -v {tool}")])
            .output()
            .is_ok_and(|o| o.status.success())
    };
    if !on_path("slurmctld") && !on_path("apt-get") {
        return Some("neither Slurm nor apt-get to install it".into());
    }
    let site = Path::new("/etc/slurm/slurm.conf");
    if site.exists() && !std::fs::read_to_string(site).is_ok_and(|t| t.contains("local-slurm.sh")) {
        return Some(
            "/etc/slurm/slurm.conf is a real site's configuration, not local-slurm.sh's".into(),
        );
    }
    None
}

/// Starts the local cluster once per test binary (idempotent), and serializes the tests: each
/// fills the node. None (after saying why) when this machine cannot run them.
fn cluster() -> Option<MutexGuard<'static, ()>> {
    static STARTED: OnceLock<Result<(), String>> = OnceLock::new();
    static SERIAL: Mutex<()> = Mutex::new(());
    let guard = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let started = STARTED.get_or_init(|| {
        if let Some(why) = cannot_run() {
            return Err(why);
        }
        let out = Command::new(script("local-slurm.sh"))
            .arg("start")
            .output()
            .expect("local-slurm.sh runs");
        assert!(
            out.status.success(),
            "local-slurm.sh start failed:\n{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        Ok(())
    });
    match started {
        Ok(()) => Some(guard),
        Err(why) => {
            assert!(
                std::env::var("NRSLAM_SLURM_TEST").as_deref() != Ok("require"),
                "NRSLAM_SLURM_TEST=require, but this machine cannot run the Slurm test: {why}"
            );
            eprintln!("slurm test skipped: {why}");
            None
        }
    }
}

/// Runs a study script from the repository root with `env`, the debug nrslam and OUT=`out`.
fn submit(name: &str, out: &Path, env: &[(&str, &str)]) -> Output {
    Command::new(script(name))
        .current_dir(root())
        .env("NRSLAM", env!("CARGO_BIN_EXE_nrslam"))
        .env("OUT", out)
        .envs(env.iter().copied())
        .output()
        .expect("the study script runs")
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// The jobs' logs under `out/logs`, for a failure message.
fn logs(out: &Path) -> String {
    let mut all = String::new();
    if let Ok(entries) = std::fs::read_dir(out.join("logs")) {
        let mut paths: Vec<_> = entries.flatten().map(|e| e.path()).collect();
        paths.sort();
        for path in paths {
            all += &format!(
                "---- {}\n{}",
                path.display(),
                std::fs::read_to_string(&path).unwrap_or_default()
            );
        }
    }
    all
}

/// The job ids in the script's first line, "submitted array job A (...) and merge job M": (A, M).
fn job_ids(stdout: &str) -> (String, String) {
    let words: Vec<&str> = stdout
        .lines()
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect();
    let array = words.iter().position(|w| *w == "job").map(|i| words[i + 1]);
    match (array, words.last()) {
        (Some(array), Some(last)) => (array.to_string(), last.to_string()),
        _ => panic!("no job ids in {stdout:?}"),
    }
}

/// A job's state from `scontrol show job` (finished jobs stay listed: MinJobAge is an hour in
/// local-slurm.sh's configuration), with its reason.
fn job_state(job: &str) -> (String, String) {
    let out = Command::new("scontrol")
        .args(["show", "job", job, "--oneliner"])
        .output()
        .expect("scontrol runs");
    let line = text(&out.stdout);
    let field = |name: &str| {
        line.split_whitespace()
            .find_map(|f| f.strip_prefix(name))
            .unwrap_or("")
            .to_string()
    };
    (field("JobState="), field("Reason="))
}

/// Waits until the final job `last` (which depends on the array `array`) completes, failing on a
/// failed job, a dependency that can never be met, or the timeout (cancelling both jobs).
fn wait_for(array: &str, last: &str, out: &Path) {
    let start = Instant::now();
    loop {
        let (state, reason) = job_state(last);
        match state.as_str() {
            "COMPLETED" => return,
            "PENDING" | "RUNNING" | "CONFIGURING" | "COMPLETING"
                if reason != "DependencyNeverSatisfied" => {}
            _ => {
                let _ = Command::new("scancel").args([array, last]).status();
                panic!("job {last} is {state} ({reason}); logs:\n{}", logs(out));
            }
        }
        if start.elapsed() > TIMEOUT {
            let _ = Command::new("scancel").args([array, last]).status();
            panic!(
                "job {last} not done after {TIMEOUT:?} ({state}, {reason}); logs:\n{}",
                logs(out)
            );
        }
        std::thread::sleep(Duration::from_secs(2));
    }
}

#[test]
fn montecarlo_job_array_merges_into_the_unsharded_files() {
    let Some(_cluster) = cluster() else { return };
    let dir = temp();
    let out = dir.path().join("mc");
    let launch = "launch/paper-ideal.toml loop_closure:=false viz:=false frames:=40";
    let submitted = submit(
        "slurm-montecarlo.sh",
        &out,
        &[
            ("SHARDS", "4"),
            ("TRIALS", "8"),
            ("LAUNCH", launch),
            ("CPUS_PER_TASK", "1"),
            ("TIME_LIMIT", "00:15:00"),
        ],
    );
    assert!(
        submitted.status.success(),
        "submission failed: {}{}",
        text(&submitted.stdout),
        text(&submitted.stderr)
    );
    let (array, merge) = job_ids(&text(&submitted.stdout));

    // The one-machine run, while the cluster works.
    let unsharded = dir.path().join("unsharded");
    let mut args: Vec<&str> = vec!["montecarlo"];
    args.extend(launch.split_whitespace());
    args.extend([
        "--trials",
        "8",
        "--seed",
        "1",
        "--threads",
        "1",
        "--out",
        unsharded.to_str().unwrap(),
    ]);
    run_ok(&args);

    wait_for(&array, &merge, &out);
    for k in 1..=4 {
        assert!(
            out.join(format!("logs/nrslam-mc-{array}_{k}.log"))
                .is_file(),
            "no log of task {k}: {}",
            logs(&out)
        );
    }
    for file in ["montecarlo.csv", "trials.csv", "study.json"] {
        let merged = std::fs::read(out.join("merged").join(file))
            .unwrap_or_else(|e| panic!("merged/{file}: {e}\n{}", logs(&out)));
        assert!(
            merged == std::fs::read(unsharded.join(file)).unwrap(),
            "merged {file} differs from the unsharded run's"
        );
    }
}

#[test]
fn a_request_no_node_can_hold_is_refused_before_submitting() {
    let Some(_cluster) = cluster() else { return };
    let cpus = Command::new("sinfo")
        .args(["-h", "-N", "-o", "%c"])
        .output()
        .expect("sinfo runs");
    let most: u32 = text(&cpus.stdout)
        .split_whitespace()
        .filter_map(|c| c.trim_end_matches('+').parse().ok())
        .max()
        .expect("sinfo lists a node");
    let too_many = (most + 1).to_string();
    let dir = temp();
    let out = dir.path().join("mc");
    let refused = submit(
        "slurm-montecarlo.sh",
        &out,
        &[
            ("SHARDS", "2"),
            ("TRIALS", "2"),
            ("CPUS_PER_TASK", &too_many),
        ],
    );
    assert_eq!(
        refused.status.code(),
        Some(2),
        "{}{}",
        text(&refused.stdout),
        text(&refused.stderr)
    );
    let message = text(&refused.stderr);
    assert!(
        message.contains(&format!("CPUS_PER_TASK={too_many}"))
            && message.contains(&format!("has {most} CPUs")),
        "{message}"
    );
    assert!(
        !out.exists(),
        "nothing is created or submitted when the request is refused"
    );
}

/// The files of a sizing study folder: every file but the logs, by path relative to `dir`.
fn study_files(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        for entry in std::fs::read_dir(&folder).unwrap().flatten() {
            let path = entry.path();
            let relative = path.strip_prefix(dir).unwrap().to_path_buf();
            if relative.starts_with("logs") {
                continue;
            } else if path.is_dir() {
                stack.push(path);
            } else {
                files.push((relative, std::fs::read(&path).unwrap()));
            }
        }
    }
    files.sort();
    files
}

#[test]
fn sizing_job_array_gives_the_one_machine_study() {
    let Some(_cluster) = cluster() else { return };
    let dir = temp();
    let requirement = dir.path().join("requirement.toml");
    std::fs::write(
        &requirement,
        format!(
            "[scene]\nlaunch = {:?}\nframes = 20\n\n[[requirement]]\nmetric = \
             \"position_error_rmse_m\"\nthreshold = 0.5\n\n[search]\nbandwidth_mhz = [100, 400]\n\
             antennas = [4, 8]\n\n[trials]\nfirst = 2\nbatch = 2\nmax = 4\n",
            root().join("launch/paper-5g.toml")
        ),
    )
    .unwrap();
    let out = dir.path().join("sizing");
    let submitted = submit(
        "slurm-sizing.sh",
        &out,
        &[
            ("REQUIREMENT", requirement.to_str().unwrap()),
            ("SHARDS", "3"),
            ("CPUS_PER_TASK", "1"),
            ("TIME_LIMIT", "00:15:00"),
        ],
    );
    assert!(
        submitted.status.success(),
        "submission failed: {}{}",
        text(&submitted.stdout),
        text(&submitted.stderr)
    );
    let (array, last) = job_ids(&text(&submitted.stdout));

    let one = dir.path().join("one-machine");
    run_ok(&[
        "sizing",
        requirement.to_str().unwrap(),
        "--out",
        one.to_str().unwrap(),
        "--threads",
        "1",
    ]);

    wait_for(&array, &last, &out);
    let sharded = study_files(&out);
    let unsharded = study_files(&one);
    let names =
        |files: &[(PathBuf, Vec<u8>)]| files.iter().map(|f| f.0.clone()).collect::<Vec<_>>();
    assert_eq!(
        names(&sharded),
        names(&unsharded),
        "the same files\n{}",
        logs(&out)
    );
    assert!(
        sharded.iter().any(|f| f.0 == Path::new("frontier.csv")),
        "{}",
        logs(&out)
    );
    for ((name, a), (_, b)) in sharded.iter().zip(&unsharded) {
        if name == Path::new("sizing.md") {
            // It quotes the command, whose --out differs.
            let a = text(a).replace(out.to_str().unwrap(), "OUT");
            let b = text(b).replace(one.to_str().unwrap(), "OUT");
            assert_eq!(a, b, "sizing.md");
        } else {
            assert!(
                a == b,
                "{} differs from the one-machine study's",
                name.display()
            );
        }
    }
}
