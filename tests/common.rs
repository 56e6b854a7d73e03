//! Helpers shared by the integration tests: run the real `nrslam` binary.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

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

/// The summary.json of a run as JSON.
pub fn summary(dir: &Path) -> serde_json::Value {
    serde_json::from_str(&read(&dir.join("summary.json"))).expect("summary.json is JSON")
}
