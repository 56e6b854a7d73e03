//! What the back end's pose uncertainty adds to a fitted shape's covariance.
//!
//! A shape is fitted to the occupancy map, and every cell of the map was placed by the poses of
//! the keyframes whose detections hit it. A keyframe whose pose is off by δ = (δx, δy, δψ) moves
//! the cells it placed near a centre c by `J δ`, `J = [[1, 0, −l_y], [0, 1, l_x]]` with the
//! lever `l = c − p` from the keyframe's position p. The fit's own covariance describes only the
//! scatter of the cells about the outline; through SLAM the outline as a whole is displaced by
//! the pose errors of the keyframes that saw it, which the fit cannot see.
//!
//! Those errors are much alike for keyframes close together in time, so the model takes them as
//! one error with the keyframes' mean covariance Σ̄, acting through the mean lever l̄ (keyframes
//! on opposite sides of a target turn its cells in opposite directions, which the fit averages):
//! `share · J(l̄) Σ̄ J(l̄)ᵀ` over the keyframes within `pose_support_m` of the centre, Σ̄ being
//! their published marginal covariances (`/slam/keyframe_poses`) and J extended by a yaw row
//! (0, 0, 1): the centre's block, a rectangle's yaw variance and the cross terms between them
//! (one pose error moves and turns the shape together). `share` (`pose_covariance_share`) says how much of that error the fit
//! keeps: the errors of the tens of keyframes that see a target are not one error, and partly
//! average out (measured: docs/shapes.md).

/// A keyframe as the shapes see it: where it was and how sure the back end is of its pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Viewpoint {
    /// Position in the map frame (m).
    pub position_m: [f64; 2],
    /// Covariance of its pose over (x m, y m, yaw rad), map frame; zero when unknown.
    pub covariance: [[f64; 3]; 3],
}

/// The covariance the viewpoints' pose errors add to a shape centred at `center_m`, times
/// `share`, over (centre x m, centre y m, yaw rad): the centre's 2 × 2 block, the yaw's variance
/// and their cross terms (one pose error moves and turns the shape together). Zero when no
/// viewpoint lies within `support_m`. A viewpoint whose covariance is not finite or has a
/// negative variance is left out, and a sum that overflows gives zero: a malformed input adds
/// nothing rather than NaN.
pub fn pose_covariance(
    center_m: [f64; 2],
    viewpoints: &[Viewpoint],
    support_m: f64,
    share: f64,
) -> [[f64; 3]; 3] {
    let mut lever_sum = [0.0; 2];
    let mut covariance_sum = [[0.0; 3]; 3];
    let mut count = 0.0;
    for v in viewpoints {
        let lever = [center_m[0] - v.position_m[0], center_m[1] - v.position_m[1]];
        let usable = v.covariance.iter().flatten().all(|x| x.is_finite())
            && (0..3).all(|d| v.covariance[d][d] >= 0.0);
        // A NaN distance (a NaN centre) is within no support.
        let within = lever[0]
            .hypot(lever[1])
            .partial_cmp(&support_m)
            .is_some_and(|o| o.is_le());
        if !within || !usable {
            continue;
        }
        for axis in 0..2 {
            lever_sum[axis] += lever[axis];
        }
        for (row, total) in v.covariance.iter().zip(covariance_sum.iter_mut()) {
            for (value, t) in row.iter().zip(total.iter_mut()) {
                *t += value;
            }
        }
        count += 1.0;
    }
    if count == 0.0 {
        return [[0.0; 3]; 3];
    }
    let mean_lever = lever_sum.map(|v| v / count);
    let mean_covariance = covariance_sum.map(|row| row.map(|v| share * v / count));
    let out = sandwich(&jacobian(mean_lever), &mean_covariance);
    if out.iter().flatten().all(|v| v.is_finite()) {
        out
    } else {
        [[0.0; 3]; 3]
    }
}

/// How a pose error (δx, δy, δψ) moves and turns a shape whose centre is `lever` away from the
/// pose's position: (centre x, centre y, yaw).
fn jacobian(lever: [f64; 2]) -> [[f64; 3]; 3] {
    [[1.0, 0.0, -lever[1]], [0.0, 1.0, lever[0]], [0.0, 0.0, 1.0]]
}

/// `J Σ Jᵀ`.
fn sandwich(j: &[[f64; 3]; 3], s: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (r, row) in out.iter_mut().enumerate() {
        for (c, value) in row.iter_mut().enumerate() {
            for a in 0..3 {
                for b in 0..3 {
                    *value += j[r][a] * s[a][b] * j[c][b];
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn viewpoint(x: f64, y: f64, var_m2: f64, var_rad2: f64) -> Viewpoint {
        Viewpoint {
            position_m: [x, y],
            covariance: [[var_m2, 0.0, 0.0], [0.0, var_m2, 0.0], [0.0, 0.0, var_rad2]],
        }
    }

    #[test]
    fn position_error_moves_the_centre_and_yaw_error_moves_it_across_the_lever() {
        // A keyframe 10 m west of the centre: its yaw error moves the centre north-south only.
        let c = pose_covariance([10.0, 0.0], &[viewpoint(0.0, 0.0, 0.01, 1e-4)], 20.0, 1.0);
        assert!((c[0][0] - 0.01).abs() < 1e-12);
        assert!((c[1][1] - (0.01 + 100.0 * 1e-4)).abs() < 1e-12);
        assert!(c[0][1].abs() < 1e-12 && (c[2][2] - 1e-4).abs() < 1e-15);
        // The same turn moves the centre north and turns the shape: correlated, 10 m × 1e-4.
        assert!((c[1][2] - 10.0 * 1e-4).abs() < 1e-15 && c[1][2] == c[2][1]);
        assert!(c[0][2].abs() < 1e-15);
        let half = pose_covariance([10.0, 0.0], &[viewpoint(0.0, 0.0, 0.01, 1e-4)], 20.0, 0.5);
        for (a, b) in half.iter().flatten().zip(c.iter().flatten()) {
            assert!((a - 0.5 * b).abs() < 1e-15);
        }
    }

    #[test]
    fn opposite_levers_cancel_and_far_or_broken_viewpoints_add_nothing() {
        // Keyframes 5 m north and south: their mean lever is zero, so only position error stays.
        let around = [
            viewpoint(0.0, 5.0, 0.04, 1e-3),
            viewpoint(0.0, -5.0, 0.02, 1e-3),
        ];
        let far = viewpoint(100.0, 0.0, 50.0, 1.0);
        let c = pose_covariance([0.0, 0.0], &[around[0], around[1], far], 20.0, 1.0);
        assert!(
            (c[0][0] - 0.03).abs() < 1e-12 && (c[1][1] - 0.03).abs() < 1e-12,
            "{c:?}"
        );
        let zero = [[0.0; 3]; 3];
        assert_eq!(pose_covariance([0.0, 0.0], &[far], 20.0, 1.0), zero);
        for bad in [f64::NAN, -1.0] {
            let mut broken = around[0];
            broken.covariance[0][0] = bad;
            assert_eq!(pose_covariance([0.0, 0.0], &[broken], 20.0, 1.0), zero);
        }
        // Finite but huge: the sum overflows, and nothing is added rather than NaN.
        let mut huge = around[0];
        huge.covariance = [[1e308; 3]; 3];
        assert_eq!(pose_covariance([0.0, 0.0], &[huge, huge], 20.0, 1.0), zero);
        // A NaN lever (a NaN centre) is never within the support.
        assert_eq!(pose_covariance([f64::NAN, 0.0], &around, 20.0, 1.0), zero);
    }
}
