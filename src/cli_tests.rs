//! Every flag of every verb against extreme and random values, through the real parser and the
//! verbs' `validate()` ([`parse_and_validate`], what `main` runs before any work): nothing may
//! panic, a refused value gives one line naming its flag, and each numeric flag accepts exactly
//! the range written in [`RANGES`] (the specification, kept apart from the code's constants).
//!
//! The flags are found by walking clap's command tree, so a flag added later is fed the same
//! values; a new numeric flag without a line in [`RANGES`] (or a new verb without a line in
//! [`BASE`]) fails the test. Spawning the binary for a few of these cases is
//! tests/cli_numeric_flags.rs.

use crate::{parse_and_validate, Cli, Refused};
use clap::CommandFactory;
use proptest::prelude::*;
use std::any::TypeId;

/// A valid command line for each verb (path of subcommand names, then arguments); a flag under
/// test replaces its own entry here.
const BASE: &[(&str, &[&str])] = &[
    ("launch", &["launch/paper-ideal.toml"]),
    ("run", &["radar"]),
    ("topics", &[]),
    ("echo", &["/clock"]),
    ("metric", &["--truth", "t.csv", "--estimates", "e.csv"]),
    (
        "segment",
        &["--input", "i.csv", "--eps", "1", "--min-samples", "2"],
    ),
    ("accuracy", &["--out", "o"]),
    ("montecarlo", &["l.toml", "--trials", "2", "--out", "o"]),
    ("merge", &["a", "--out", "o"]),
    ("reproduce", &["--out", "o"]),
    ("tradeoff", &["--out", "o"]),
    ("scene", &["--random", "--out", "o"]),
    ("bag record", &["d"]),
    ("bag info", &["d"]),
    ("bag play", &["d"]),
];

/// What a numeric flag accepts.
#[derive(Debug, Clone, Copy)]
enum Range {
    /// Finite reals in [min, max] (`min` excluded when `open`), plus 0 when `zero`.
    Real {
        min: f64,
        max: f64,
        open: bool,
        zero: bool,
    },
    /// Whole numbers in [min, max].
    Whole { min: u128, max: u128 },
    /// Not this test's to say (the flag belongs to `nrslam bag`, src/bag.rs): only "no panic,
    /// one line naming the flag".
    Unchecked,
}

const fn real(min: f64, max: f64) -> Range {
    Range::Real {
        min,
        max,
        open: false,
        zero: false,
    }
}

const fn whole(min: u128, max: u128) -> Range {
    Range::Whole { min, max }
}

const SEED: Range = whole(0, u64::MAX as u128);
const RATE: Range = Range::Real {
    min: 1e-6,
    max: 1e6,
    open: false,
    zero: true,
};
const WEEK_S: u128 = 604_800;

/// The allowed range of every numeric flag: (verb, flag, range).
const RANGES: &[(&str, &str, Range)] = &[
    ("launch", "--seed", SEED),
    ("launch", "--rate", RATE),
    ("launch", "--start-timeout-s", whole(1, WEEK_S)),
    ("launch", "--chunk-size-kib", whole(1, 1 << 20)),
    ("launch", "--ros-domain-id", whole(0, 232)),
    ("run", "--seed", SEED),
    ("run", "--start-timeout-s", whole(1, WEEK_S)),
    ("run", "--startup-delay-s", real(0.0, 3600.0)),
    ("run", "--rate", RATE),
    ("topics", "--duration-s", real(1e-3, 3600.0)),
    ("echo", "--count", whole(0, u64::MAX as u128)),
    ("metric", "--c", real(1e-12, 1e12)),
    // 0 < α ≤ 2, and c^p/α ≤ 1e100: with the default c = 5, p = 1, α ≥ 5e-100.
    ("metric", "--alpha", real(5e-100, 2.0)),
    ("segment", "--eps", real(0.0, 1e9)),
    ("segment", "--min-samples", whole(1, u32::MAX as u128)),
    ("accuracy", "--trials", whole(1, 1_000_000)),
    ("accuracy", "--seed", SEED),
    // N × K ≤ 2^28 with the other at its default (K = 32, N = 10240).
    ("accuracy", "--subcarriers", whole(1, (1 << 28) / 32)),
    ("accuracy", "--antennas", whole(1, 4096)),
    ("montecarlo", "--trials", whole(1, 100_000)),
    ("montecarlo", "--seed", SEED),
    ("montecarlo", "--threads", whole(1, 1024)),
    ("reproduce", "--trials", whole(1, 100_000)),
    ("reproduce", "--seed", SEED),
    ("reproduce", "--frames", whole(0, 1_000_000)),
    ("tradeoff", "--trials", whole(1, 1000)),
    ("tradeoff", "--frames", whole(0, 1_000_000)),
    ("tradeoff", "--sensing-trials", whole(1, 1_000_000)),
    ("tradeoff", "--snr-db", real(-100.0, 100.0)),
    ("tradeoff", "--seed", SEED),
    ("scene", "--seed", SEED),
    ("scene", "--circle-fraction", real(0.0, 1.0)),
    ("scene", "--target-gap-m", real(0.1, 100.0)),
    ("bag record", "--duration-s", Range::Unchecked),
    ("bag record", "--chunk-size-kib", Range::Unchecked),
    // 0 (one file) or 1024 to 2^50 bytes: a gap this test's ranges cannot say.
    ("bag record", "--max-bag-size", Range::Unchecked),
    ("bag record", "--max-bag-duration", real(0.0, 604_800.0)),
    ("launch", "--max-bag-size", Range::Unchecked),
    ("launch", "--max-bag-duration", real(0.0, 604_800.0)),
    ("bag play", "--rate", Range::Unchecked),
    ("bag play", "--start-offset", real(0.0, 31_536_000.0)),
    ("bag play", "--clock", real(0.001, 10_000.0)),
    ("bag play", "--match-timeout-s", Range::Unchecked),
    ("bag play", "--ros-domain-id", Range::Unchecked),
];

/// Values from the edges of every numeric type, as typed on a command line.
const EXTREMES: &[&str] = &[
    "0",
    "-0",
    "+0",
    "0.0",
    "-0.0",
    "1",
    "-1",
    "2",
    "0.5",
    "1e-300",
    "-1e-300",
    "4.9e-324",
    "1e-6",
    "1e-7",
    "1e6",
    "1e300",
    "-1e300",
    "1.7976931348623157e308",
    "1e309",
    "NaN",
    "nan",
    "-NaN",
    "inf",
    "-inf",
    "infinity",
    "232",
    "233",
    "3600",
    "3601",
    "604800",
    "604801",
    "4294967295",
    "4294967296",
    "9223372036854775807",
    "-9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "-18446744073709551615",
    "340282366920938463463374607431768211456",
    "99999999999999999999999999999999999999999999999999",
    "1e19",
    "1.5",
    "0x10",
    "",
    " ",
    "five",
    "--rate",
    "1:2",
    "∞",
];

/// Every flag that takes a value, per verb: (verb path, long flag, its value type).
fn flags() -> Vec<(String, String, TypeId)> {
    fn walk(command: &clap::Command, path: &str, out: &mut Vec<(String, String, TypeId)>) {
        for sub in command.get_subcommands() {
            let path = if path.is_empty() {
                sub.get_name().to_owned()
            } else {
                format!("{path} {}", sub.get_name())
            };
            if sub.has_subcommands() {
                walk(sub, &path, out);
                continue;
            }
            for arg in sub.get_arguments() {
                let takes_value = arg.get_num_args().is_some_and(|n| n.takes_values());
                if let (Some(long), true) = (arg.get_long(), takes_value) {
                    let parser = arg.get_value_parser();
                    let type_id = [
                        TypeId::of::<f64>(),
                        TypeId::of::<f32>(),
                        TypeId::of::<u64>(),
                        TypeId::of::<u32>(),
                        TypeId::of::<usize>(),
                        TypeId::of::<i64>(),
                        TypeId::of::<i32>(),
                    ]
                    .into_iter()
                    .find(|t| parser.type_id() == *t)
                    .unwrap_or(TypeId::of::<String>());
                    out.push((path.clone(), format!("--{long}"), type_id));
                }
            }
        }
    }
    let mut out = Vec::new();
    // Built, so that every argument has its number of values set.
    let mut command = Cli::command();
    command.build();
    walk(&command, "", &mut out);
    out
}

fn is_numeric(type_id: TypeId) -> bool {
    type_id != TypeId::of::<String>()
}

fn range_of(verb: &str, flag: &str) -> Option<Range> {
    RANGES
        .iter()
        .find(|(v, f, _)| *v == verb && *f == flag)
        .map(|(_, _, r)| *r)
}

/// Whether `range` holds `text`, by the specification.
fn allowed(range: Range, text: &str) -> Option<bool> {
    match range {
        Range::Unchecked => None,
        Range::Real {
            min,
            max,
            open,
            zero,
        } => Some(match text.trim().parse::<f64>() {
            Ok(v) if v.is_finite() => {
                (zero && v == 0.0) || ((if open { v > min } else { v >= min }) && v <= max)
            }
            _ => false,
        }),
        Range::Whole { min, max } => {
            let digits = text.trim();
            let unsigned = digits.strip_prefix('+').unwrap_or(digits);
            Some(
                if unsigned.bytes().all(|b| b.is_ascii_digit()) && !unsigned.is_empty() {
                    unsigned
                        .parse::<u128>()
                        .is_ok_and(|v| (min..=max).contains(&v))
                } else {
                    // "-0" is 0 too.
                    digits
                        .strip_prefix('-')
                        .is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b == b'0') && min == 0)
                },
            )
        }
    }
}

/// The command line for `verb` with `flag` set to `value` (replacing the base's own `flag`).
fn argv(verb: &str, flag: &str, value: &str, joined: bool) -> Vec<String> {
    let base = BASE
        .iter()
        .find(|(v, _)| *v == verb)
        .unwrap_or_else(|| panic!("verb {verb:?} has no line in BASE"))
        .1;
    let mut args: Vec<String> = vec!["nrslam".into()];
    args.extend(verb.split(' ').map(str::to_owned));
    let mut k = 0;
    while k < base.len() {
        if base[k] == flag {
            k += 2;
            continue;
        }
        args.push(base[k].to_owned());
        k += 1;
    }
    if joined {
        args.push(format!("{flag}={value}"));
    } else {
        args.push(flag.to_owned());
        args.push(value.to_owned());
    }
    args
}

/// Runs one case: no panic; a refusal is one line naming `flag`; a numeric flag with a range
/// accepts `value` exactly when the range holds it. `Err` describes a failure.
fn check(verb: &str, flag: &str, type_id: TypeId, value: &str) -> Result<(), String> {
    let numeric_with_range = is_numeric(type_id)
        .then(|| range_of(verb, flag))
        .flatten()
        .filter(|r| !matches!(r, Range::Unchecked));
    // The separate form `--flag VALUE` only for the flags with a range (they take hyphen
    // values) whose value is not optional (`--clock -e` is `--clock` then `-e`); `--flag=VALUE`
    // for all.
    let optional_value = (verb, flag) == ("bag play", "--clock");
    let forms: &[bool] = if numeric_with_range.is_some() && !optional_value {
        &[true, false]
    } else {
        &[true]
    };
    for &joined in forms {
        let args = argv(verb, flag, value, joined);
        let outcome = std::panic::catch_unwind(|| parse_and_validate(args.clone()))
            .map_err(|_| format!("{args:?}: panicked"))?;
        let accepted = match &outcome {
            Ok(_) => true,
            Err(Refused::Line(line)) => {
                let names = line.starts_with(&format!("{flag}:"))
                    || line.starts_with(&format!("{flag}/"))
                    || line.contains(&format!("/{flag}:"));
                if !names || line.contains('\n') {
                    return Err(format!("{args:?}: refusal does not name {flag}: {line:?}"));
                }
                false
            }
            Err(Refused::Clap(error)) => {
                use clap::error::ErrorKind;
                if matches!(
                    error.kind(),
                    ErrorKind::ValueValidation | ErrorKind::InvalidValue
                ) {
                    return Err(format!("{args:?}: a value error clap printed: {error}"));
                }
                // Anything else is clap's usage error on an odd value (not our concern here).
                false
            }
        };
        if let Some(range) = numeric_with_range {
            if let Some(expected) = allowed(range, value) {
                if accepted != expected {
                    return Err(format!(
                        "{args:?}: accepted = {accepted}, the range {range:?} says {expected} \
                         ({outcome:?})"
                    ));
                }
            }
        }
    }
    Ok(())
}

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
