//! `nrslam metric` equals a brute-force enumeration of the FUSION 2017 GOSPA (Rahmathullah,
//! García-Fernández, Svensson): min over all assignments γ of
//! Σ_{(i,j)∈γ} d^(c)(x_i, y_j)^p + c^p/α (|X| + |Y| − 2|γ|), to the power 1/p. The oracle here is
//! written independently of the evaluator crate.

mod common;
use common::*;
use rand::{Rng, SeedableRng};

/// Every partial injective assignment of X into Y, exhaustively.
fn brute_force_gospa(x: &[(f64, f64)], y: &[(f64, f64)], c: f64, p: f64, alpha: f64) -> f64 {
    let unassigned = c.powf(p) / alpha;
    let mut best = f64::INFINITY;
    // Stack of (next x index, used y flags, cost so far): depth-first over all partial assignments.
    let mut stack = vec![(0usize, vec![false; y.len()], 0.0f64)];
    while let Some((i, used, cost)) = stack.pop() {
        if i == x.len() {
            let free_y = used.iter().filter(|u| !**u).count();
            best = best.min(cost + unassigned * free_y as f64);
            continue;
        }
        stack.push((i + 1, used.clone(), cost + unassigned));
        for j in 0..y.len() {
            if !used[j] {
                let d = ((x[i].0 - y[j].0).powi(2) + (x[i].1 - y[j].1).powi(2))
                    .sqrt()
                    .min(c);
                let mut next = used.clone();
                next[j] = true;
                stack.push((i + 1, next, cost + d.powf(p)));
            }
        }
    }
    best.powf(1.0 / p)
}

#[test]
fn metric_cli_equals_brute_force_gospa_on_small_random_sets() {
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(2017);
    let dir = temp();
    let truth = dir.path().join("truth.csv");
    let estimates = dir.path().join("estimates.csv");
    for case in 0..12 {
        let n_truth = rng.random_range(0..5);
        let n_est = rng.random_range(0..6);
        let x: Vec<(f64, f64)> = (0..n_truth)
            .map(|_| (rng.random_range(0.0..8.0), rng.random_range(0.0..8.0)))
            .collect();
        let y: Vec<(f64, f64)> = (0..n_est)
            .map(|_| (rng.random_range(0.0..8.0), rng.random_range(0.0..8.0)))
            .collect();
        let c = [1.0, 2.0, 5.0][case % 3];
        let p = [1.0, 2.0, 3.0][(case / 3) % 3];
        let alpha = [2.0, 1.0][case % 2];
        // Each truth point is its own target, so the GOSPA truth set is exactly x.
        let mut text = String::from("target,x,y\n");
        for (i, (px, py)) in x.iter().enumerate() {
            text += &format!("{i},{px:?},{py:?}\n");
        }
        std::fs::write(&truth, text).unwrap();
        let mut text = String::from("x,y\n");
        for (px, py) in &y {
            text += &format!("{px:?},{py:?}\n");
        }
        std::fs::write(&estimates, text).unwrap();
        let (c_text, p_text, alpha_text) = (c.to_string(), p.to_string(), alpha.to_string());
        let flags = [
            "--c",
            &c_text,
            "--p",
            &p_text,
            "--alpha",
            &alpha_text,
            "--json",
        ];
        let output = metric(&truth, &estimates, &flags);
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let report: serde_json::Value = serde_json::from_slice(&output.stdout).unwrap();
        let cli = report["gospa"]["total"].as_f64().unwrap();
        let oracle = brute_force_gospa(&x, &y, c, p, alpha);
        assert!(
            (cli - oracle).abs() <= 1e-9 * oracle.max(1.0),
            "case {case}: cli {cli} oracle {oracle} (c {c} p {p} α {alpha})"
        );
    }
}
