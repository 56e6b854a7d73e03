//! Sequential Monte Carlo decisions: after `first` trials, and after every further `batch`, each
//! requirement's one-sided Student-t confidence interval on the mean is compared with its
//! threshold. Entirely below: met; entirely above: not met; straddling: more trials, until `max`
//! (then undecided, with its interval).
//!
//! The looks fall at fixed trial counts (first, first + batch, ..., max), so a configuration's
//! decision depends on its trials' values alone: not on threads, shards, or where a study was
//! stopped and resumed. Repeated looks spend the stated confidence more than once; docs/sizing.md
//! measures how often the sequential decision differs from one look at 500 trials.

use super::requirement::{MetricRequirement, TrialBudget};
use super::trial::value;
use statrs::distribution::{ContinuousCDF, StudentsT};

/// What is known of one requirement, or of a whole configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Status {
    Met,
    NotMet,
    /// The interval still straddles the threshold: more trials, or the budget is spent.
    Undecided,
}

impl Status {
    pub fn name(self) -> &'static str {
        match self {
            Status::Met => "met",
            Status::NotMet => "not met",
            Status::Undecided => "undecided",
        }
    }
}

/// One requirement's estimate from n trials.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub mean: f64,
    /// One-sided bounds at the requirement's confidence: P(true mean > high) ≤ 1 − confidence.
    pub low: f64,
    pub high: f64,
    pub status: Status,
}

/// The requirement's estimate from `summaries` (each a trial's metrics).
pub fn estimate(requirement: &MetricRequirement, summaries: &[[f64; 5]]) -> Estimate {
    let values: Vec<f64> = summaries
        .iter()
        .map(|s| value(s, requirement.metric))
        .collect();
    let n = values.len();
    let mean = values.iter().sum::<f64>() / n.max(1) as f64;
    if n < 2 {
        return Estimate {
            mean,
            low: f64::NEG_INFINITY,
            high: f64::INFINITY,
            status: Status::Undecided,
        };
    }
    let variance = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    let half = t_quantile(requirement.confidence, n - 1) * (variance / n as f64).sqrt();
    let (low, high) = (mean - half, mean + half);
    let status = if high < requirement.threshold {
        Status::Met
    } else if low > requirement.threshold {
        Status::NotMet
    } else {
        Status::Undecided
    };
    Estimate {
        mean,
        low,
        high,
        status,
    }
}

/// The `p` quantile of Student's t with `freedom` degrees of freedom.
pub fn t_quantile(p: f64, freedom: usize) -> f64 {
    StudentsT::new(0.0, 1.0, freedom as f64)
        .map(|t| t.inverse_cdf(p))
        // Only freedom = 0 is refused, and n ≥ 2 here; the normal quantile would be too narrow.
        .unwrap_or(f64::INFINITY)
}

/// A configuration's status: met if every requirement is, not met if any is not.
pub fn combined(estimates: &[Estimate]) -> Status {
    if estimates.iter().any(|e| e.status == Status::NotMet) {
        Status::NotMet
    } else if estimates.iter().all(|e| e.status == Status::Met) {
        Status::Met
    } else {
        Status::Undecided
    }
}

/// The trial counts at which decisions are taken: first, first + batch, ..., max.
pub fn next_look(budget: &TrialBudget, done: u32) -> Option<u32> {
    if done < budget.first {
        return Some(budget.first);
    }
    if done >= budget.max {
        return None;
    }
    let since = done - budget.first;
    let next = budget.first + (since / budget.batch + 1) * budget.batch;
    Some(next.min(budget.max))
}

/// Replays the looks over `summaries` (trials 0, 1, ... in order): the count at which the
/// configuration was decided and its estimates there, or, undecided, the estimates of every
/// trial and whether more are due.
pub fn decide(
    requirements: &[MetricRequirement],
    budget: &TrialBudget,
    summaries: &[[f64; 5]],
) -> Decision {
    let mut look = next_look(budget, 0);
    while let Some(n) = look {
        if n as usize > summaries.len() {
            break;
        }
        let estimates: Vec<Estimate> = requirements
            .iter()
            .map(|r| estimate(r, &summaries[..n as usize]))
            .collect();
        let status = combined(&estimates);
        if status != Status::Undecided || n >= budget.max {
            return Decision {
                trials: n,
                estimates,
                status,
                more_due: None,
            };
        }
        look = next_look(budget, n);
    }
    let estimates = requirements
        .iter()
        .map(|r| estimate(r, summaries))
        .collect();
    Decision {
        trials: summaries.len() as u32,
        estimates,
        status: Status::Undecided,
        more_due: look,
    }
}

/// The outcome of [`decide`].
#[derive(Debug, Clone, PartialEq)]
pub struct Decision {
    /// Trials the decision rests on.
    pub trials: u32,
    pub estimates: Vec<Estimate>,
    pub status: Status,
    /// Undecided with budget left: the trial count of the next look.
    pub more_due: Option<u32>,
}

#[cfg(test)]
mod tests {
    use super::super::trial::Metric;
    use super::*;
    use proptest::prelude::*;

    fn requirement(threshold: f64) -> MetricRequirement {
        MetricRequirement {
            metric: Metric::FinalEtgospa,
            threshold,
            confidence: 0.95,
        }
    }

    fn trials(values: &[f64]) -> Vec<[f64; 5]> {
        values.iter().map(|&v| [0.0, 0.0, 0.0, v, 0.0]).collect()
    }

    const BUDGET: TrialBudget = TrialBudget {
        seed: 1,
        first: 10,
        batch: 10,
        max: 40,
    };

    #[test]
    fn the_t_quantile_matches_the_tables() {
        // Student-t tables: t(0.95; 9) = 1.833, t(0.975; 30) = 2.042, t(0.95; ∞) → 1.645.
        assert!((t_quantile(0.95, 9) - 1.8331).abs() < 1e-3);
        assert!((t_quantile(0.975, 30) - 2.0423).abs() < 1e-3);
        assert!((t_quantile(0.95, 100_000) - 1.6449).abs() < 1e-3);
    }

    #[test]
    fn looks_fall_at_fixed_counts() {
        let looks: Vec<u32> =
            std::iter::successors(next_look(&BUDGET, 0), |&n| next_look(&BUDGET, n)).collect();
        assert_eq!(looks, vec![10, 20, 30, 40]);
        let odd = TrialBudget { max: 35, ..BUDGET };
        assert_eq!(next_look(&odd, 30), Some(35));
        assert_eq!(next_look(&odd, 35), None);
        // A count between looks (a study killed mid-batch keeps only whole batches) goes on to
        // the next look.
        assert_eq!(next_look(&BUDGET, 14), Some(20));
    }

    #[test]
    fn clear_cases_are_decided_at_the_first_look() {
        let low: Vec<f64> = (0..40).map(|i| 1.0 + 0.01 * (i % 3) as f64).collect();
        let d = decide(&[requirement(2.0)], &BUDGET, &trials(&low));
        assert_eq!((d.status, d.trials), (Status::Met, 10));
        let d = decide(&[requirement(0.5)], &BUDGET, &trials(&low));
        assert_eq!((d.status, d.trials), (Status::NotMet, 10));
    }

    #[test]
    fn a_mean_at_the_threshold_stays_undecided_until_the_budget_is_spent() {
        let values: Vec<f64> = (0..40)
            .map(|i| if i % 2 == 0 { 0.0 } else { 2.0 })
            .collect();
        let d = decide(&[requirement(1.0)], &BUDGET, &trials(&values[..25]));
        assert_eq!(
            (d.status, d.trials, d.more_due),
            (Status::Undecided, 25, Some(30))
        );
        let d = decide(&[requirement(1.0)], &BUDGET, &trials(&values));
        assert_eq!(
            (d.status, d.trials, d.more_due),
            (Status::Undecided, 40, None)
        );
        assert!(d.estimates[0].low < 1.0 && d.estimates[0].high > 1.0);
    }

    #[test]
    fn one_failed_requirement_fails_the_configuration() {
        let values = trials(&[1.0; 10]);
        let d = decide(&[requirement(2.0), requirement(0.5)], &BUDGET, &values);
        assert_eq!(d.status, Status::NotMet);
    }

    proptest! {
        #[test]
        fn the_interval_holds_the_mean_and_narrows_with_confidence(
            values in proptest::collection::vec(-1e3f64..1e3, 2..60),
        ) {
            let loose = MetricRequirement { confidence: 0.6, ..requirement(0.0) };
            let strict = MetricRequirement { confidence: 0.99, ..requirement(0.0) };
            let a = estimate(&loose, &trials(&values));
            let b = estimate(&strict, &trials(&values));
            prop_assert!(a.low <= a.mean + 1e-9 && a.mean <= a.high + 1e-9);
            prop_assert!(b.low <= a.low + 1e-9 && a.high <= b.high + 1e-9);
        }

        #[test]
        fn a_decision_never_changes_with_trials_after_it(
            values in proptest::collection::vec(0.0f64..2.0, 40..41),
        ) {
            let all = decide(&[requirement(1.0)], &BUDGET, &trials(&values));
            let prefix = decide(&[requirement(1.0)], &BUDGET, &trials(&values[..all.trials as usize]));
            prop_assert_eq!(all.status, prefix.status);
            prop_assert_eq!(all.trials, prefix.trials);
        }
    }
}
