//! The parts of a GOSPA or ET-GOPSA result once the assignment is known: localisation,
//! confusion (ET-GOPSA only), the truth points (or target slots) and estimates the assignment
//! leaves out, and the total. Both metrics charge these alike, so both results are built from
//! this one computation; GOSPA is the case without a confusion term.

use crate::gospa::{pow_p, root_p};

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

/// A metric's value and its decomposition, before the metric's own result type names them.
pub(crate) struct Parts {
    /// The metric (m, or m² with squared distances).
    pub total: f64,
    /// Localisation part: a p-th-power sum, or the bottleneck distance for p = ∞.
    pub localisation: f64,
    /// Confusion part (ET-GOPSA); zero without a confusion term and for p = ∞.
    pub confusion: f64,
    /// What the assignment leaves out.
    pub left: Unassigned,
}

impl Parts {
    /// p = ∞: the parts of a bottleneck matching of `assigned` pairs with largest distance
    /// `bottleneck` (`None` without a pair); the total is the largest part.
    pub(crate) fn bottleneck(
        (truth, estimates): (usize, usize),
        assigned: usize,
        c: f64,
        bottleneck: Option<f64>,
    ) -> Self {
        let localisation = bottleneck.unwrap_or(0.0);
        let left = Unassigned::bottleneck(truth, estimates, assigned, c);
        Self {
            total: localisation.max(left.missed).max(left.false_estimates),
            localisation,
            confusion: 0.0,
            left,
        }
    }

    /// 1 ≤ p < ∞: the parts of an optimal assignment `pairs` over `truth` × `estimates` items,
    /// given min(c, δ) of a pair (`clipped`) and, for ET-GOPSA's confusion term, min(c, δ_{−i})
    /// (`clipped_other`, eq. GOPSA_9).
    pub(crate) fn summed<F, G>(
        pairs: &[(usize, usize)],
        (truth, estimates): (usize, usize),
        (c, p, alpha): (f64, f64, f64),
        clipped: F,
        clipped_other: Option<G>,
    ) -> Self
    where
        F: Fn(usize, usize) -> f64,
        G: Fn(usize, usize) -> f64,
    {
        let c_pow_p = pow_p(c, p);
        let left = Unassigned::summed(truth, estimates, pairs.len(), c_pow_p / alpha);
        let localisation: f64 = pairs.iter().map(|&(i, j)| pow_p(clipped(i, j), p)).sum();
        // Bases of the p-th-power terms, for an underflow-proof root: a pair contributes
        // D_i = δ_i^p and c^p − D_{−i} = (c (1 − (δ_{−i}/c)^p)^{1/p})^p; an unassigned item c^p/α.
        let mut bases: Vec<(f64, usize)> = Vec::with_capacity(2 * pairs.len() + 1);
        for &(i, j) in pairs {
            bases.push((clipped(i, j), 1));
            if let Some(other) = &clipped_other {
                bases.push((c * (1.0 - pow_p(other(i, j) / c, p)).powf(1.0 / p), 1));
            }
        }
        // −0.0 without a confusion term: adding it leaves every sum bit for bit as it was.
        let confusion: f64 = match &clipped_other {
            Some(other) => pairs
                .iter()
                .map(|&(i, j)| c_pow_p - pow_p(other(i, j), p))
                .sum(),
            None => -0.0,
        };
        bases.push((
            c * alpha.powf(-1.0 / p),
            left.missed_count + left.false_count,
        ));
        let direct = localisation + confusion + left.missed + left.false_estimates;
        Self {
            total: root_p(direct, &bases, p),
            localisation,
            confusion,
            left,
        }
    }
}
