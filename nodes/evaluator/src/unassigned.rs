//! The unassigned part of a GOSPA or ET-GOPSA result: truth points (or target slots) and
//! estimates that the optimal assignment leaves out, and what they cost. Both metrics charge them
//! alike, so both results are built from this one computation.

/// Counts left out by an assignment of `assigned` pairs, and their cost terms.
pub(crate) struct Unassigned {
    /// Truth points or slots left unassigned.
    pub missed_count: usize,
    /// Estimates left unassigned.
    pub false_count: usize,
    /// The missed part of the metric.
    pub missed: f64,
    /// The false-estimate part of the metric.
    pub false_estimates: f64,
}

impl Unassigned {
    fn counts(truth: usize, estimates: usize, assigned: usize) -> (usize, usize) {
        (truth - assigned, estimates - assigned)
    }

    /// For p = ∞: each part is c when anything of its side is left out, else 0.
    pub(crate) fn bottleneck(truth: usize, estimates: usize, assigned: usize, c: f64) -> Self {
        let (missed_count, false_count) = Self::counts(truth, estimates, assigned);
        let any = |count: usize| if count > 0 { c } else { 0.0 };
        Self {
            missed_count,
            false_count,
            missed: any(missed_count),
            false_estimates: any(false_count),
        }
    }

    /// For 1 ≤ p < ∞: each item left out costs `unassigned_cost` = c^p/α.
    pub(crate) fn summed(
        truth: usize,
        estimates: usize,
        assigned: usize,
        unassigned_cost: f64,
    ) -> Self {
        let (missed_count, false_count) = Self::counts(truth, estimates, assigned);
        Self {
            missed_count,
            false_count,
            missed: unassigned_cost * missed_count as f64,
            false_estimates: unassigned_cost * false_count as f64,
        }
    }
}
