//! Behaviour of the occupancy map through its public API, on grids small enough to check cell by
//! cell.

use nrslam_mapper::{MapError, OccupancyMap, Params, Pose2};
use nrslam_msgs::{Detection, Keyframe, Pose, Time};
use proptest::prelude::*;
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// A grid of `width` × `height` one-metre cells with its corner at the map origin.
fn tiny(width: f64, height: f64, free_space: bool) -> OccupancyMap {
    OccupancyMap::new(&Params {
        resolution_m: 1.0,
        origin_x_m: 0.0,
        origin_y_m: 0.0,
        width_m: width,
        height_m: height,
        free_space,
        ..Params::default()
    })
    .unwrap()
}

fn echo(range_m: f64, angle_rad: f64) -> Detection {
    Detection {
        range_m,
        angle_rad,
        ..Detection::default()
    }
}

/// AGV at (`x_m`, `y_m`) facing +x.
fn at(x_m: f64, y_m: f64) -> Pose2 {
    Pose2 {
        x_m,
        y_m,
        yaw_rad: 0.0,
    }
}

fn p(map: &OccupancyMap, column: usize, row: usize) -> Option<f64> {
    map.probability(column, row)
}

fn sigmoid(l: f64) -> f64 {
    1.0 / (1.0 + (-l).exp())
}

fn logit(p: f64) -> f64 {
    (p / (1.0 - p)).ln()
}

fn close(a: Option<f64>, b: f64) -> bool {
    a.is_some_and(|a| (a - b).abs() < 1e-12)
}

#[test]
fn hits_raise_occupancy() {
    let mut map = tiny(8.0, 3.0, false);
    map.integrate_detections(at(0.5, 1.5), 0.0, &[echo(5.0, 0.0)])
        .unwrap();
    assert!(close(p(&map, 5, 1), 0.7));
    map.integrate_detections(at(0.5, 1.5), 0.0, &[echo(5.0, 0.0)])
        .unwrap();
    // Two independent hits: log-odds add.
    assert!(close(p(&map, 5, 1), sigmoid(2.0 * logit(0.7))));
    assert!(p(&map, 5, 1).unwrap() > 0.84);
}

#[test]
fn free_space_lowers_occupancy_up_to_but_not_including_the_hit() {
    let mut map = tiny(8.0, 3.0, true);
    let report = map
        .integrate_detections(at(0.5, 1.5), 0.0, &[echo(5.0, 0.0)])
        .unwrap();
    assert_eq!((report.hit_cells, report.free_cells), (1, 5));
    for column in 0..5 {
        assert!(close(p(&map, column, 1), 0.4), "column {column}");
    }
    assert!(close(p(&map, 5, 1), 0.7));
    // Beyond the hit and beside the beam: never observed.
    for (column, row) in [(6, 1), (7, 1), (2, 0), (2, 2)] {
        assert_eq!(p(&map, column, row), None);
    }
}

#[test]
fn free_space_off_observes_only_hit_cells() {
    let mut map = tiny(8.0, 3.0, false);
    map.integrate_detections(at(0.5, 1.5), 0.0, &[echo(5.0, 0.0)])
        .unwrap();
    let observed = map.occupancy_data().iter().filter(|&&v| v != -1).count();
    assert_eq!(observed, 1);
}

#[test]
fn clamping_holds_under_a_thousand_repeated_hits_and_misses() {
    let mut map = tiny(8.0, 3.0, true);
    let hit = [echo(5.0, 0.0)];
    let beyond = [echo(6.0, 0.0)]; // the beam crosses (5, 1), a miss for it
    for _ in 0..1000 {
        map.integrate_detections(at(0.5, 1.5), 0.0, &hit).unwrap();
    }
    assert!(close(p(&map, 5, 1), 0.97));
    assert_eq!(map.occupancy_data()[8 + 5], 97);
    // Because of the clamp, ⌈logit(0.97) / −logit(0.4)⌉ = 9 misses turn the cell free again,
    // not the ~2000 that 1000 unclamped hits would need.
    for _ in 0..8 {
        map.integrate_detections(at(0.5, 1.5), 0.0, &beyond)
            .unwrap();
    }
    assert!(p(&map, 5, 1).unwrap() > 0.5);
    map.integrate_detections(at(0.5, 1.5), 0.0, &beyond)
        .unwrap();
    assert!(p(&map, 5, 1).unwrap() < 0.5);
    for _ in 0..1000 {
        map.integrate_detections(at(0.5, 1.5), 0.0, &beyond)
            .unwrap();
    }
    assert!(close(p(&map, 5, 1), 0.12));
    assert_eq!(map.occupancy_data()[8 + 5], 12);
}

#[test]
fn a_beam_through_a_hit_cell_lowers_it() {
    let mut map = tiny(8.0, 3.0, true);
    map.integrate_detections(at(0.5, 1.5), 0.0, &[echo(3.0, 0.0)])
        .unwrap();
    assert!(close(p(&map, 3, 1), 0.7));
    // Next keyframe: the echo comes from further along the same line.
    map.integrate_detections(at(0.5, 1.5), 0.0, &[echo(6.0, 0.0)])
        .unwrap();
    assert!(close(p(&map, 3, 1), sigmoid(logit(0.7) + logit(0.4))));
    assert!(close(p(&map, 6, 1), 0.7));
    // Cells crossed twice are updated twice; the sensor's own cell too.
    assert!(close(p(&map, 1, 1), sigmoid(2.0 * logit(0.4))));
    assert!(close(p(&map, 0, 1), sigmoid(2.0 * logit(0.4))));
}

#[test]
fn within_one_keyframe_hit_beats_free_and_each_cell_counts_once() {
    let mut map = tiny(8.0, 3.0, true);
    // Two echoes in cell (3, 1), one in (6, 1) whose beam crosses (3, 1).
    let report = map
        .integrate_detections(
            at(0.5, 1.5),
            0.0,
            &[echo(3.0, 0.0), echo(3.2, 0.0), echo(6.0, 0.0)],
        )
        .unwrap();
    assert_eq!(report.hit_cells, 2);
    assert!(close(p(&map, 3, 1), 0.7), "hit once, not twice, not missed");
    assert!(close(p(&map, 6, 1), 0.7));
    // (4, 1) and (5, 1) are crossed by one beam only; (1, 1) by all three, still one miss.
    assert!(close(p(&map, 4, 1), 0.4));
    assert!(close(p(&map, 1, 1), 0.4));
    assert_eq!(report.free_cells, 5); // columns 0, 1, 2, 4, 5
}

#[test]
fn detections_outside_the_grid_are_ignored_and_counted() {
    let mut map = tiny(8.0, 3.0, true);
    let before = map.occupancy_data();
    let report = map
        .integrate_detections(
            at(0.5, 1.5),
            0.0,
            &[echo(8.0, 0.0), echo(1e9, 0.3), echo(2.0, PI / 2.0 - 1e-9)],
        )
        .unwrap();
    // x = 8.5 is past the last column; 1e9 m is far away; the third lands at y ≈ 3.5, above the top.
    assert_eq!(report.out_of_grid, 3);
    assert_eq!((report.hit_cells, report.free_cells), (0, 0));
    assert_eq!(map.occupancy_data(), before);
    map.integrate_detections(at(0.5, 1.5), 0.0, &[echo(-0.0, 0.0), echo(9.0, PI)])
        .unwrap();
    assert_eq!(map.out_of_grid_detections(), 4);
}

#[test]
fn a_sensor_outside_the_grid_still_clears_from_the_grid_edge() {
    let mut map = tiny(8.0, 3.0, true);
    let report = map
        .integrate_detections(at(-10.0, 1.5), 0.0, &[echo(14.0, 0.0)])
        .unwrap();
    assert_eq!(report.out_of_grid, 0);
    assert!(close(p(&map, 4, 1), 0.7));
    for column in 0..4 {
        assert!(close(p(&map, column, 1), 0.4));
    }
}

#[test]
fn a_zero_range_detection_hits_the_sensor_cell_and_clears_nothing() {
    let mut map = tiny(8.0, 3.0, true);
    let report = map
        .integrate_detections(at(2.5, 1.5), 0.0, &[echo(0.0, 0.0)])
        .unwrap();
    assert_eq!((report.hit_cells, report.free_cells), (1, 0));
    assert!(close(p(&map, 2, 1), 0.7));
    assert_eq!(map.occupancy_data().iter().filter(|&&v| v != -1).count(), 1);
}

#[test]
fn nan_and_other_invalid_detections_are_refused_and_leave_the_map_unchanged() {
    let mut map = tiny(8.0, 3.0, true);
    map.integrate_detections(at(0.5, 1.5), 0.0, &[echo(3.0, 0.0)])
        .unwrap();
    let before = map.occupancy_data();
    let bad = [
        echo(f64::NAN, 0.0),
        echo(2.0, f64::NAN),
        echo(f64::INFINITY, 0.0),
        echo(-1.0, 0.0),
        echo(2.0, f64::NEG_INFINITY),
    ];
    for detection in bad {
        // A good detection first: the whole keyframe is refused, not just the bad one.
        let result = map.integrate_detections(at(0.5, 1.5), 0.0, &[echo(5.0, 0.0), detection]);
        assert!(
            matches!(result, Err(MapError::InvalidDetection { index: 1, .. })),
            "{detection:?}: {result:?}"
        );
    }
    for pose in [
        at(f64::NAN, 1.0),
        Pose2 {
            yaw_rad: f64::INFINITY,
            ..at(0.5, 1.5)
        },
    ] {
        assert!(matches!(
            map.integrate_detections(pose, 0.0, &[echo(1.0, 0.0)]),
            Err(MapError::NonFinitePose { .. })
        ));
    }
    assert!(map
        .integrate_detections(at(0.5, 1.5), f64::NAN, &[echo(1.0, 0.0)])
        .is_err());
    // Finite inputs whose point overflows.
    assert!(matches!(
        map.integrate_points([0.5, 1.5], &[[f64::INFINITY, 0.0]]),
        Err(MapError::NonFinitePoint { .. })
    ));
    assert_eq!(map.occupancy_data(), before);
}

#[test]
fn export_is_row_major_from_the_origin_x_fastest() {
    // 3 columns × 2 rows of 0.5 m cells, corner at (10, 20).
    let mut map = OccupancyMap::new(&Params {
        resolution_m: 0.5,
        origin_x_m: 10.0,
        origin_y_m: 20.0,
        width_m: 1.5,
        height_m: 1.0,
        ..Params::default()
    })
    .unwrap();
    assert_eq!((map.width_cells(), map.height_cells()), (3, 2));
    // From the centre of cell (0, 1) to the centre of cell (2, 1): (0, 1), (1, 1) free, (2, 1) hit.
    map.integrate_detections(at(10.25, 20.75), 0.0, &[echo(1.0, 0.0)])
        .unwrap();
    assert_eq!(map.occupancy_data(), vec![-1, -1, -1, 40, 40, 70]);
    // And a hit in cell (1, 0) seen from below the grid, looking up (+y): no free cell inside.
    map.integrate_detections(
        Pose2 {
            x_m: 10.75,
            y_m: 19.0,
            yaw_rad: FRAC_PI_2,
        },
        0.0,
        &[echo(1.25, 0.0)],
    )
    .unwrap();
    assert_eq!(map.occupancy_data(), vec![-1, 70, -1, 40, 40, 70]);

    let grid = map.to_occupancy_grid(Time::from_seconds(3.5));
    assert_eq!(grid.header.frame_id, "map");
    assert_eq!(grid.header.stamp, Time::from_seconds(3.5));
    assert_eq!(grid.info.map_load_time, Time::from_seconds(3.5));
    assert_eq!((grid.info.width, grid.info.height), (3, 2));
    assert_eq!(grid.info.resolution, 0.5);
    assert_eq!(grid.info.origin.planar(), (10.0, 20.0, 0.0));
    assert_eq!(grid.data, map.occupancy_data());
}

#[test]
fn keyframe_pose_boresight_and_angle_add_up_as_the_conventions_say() {
    let mut map = tiny(8.0, 8.0, false);
    // Heading +y, boresight a further 45°, echo 45° left of boresight: bearing π, i.e. −x.
    let keyframe = Keyframe {
        pose: Pose::from_planar(6.5, 2.5, FRAC_PI_2),
        boresight_rad: FRAC_PI_4,
        detections: vec![echo(4.0, FRAC_PI_4)],
        ..Keyframe::default()
    };
    map.integrate_keyframe(&keyframe).unwrap();
    assert!(close(p(&map, 2, 2), 0.7));
    assert_eq!(map.occupancy_data().iter().filter(|&&v| v != -1).count(), 1);
}

#[test]
fn default_grid_integrates_a_wide_keyframe() {
    let mut map = OccupancyMap::new(&Params::default()).unwrap();
    assert_eq!((map.width_cells(), map.height_cells()), (600, 500));
    // 181 echoes on a 20 m arc in front of an AGV at the hall centre (docs/scene.md).
    let detections: Vec<Detection> = (-90..=90)
        .map(|k| echo(20.0, f64::from(k).to_radians() * 0.99))
        .collect();
    let report = map
        .integrate_detections(at(27.0, 22.0), 0.0, &detections)
        .unwrap();
    assert_eq!(report.out_of_grid, 0);
    // Consecutive echoes 0.35 m apart on the arc: each lands in its own cell.
    assert_eq!(report.hit_cells, 181);
    // Roughly the half disc of radius 20 m, in 0.01 m² cells.
    let half_disc_cells = 0.5 * PI * 20.0f64.powi(2) / 0.01;
    let free = report.free_cells as f64;
    assert!(free < half_disc_cells, "{free}");
    assert!(free > 0.1 * half_disc_cells, "{free}");
}

/// An 8 m × 6 m map of 0.5 m cells from the origin.
fn small_map(free_space: bool) -> OccupancyMap {
    OccupancyMap::new(&Params {
        resolution_m: 0.5,
        origin_x_m: 0.0,
        origin_y_m: 0.0,
        width_m: 8.0,
        height_m: 6.0,
        free_space,
        ..Params::default()
    })
    .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Any finite keyframe, the sensor inside the grid or not: no panic, values within the clamps,
    /// the out-of-grid count exact, and a first keyframe's hit cells at exactly the hit value.
    #[test]
    fn arbitrary_keyframes_keep_the_map_consistent(
        x_m in -6.0f64..14.0,
        y_m in -6.0f64..12.0,
        yaw_rad in -PI..PI,
        boresight_rad in -PI..PI,
        detections in prop::collection::vec((0.0f64..20.0, -1.6f64..1.6), 0..40),
        free_space in any::<bool>(),
    ) {
        let mut map = small_map(free_space);
        let pose = Pose2 { x_m, y_m, yaw_rad };
        let detections: Vec<Detection> = detections.into_iter().map(|(r, a)| echo(r, a)).collect();
        let report = map.integrate_detections(pose, boresight_rad, &detections).unwrap();

        let mut hit_cells = std::collections::BTreeSet::new();
        let mut outside = 0;
        for d in &detections {
            let point = nrslam_mapper::detection_point(pose, boresight_rad, d.range_m, d.angle_rad);
            match map.cell_of(point[0], point[1]) {
                Some(cell) => { hit_cells.insert(cell); }
                None => outside += 1,
            }
        }
        prop_assert_eq!(report.out_of_grid, outside);
        prop_assert_eq!(report.hit_cells, hit_cells.len());
        for &(column, row) in &hit_cells {
            prop_assert!(close(map.probability(column, row), 0.7));
        }
        let data = map.occupancy_data();
        let observed = data.iter().filter(|&&v| v != -1).count();
        prop_assert_eq!(observed, report.hit_cells + report.free_cells);
        for &v in &data {
            prop_assert!(v == -1 || v == 40 || v == 70, "value {}", v);
        }
        if !free_space {
            prop_assert_eq!(report.free_cells, 0);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// The published grid is kept up to date cell by cell as keyframes arrive; after any sequence
    /// of keyframes it equals the definition applied to every cell's log-odds: −1 where never
    /// observed, else round(100 / (1 + e^−l)).
    #[test]
    fn the_published_grid_equals_the_definition_after_any_keyframes(
        keyframes in prop::collection::vec(
            (-4.0f64..12.0, -4.0f64..10.0, -PI..PI,
             prop::collection::vec((0.0f64..12.0, -1.6f64..1.6), 0..30)),
            1..8),
        free_space in any::<bool>(),
    ) {
        let mut map = small_map(free_space);
        for (x_m, y_m, yaw_rad, echoes) in keyframes {
            let detections: Vec<Detection> = echoes.into_iter().map(|(r, a)| echo(r, a)).collect();
            map.integrate_detections(Pose2 { x_m, y_m, yaw_rad }, 0.0, &detections).unwrap();
        }
        let data = map.occupancy_data();
        prop_assert_eq!(data.len(), map.width_cells() * map.height_cells());
        for row in 0..map.height_cells() {
            for column in 0..map.width_cells() {
                let expected = map
                    .log_odds_at(column, row)
                    .map_or(-1, nrslam_mapper::occupancy_percent);
                prop_assert_eq!(data[row * map.width_cells() + column], expected, "cell ({}, {})", column, row);
            }
        }
    }
}

#[test]
fn the_footprint_covers_the_resolution_cell_and_widens_with_range() {
    let params = Params {
        footprint: true,
        free_space: false,
        ..Params::default()
    };
    let hit_cells = |range_m: f64| {
        let mut map = OccupancyMap::new(&params).unwrap();
        let echo = Detection {
            range_m,
            ..Detection::default()
        };
        let pose = Pose2 {
            x_m: 0.0,
            y_m: 20.0,
            yaw_rad: 0.0,
        };
        map.integrate_detections(pose, 0.0, &[echo])
            .unwrap()
            .hit_cells
    };
    let (near, far) = (hit_cells(5.0), hit_cells(20.0));
    // 3.58° at 20 m is 1.25 m across the beam: about 13 cells of 0.1 m, times 2-3 along it.
    assert!((20..=60).contains(&far), "{far}");
    assert!(far > 2 * near, "near {near}, far {far}");
    let point = Params {
        free_space: false,
        ..Params::default()
    };
    let mut map = OccupancyMap::new(&point).unwrap();
    let echo = Detection {
        range_m: 20.0,
        ..Detection::default()
    };
    let pose = Pose2 {
        x_m: 0.0,
        y_m: 20.0,
        yaw_rad: 0.0,
    };
    assert_eq!(
        map.integrate_detections(pose, 0.0, &[echo])
            .unwrap()
            .hit_cells,
        1
    );
}

/// Keyframes at random poses on a 12 m × 10 m grid, each with up to five echoes.
fn keyframes() -> impl Strategy<Value = Vec<Keyframe>> {
    let echoes = proptest::collection::vec((0.0..9.0f64, -1.2..1.2f64), 0..6);
    proptest::collection::vec((0.0..12.0f64, 0.0..10.0f64, -PI..PI, echoes), 0..30).prop_map(
        |frames| {
            frames
                .into_iter()
                .enumerate()
                .map(|(id, (x_m, y_m, yaw_rad, echoes))| Keyframe {
                    id: id as u32,
                    pose: Pose::from_planar(x_m, y_m, yaw_rad),
                    boresight_rad: FRAC_PI_2,
                    detections: echoes.into_iter().map(|(r, a)| echo(r, a)).collect(),
                    ..Keyframe::default()
                })
                .collect()
        },
    )
}

fn half_metre_grid() -> OccupancyMap {
    OccupancyMap::new(&Params {
        resolution_m: 0.5,
        origin_x_m: 0.0,
        origin_y_m: 0.0,
        width_m: 12.0,
        height_m: 10.0,
        ..Params::default()
    })
    .unwrap()
}

proptest! {
    /// The rebuild's batch, which converts each cell's percentage once at its end, publishes
    /// what integrating the keyframes one by one publishes; a keyframe that fails stops the
    /// batch where one-by-one integration would stop, with no cell left unconverted.
    #[test]
    fn a_batch_of_keyframes_publishes_what_one_by_one_does(
        mut keyframes in keyframes(),
        bad in proptest::option::of(0usize..30),
    ) {
        let bad = bad.filter(|&i| i < keyframes.len());
        if let Some(i) = bad {
            keyframes[i].detections.push(echo(f64::NAN, 0.0));
        }
        let mut one_by_one = half_metre_grid();
        for keyframe in &keyframes {
            if one_by_one.integrate_keyframe(keyframe).is_err() {
                break;
            }
        }
        let mut batch = half_metre_grid();
        let result = batch.integrate_keyframes(&keyframes);
        prop_assert_eq!(result.err().map(|(i, _)| i), bad);
        prop_assert_eq!(batch.occupancy_data(), one_by_one.occupancy_data());
        prop_assert!(batch.occupancy_data().iter().all(|&v| (-1..=100).contains(&v)));
    }
}
