//! `$(var NAME)` substitution: arguments that name other arguments, expanded once each, with
//! cycles reported and depth and length bounded, so no launch file or `name:=value` can make it
//! loop or blow up.

use std::collections::BTreeMap;

/// Deepest chain of arguments whose values name other arguments (`a` = "$(var b)", `b` =
/// "$(var c)", ...) that is expanded.
pub const MAX_SUBSTITUTION_DEPTH: usize = 32;

/// Longest string a substitution may produce, in bytes: with references nested, each level can
/// double the text (`a` = "$(var b)$(var b)"), so without a bound 32 levels would ask for 4 GiB.
pub const MAX_SUBSTITUTED_BYTES: usize = 1 << 20;

/// Why a `$(var ...)` could not be expanded.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum SubstitutionError {
    Undeclared(String),
    Unterminated(String),
    /// The arguments of the cycle, the first repeated at the end.
    Cycle(Vec<String>),
    /// The chain that went past [`MAX_SUBSTITUTION_DEPTH`].
    TooDeep(Vec<String>),
    TooLong,
}

impl std::fmt::Display for SubstitutionError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Undeclared(name) => write!(f, "uses undeclared argument {name:?}"),
            Self::Unterminated(text) => write!(f, "unterminated $(var ...) in {text:?}"),
            Self::Cycle(chain) => write!(f, "substitution cycle: {}", chain.join(" -> ")),
            Self::TooDeep(chain) => write!(
                f,
                "substitution nested deeper than {MAX_SUBSTITUTION_DEPTH} arguments: {} -> ...",
                chain.join(" -> ")
            ),
            Self::TooLong => write!(
                f,
                "substitution makes a string longer than {MAX_SUBSTITUTED_BYTES} bytes"
            ),
        }
    }
}

/// `text` with every `$(var NAME)` replaced by the text of `lookup(NAME)`, left to right; the
/// replacements are not scanned again (they come already expanded).
pub(super) fn expand_text(
    text: &str,
    mut lookup: impl FnMut(&str) -> Result<toml::Value, SubstitutionError>,
) -> Result<String, SubstitutionError> {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find("$(var ") {
        out.push_str(&rest[..start]);
        let after = &rest[start + 6..];
        let end = after
            .find(')')
            .ok_or_else(|| SubstitutionError::Unterminated(text.to_owned()))?;
        match lookup(after[..end].trim())? {
            toml::Value::String(s) => out.push_str(&s),
            other => out.push_str(&other.to_string()),
        }
        if out.len() > MAX_SUBSTITUTED_BYTES {
            return Err(SubstitutionError::TooLong);
        }
        rest = &after[end + 1..];
    }
    out.push_str(rest);
    if out.len() > MAX_SUBSTITUTED_BYTES {
        return Err(SubstitutionError::TooLong);
    }
    Ok(out)
}

/// Every argument's value with the `$(var ...)` in string values expanded (an argument may name
/// others, e.g. `out_dir` = "runs/$(var label)"). Each argument is expanded once (memoised), a
/// cycle is reported with its arguments, and depth and length are bounded
/// ([`MAX_SUBSTITUTION_DEPTH`], [`MAX_SUBSTITUTED_BYTES`]). `Err` names the argument.
pub(super) fn expand_arguments(
    arguments: &BTreeMap<String, toml::Value>,
) -> Result<BTreeMap<String, toml::Value>, (String, SubstitutionError)> {
    fn expand(
        name: &str,
        arguments: &BTreeMap<String, toml::Value>,
        done: &mut BTreeMap<String, toml::Value>,
        stack: &mut Vec<String>,
    ) -> Result<toml::Value, SubstitutionError> {
        if let Some(value) = done.get(name) {
            return Ok(value.clone());
        }
        if let Some(at) = stack.iter().position(|n| n == name) {
            let mut chain = stack[at..].to_vec();
            chain.push(name.to_owned());
            return Err(SubstitutionError::Cycle(chain));
        }
        if stack.len() >= MAX_SUBSTITUTION_DEPTH {
            return Err(SubstitutionError::TooDeep(stack.clone()));
        }
        let value = arguments
            .get(name)
            .ok_or_else(|| SubstitutionError::Undeclared(name.to_owned()))?;
        let expanded = match value {
            toml::Value::String(text) if text.contains("$(var ") => {
                stack.push(name.to_owned());
                let text = expand_text(text, |inner| expand(inner, arguments, done, stack));
                stack.pop();
                toml::Value::String(text?)
            }
            other => other.clone(),
        };
        done.insert(name.to_owned(), expanded.clone());
        Ok(expanded)
    }
    let mut done = BTreeMap::new();
    for name in arguments.keys() {
        let mut stack = Vec::new();
        expand(name, arguments, &mut done, &mut stack).map_err(|e| (name.clone(), e))?;
    }
    Ok(done)
}

/// Substitutes the (already expanded) `arguments` into a node parameter (or any value written in a
/// launch file): a string that is exactly `$(var NAME)` takes the argument's typed value, other
/// strings have each `$(var NAME)` replaced by its text; arrays and tables are walked.
pub(super) fn substitute(
    value: &mut toml::Value,
    arguments: &BTreeMap<String, toml::Value>,
) -> Result<(), SubstitutionError> {
    let lookup = |name: &str| {
        arguments
            .get(name)
            .cloned()
            .ok_or_else(|| SubstitutionError::Undeclared(name.to_owned()))
    };
    match value {
        toml::Value::String(text) => {
            if let Some(name) = whole_reference(text) {
                *value = lookup(name)?;
                return Ok(());
            }
            if text.contains("$(var ") {
                *text = expand_text(text, lookup)?;
            }
            Ok(())
        }
        toml::Value::Array(items) => items.iter_mut().try_for_each(|v| substitute(v, arguments)),
        toml::Value::Table(table) => table
            .iter_mut()
            .try_for_each(|(_, v)| substitute(v, arguments)),
        _ => Ok(()),
    }
}

/// The argument named by `text` when `text` is exactly one `$(var NAME)`.
pub(super) fn whole_reference(text: &str) -> Option<&str> {
    let name = text.strip_prefix("$(var ")?.strip_suffix(')')?;
    (!name.contains("$(") && !name.contains(')')).then(|| name.trim())
}
