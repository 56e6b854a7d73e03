//! What the launch-file tests share.

/// Asserts that `result` is an error whose message contains each of `needles`.
pub(super) fn assert_refused<T: std::fmt::Debug, E: std::fmt::Display>(
    result: Result<T, E>,
    needles: &[&str],
) {
    let error = result.unwrap_err().to_string();
    for needle in needles {
        assert!(error.contains(needle), "{needle:?} not in: {error}");
    }
}
