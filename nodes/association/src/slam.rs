//! The association algorithm: odometry prediction, scan-to-map correction, keyframes.
//!
//! This is the loop between the paper's "location" and "mapping" tasks (Sec. III-A, *Location &
//! mapping*: "location requires feature points […] of map, and mapping requires accurate location
//! information"). Each frame:
//!
//! 1. **Predict.** The wheel-odometry increment since the previous frame, a relative pose in the
//!    odometry frame, is applied to the current SLAM pose. Odometry drifts, but its increments are
//!    accurate over one frame; only increments are used, so the drift of the odometry frame
//!    against the map frame does not matter. The first odometry message initialises the SLAM pose
//!    (the map frame equals the odometry frame at t0, `docs/conventions.md`).
//! 2. **Correct.** The frame's detections are matched against the keyframe map by ICP
//!    ([`crate::icp::align`]), which replaces the prediction when it is trusted.
//! 3. **Map.** If the corrected pose is far enough from the last keyframe
//!    ([`crate::keyframe::KeyframeSelector`]), the frame is a keyframe and its detections, placed
//!    with the corrected pose, join the map.
//!
//! There is no loop closure, as in the paper, so errors that scan matching cannot see (the map's
//! own error) accumulate: the paper's Fig. 7 shows the AGV position MSE growing with time.

use nrslam_runtime::InvalidParam;

use crate::icp::{align, IcpResult, PointMap};
use crate::keyframe::KeyframeSelector;
use crate::params::Params;
use crate::pose::Pose2;

/// A detection at `range_m` and angle of arrival `angle_rad` (from the array boresight,
/// counter-clockwise), for an array whose boresight is `boresight_rad` from the AGV heading, as a
/// point in the AGV frame, metres (`docs/conventions.md`, "Frames and units").
pub fn detection_to_agv_m(range_m: f64, angle_rad: f64, boresight_rad: f64) -> [f64; 2] {
    let (sin, cos) = (boresight_rad + angle_rad).sin_cos();
    [range_m * cos, range_m * sin]
}

/// Errors of the association algorithm.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AssociationError {
    /// A scan arrived before any odometry, so there is no pose to start from.
    #[error("detections arrived before the first odometry message: no initial pose")]
    NoOdometry,
    /// An odometry pose had a non-finite component.
    #[error("odometry pose is not finite: {0:?}")]
    NonFiniteOdometry(Pose2),
}

/// What one frame produced.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameOutcome {
    /// The SLAM estimate of the AGV pose in the map frame.
    pub pose: Pose2,
    /// The odometry prediction the estimate started from.
    pub predicted: Pose2,
    /// The scan matching that turned the prediction into the estimate.
    pub icp: IcpResult,
    /// The keyframe id if this frame is a keyframe (its points have joined the map).
    pub keyframe_id: Option<u32>,
}

/// The association state: SLAM pose, last odometry, keyframe map.
#[derive(Debug)]
pub struct Association {
    params: Params,
    map: PointMap,
    keyframes: KeyframeSelector,
    /// The SLAM pose after the last scan (or the initial pose before any scan).
    slam_pose: Option<Pose2>,
    /// The odometry pose that `slam_pose` corresponds to.
    odom_at_slam_pose: Option<Pose2>,
    /// The latest odometry pose received.
    latest_odom: Option<Pose2>,
}

impl Association {
    /// A new association with validated `params`, before any odometry.
    pub fn new(params: Params) -> Result<Self, InvalidParam> {
        params.validate()?;
        let keyframes =
            KeyframeSelector::new(params.keyframe_distance_m, params.keyframe_rotation_rad());
        let map = PointMap::for_params(&params);
        Ok(Association {
            params,
            map,
            keyframes,
            slam_pose: None,
            odom_at_slam_pose: None,
            latest_odom: None,
        })
    }

    /// Records an odometry pose (odometry frame). The first one also initialises the SLAM pose.
    pub fn on_odometry(&mut self, odom_pose: Pose2) -> Result<(), AssociationError> {
        if !odom_pose.is_finite() {
            return Err(AssociationError::NonFiniteOdometry(odom_pose));
        }
        if self.slam_pose.is_none() {
            self.slam_pose = Some(odom_pose);
            self.odom_at_slam_pose = Some(odom_pose);
        }
        self.latest_odom = Some(odom_pose);
        Ok(())
    }

    /// The odometry prediction for a scan now: the SLAM pose moved by the odometry increment
    /// since the last scan. `None` before the first odometry.
    pub fn predict(&self) -> Option<Pose2> {
        let slam = self.slam_pose?;
        let (from, to) = (self.odom_at_slam_pose?, self.latest_odom?);
        if from == to {
            // No motion: keep the pose bit for bit instead of composing a rounded identity.
            return Some(slam);
        }
        Some(slam.compose(&from.between(&to)))
    }

    /// Processes one frame's detections, as points in the AGV frame (metres; see
    /// [`detection_to_agv_m`]). Non-finite points are ignored. An empty scan is valid: the
    /// prediction stands.
    pub fn on_scan(&mut self, scan_agv_m: &[[f64; 2]]) -> Result<FrameOutcome, AssociationError> {
        let predicted = self.predict().ok_or(AssociationError::NoOdometry)?;
        let icp = align(&self.map, scan_agv_m, predicted, &self.params);
        let pose = icp.pose;
        let keyframe_id = self.keyframes.offer(&pose);
        if keyframe_id.is_some() {
            let points_m: Vec<[f64; 2]> = scan_agv_m
                .iter()
                .map(|&p| pose.transform_point(p))
                .collect();
            self.map.extend(&points_m);
        }
        self.slam_pose = Some(pose);
        self.odom_at_slam_pose = self.latest_odom;
        Ok(FrameOutcome {
            pose,
            predicted,
            icp,
            keyframe_id,
        })
    }

    /// The current SLAM pose (map frame); `None` before the first odometry.
    pub fn pose(&self) -> Option<Pose2> {
        self.slam_pose
    }

    /// The keyframe map.
    pub fn map(&self) -> &PointMap {
        &self.map
    }

    /// The keyframe selector (count and last keyframe pose).
    pub fn keyframes(&self) -> &KeyframeSelector {
        &self.keyframes
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }
}
