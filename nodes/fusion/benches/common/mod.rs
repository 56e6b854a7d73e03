//! Synthetic scenes for the fusion tests and benches: boxes, lap paths and what an AGV sees.
#![allow(dead_code)]

use nrslam_association::Pose2;

/// Points along the outline of an axis-aligned box (centre, size), `step_m` apart.
pub fn box_outline(cx: f64, cy: f64, w: f64, h: f64, step_m: f64) -> Vec<[f64; 2]> {
    let mut points = Vec::new();
    let corners = [
        [cx - w / 2.0, cy - h / 2.0],
        [cx + w / 2.0, cy - h / 2.0],
        [cx + w / 2.0, cy + h / 2.0],
        [cx - w / 2.0, cy + h / 2.0],
    ];
    for i in 0..4 {
        let (a, b) = (corners[i], corners[(i + 1) % 4]);
        let length = (b[0] - a[0]).hypot(b[1] - a[1]);
        let n = (length / step_m).ceil() as usize;
        for k in 0..n {
            let t = k as f64 / n as f64;
            points.push([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])]);
        }
    }
    points
}

/// An irregular layout of boxes (no symmetry that would make two places look alike), offset.
pub fn scene(offset_x_m: f64) -> Vec<[f64; 2]> {
    let boxes = [
        (10.0, 10.0, 4.0, 3.0),
        (20.0, 11.0, 5.0, 1.5),
        (31.0, 9.0, 2.0, 2.0),
        (11.0, 21.0, 1.5, 5.0),
        (22.0, 20.0, 6.0, 2.5),
        (30.0, 22.0, 3.0, 4.0),
    ];
    boxes
        .iter()
        .flat_map(|&(cx, cy, w, h)| box_outline(cx + offset_x_m, cy, w, h, 0.25))
        .collect()
}

/// Counter-clockwise loop around [x0, x1] × [y0, y1], one pose per `step_m`.
pub fn lap(x0: f64, y0: f64, x1: f64, y1: f64, step_m: f64) -> Vec<Pose2> {
    let corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
    let mut poses = Vec::new();
    for i in 0..4 {
        let (a, b) = (corners[i], corners[(i + 1) % 4]);
        let yaw = (b[1] - a[1]).atan2(b[0] - a[0]);
        let length = (b[0] - a[0]).hypot(b[1] - a[1]);
        let n = (length / step_m).round() as usize;
        for k in 0..n {
            let t = k as f64 / n as f64;
            poses.push(Pose2::new(
                a[0] + t * (b[0] - a[0]),
                a[1] + t * (b[1] - a[1]),
                yaw,
            ));
        }
    }
    poses
}

/// The scene's points an AGV at `pose` sees (within 15 m, ±60° about its left), body frame.
pub fn observe(scene: &[[f64; 2]], pose: &Pose2) -> Vec<[f64; 2]> {
    let to_body = pose.inverse();
    scene
        .iter()
        .map(|p| to_body.transform_point(*p))
        .filter(|p| {
            let range = p[0].hypot(p[1]);
            let bearing = p[1].atan2(p[0]) - std::f64::consts::FRAC_PI_2;
            range <= 15.0 && bearing.abs() <= 60f64.to_radians()
        })
        .collect()
}
