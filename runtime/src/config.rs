//! Typed parameters: every node's `Params` validates itself and names the bad field.

use serde::de::DeserializeOwned;

/// A parameter outside its allowed range, named.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{field}: {problem} (allowed: {allowed})")]
pub struct InvalidParam {
    /// Dotted field name, e.g. `range_std_m`.
    pub field: String,
    /// What is wrong, with the offending value.
    pub problem: String,
    /// The allowed range or set.
    pub allowed: String,
}

impl InvalidParam {
    /// A bad `field`: `problem` (include the value), allowed `allowed`.
    pub fn new(
        field: impl Into<String>,
        problem: impl Into<String>,
        allowed: impl Into<String>,
    ) -> Self {
        Self {
            field: field.into(),
            problem: problem.into(),
            allowed: allowed.into(),
        }
    }

    /// Checks `lower <= value <= upper` and finiteness for the float parameter `field`.
    pub fn check_range(
        field: &str,
        value: f64,
        lower: f64,
        upper: f64,
    ) -> Result<(), InvalidParam> {
        if value.is_finite() && value >= lower && value <= upper {
            Ok(())
        } else {
            Err(Self::out_of_range(field, value, lower, upper))
        }
    }

    /// Checks `lower <= value <= upper` for the whole-number parameter `field`.
    pub fn check_count<T: PartialOrd + std::fmt::Display>(
        field: &str,
        value: T,
        lower: T,
        upper: T,
    ) -> Result<(), InvalidParam> {
        if lower <= value && value <= upper {
            Ok(())
        } else {
            Err(Self::out_of_range(field, value, lower, upper))
        }
    }

    /// `field`'s `value` is outside `lower` to `upper`.
    fn out_of_range<T: std::fmt::Display>(field: &str, value: T, lower: T, upper: T) -> Self {
        Self::new(
            field,
            format!("{value} is out of range"),
            format!("{lower} to {upper}"),
        )
    }
}

/// The check of a params test's table (see [`one_bad_field!`](crate::one_bad_field)): `validate`
/// refuses every case with an [`InvalidParam`] for that case's field.
///
/// # Panics
/// At the first case that is accepted or blamed on another field, naming both.
pub fn assert_each_refused_by_name<P>(
    cases: Vec<(P, &str)>,
    validate: impl Fn(&P) -> Result<(), InvalidParam>,
) {
    for (params, field) in cases {
        match validate(&params) {
            Ok(()) => panic!("a bad {field} was accepted"),
            Err(err) => assert_eq!(err.field, field, "{err}"),
        }
    }
}

/// The check of a params test that TOML fills the defaults and refuses unknown fields: `table`
/// parses to `expected`, and `misspelt`, a table of one `key = value` whose key is no field, is
/// refused naming that key.
///
/// # Panics
/// When either does not hold.
pub fn assert_toml_fills_defaults<P>(table: &str, expected: &P, misspelt: &str)
where
    P: DeserializeOwned + PartialEq + std::fmt::Debug,
{
    assert_eq!(&toml::from_str::<P>(table).unwrap(), expected, "{table}");
    let key = misspelt.split('=').next().unwrap_or_default().trim();
    match toml::from_str::<P>(misspelt) {
        Ok(parsed) => panic!("{misspelt} was accepted: {parsed:?}"),
        Err(err) => assert!(err.to_string().contains(key), "{err}"),
    }
}

/// Why a parameter table could not become typed parameters.
#[derive(Debug, thiserror::Error)]
pub enum ParamsError {
    /// Unknown field, wrong type, missing value.
    #[error("{0}")]
    Parse(String),
    /// Parsed but out of range.
    #[error(transparent)]
    Invalid(#[from] InvalidParam),
}

/// Parses a TOML table into `P` (unknown fields refused by `P`'s `deny_unknown_fields`).
pub fn parse_params<P: DeserializeOwned>(table: toml::Table) -> Result<P, ParamsError> {
    P::deserialize(toml::Value::Table(table))
        .map_err(|e| ParamsError::Parse(e.to_string().trim().to_owned()))
}

/// The table of a "validate names the bad field" test: `P::default()` with one field set to each
/// of the listed bad values, paired with that field's name, in the order written. The name comes
/// from the field itself, so a case cannot be filed under the wrong field.
///
/// ```
/// #[derive(Default)]
/// struct Params { eps_m: f64, min_samples: usize }
/// let cases = nrslam_runtime::one_bad_field!(Params {
///     eps_m: [0.0, f64::NAN],
///     min_samples: [0],
/// });
/// let names: Vec<&str> = cases.iter().map(|(_, field)| *field).collect();
/// assert_eq!(names, ["eps_m", "eps_m", "min_samples"]);
/// assert!(cases[1].0.eps_m.is_nan() && cases[1].0.min_samples == 0);
/// ```
#[macro_export]
macro_rules! one_bad_field {
    ($params:ident { $($field:ident: [$($value:expr),+ $(,)?]),+ $(,)? }) => {
        vec![$($(
            (
                $params { $field: $value, ..<$params as Default>::default() },
                stringify!($field),
            ),
        )+)+]
    };
}
