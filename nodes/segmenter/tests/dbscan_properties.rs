//! DBSCAN on a grid of ε-cells against the O(n²) oracle, label for label, and at sizes the oracle cannot
//! reach.

use nrslam_segmenter::{dbscan, dbscan_brute_force, Clustering, NOISE};
use proptest::prelude::*;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Points on a coarse lattice (step 0.25 m, exact in binary), so that many pairs lie at exactly
/// eps and coincident points are common: the cases where ≤ versus < and duplicate handling matter.
fn lattice_points(max_len: usize) -> impl Strategy<Value = Vec<[f64; 2]>> {
    prop::collection::vec((0i32..12, 0i32..12), 0..max_len).prop_map(|cells| {
        cells
            .into_iter()
            .map(|(i, j)| [f64::from(i) * 0.25, f64::from(j) * 0.25])
            .collect()
    })
}

/// Arbitrary real coordinates in a few-metre box, with occasional large offsets.
fn real_points(max_len: usize) -> impl Strategy<Value = Vec<[f64; 2]>> {
    prop::collection::vec(
        (-3.0f64..3.0, -3.0f64..3.0, prop::bool::weighted(0.05)),
        0..max_len,
    )
    .prop_map(|raw| {
        raw.into_iter()
            .map(|(x, y, far)| if far { [x * 1e6, y] } else { [x, y] })
            .collect()
    })
}

fn eps_values() -> impl Strategy<Value = f64> {
    prop_oneof![
        Just(0.0),
        Just(0.25),
        Just(0.5),
        // sqrt(2)·0.25 is not exact: diagonal neighbours fall either side depending on rounding,
        // identically in both implementations.
        Just(0.353_553_390_593_273_8),
        0.0f64..1.5,
    ]
}

/// Structural checks that hold for any correct DBSCAN output.
fn check_invariants(points: &[[f64; 2]], eps_m: f64, min_samples: usize, c: &Clustering) {
    assert_eq!(c.labels.len(), points.len());
    let eps_sq = eps_m * eps_m;
    let close = |a: [f64; 2], b: [f64; 2]| {
        let (dx, dy) = (a[0] - b[0], a[1] - b[1]);
        dx * dx + dy * dy <= eps_sq
    };
    // Clusters are numbered by their first core point's index (not their first point's: a border
    // point early in the input may belong to a cluster seeded later).
    let mut next = 0;
    for (&label, _) in c.labels.iter().zip(&c.is_core).filter(|(_, &core)| core) {
        if label == next {
            next += 1;
        }
        assert!(label < next, "label {label} appears before label {}", next);
    }
    assert_eq!(next as usize, c.cluster_count);
    for (i, &p) in points.iter().enumerate() {
        let neighbours: Vec<usize> = (0..points.len()).filter(|&j| close(p, points[j])).collect();
        assert_eq!(c.is_core[i], neighbours.len() >= min_samples);
        if c.is_core[i] {
            // Core neighbours share the cluster.
            for &j in &neighbours {
                if c.is_core[j] {
                    assert_eq!(c.labels[i], c.labels[j]);
                }
            }
            assert_ne!(c.labels[i], NOISE);
        } else if c.labels[i] == NOISE {
            assert!(neighbours.iter().all(|&j| !c.is_core[j]));
        } else {
            // Border: the lowest cluster among its core neighbours.
            let lowest = neighbours
                .iter()
                .filter(|&&j| c.is_core[j])
                .map(|&j| c.labels[j])
                .min();
            assert_eq!(Some(c.labels[i]), lowest);
        }
    }
}

/// The grid DBSCAN labels `points` as the brute-force one does, and its labels keep the
/// invariants.
fn check_against_brute_force(
    points: &[[f64; 2]],
    eps_m: f64,
    min_samples: usize,
) -> Result<(), TestCaseError> {
    let fast = dbscan(points, eps_m, min_samples).unwrap();
    let slow = dbscan_brute_force(points, eps_m, min_samples).unwrap();
    prop_assert_eq!(&fast, &slow);
    check_invariants(points, eps_m, min_samples, &fast);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn grid_matches_brute_force_on_lattice(
        points in lattice_points(120),
        eps_m in eps_values(),
        min_samples in 1usize..8,
    ) {
        check_against_brute_force(&points, eps_m, min_samples)?;
    }

    #[test]
    fn grid_matches_brute_force_on_real_points(
        points in real_points(150),
        eps_m in eps_values(),
        min_samples in 1usize..8,
    ) {
        check_against_brute_force(&points, eps_m, min_samples)?;
    }

    /// Permuting the input may renumber clusters and move border points, but core points keep
    /// their grouping: the clusters restricted to core points are the connected components.
    #[test]
    fn core_partition_is_independent_of_input_order(
        points in lattice_points(80),
        eps_m in eps_values(),
        min_samples in 1usize..6,
        seed in any::<u64>(),
    ) {
        let mut order: Vec<usize> = (0..points.len()).collect();
        order.shuffle(&mut ChaCha8Rng::seed_from_u64(seed));
        let shuffled: Vec<[f64; 2]> = order.iter().map(|&i| points[i]).collect();
        let a = dbscan(&points, eps_m, min_samples).unwrap();
        let b = dbscan(&shuffled, eps_m, min_samples).unwrap();
        prop_assert_eq!(a.cluster_count, b.cluster_count);
        for (k, &i) in order.iter().enumerate() {
            prop_assert_eq!(a.is_core[i], b.is_core[k]);
            for (l, &j) in order.iter().enumerate() {
                if a.is_core[i] && a.is_core[j] {
                    prop_assert_eq!(a.labels[i] == a.labels[j], b.labels[k] == b.labels[l]);
                }
            }
        }
    }
}

/// Points like a segmented map: dense patches of occupied-cell centres on a 0.1 m lattice (many
/// points sharing each coordinate value), isolated noise points between them, in shuffled order.
/// Returns the points and, per point, its patch index or None for noise.
fn patches_and_noise(
    patches: usize,
    noise: usize,
    seed: u64,
) -> (Vec<[f64; 2]>, Vec<Option<usize>>) {
    const PITCH_M: f64 = 5.0;
    const COLUMNS: usize = 50;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut tagged = Vec::new();
    for patch in 0..patches {
        let (ox, oy) = (
            (patch % COLUMNS) as f64 * PITCH_M,
            (patch / COLUMNS) as f64 * PITCH_M,
        );
        // 10 × 20 cells of 0.1 m: 200 points, an extended target 1 m × 2 m.
        for i in 0..10 {
            for j in 0..20 {
                tagged.push(([ox + 0.1 * i as f64, oy + 0.1 * j as f64], Some(patch)));
            }
        }
    }
    for k in 0..noise {
        // Between patches, more than eps from any patch and from each other.
        let slot = k % (patches.max(1));
        let (ox, oy) = (
            (slot % COLUMNS) as f64 * PITCH_M,
            (slot / COLUMNS) as f64 * PITCH_M,
        );
        let jitter = rng.random_range(-0.3..0.3);
        tagged.push((
            [
                ox + 3.0 + jitter,
                oy + 3.5 + (k / patches.max(1)) as f64 * 0.7,
            ],
            None,
        ));
    }
    tagged.shuffle(&mut rng);
    tagged.into_iter().unzip()
}

/// Expected labels: each patch is one cluster, numbered by the first of its points in input order.
fn expected_labels(tags: &[Option<usize>]) -> (Vec<i32>, usize) {
    let mut numbering = std::collections::BTreeMap::new();
    let labels = tags
        .iter()
        .map(|tag| match tag {
            None => NOISE,
            Some(patch) => {
                let next = numbering.len() as i32;
                *numbering.entry(*patch).or_insert(next)
            }
        })
        .collect();
    (labels, numbering.len())
}

#[test]
fn twenty_thousand_points_match_the_oracle() {
    // 98 patches × 200 + 400 noise = 20,000 points.
    let (points, tags) = patches_and_noise(98, 400, 7);
    assert_eq!(points.len(), 20_000);
    let fast = dbscan(&points, 0.15, 4).unwrap();
    let (labels, clusters) = expected_labels(&tags);
    assert_eq!(fast.cluster_count, clusters);
    assert_eq!(fast.labels, labels);
    // The O(n²) oracle at this size takes ~25 s unoptimised; it is compared on 3,000 random points
    // below and in the property tests.
}

#[test]
#[cfg_attr(
    debug_assertions,
    ignore = "200k points: run with `cargo test --release` (seconds) or `-- --ignored`"
)]
fn two_hundred_thousand_points_cluster_in_seconds() {
    // 995 patches × 200 + 1,000 noise = 200,000 points.
    let (points, tags) = patches_and_noise(995, 1_000, 11);
    assert_eq!(points.len(), 200_000);
    let started = std::time::Instant::now();
    let fast = dbscan(&points, 0.15, 4).unwrap();
    let elapsed = started.elapsed();
    let (labels, clusters) = expected_labels(&tags);
    assert_eq!(fast.cluster_count, clusters);
    assert_eq!(fast.noise_count(), 1_000);
    assert_eq!(fast.labels, labels);
    eprintln!("dbscan on 200,000 points: {elapsed:?}");
}

#[test]
fn all_identical_points_are_one_cluster() {
    // 1,000 coincident points: each neighbourhood is the whole input (the O(n²) worst case), and
    // all of them share one cell. (5,000 take 0.4 s in
    // release but 15 s unoptimised.)
    let points = vec![[1.5, -2.5]; 1_000];
    for eps_m in [0.0, 1.0] {
        let c = dbscan(&points, eps_m, 1_000).unwrap();
        assert_eq!(c.cluster_count, 1);
        assert!(c.labels.iter().all(|&l| l == 0));
        let c = dbscan(&points, eps_m, 1_001).unwrap();
        assert_eq!(c.noise_count(), 1_000);
    }
}

#[test]
fn random_real_points_match_the_oracle_at_moderate_size() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let points: Vec<[f64; 2]> = (0..3_000)
        .map(|_| [rng.random_range(0.0..20.0), rng.random_range(0.0..20.0)])
        .collect();
    for (eps_m, min_samples) in [(0.3, 3), (0.5, 5), (0.6, 10)] {
        let fast = dbscan(&points, eps_m, min_samples).unwrap();
        let slow = dbscan_brute_force(&points, eps_m, min_samples).unwrap();
        assert_eq!(fast, slow);
        // The parameters were chosen so that each case has clusters and noise both.
        assert!(
            fast.cluster_count > 1 && fast.noise_count() > 0,
            "{eps_m} {min_samples}"
        );
    }
}
