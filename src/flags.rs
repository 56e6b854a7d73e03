//! Numeric command-line flags: every one has a stated range, checked where clap parses it and
//! again by the verb's `validate()`, so no value can reach arithmetic that would overflow or
//! panic (a `Duration` from 1e300 seconds, an `Instant` 1e19 s ahead, a billion threads).
//!
//! A refused value gives the CLI's one-line error, `error: --FLAG: VALUE is out of range
//! (allowed: RANGE UNIT)`, exit status 1 ([`clap_error_line`] turns clap's value errors into that
//! line). [`seconds`] and [`deadline`] are the only ways the verbs turn flag values into
//! `Duration`s and `Instant`s: checked, so a value that slipped past a range still gives an
//! error, not a panic.

use anyhow::{anyhow, Result};
use std::time::{Duration, Instant};

/// A week, in seconds: the longest timeout any flag accepts.
pub const WEEK_S: u64 = 7 * 24 * 3600;

/// A flag value refused by one of this module's parsers (the message names the value and the
/// allowed range; clap adds the flag).
#[derive(Debug, Clone)]
pub struct FlagError(pub String);

impl std::fmt::Display for FlagError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for FlagError {}

/// The allowed values of a real flag: `[min, max]` (`min` excluded with `open_min`), plus 0 when
/// `zero` is set (e.g. `--rate 0`, as fast as possible). NaN and infinities are never allowed.
#[derive(Debug, Clone, Copy)]
pub struct Real {
    pub min: f64,
    pub max: f64,
    pub open_min: bool,
    pub zero: bool,
    /// The range as the error and `--help` state it, with its unit.
    pub allowed: &'static str,
}

impl Real {
    /// `min ≤ value ≤ max`.
    pub const fn closed(min: f64, max: f64, allowed: &'static str) -> Self {
        Self {
            min,
            max,
            open_min: false,
            zero: false,
            allowed,
        }
    }

    /// Whether `value` is allowed.
    pub fn contains(&self, value: f64) -> bool {
        if !value.is_finite() {
            return false;
        }
        if self.zero && value == 0.0 {
            return true;
        }
        let above = if self.open_min {
            value > self.min
        } else {
            value >= self.min
        };
        above && value <= self.max
    }

    /// `value` if allowed, else the message (`VALUE is out of range (allowed: ...)`).
    pub fn check(&self, value: f64) -> Result<f64, FlagError> {
        if self.contains(value) {
            // -0 is 0.
            Ok(value + 0.0)
        } else {
            Err(out_of_range(&format!("{value:?}"), self.allowed))
        }
    }

    /// Parses `text` as a real and checks it.
    pub fn parse(&self, text: &str) -> Result<f64, FlagError> {
        let value: f64 = text
            .trim()
            .parse()
            .map_err(|_| not_a(text, "number", self.allowed))?;
        if self.contains(value) {
            Ok(value + 0.0)
        } else {
            Err(out_of_range(text.trim(), self.allowed))
        }
    }

    /// A clap value parser for this range.
    pub fn parser(self) -> impl Fn(&str) -> Result<f64, FlagError> + Clone + Send + Sync + 'static {
        move |text: &str| self.parse(text)
    }
}

/// The allowed values of a whole-number flag, `min ≤ value ≤ max`.
#[derive(Debug, Clone, Copy)]
pub struct Whole {
    pub min: u64,
    pub max: u64,
    /// The range as the error and `--help` state it, with its unit.
    pub allowed: &'static str,
}

impl Whole {
    /// `min ≤ value ≤ max`.
    pub const fn new(min: u64, max: u64, allowed: &'static str) -> Self {
        Self { min, max, allowed }
    }

    /// `value` if allowed, else the message.
    pub fn check<T: Into<u128> + Copy + std::fmt::Display>(
        &self,
        value: T,
    ) -> Result<T, FlagError> {
        let wide: u128 = value.into();
        if (u128::from(self.min)..=u128::from(self.max)).contains(&wide) {
            Ok(value)
        } else {
            Err(out_of_range(&value.to_string(), self.allowed))
        }
    }

    /// Parses `text` as a whole number in range, as a `T` (whose range must hold `max`).
    pub fn parse<T: TryFrom<u64>>(&self, text: &str) -> Result<T, FlagError> {
        let trimmed = text.trim();
        let digits = trimmed.strip_prefix(['+', '-']).unwrap_or(trimmed);
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return Err(not_a(text, "whole number", self.allowed));
        }
        let in_range = trimmed
            .parse::<i128>()
            .ok()
            .and_then(|v| u64::try_from(v).ok())
            .filter(|v| (self.min..=self.max).contains(v));
        match in_range.map(T::try_from) {
            Some(Ok(value)) => Ok(value),
            _ => Err(out_of_range(trimmed, self.allowed)),
        }
    }

    /// A clap value parser for this range, giving a `T`.
    pub fn parser<T: TryFrom<u64> + Clone + Send + Sync + 'static>(
        self,
    ) -> impl Fn(&str) -> Result<T, FlagError> + Clone + Send + Sync + 'static {
        move |text: &str| self.parse::<T>(text)
    }
}

fn out_of_range(value: &str, allowed: &str) -> FlagError {
    FlagError(format!("{value} is out of range (allowed: {allowed})"))
}

fn not_a(text: &str, what: &str, allowed: &str) -> FlagError {
    FlagError(format!("{text:?} is not a {what} (allowed: {allowed})"))
}

/// `result` with the flag's name in front of its error: `--flag: message`.
pub fn check<T>(flag: &str, result: Result<T, FlagError>) -> Result<T> {
    result.map_err(|e| anyhow!("{flag}: {e}"))
}

/// Any seed.
pub const SEED: Whole = Whole::new(0, u64::MAX, "0 to 18446744073709551615");
/// A real-time factor.
pub const RATE: Real = Real {
    min: 1e-6,
    max: 1e6,
    open_min: false,
    zero: true,
    allowed: "0 for as fast as possible, or a real-time factor from 1e-6 to 1e6",
};
/// A timeout in whole seconds.
pub const TIMEOUT_S: Whole = Whole::new(1, WEEK_S, "1 to 604800 s (a week)");

/// Checks `--rate` and `--start-timeout-s`, which `launch` and `run` share.
pub fn check_pacing(pacing: &crate::args::RateArgs, start_timeout_s: u64) -> Result<()> {
    pacing.validate()?;
    check("--start-timeout-s", TIMEOUT_S.check(start_timeout_s))?;
    Ok(())
}

/// `seconds` as a `Duration`, refusing NaN, negative and unrepresentable values with the flag's
/// name (never panics, unlike `Duration::from_secs_f64`).
pub fn seconds(flag: &str, seconds: f64) -> Result<Duration> {
    Duration::try_from_secs_f64(seconds)
        .map_err(|_| anyhow!("{flag}: {seconds:?} s is not a duration this machine can represent"))
}

/// The instant `after` from now, refusing one past the clock's range with the flag's name (never
/// panics, unlike `Instant + Duration`).
pub fn deadline(flag: &str, after: Duration) -> Result<Instant> {
    Instant::now().checked_add(after).ok_or_else(|| {
        anyhow!(
            "{flag}: {} s from now is past the end of this machine's clock",
            after.as_secs()
        )
    })
}

/// One line for a clap error about a flag's value, `--flag: message`, or `None` for the errors
/// clap prints itself (help, version, unknown or missing arguments).
pub fn clap_error_line(error: &clap::Error) -> Option<String> {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if !matches!(
        error.kind(),
        ErrorKind::ValueValidation | ErrorKind::InvalidValue
    ) {
        return None;
    }
    let flag = match error.get(ContextKind::InvalidArg) {
        Some(ContextValue::String(arg)) => arg.split_whitespace().next().unwrap_or(arg).to_owned(),
        _ => return None,
    };
    let value = match error.get(ContextKind::InvalidValue) {
        Some(ContextValue::String(value)) => value.clone(),
        _ => String::new(),
    };
    let source = std::error::Error::source(error);
    Some(match source {
        Some(cause) if cause.downcast_ref::<FlagError>().is_some() => format!("{flag}: {cause}"),
        Some(cause) => format!("{flag}: {value:?}: {cause}"),
        None => format!("{flag}: {value:?} is not allowed"),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reals_refuse_non_finite_and_out_of_range_values_with_the_text_typed() {
        assert_eq!(RATE.parse("0").unwrap(), 0.0);
        assert_eq!(RATE.parse("-0").unwrap().to_bits(), 0.0f64.to_bits());
        assert_eq!(RATE.parse("2").unwrap(), 2.0);
        for bad in ["1e-300", "1e300", "-1", "NaN", "inf", "-inf", "1e7"] {
            let error = RATE.parse(bad).unwrap_err().to_string();
            assert!(
                error.starts_with(&format!("{bad} is out of range (allowed: 0 for")),
                "{error}"
            );
        }
        let error = RATE.parse("fast").unwrap_err().to_string();
        assert!(error.contains("\"fast\" is not a number"), "{error}");
        let open = Real {
            open_min: true,
            ..Real::closed(0.0, 2.0, "0 < A ≤ 2")
        };
        assert!(!open.contains(0.0) && open.contains(1e-300) && open.contains(2.0));
        assert!(open.check(2.5).is_err());
    }

    #[test]
    fn whole_numbers_refuse_signs_fractions_and_overflow() {
        assert_eq!(TIMEOUT_S.parse::<u64>("30").unwrap(), 30);
        assert_eq!(SEED.parse::<u64>("18446744073709551615").unwrap(), u64::MAX);
        for bad in [
            "0",
            "-1",
            "604801",
            "18446744073709551616",
            "-9223372036854775808",
        ] {
            let error = TIMEOUT_S.parse::<u64>(bad).unwrap_err().to_string();
            assert!(error.contains("is out of range"), "{bad}: {error}");
        }
        for bad in ["1e19", "1.5", "", "NaN", "0x10", "--rate"] {
            let error = TIMEOUT_S.parse::<u64>(bad).unwrap_err().to_string();
            assert!(error.contains("is not a whole number"), "{bad}: {error}");
        }
        // The target type must hold the value: a u32 flag refuses what does not fit.
        assert!(Whole::new(0, u64::MAX, "any")
            .parse::<u32>("4294967296")
            .is_err());
        assert_eq!(TIMEOUT_S.check(5u32).unwrap(), 5);
        assert!(TIMEOUT_S.check(0u64).is_err());
    }

    #[test]
    fn durations_and_deadlines_are_checked_not_panicking() {
        assert!(seconds("--x", 1e300)
            .unwrap_err()
            .to_string()
            .starts_with("--x: "));
        assert!(seconds("--x", f64::NAN).is_err());
        assert!(seconds("--x", -1.0).is_err());
        assert_eq!(seconds("--x", 1.5).unwrap(), Duration::from_millis(1500));
        let error = deadline("--start-timeout-s", Duration::MAX).unwrap_err();
        assert!(
            error.to_string().starts_with("--start-timeout-s: "),
            "{error}"
        );
        assert!(deadline("--x", Duration::from_secs(WEEK_S)).is_ok());
    }
}
