//! The real binary on out-of-range numeric flags (issue 13, item 5): exit status 1, exactly one
//! line `error: --flag: ...` naming the flag, the value and the allowed range, and no panic.
//! Every verb's every flag against extreme and random values is src/cli_tests.rs (parser and
//! validation, in-process); these spawn the binary for representative cases, including the ones
//! the issue reported (`--rate 1e-300`, `--start-timeout-s 1e19`), a launch substitution cycle and
//! a `metric` whose assignment component is too large for the dense solver.

mod common;
use common::*;

/// Asserts a clean refusal: status 1, one stderr line starting `error: ` and holding `needles`.
fn assert_refused(args: &[&str], needles: &[&str]) {
    let output = run(args);
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert_eq!(output.status.code(), Some(1), "{args:?}: {stderr}");
    assert!(!stderr.contains("panicked"), "{args:?} panicked: {stderr}");
    let lines: Vec<&str> = stderr.lines().filter(|l| !l.trim().is_empty()).collect();
    assert_eq!(lines.len(), 1, "{args:?}: one line expected, got {stderr}");
    assert!(lines[0].starts_with("error: "), "{args:?}: {}", lines[0]);
    for needle in needles {
        assert!(
            lines[0].contains(needle),
            "{args:?}: {needle:?} missing from {}",
            lines[0]
        );
    }
}

#[test]
fn the_reported_overflows_are_refused_in_one_line() {
    assert_refused(
        &["launch", "launch/paper-ideal.toml", "--rate", "1e-300"],
        &["error: --rate: 1e-300 is out of range (allowed: 0 for as fast as possible"],
    );
    assert_refused(
        &[
            "launch",
            "launch/paper-ideal.toml",
            "--start-timeout-s",
            "1e19",
        ],
        &["error: --start-timeout-s: \"1e19\"", "1 to 604800 s"],
    );
    assert_refused(
        &[
            "launch",
            "launch/paper-ideal.toml",
            "--start-timeout-s",
            "10000000000000000000",
        ],
        &["error: --start-timeout-s: 10000000000000000000 is out of range"],
    );
    assert_refused(
        &["run", "radar", "--startup-delay-s", "1e300"],
        &["error: --startup-delay-s: 1e300 is out of range (allowed: 0 to 3600 s)"],
    );
}

#[test]
fn representative_flags_of_other_verbs() {
    let cases: &[(&[&str], &str)] = &[
        (&["run", "radar", "--rate", "NaN"], "--rate: NaN"),
        (
            &["launch", "l.toml", "--seed", "-1"],
            "--seed: -1 is out of range",
        ),
        (
            &["launch", "l.toml", "--seed", "18446744073709551616"],
            "--seed: 18446744073709551616 is out of range",
        ),
        (&["topics", "--duration-s", "inf"], "--duration-s: inf"),
        (&["echo", "/clock", "--count", "-5"], "--count: -5"),
        (
            &["metric", "--truth", "t", "--estimates", "e", "--alpha", "0"],
            "--alpha: 0 is out of range (allowed: 0 < alpha ≤ 2)",
        ),
        (
            &[
                "segment",
                "--input",
                "i",
                "--eps",
                "-1",
                "--min-samples",
                "0",
            ],
            "--eps: -1 is out of range",
        ),
        (
            &["accuracy", "--out", "o", "--antennas", "1e9"],
            "--antennas: \"1e9\" is not a whole number",
        ),
        (
            &[
                "montecarlo",
                "l.toml",
                "--out",
                "o",
                "--trials",
                "1000000000",
            ],
            "--trials: 1000000000 is out of range (allowed: 1 to 100000 trials)",
        ),
        (
            &[
                "montecarlo",
                "l.toml",
                "--out",
                "o",
                "--trials",
                "3",
                "--threads",
                "0",
            ],
            "--threads: 0 is out of range",
        ),
        (
            &["reproduce", "--out", "o", "--frames", "4294967296"],
            "--frames: 4294967296 is out of range",
        ),
        (
            &["tradeoff", "--out", "o", "--snr-db", "-1e300"],
            "--snr-db: -1e300 is out of range (allowed: -100 to 100 dB)",
        ),
        (
            &["scene", "--random", "--out", "o", "--circle-fraction", "2"],
            "--circle-fraction: 2 is out of range (allowed: 0 to 1)",
        ),
        // A flag of `nrslam bag` (its own module): clap's refusal, still one line.
        (
            &["bag", "play", "d", "--match-timeout-s=x"],
            "--match-timeout-s: \"x\"",
        ),
    ];
    for (args, needle) in cases {
        assert_refused(args, &[needle]);
    }
}

#[test]
fn a_launch_substitution_cycle_is_named() {
    let dir = temp();
    let file = dir.path().join("cycle.toml");
    std::fs::write(
        &file,
        "[arguments.a]\ndefault = \"$(var b)\"\n[arguments.b]\ndefault = \"x-$(var a)\"\n\
         [[node]]\nname = \"radar\"\nkind = \"radar\"\n[node.params]\nscene = \"$(var a)\"\n",
    )
    .unwrap();
    assert_refused(
        &["launch", file.to_str().unwrap()],
        &["cycle.toml: argument a: substitution cycle: a -> b -> a"],
    );
}

#[test]
fn a_metric_too_large_for_the_dense_assignment_is_refused_with_its_sizes() {
    let dir = temp();
    let truth = dir.path().join("truth.csv");
    let estimates = dir.path().join("estimates.csv");
    // 10 000 truth points × 10 000 estimates 1 m apart: c = 5 m chains them into one component
    // of 1e8 cells, past the 2^26 limit.
    let mut text = "target,x,y\n".to_owned();
    for k in 0..10_000 {
        text.push_str(&format!("{},{k},0\n", k / 4));
    }
    std::fs::write(&truth, text).unwrap();
    let mut text = "x,y\n".to_owned();
    for k in 0..10_000 {
        text.push_str(&format!("{k},1\n"));
    }
    std::fs::write(&estimates, text).unwrap();
    assert_refused(
        &[
            "metric",
            "--truth",
            truth.to_str().unwrap(),
            "--estimates",
            estimates.to_str().unwrap(),
        ],
        &["10000 × 10000 = 100000000 cells", "limit of 67108864 cells"],
    );
}
