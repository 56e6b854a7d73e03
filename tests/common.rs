//! Helpers shared by the integration tests: run the real `nrslam` binary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The column `name` of a CSV text with a header row, each field parsed as written (a NaN stays
/// NaN).
pub fn csv_column(csv: &str, name: &str) -> Vec<f64> {
    let mut lines = csv.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let index = header
        .iter()
        .position(|h| *h == name)
        .unwrap_or_else(|| panic!("no column {name}"));
    lines
        .map(|l| l.split(',').nth(index).unwrap().parse().unwrap())
        .collect()
}

/// The `nrslam` binary cargo built for these tests.
pub fn nrslam() -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_nrslam"));
    command.current_dir(env!("CARGO_MANIFEST_DIR"));
    command
}

/// Runs `nrslam` with `args`, returning its output.
pub fn run(args: &[&str]) -> Output {
    nrslam().args(args).output().expect("nrslam runs")
}

/// Runs `nrslam` with `args` and asserts that it succeeded, showing its stderr if not.
pub fn run_ok(args: &[&str]) -> Output {
    let output = run(args);
    assert!(
        output.status.success(),
        "nrslam {args:?} failed: {}",
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

/// The repository root.
pub fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A fresh temporary folder.
pub fn temp() -> tempfile::TempDir {
    tempfile::tempdir().expect("temp dir")
}

/// Reads a file to a string, naming it on failure.
pub fn read(path: &Path) -> String {
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A free loopback TCP port.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// Waits until something listens on loopback TCP `port` (a launcher started with `--listen`),
/// calling `still_waiting` between tries (to fail early when that launcher has ended); at most
/// 60 s.
pub fn wait_listening(port: u16, mut still_waiting: impl FnMut()) {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
        still_waiting();
        assert!(
            std::time::Instant::now() < deadline,
            "nothing listened on port {port}"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

/// The summary.json of a run as JSON.
pub fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&read(&dir.join("summary.json"))).expect("summary.json is JSON")
}

/// Runs `nrslam` with `args` in `dir` and asserts that it succeeded, showing its stderr if not.
pub fn run_ok_in(dir: &Path, args: &[&str]) -> Output {
    let output = nrslam()
        .current_dir(dir)
        .args(args)
        .output()
        .expect("nrslam runs");
    assert!(
        output.status.success(),
        "nrslam {args:?} in {} failed: {}",
        dir.display(),
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

/// The standard output of a run, as text.
pub fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// Asserts that `output` is a failure reported as one line of stderr (no panic) that contains
/// each of `must_contain`.
pub fn assert_one_line_failure(output: &Output, must_contain: &[&str]) {
    assert!(!output.status.success(), "should fail");
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!stderr.contains("panicked"), "panicked: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "one line expected, got: {stderr}");
    for needle in must_contain {
        assert!(
            lines[0].contains(needle),
            "{needle:?} missing from: {}",
            lines[0]
        );
    }
}

/// A zenoh peer of this test process, without scouting, listening on `listen` and connecting to
/// `connect`, set up as nrslam's own sessions are.
pub fn zenoh_peer(listen: &[String], connect: &[String]) -> zenoh::Session {
    let config = nrslam_runtime::transport::TransportConfig {
        listen: listen.to_vec(),
        connect: connect.to_vec(),
        ..Default::default()
    };
    nrslam_runtime::transport::open(&config).expect("the test's zenoh session opens")
}

/// `nrslam metric` on the `truth` and `estimates` CSV files, with `extra` flags.
pub fn metric(truth: &Path, estimates: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "metric",
        "--truth",
        truth.to_str().unwrap(),
        "--estimates",
        estimates.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    run(&args)
}

/// Writes `text` as the launch file `bad.toml` in a new temporary folder, launches it, and
/// asserts the one-line failure of [`assert_one_line_failure`].
pub fn assert_launch_refused(text: &str, must_contain: &[&str]) {
    let dir = temp();
    let file = dir.path().join("bad.toml");
    std::fs::write(&file, text).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
    let output = run(&["launch", file.to_str().unwrap()]);
    assert_one_line_failure(&output, must_contain);
}

/// The pid of the child of `parent` running the node `name` (`--name NAME` on its command
/// line, as processes mode starts each node), read from /proc; `None` where there is none.
pub fn node_pid(parent: u32, name: &str) -> Option<u32> {
    let needle = format!("--name\0{name}\0");
    for entry in std::fs::read_dir("/proc").ok()?.flatten() {
        let Ok(pid) = entry.file_name().to_string_lossy().parse::<u32>() else {
            continue;
        };
        let Ok(stat) = std::fs::read_to_string(format!("/proc/{pid}/stat")) else {
            continue;
        };
        // The parent pid is the second field after the parenthesised command name.
        let ppid = stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().nth(1))
            .and_then(|p| p.parse::<u32>().ok());
        let cmdline = std::fs::read(format!("/proc/{pid}/cmdline")).unwrap_or_default();
        if ppid == Some(parent) && String::from_utf8_lossy(&cmdline).contains(&needle) {
            return Some(pid);
        }
    }
    None
}
