//! Every flag of every verb against extreme and random values, through the real parser and the
//! verbs' `validate()` ([`parse_and_validate`], what `main` runs before any work): nothing may
//! panic, a refused value gives one line naming its flag, and each numeric flag accepts exactly
//! the range written in [`RANGES`] (the specification, kept apart from the code's constants).
//!
//! The flags are found by walking clap's command tree, so a flag added later is fed the same
//! values; a new numeric flag without a line in [`RANGES`] (or a new verb without a line in
//! [`BASE`]) fails the test. Spawning the binary for a few of these cases is
//! tests/cli_numeric_flags.rs.
mod harness;
mod spec;

use crate::{parse_and_validate, Refused};
use harness::{check, flags, is_numeric, range_of};
use proptest::prelude::*;
use spec::{BASE, EXTREMES, RANGES};

#[test]
fn every_verb_has_a_base_and_every_numeric_flag_a_range() {
    let flags = flags();
    assert!(flags.len() > 60, "only {} flags found", flags.len());
    let numeric = |verb: &str, flag: &str| {
        flags
            .iter()
            .find(|(v, f, _)| v == verb && f == flag)
            .map(|(_, _, t)| is_numeric(*t))
    };
    assert_eq!(numeric("launch", "--rate"), Some(true));
    assert_eq!(numeric("bag play", "--ros-domain-id"), Some(true));
    assert_eq!(numeric("metric", "--p"), Some(false));
    assert_eq!(
        flags.iter().filter(|(_, _, t)| is_numeric(*t)).count(),
        RANGES.len()
    );
    for (verb, flag, type_id) in &flags {
        assert!(
            BASE.iter().any(|(v, _)| v == verb),
            "verb {verb:?} has no line in BASE"
        );
        if is_numeric(*type_id) {
            assert!(
                range_of(verb, flag).is_some(),
                "{verb} {flag} is numeric and has no line in RANGES"
            );
        }
    }
    for (verb, flag, _) in RANGES {
        assert!(
            flags.iter().any(|(v, f, _)| v == verb && f == flag),
            "RANGES names {verb} {flag}, which is not a flag"
        );
    }
    // Each base command line is valid as it stands.
    for (verb, base) in BASE {
        let mut args = vec!["nrslam".to_owned()];
        args.extend(verb.split(' ').map(str::to_owned));
        args.extend(base.iter().map(|s| s.to_string()));
        assert!(parse_and_validate(args.clone()).is_ok(), "{args:?}");
    }
}

#[test]
fn extreme_values_of_every_flag_are_refused_in_one_line_or_accepted_by_the_range() {
    let mut failures = Vec::new();
    for (verb, flag, type_id) in flags() {
        for value in EXTREMES {
            if let Err(failure) = check(&verb, &flag, type_id, value) {
                failures.push(failure);
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn the_issue_cases_name_the_flag_the_value_and_the_range() {
    let line = |args: &[&str]| match parse_and_validate(args.iter().copied()) {
        Err(Refused::Line(line)) => line,
        other => panic!("{args:?}: {other:?}"),
    };
    assert_eq!(
        line(&["nrslam", "launch", "l.toml", "--rate", "1e-300"]),
        "--rate: 1e-300 is out of range (allowed: 0 for as fast as possible, or a real-time \
         factor from 1e-6 to 1e6)"
    );
    assert_eq!(
        line(&["nrslam", "launch", "l.toml", "--start-timeout-s", "1e19"]),
        "--start-timeout-s: \"1e19\" is not a whole number (allowed: 1 to 604800 s (a week))"
    );
    assert_eq!(
        line(&[
            "nrslam",
            "run",
            "radar",
            "--start-timeout-s",
            "10000000000000000000"
        ]),
        "--start-timeout-s: 10000000000000000000 is out of range (allowed: 1 to 604800 s (a week))"
    );
    let joint = line(&[
        "nrslam",
        "metric",
        "--truth",
        "t",
        "--estimates",
        "e",
        "--c",
        "10",
        "--p",
        "200",
    ]);
    assert!(joint.starts_with("--p: c^p = 1e200"), "{joint}");
    let joint = line(&[
        "nrslam",
        "accuracy",
        "--out",
        "o",
        "--subcarriers",
        "16777216",
        "--antennas",
        "4096",
    ]);
    assert!(
        joint.starts_with("--subcarriers/--antennas: N × K = 16777216 × 4096"),
        "{joint}"
    );
}

fn any_value() -> impl Strategy<Value = String> {
    prop_oneof![
        any::<f64>().prop_map(|v| format!("{v:?}")),
        any::<f64>().prop_map(|v| format!("{v:e}")),
        (-1e7..1e7f64).prop_map(|v| v.to_string()),
        any::<u64>().prop_map(|v| v.to_string()),
        any::<i64>().prop_map(|v| v.to_string()),
        (0u64..2_000_000).prop_map(|v| v.to_string()),
        "[0-9]{15,60}",
        "-?[0-9.eE+-]{1,12}",
        ".{0,12}",
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn random_values_of_every_flag_never_panic_and_follow_the_ranges(
        pick in any::<prop::sample::Index>(),
        value in any_value(),
    ) {
        let flags = flags();
        let (verb, flag, type_id) = &flags[pick.index(flags.len())];
        if let Err(failure) = check(verb, flag, *type_id, &value) {
            prop_assert!(false, "{}", failure);
        }
    }
}
