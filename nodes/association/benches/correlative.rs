//! Correlative scan matching: branch and bound (`correlative::search_with`) against the
//! exhaustive search of the same lattice (`correlative::exhaustive_search`), in the same run, on
//! a loop-closure-sized case: a 447-point submap of rectangle and circle outlines spread over
//! ~20 m, a 224-point query of the same place seen from a pose 3.4 m and 7° from the initial
//! guess, with 0.05 m noise, and a ±6 m × ±12° window. Both searches are checked to return the
//! same match before they are timed. The grids are padded as `MultiResolutionGrid::for_window`
//! pads them (twice the window's steps of zeros around the submap).
//!
//! `cargo bench -p nrslam-association --bench correlative -- --warm-up-time 1 --measurement-time 3`
//!
//! Groups: `paper_step/<cell>` is a Gaussian grid (σ = the cell) with Hess et al.'s angular step
//! for the query (0.49° at 0.1 m, 1.21° at 0.25 m) and no prior; `loop_closure` is what
//! `match_loop` runs (hit raster on 0.25 m cells, 1° steps, prior σ = 3 m: half the 6 m
//! radius, a scattered query's `scattered_prior_sigma_radii` and every query's before commit
//! 24d3e82) for the best motion and then the runner-up ≥ 2 m from it, and
//! `prepared_best_and_runner_up_prior_6m` the same with the default prior of a query that does
//! not scatter (σ = the radius, `prior_sigma_radii`); `precompute` is building
//! the grid and its maxima, padded and not; `depth` is the branch and bound with 1 to 7
//! precomputed levels (`suggested_depth` picks 4 at 0.25 m and 5 at 0.1 m here);
//! `fine_search/<step>` is loop closure's fine search after the ICP (field and maxima built, then
//! searched), at the two `fine_step_m` values docs/slam-log.md compares; `plateau/<window>` is the
//! plateau's centre that loop closure takes at a metre of scatter (`plateau_window_m` 1.5, 2.5
//! and 3.5 m, ±3°), beside the best-plus-runner-up search every candidate runs: 0.109, 0.282 and
//! 0.541 ms against 0.402 ms (the cost grows with the window's area; 2.5 m, the default, holds
//! the Δθ 5° plateau whole).
//!
//! Measured on the 2-core machine at commit dde5e4f (criterion's means; the VM moves them by
//! ±15 % between runs):
//!
//! | case                                   | branch and bound | exhaustive | ratio |
//! |----------------------------------------|------------------|------------|-------|
//! | `paper_step/0.1` (±60 cells, 51 rot.)  | 0.32 ms          | 82 ms      | 260×  |
//! | `paper_step/0.25` (±24 cells, 21 rot.) | 0.088 ms         | 4.35 ms    | 50×   |
//! | `loop_closure`, best + runner-up       | 0.736 ms         | 10.8 ms    | 15×   |
//! | `loop_closure`, best only              | 0.237 ms         | 5.41 ms    | 23×   |
//!
//! Before the padding (commit eccf3b6, a saved criterion baseline in the same session) the loop
//! search took 1.486 ms (best + runner-up) and 0.455 ms (best only). Building the padded grids
//! costs 0.040 ms (hit raster, 0.25 m; 0.016 ms unpadded), 0.154 ms (Gaussian, 0.25 m; 0.129)
//! and 0.343 ms (Gaussian, 0.1 m; 0.181). The runner-up search costs twice the first: it must
//! prove that nothing outside the excluded disc beats a score under half the best's, and coarse
//! bounds seldom fall that low.
//!
//! The prior's width (commit 24d3e82, one session): best and runner-up from one preparation took
//! 0.812 ms at σ = 3 m and 0.821 ms at σ = 6 m (+1 %), with the same best match. This case has
//! one clear peak; in whole hall trials the flatter prior took the search's share of the samples
//! from 5.3 to 6.5 % (docs/performance.md).

#[path = "common/mod.rs"]
mod common;

use common::{build_grids, scene, window_pad};
use criterion::{criterion_group, criterion_main, Criterion};
use nrslam_association::correlative::{
    exhaustive_search, plateau_centre, runner_up, search_with, suggested_depth, CorrelativeError,
    Exclusion, Kernel, Match, MultiResolutionGrid, PreparedSearch, SearchOptions, SearchWindow,
};
use nrslam_association::Pose2;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};
use std::hint::black_box;

struct Case {
    submap: Vec<[f64; 2]>,
    query: Vec<[f64; 2]>,
    initial: Pose2,
    window: SearchWindow,
}

fn case() -> Case {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let noise = Normal::new(0.0, 0.05).unwrap();
    let submap = scene(0.2);
    // The query pose, and what it sees: every other point of a denser sampling within 12 m.
    let truth = Pose2::new(1.0, -0.5, 0.2);
    let inverse = truth.inverse();
    let query: Vec<[f64; 2]> = scene(0.2)
        .iter()
        .filter(|p| (p[0] - truth.x_m).hypot(p[1] - truth.y_m) < 12.0)
        .step_by(2)
        .map(|p| {
            let q = inverse.transform_point(*p);
            [q[0] + noise.sample(&mut rng), q[1] + noise.sample(&mut rng)]
        })
        .collect();
    let initial = Pose2::new(truth.x_m - 2.5, truth.y_m + 2.3, truth.yaw_rad + 0.12);
    Case {
        submap,
        query,
        initial,
        window: SearchWindow {
            linear_m: 6.0,
            angular_rad: 12f64.to_radians(),
        },
    }
}

impl Case {
    /// The submap's grids on cells of `cell_m` with `kernel` and `depth` levels, padded for the
    /// case's window as `MultiResolutionGrid::for_window` pads them.
    fn grids(&self, cell_m: f64, kernel: Kernel, depth: u32) -> MultiResolutionGrid {
        let pad = window_pad(self.window.linear_m, cell_m);
        build_grids(&self.submap, cell_m, kernel, pad, depth)
    }

    /// The branch and bound over `grids` from the case's prediction and window.
    fn fast(&self, grids: &MultiResolutionGrid, options: &SearchOptions) -> Found {
        search_with(
            grids,
            black_box(&self.query),
            self.initial,
            &self.window,
            options,
            0.0,
        )
    }

    /// The exhaustive search of the finest grid, the reference the branch and bound must equal.
    fn slow(&self, grids: &MultiResolutionGrid, options: &SearchOptions) -> Found {
        exhaustive_search(
            grids.grid(),
            black_box(&self.query),
            self.initial,
            &self.window,
            options,
            0.0,
        )
    }
}

type Found = Result<Option<Match>, CorrelativeError>;

/// Tracking's step: a Gaussian grid, best match only, at two cell sizes.
fn paper_step(c: &mut Criterion, case: &Case) {
    for cell_m in [0.1, 0.25] {
        let gaussian = Kernel::Gaussian { sigma_m: cell_m };
        let depth = suggested_depth(case.window.linear_m, cell_m);
        let grids = case.grids(cell_m, gaussian, depth);
        let options = SearchOptions::default();
        let fast = case.fast(&grids, &options);
        assert_eq!(fast, case.slow(&grids, &options));
        eprintln!("paper_step/{cell_m}: {:?}", fast.unwrap().unwrap());
        let mut group = c.benchmark_group(format!("paper_step/{cell_m}"));
        group.sample_size(10);
        group.bench_function("branch_and_bound", |b| {
            b.iter(|| case.fast(&grids, &options))
        });
        group.bench_function("exhaustive", |b| b.iter(|| case.slow(&grids, &options)));
        group.finish();
    }
}

/// The search options of loop closure's defaults.
fn loop_options() -> SearchOptions {
    SearchOptions {
        angular_step_rad: Some(1f64.to_radians()),
        prior_sigma_m: Some(3.0),
        exclude: None,
    }
}

/// What match_loop does with the default parameters: the hit raster, best, then runner-up 2 m
/// away.
fn loop_closure(c: &mut Criterion, case: &Case) {
    let hit = Kernel::Hit { cells: 1 };
    let depth = suggested_depth(case.window.linear_m, 0.25);
    let grids = case.grids(0.25, hit, depth);
    let options = loop_options();
    // `ambiguity` > 0: only a runner-up above that fraction of the best is looked for, as the
    // loop verifier asks (its `max_ambiguity`).
    let both_fast_above = |ambiguity: f64| {
        let best = case.fast(&grids, &options).unwrap().unwrap();
        let second = runner_up(
            &grids,
            &case.query,
            case.initial,
            &case.window,
            &options,
            Exclusion::around(&best, 2.0),
            ambiguity * best.score,
        )
        .unwrap();
        (best, second)
    };
    let both_fast = || both_fast_above(0.0);
    let both_slow = || {
        let best = case.slow(&grids, &options).unwrap().unwrap();
        let exclude = SearchOptions {
            exclude: Some(Exclusion {
                center_m: [best.pose.x_m, best.pose.y_m],
                radius_m: 2.0,
            }),
            ..options
        };
        (best, case.slow(&grids, &exclude).unwrap())
    };
    assert_eq!(both_fast(), both_slow());
    eprintln!("loop_closure: {:?}", both_fast());
    let mut group = c.benchmark_group("loop_closure");
    group.sample_size(10);
    group.bench_function("branch_and_bound_best_only", |b| {
        b.iter(|| case.fast(&grids, &options))
    });
    group.bench_function("exhaustive_best_only", |b| {
        b.iter(|| case.slow(&grids, &options))
    });
    group.bench_function("branch_and_bound", |b| b.iter(both_fast));
    // What `match_loop` runs: both searches from one preparation of the query's cells.
    let prepared = |options: &SearchOptions| {
        let mut search = PreparedSearch::new(
            &grids,
            black_box(&case.query),
            case.initial,
            &case.window,
            options,
        )
        .unwrap();
        let best = search.best_outside(None, 0.0).unwrap().unwrap();
        let second = search
            .best_outside(Some(Exclusion::around(&best, 2.0)), 0.0)
            .unwrap();
        (best, second)
    };
    let both_prepared = || prepared(&options);
    assert_eq!(both_prepared(), both_fast());
    group.bench_function("prepared_best_and_runner_up", |b| b.iter(both_prepared));
    // The default prior of a query that does not scatter: σ = the 6 m radius
    // (`prior_sigma_radii` = 1). Flatter, it lets the bounds prune less.
    let flat = SearchOptions {
        prior_sigma_m: Some(6.0),
        ..options
    };
    eprintln!("loop_closure, prior σ = 6 m: {:?}", prepared(&flat));
    group.bench_function("prepared_best_and_runner_up_prior_6m", |b| {
        b.iter(|| prepared(&flat))
    });
    group.bench_function("branch_and_bound_runner_up_above_0.85", |b| {
        b.iter(|| both_fast_above(0.85))
    });
    group.bench_function("exhaustive", |b| b.iter(both_slow));
    group.finish();
}

/// Building the grids, per kernel and cell size, padded for the case's window as
/// `MultiResolutionGrid::for_window` pads them and without padding (what the padding costs).
fn precompute(c: &mut Criterion, case: &Case) {
    let mut group = c.benchmark_group("precompute");
    for (name, cell_m, kernel) in [
        ("gaussian/0.1", 0.1, Kernel::Gaussian { sigma_m: 0.1 }),
        ("gaussian/0.25", 0.25, Kernel::Gaussian { sigma_m: 0.25 }),
        ("hit/0.25", 0.25, Kernel::Hit { cells: 1 }),
    ] {
        let depth = suggested_depth(case.window.linear_m, cell_m);
        for (padding, pad) in [
            ("padded", window_pad(case.window.linear_m, cell_m)),
            ("unpadded", 0),
        ] {
            group.bench_function(format!("{name}/{padding}"), |b| {
                b.iter(|| build_grids(black_box(&case.submap), cell_m, kernel, pad, depth))
            });
        }
    }
    group.finish();
}

/// The branch and bound at every depth of the grid pyramid.
fn depth(c: &mut Criterion, case: &Case) {
    let mut group = c.benchmark_group("depth");
    group.sample_size(20);
    for (name, cell_m, kernel, options) in [
        (
            "paper_step/0.25",
            0.25,
            Kernel::Gaussian { sigma_m: 0.25 },
            SearchOptions::default(),
        ),
        (
            "paper_step/0.1",
            0.1,
            Kernel::Gaussian { sigma_m: 0.1 },
            SearchOptions::default(),
        ),
        (
            "loop_closure",
            0.25,
            Kernel::Hit { cells: 1 },
            loop_options(),
        ),
    ] {
        for depth in 1..=7 {
            let grids = case.grids(cell_m, kernel, depth);
            group.bench_function(format!("{name}/{depth}"), |b| {
                b.iter(|| case.fast(&grids, &options))
            });
        }
    }
    group.finish();
}

/// Loop closure's fine search (`fine_sigma_m` 0.1 m, ±0.3 m × ±1.5°, Hess's angular step) from
/// 0.14 m and 0.5° off the query's true pose, at the two `fine_step_m` values measured in
/// docs/slam-log.md: building the field and its maxima, then the branch and bound.
fn fine_search(c: &mut Criterion, case: &Case) {
    let truth = Pose2::new(1.0, -0.5, 0.2);
    let start = truth.compose(&Pose2::new(0.1, -0.1, 0.5f64.to_radians()));
    let window = SearchWindow {
        linear_m: 0.3,
        angular_rad: 1.5f64.to_radians(),
    };
    let options = SearchOptions::default();
    let mut group = c.benchmark_group("fine_search");
    group.sample_size(20);
    for step_m in [0.05, 0.1] {
        let kernel = Kernel::Gaussian { sigma_m: 0.1 };
        let depth = suggested_depth(window.linear_m, step_m);
        let settle = || {
            let grids = build_grids(
                black_box(&case.submap),
                step_m,
                kernel,
                window_pad(window.linear_m, step_m),
                depth,
            );
            search_with(&grids, &case.query, start, &window, &options, 0.0)
        };
        let found = settle().unwrap().unwrap();
        eprintln!(
            "fine_search/{step_m}: {:.3} m, {:.2}° from the truth",
            found.pose.distance_m(&truth),
            found.pose.rotation_to_rad(&truth).to_degrees()
        );
        group.bench_function(format!("{step_m}"), |b| b.iter(settle));
    }
    group.finish();
}

/// Loop closure's plateau centre at a metre of scatter (`plateau_fraction` 0.03, ±3° in 1°
/// steps on the hit raster of 0.25 m), at the three `plateau_window_m` values docs/slam-log.md
/// compares, beside the best-plus-runner-up search that every loop candidate runs, in the same
/// run.
fn plateau(c: &mut Criterion, case: &Case) {
    let hit = Kernel::Hit { cells: 1 };
    let depth = suggested_depth(case.window.linear_m, 0.25);
    let grids = case.grids(0.25, hit, depth);
    let options = SearchOptions {
        prior_sigma_m: None,
        ..loop_options()
    };
    let best = case.fast(&grids, &loop_options()).unwrap().unwrap();
    let mut group = c.benchmark_group("plateau");
    group.sample_size(20);
    group.bench_function("search_best_and_runner_up", |b| {
        b.iter(|| {
            let best = case.fast(&grids, &loop_options()).unwrap().unwrap();
            runner_up(
                &grids,
                &case.query,
                case.initial,
                &case.window,
                &loop_options(),
                Exclusion::around(&best, 2.0),
                0.85 * best.score,
            )
        })
    });
    for window_m in [1.5, 2.5, 3.5] {
        let window = SearchWindow {
            linear_m: window_m,
            angular_rad: 3f64.to_radians(),
        };
        let centre = || {
            plateau_centre(
                grids.grid(),
                &case.query,
                best.pose,
                &window,
                &options,
                0.03,
            )
        };
        let (pose, motions) = centre().unwrap().unwrap();
        eprintln!(
            "plateau/{window_m}: {motions} motions, centre {:.3} m from the best",
            pose.distance_m(&best.pose)
        );
        group.bench_function(format!("{window_m}"), |b| b.iter(centre));
    }
    group.finish();
}

fn correlative(c: &mut Criterion) {
    let case = case();
    eprintln!(
        "submap {} points, query {} points",
        case.submap.len(),
        case.query.len()
    );
    paper_step(c, &case);
    loop_closure(c, &case);
    precompute(c, &case);
    depth(c, &case);
    fine_search(c, &case);
    plateau(c, &case);
}

criterion_group!(benches, correlative);
criterion_main!(benches);
