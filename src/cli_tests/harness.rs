//! Finds every flag through clap's command tree and runs one value through the parser and
//! `validate()`, checking the outcome against [`RANGES`](super::spec::RANGES).

use super::spec::{Range, BASE, RANGES};
use crate::{parse_and_validate, Cli, Refused};
use clap::CommandFactory;
use std::any::TypeId;

/// Every flag that takes a value, per verb: (verb path, long flag, its value type).
pub(super) fn flags() -> Vec<(String, String, TypeId)> {
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

pub(super) fn is_numeric(type_id: TypeId) -> bool {
    type_id != TypeId::of::<String>()
}

pub(super) fn range_of(verb: &str, flag: &str) -> Option<Range> {
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
pub(super) fn check(verb: &str, flag: &str, type_id: TypeId, value: &str) -> Result<(), String> {
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
