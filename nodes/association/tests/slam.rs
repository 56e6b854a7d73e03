//! The association loop on simulated runs: an AGV loops among rectangular and circular targets
//! (the paper's scene, Sec. II-A, scaled down), with wheel odometry and radar detections
//! generated here from the ground truth.

use nrslam_association::{
    detection_to_agv_m, Association, AssociationError, IcpStatus, Params, Pose2,
};
use std::f64::consts::PI;

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Target outlines as closed polygons (map frame, metres).
fn scene() -> Vec<Vec<[f64; 2]>> {
    let rect = |x0: f64, y0: f64, w: f64, h: f64| {
        vec![[x0, y0], [x0 + w, y0], [x0 + w, y0 + h], [x0, y0 + h]]
    };
    let circle = |cx: f64, cy: f64, r: f64| {
        (0..32)
            .map(|i| {
                let a = f64::from(i) * std::f64::consts::TAU / 32.0;
                [cx + r * a.cos(), cy + r * a.sin()]
            })
            .collect::<Vec<_>>()
    };
    vec![
        rect(-2.0, -6.0, 4.0, 1.5),
        rect(6.0, -5.0, 1.5, 3.0),
        rect(6.0, 3.0, 2.0, 2.0),
        rect(-1.5, 5.0, 3.0, 1.0),
        rect(-8.0, 2.0, 1.5, 3.0),
        rect(-8.0, -4.0, 2.0, 1.5),
        circle(0.0, 0.0, 1.0),
        circle(-4.0, 0.5, 0.6),
    ]
}

/// Points every `step_m` along every outline.
fn outline_points(step_m: f64) -> Vec<[f64; 2]> {
    let mut points = Vec::new();
    for polygon in scene() {
        for i in 0..polygon.len() {
            let (a, b) = (polygon[i], polygon[(i + 1) % polygon.len()]);
            let n = ((b[0] - a[0]).hypot(b[1] - a[1]) / step_m).ceil().max(1.0) as usize;
            for k in 0..n {
                let s = k as f64 / n as f64;
                points.push([a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])]);
            }
        }
    }
    points
}

/// The ground-truth trajectory: a 8 m × 7 m ellipse, counter-clockwise, `step_m` per frame.
fn trajectory(frames: usize, step_m: f64) -> Vec<Pose2> {
    let (a, b) = (4.0, 3.5);
    (0..frames)
        .map(|k| {
            // Parametrised by time (3.75 m is about the mean radius); heading along the velocity.
            let t = k as f64 * step_m / 3.75;
            let (x, y) = (a * t.cos(), b * t.sin());
            let yaw = (b * t.cos()).atan2(-a * t.sin());
            Pose2::new(x, y, yaw)
        })
        .collect()
}

/// How the simulated sensors err.
#[derive(Clone, Copy)]
struct Noise {
    range_std_m: f64,
    angle_std_rad: f64,
    /// Per-frame odometry increment noise (translation, metres; rotation, radians).
    odom_step_std_m: f64,
    odom_step_std_rad: f64,
    /// Systematic odometry errors: scale of the travelled distance, heading drift per metre.
    odom_scale: f64,
    odom_yaw_drift_rad_per_m: f64,
}

const NOISE_FREE: Noise = Noise {
    range_std_m: 0.0,
    angle_std_rad: 0.0,
    odom_step_std_m: 0.0,
    odom_step_std_rad: 0.0,
    odom_scale: 1.0,
    odom_yaw_drift_rad_per_m: 0.0,
};

/// The simulated radar: boresight from the AGV heading, half field of view, maximum range.
#[derive(Clone, Copy)]
struct Sensor {
    boresight_rad: f64,
    half_fov_rad: f64,
    max_range_m: f64,
}

/// A forward-looking radar, ±60°, 12 m.
const RADAR: Sensor = Sensor {
    boresight_rad: 0.0,
    half_fov_rad: PI / 3.0,
    max_range_m: 12.0,
};

/// Sees everything.
const OMNISCIENT: Sensor = Sensor {
    boresight_rad: 0.0,
    half_fov_rad: PI,
    max_range_m: f64::INFINITY,
};

/// A simulated run.
#[derive(Clone)]
struct Scenario {
    frames: usize,
    step_m: f64,
    noise: Noise,
    /// `None` draws 200 fresh random points on the outlines each frame (a diffuse target);
    /// `Some(points)` observes the same points every frame.
    scatterers: Option<Vec<[f64; 2]>>,
    sensor: Sensor,
    seed: u64,
}

impl Scenario {
    fn new(frames: usize, noise: Noise, scatterers: Option<Vec<[f64; 2]>>, seed: u64) -> Self {
        Scenario {
            frames,
            step_m: 0.1,
            noise,
            scatterers,
            sensor: RADAR,
            seed,
        }
    }
}

/// One frame of input: the odometry pose and the detections as AGV-frame points.
struct Frame {
    truth: Pose2,
    odom: Pose2,
    scan_agv_m: Vec<[f64; 2]>,
}

fn simulate(scenario: &Scenario) -> Vec<Frame> {
    let noise = scenario.noise;
    let sensor = scenario.sensor;
    let mut rng = ChaCha8Rng::seed_from_u64(scenario.seed);
    let standard = Normal::new(0.0, 1.0).unwrap();
    let dense = outline_points(0.02);
    let truth = trajectory(scenario.frames, scenario.step_m);
    // The odometry frame starts somewhere else: only its increments matter.
    let mut odom = Pose2::new(10.0, -20.0, 1.0);
    let mut out = Vec::with_capacity(scenario.frames);
    for (k, pose) in truth.iter().enumerate() {
        if k > 0 {
            let step = truth[k - 1].between(pose);
            let length_m = step.x_m.hypot(step.y_m);
            let noisy = Pose2::new(
                step.x_m * noise.odom_scale + noise.odom_step_std_m * standard.sample(&mut rng),
                step.y_m * noise.odom_scale + noise.odom_step_std_m * standard.sample(&mut rng),
                step.yaw_rad
                    + noise.odom_yaw_drift_rad_per_m * length_m
                    + noise.odom_step_std_rad * standard.sample(&mut rng),
            );
            odom = odom.compose(&noisy);
        }
        let drawn: Vec<[f64; 2]>;
        let points = match &scenario.scatterers {
            Some(points) => points,
            None => {
                drawn = (0..200)
                    .map(|_| dense[rng.random_range(0..dense.len())])
                    .collect();
                &drawn
            }
        };
        // The radar's pose: at the AGV centre, turned by the boresight.
        let radar = pose.compose(&Pose2::new(0.0, 0.0, sensor.boresight_rad));
        let inverse = radar.inverse();
        let mut scan_agv_m = Vec::new();
        for &p in points {
            let local = inverse.transform_point(p);
            let range_m = local[0].hypot(local[1]);
            let angle_rad = local[1].atan2(local[0]);
            if range_m > sensor.max_range_m || angle_rad.abs() > sensor.half_fov_rad {
                continue;
            }
            scan_agv_m.push(detection_to_agv_m(
                range_m + noise.range_std_m * standard.sample(&mut rng),
                angle_rad + noise.angle_std_rad * standard.sample(&mut rng),
                sensor.boresight_rad,
            ));
        }
        out.push(Frame {
            truth: *pose,
            odom,
            scan_agv_m,
        });
    }
    out
}

/// Runs the association over `frames`; the SLAM pose of each frame, expressed so that it is
/// comparable with the truth (the map frame is the odometry frame at t0, and the truth frame
/// differs from it by the first odometry pose against the first true pose).
struct Run {
    poses: Vec<Pose2>,
    keyframes: Vec<Option<u32>>,
    statuses: Vec<IcpStatus>,
    map_len: usize,
}

fn run(frames: &[Frame], params: Params) -> Run {
    let mut slam = Association::new(params).unwrap();
    let to_truth = frames[0].truth.compose(&frames[0].odom.inverse());
    let mut run = Run {
        poses: Vec::new(),
        keyframes: Vec::new(),
        statuses: Vec::new(),
        map_len: 0,
    };
    for frame in frames {
        slam.on_odometry(frame.odom).unwrap();
        let outcome = slam.on_scan(&frame.scan_agv_m).unwrap();
        run.poses.push(to_truth.compose(&outcome.pose));
        run.keyframes.push(outcome.keyframe_id);
        run.statuses.push(outcome.icp.status);
    }
    run.map_len = slam.map().len();
    run
}

fn position_errors(frames: &[Frame], poses: &[Pose2]) -> Vec<f64> {
    frames
        .iter()
        .zip(poses)
        .map(|(f, p)| f.truth.distance_m(p))
        .collect()
}

fn max(values: &[f64]) -> f64 {
    values.iter().copied().fold(0.0, f64::max)
}

#[test]
fn noise_free_inputs_stay_within_the_cell_bias() {
    // Every scatterer visible in every frame, exact measurements and odometry. Scan matching
    // summarises the map in 0.5 m cells, so even a scan that has an exact twin in the map settles
    // where the cell means put it, not exactly on the truth: on these outlines sampled every
    // 0.1 m the error stays under 3 cm over 30 m (2.6 cm when measured), and does not grow.
    // (On outlines sampled every 0.5 m, a cell holds one or two points and the error reaches
    // 15 cm: cell statistics need a dense map, which keyframes of a radar's outlines give.)
    let frames = simulate(&Scenario {
        sensor: OMNISCIENT,
        ..Scenario::new(300, NOISE_FREE, Some(outline_points(0.1)), 1)
    });
    let result = run(&frames, Params::default());
    let errors = position_errors(&frames, &result.poses);
    assert!(max(&errors) < 0.04, "max error {} m", max(&errors));
    assert!(
        max(&errors[200..]) < 0.04,
        "late error {} m",
        max(&errors[200..])
    );
    for (frame, pose) in frames.iter().zip(&result.poses) {
        assert!(frame.truth.rotation_to_rad(pose).to_degrees() < 0.5);
    }
    assert!(result.statuses[1..].iter().all(|s| s.is_accepted()));
}

#[test]
fn dead_reckoning_with_noise_free_odometry_is_the_truth() {
    let frames = simulate(&Scenario::new(300, NOISE_FREE, None, 2));
    let result = run(
        &frames,
        Params {
            scan_matching: false,
            ..Params::default()
        },
    );
    assert!(max(&position_errors(&frames, &result.poses)) < 1e-9);
    assert!(result.statuses.iter().all(|&s| s == IcpStatus::Disabled));
}

#[test]
fn noise_free_odometry_with_a_limited_field_of_view_stays_on_the_truth() {
    // New scatterers enter the field of view unmapped and pair with mapped neighbours; the
    // resulting pull, with the cell bias (see above), must stay small: 3.5 cm when measured.
    let frames = simulate(&Scenario::new(
        300,
        NOISE_FREE,
        Some(outline_points(0.3)),
        3,
    ));
    let result = run(&frames, Params::default());
    let errors = position_errors(&frames, &result.poses);
    assert!(max(&errors) < 0.05, "max error {} m", max(&errors));
}

fn drifting_noise() -> Noise {
    Noise {
        range_std_m: 0.03,
        angle_std_rad: 0.5f64.to_radians(),
        odom_step_std_m: 0.005,
        odom_step_std_rad: 0.1f64.to_radians(),
        odom_scale: 1.03,
        odom_yaw_drift_rad_per_m: 1f64.to_radians(),
    }
}

#[test]
fn scan_matching_bounds_the_odometry_drift() {
    let frames = simulate(&Scenario::new(400, drifting_noise(), None, 4));
    let dead_reckoning = run(
        &frames,
        Params {
            scan_matching: false,
            ..Params::default()
        },
    );
    let dr_errors = position_errors(&frames, &dead_reckoning.poses);
    let slam = run(&frames, Params::default());
    let errors = position_errors(&frames, &slam.poses);
    assert!(max(&dr_errors) > 1.0, "the scenario must drift");
    assert!(max(&errors) < 0.3, "max {} m", max(&errors));
    assert!(max(&errors) < max(&dr_errors) / 4.0);
}

#[test]
fn same_inputs_give_bit_identical_outputs() {
    let frames = simulate(&Scenario::new(300, drifting_noise(), None, 5));
    let a = run(&frames, Params::default());
    let b = run(&frames, Params::default());
    let bits = |poses: &[Pose2]| -> Vec<[u64; 3]> {
        poses
            .iter()
            .map(|p| [p.x_m.to_bits(), p.y_m.to_bits(), p.yaw_rad.to_bits()])
            .collect()
    };
    assert_eq!(bits(&a.poses), bits(&b.poses));
    assert_eq!(a.keyframes, b.keyframes);
    assert_eq!(a.statuses, b.statuses);
    assert_eq!(a.map_len, b.map_len);
}

#[test]
fn keyframes_are_numbered_and_spaced() {
    let frames = simulate(&Scenario::new(400, drifting_noise(), None, 6));
    let params = Params::default();
    let mut slam = Association::new(params.clone()).unwrap();
    let mut expected_id = 0;
    let mut last_keyframe: Option<Pose2> = None;
    let mut map_points = 0;
    for frame in &frames {
        slam.on_odometry(frame.odom).unwrap();
        let outcome = slam.on_scan(&frame.scan_agv_m).unwrap();
        // The keyframe decision is taken at the tracked pose; a loop closed on that keyframe
        // then moves it (and the reference for the next decision) to the corrected pose.
        let decided_at = if outcome.loop_match.is_some() {
            outcome.icp.pose
        } else {
            outcome.pose
        };
        let moved = last_keyframe.map(|k| {
            k.distance_m(&decided_at) >= params.keyframe_distance_m - 1e-9
                || k.rotation_to_rad(&decided_at) >= params.keyframe_rotation_rad() - 1e-9
        });
        match outcome.keyframe_id {
            Some(id) => {
                assert_eq!(id, expected_id);
                assert!(
                    moved.unwrap_or(true),
                    "keyframe {id} too close to the last: {last_keyframe:?} {outcome:?}"
                );
                expected_id += 1;
                last_keyframe = Some(outcome.pose);
                map_points += frame.scan_agv_m.len();
            }
            None => assert_eq!(moved, Some(false)),
        }
        assert_eq!(slam.map().len(), map_points);
    }
    // 400 frames × 0.1 m = 40 m travelled: tens of keyframes, far fewer than frames.
    assert!((20..200).contains(&expected_id), "{expected_id} keyframes");
}

/// Runs `frames` with `params`, the detections of frame k given `angle_std_deg(k)` (and 3 cm
/// in range); returns the points of the keyframes scan matching holds at the end (the back end
/// checks in debug builds, at every keyframe, that its two maps hold the same), those of the
/// keyframes within `local_map_m` of travel of the last one and of all keyframes, and the
/// keyframes' largest scatter (m).
fn map_after(
    frames: &[Frame],
    params: Params,
    angle_std_deg: impl Fn(usize) -> f64,
) -> ([usize; 3], f64) {
    let window_m = params.loop_closure.local_map_m;
    let mut slam = Association::new(params).unwrap();
    for (k, frame) in frames.iter().enumerate() {
        slam.on_odometry(frame.odom).unwrap();
        let std = vec![[0.03, angle_std_deg(k).to_radians()]; frame.scan_agv_m.len()];
        slam.on_scan_with_std(&frame.scan_agv_m, Some(&std))
            .unwrap();
    }
    let records = slam.keyframe_records();
    let last_m = records.last().unwrap().travelled_m;
    let points = |window_m: f64| -> usize {
        records
            .iter()
            .filter(|r| last_m - r.travelled_m <= window_m)
            .map(|r| r.scan_agv_m.len())
            .sum()
    };
    let scatter_m = records.iter().map(|r| r.scatter_m).fold(0.0, f64::max);
    (
        [slam.map().len(), points(window_m), points(f64::INFINITY)],
        scatter_m,
    )
}

#[test]
fn local_tracking_matches_against_the_last_window_of_keyframes_only() {
    // 400 frames × 0.1 m = 40 m of travel (loops close from 30 m) against an 8 m window.
    let frames = simulate(&Scenario::new(400, drifting_noise(), None, 7));
    let mut params = Params::default();
    params.loop_closure.local_map_m = 8.0;
    let threshold_m = 0.25;
    params.loop_closure.local_map_max_scatter_m = threshold_m;
    let ([held, window, all], scatter_m) = map_after(&frames, params.clone(), |_| 0.5);
    assert!(scatter_m < threshold_m, "{scatter_m} m");
    assert!(
        window < all / 2,
        "{window} of {all}: the window must drop keyframes"
    );
    assert_eq!(held, window);

    // Without loop closure nothing would ever correct a local map's drift: the whole map.
    params.loop_closure.enabled = false;
    let ([held, _, all], _) = map_after(&frames, params.clone(), |_| 0.5);
    assert_eq!(held, all);

    // Nor when the detections scatter farther than `local_map_max_scatter_m`: their loop
    // edges would be too loose to correct the chain.
    params.loop_closure.enabled = true;
    let ([held, _, all], scatter_m) = map_after(&frames, params.clone(), |_| 5.0);
    assert!(scatter_m > threshold_m, "{scatter_m} m");
    assert_eq!(held, all);

    // Scattered detections in the middle of the run: local, then the whole map (rebuilt), then
    // local again (the keyframes out of the window retracted), as the last query says.
    let ([held, window, _], scatter_m) = map_after(&frames, params.clone(), |k| {
        if (130..260).contains(&k) {
            5.0
        } else {
            0.5
        }
    });
    assert!(scatter_m > threshold_m, "{scatter_m} m");
    assert_eq!(held, window);

    // 0 turns local tracking off.
    params.loop_closure.local_map_m = 0.0;
    let ([held, _, all], _) = map_after(&frames, params, |_| 0.5);
    assert_eq!(held, all);
}

#[test]
fn odometry_initialises_and_predicts() {
    let mut slam = Association::new(Params::default()).unwrap();
    assert_eq!(slam.on_scan(&[]), Err(AssociationError::NoOdometry));
    assert!(matches!(
        slam.on_odometry(Pose2::new(f64::NAN, 0.0, 0.0)),
        Err(AssociationError::NonFiniteOdometry(_))
    ));
    let start = Pose2::new(5.0, -3.0, 2.0);
    slam.on_odometry(start).unwrap();
    assert_eq!(slam.pose(), Some(start));
    let first = slam.on_scan(&[]).unwrap();
    assert_eq!(first.pose, start);
    assert_eq!(first.keyframe_id, Some(0));
    assert_eq!(first.icp.status, IcpStatus::EmptyScan);
    // Several odometry messages between scans: the increment is from the last scan's odometry
    // to the latest one.
    let step = Pose2::new(0.4, 0.1, 0.05);
    let mut odom = start;
    for _ in 0..3 {
        odom = odom.compose(&step);
        slam.on_odometry(odom).unwrap();
    }
    let second = slam.on_scan(&[]).unwrap();
    let expected = start.compose(&step).compose(&step).compose(&step);
    assert!(second.pose.distance_m(&expected) < 1e-12);
    assert!(second.pose.rotation_to_rad(&expected) < 1e-12);
    assert_eq!(second.keyframe_id, Some(1), "1.2 m from the first keyframe");
    // No new odometry: the pose stays.
    let third = slam.on_scan(&[]).unwrap();
    assert_eq!(third.pose, second.pose);
    assert_eq!(third.keyframe_id, None);
}
