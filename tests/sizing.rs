//! `nrslam sizing`: the answer depends on the seed alone, not on threads, shards, or a SIGKILL
//! and resume; bad requirement files are refused naming the field.

mod common;
use common::*;
use std::path::Path;
use std::process::Stdio;
use std::time::{Duration, Instant};

/// A small study on the hall: 40 frames a trial, eight configurations of which the screen drops
/// one (100 MHz, 8 antennas, −40 dB: a best peak SNR of −1.8 dB, nothing is detected).
fn requirement(dir: &Path) -> std::path::PathBuf {
    let launch = root().join("launch/paper-5g.toml");
    let text = format!(
        r#"
[scene]
launch = "{}"
frames = 40

[[requirement]]
metric = "position_error_p95_m"
threshold = 0.6

[[requirement]]
metric = "final_etgospa"
threshold = 30.0

[search]
bandwidth_mhz = [100, 800]
antennas = [8, 32]
snr_db = [-40, 10]
estimators = ["dft"]

[cost]
per_mhz = 1.0
per_antenna = 10.0

[trials]
seed = 3
first = 3
batch = 2
max = 7
"#,
        launch.display()
    );
    let path = dir.join("requirement.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn sizing(requirement: &Path, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "sizing",
        requirement.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    run_ok(&args)
}

fn trial_files(out: &Path) -> usize {
    std::fs::read_dir(out.join("trials"))
        .map(|d| {
            d.filter(|e| {
                e.as_ref()
                    .is_ok_and(|e| e.path().extension().is_some_and(|x| x == "csv"))
            })
            .count()
        })
        .unwrap_or(0)
}

#[test]
fn threads_shards_and_sigkill_do_not_change_the_frontier() {
    let dir = temp();
    let req = requirement(dir.path());
    let whole = dir.path().join("whole");
    let output = sizing(&req, &whole, &["--threads", "2"]);
    let frontier = read(&whole.join("frontier.csv"));
    // 8 = 2 × 2 × 2 of the search space, and the paper's configuration.
    assert_eq!(frontier.lines().count(), 1 + 9, "{frontier}");
    let status = |line: &str| line.rsplit(',').next().unwrap().to_owned();
    let statuses: Vec<String> = frontier.lines().skip(1).map(status).collect();
    assert_eq!(
        statuses.iter().filter(|s| *s == "screened").count(),
        1,
        "{frontier}"
    );
    assert!(statuses
        .iter()
        .all(|s| ["met", "not met", "undecided", "screened"].contains(&s.as_str())));
    assert!(
        stdout(&output).contains("The paper's configuration"),
        "{}",
        stdout(&output)
    );
    assert!(whole.join("frontier.png").is_file() && whole.join("sizing.md").is_file());
    // Trials spent: at least `first` for each simulated configuration, at most `max`.
    for line in frontier
        .lines()
        .skip(1)
        .filter(|l| !l.ends_with(",screened"))
    {
        let trials: u32 = line.split(',').nth(16).unwrap().parse().unwrap();
        assert!((3..=7).contains(&trials), "{line}");
    }

    // One thread.
    let one = dir.path().join("one-thread");
    sizing(&req, &one, &["--threads", "1"]);
    assert_eq!(frontier, read(&one.join("frontier.csv")), "one thread");

    // Two shards into one folder, then the run that writes the answer.
    let sharded = dir.path().join("sharded");
    let shard = sizing(&req, &sharded, &["--shard", "1/2"]);
    assert!(
        !sharded.join("frontier.csv").exists(),
        "a shard writes no answer"
    );
    assert!(stdout(&shard).contains("shard 1/2"));
    sizing(&req, &sharded, &["--shard", "2/2"]);
    let files = trial_files(&sharded);
    let last = sizing(&req, &sharded, &[]);
    assert_eq!(
        trial_files(&sharded),
        files,
        "the final run found every shard's work done"
    );
    assert!(stdout(&last).contains("wrote"));
    assert_eq!(frontier, read(&sharded.join("frontier.csv")), "shards");

    // SIGKILL at three points (once a first, a third and a fifth configuration has kept its
    // trials), each time resumed by the same command; then the last resume finishes.
    let killed = dir.path().join("killed");
    for files in [1, 3, 5] {
        let mut child = nrslam()
            .args([
                "sizing",
                req.to_str().unwrap(),
                "--out",
                killed.to_str().unwrap(),
                "--threads",
                "2",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let deadline = Instant::now() + Duration::from_secs(600);
        while trial_files(&killed) < files && Instant::now() < deadline {
            if child.try_wait().unwrap().is_some() {
                break;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        child.kill().unwrap_or(()); // SIGKILL on Unix.
        child.wait().unwrap();
        assert!(
            !killed.join("frontier.csv").exists(),
            "killed after {files} files"
        );
    }
    sizing(&req, &killed, &[]);
    assert_eq!(
        frontier,
        read(&killed.join("frontier.csv")),
        "killed and resumed"
    );
}

#[test]
fn bad_requirements_are_refused_naming_the_field() {
    let dir = temp();
    let good = std::fs::read_to_string(requirement(dir.path())).unwrap();
    let cases = [
        (
            good.replace("antennas = [8, 32]", "antennas = [8, 1000]"),
            "search.antennas",
        ),
        (
            good.replace("threshold = 0.6", "threshold = -1"),
            "requirement[0].threshold",
        ),
        (
            good.replace("bandwidth_mhz = [100, 800]", "bandwidth_mhz = []"),
            "search.bandwidth_mhz",
        ),
        (
            good.replace("estimators = [\"dft\"]", "estimators = [\"fft\"]"),
            "search.estimators",
        ),
        (good.replace("max = 7", "max = 2"), "trials.max"),
        (good.replace("[cost]", "[cost]\nper_watt = 3"), "per_watt"),
        (
            good.replace("metric = \"final_etgospa\"", "metric = \"etgospa\""),
            "metric",
        ),
        (good.replace("first = 3", "first = 3\nfirst = 4"), "first"),
        ("\u{0}\u{ff}garbage".to_owned(), "not a requirement file"),
    ];
    for (i, (text, field)) in cases.iter().enumerate() {
        let path = dir.path().join(format!("bad{i}.toml"));
        std::fs::write(&path, text).unwrap();
        let output = run(&[
            "sizing",
            path.to_str().unwrap(),
            "--out",
            dir.path().join("o").to_str().unwrap(),
        ]);
        assert!(!output.status.success(), "case {i} accepted");
        let stderr = String::from_utf8_lossy(&output.stderr);
        assert!(stderr.contains(field), "case {i}: {stderr}");
        assert!(!stderr.contains("panicked"), "case {i}: {stderr}");
    }
    // A folder holding another study is refused, not mixed.
    let req = requirement(dir.path());
    let out = dir.path().join("study");
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("requirement.toml"), "another study").unwrap();
    let output = run(&[
        "sizing",
        req.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(!output.status.success());
    assert!(String::from_utf8_lossy(&output.stderr).contains("another requirement"));
}
