//! Project message types (ROS 2 package `nrslam_msgs`); their `.msg` definitions are in
//! `msgs/msg/` and in [`crate::schema`].

use crate::ros::{Header, Point, Pose};
use serde::{Deserialize, Serialize};

/// One radar detection in the sensor frame (docs/conventions.md): the paper's range and angle
/// estimates (Sec. III-B, eqs. for r_l and θ_l).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Detection {
    /// Range from the array centre (m).
    pub range_m: f64,
    /// Angle of arrival from boresight, counter-clockwise positive (rad), in (−π/2, π/2).
    pub angle_rad: f64,
    /// Standard deviation of the range error (m), as the producer models it.
    pub range_std_m: f64,
    /// Standard deviation of the angle error (rad).
    pub angle_std_rad: f64,
    /// Received power relative to a reference (dB).
    pub power_db: f64,
}

/// All detections of one radar frame (`/radar/detections`); an empty list is a valid frame.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Detections {
    /// Stamp of the frame, frame "radar".
    pub header: Header,
    /// Array boresight relative to the AGV heading (rad).
    pub boresight_rad: f64,
    /// The detections.
    pub detections: Vec<Detection>,
}

/// A keyframe chosen by data association (`/slam/keyframe`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Keyframe {
    /// Stamp of the frame it was taken from, frame "map".
    pub header: Header,
    /// Sequence number from 0.
    pub id: u32,
    /// SLAM estimate of the AGV pose in the map frame.
    pub pose: Pose,
    /// Array boresight relative to the AGV heading (rad).
    pub boresight_rad: f64,
    /// The frame's detections.
    pub detections: Vec<Detection>,
}

/// The current pose-graph estimate of every keyframe (`/slam/keyframe_poses`), published with
/// each keyframe. When `revision` changes (a loop closure re-optimised the graph), a mapper
/// rebuilds its grid from the keyframes it holds, placed at these poses.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct KeyframePoses {
    /// Stamp of the keyframe it accompanies, frame "map".
    pub header: Header,
    /// Number of pose-graph optimisations so far (0: the poses are as first published).
    pub revision: u32,
    /// Keyframe ids, ascending.
    pub ids: Vec<u32>,
    /// SLAM pose of each keyframe in `ids`, map frame.
    pub poses: Vec<Pose>,
    /// The pose graph's loop edges, oldest first: the older keyframe of each loop.
    pub loop_from_ids: Vec<u32>,
    /// The newer keyframe of each loop (the revisit), same order.
    pub loop_to_ids: Vec<u32>,
    /// What each loop measured: the pose of its newer keyframe in its older keyframe's frame
    /// (planar, m and rad). A reader should zip the three loop arrays and ignore any excess.
    pub loop_relatives: Vec<Pose>,
    /// What each loop's match pins down: its information (inverse covariance) over (x m, y m,
    /// yaw rad) of the relative pose, error taken in the relative pose's own frame, row-major,
    /// nine values per loop, same order. Empty from a back end that does not say.
    pub loop_informations: Vec<f64>,
    /// Each keyframe's pose uncertainty: its covariance over (x m, y m, yaw rad), map frame,
    /// row-major, nine values per keyframe in `ids` order (zero for the keyframe that anchors
    /// the map). Empty from a back end that does not say.
    pub pose_covariances: Vec<f64>,
}

/// What data association did with one radar frame (`/slam/association_stats`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct AssociationStats {
    /// Stamp of the radar frame, frame "map".
    pub header: Header,
    /// Detections in the frame.
    pub detections: u32,
    /// Detections paired with the map inside the correspondence gate in the last ICP iteration.
    pub associated: u32,
    /// Associated detections whose residual is within `gate_sigma` standard deviations.
    pub inliers: u32,
    /// `inliers / detections` (0 for an empty frame).
    pub inlier_ratio: f64,
    /// Root-mean-square residual of the associated detections (m).
    pub rms_residual_m: f64,
    /// How scan matching ended: converged, max_iterations, disabled, empty_scan, empty_map,
    /// too_few_correspondences, correction_rejected.
    pub icp_status: String,
    /// ICP iterations run.
    pub icp_iterations: u32,
    /// Position change from the odometry prediction (m).
    pub correction_m: f64,
    /// Heading change from the odometry prediction (rad).
    pub correction_rad: f64,
    /// The odometry increment failed the speed gate and a constant-velocity prediction was used.
    pub odometry_rejected: bool,
    /// Keyframe id of this frame, −1 if it is not a keyframe.
    pub keyframe_id: i32,
    /// Overlap of the frame with the last keyframe (fraction of detections within the
    /// correspondence distance of its points).
    pub keyframe_overlap: f64,
    /// A loop closure was accepted on this frame.
    pub loop_closed: bool,
    /// Loop closures accepted so far.
    pub loop_closures: u32,
}

/// Occupied map cells labelled by DBSCAN (`/map/segments`).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Segments {
    /// Stamp of the map segmented, frame "map".
    pub header: Header,
    /// DBSCAN neighbourhood radius (m).
    pub eps_m: f64,
    /// DBSCAN minimum neighbourhood size, the point itself included.
    pub min_samples: u32,
    /// Number of clusters; labels run 0..cluster_count.
    pub cluster_count: u32,
    /// Centres of the occupied cells (m).
    pub points: Vec<Point>,
    /// One label per point; −1 is noise.
    pub labels: Vec<i32>,
}

/// One true extended target.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Target {
    /// Identifier, 0-based.
    pub id: u32,
    /// "rectangle" or "circle".
    pub shape: String,
    /// Closed outline, counter-clockwise, last vertex not repeated (circles as a 64-gon), m.
    pub outline: Vec<Point>,
    /// The ET-GOPSA slots: sample points of the target (the paper takes 4), m.
    pub samples: Vec<Point>,
}

/// The true extended targets (`/ground_truth/targets`, latched).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct TargetSet {
    /// Stamp, frame "map".
    pub header: Header,
    /// The targets.
    pub targets: Vec<Target>,
}

/// One extended target of the map as a fitted shape (an element of [`MapTargets`]).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MapTarget {
    /// Track identifier, stable across map updates while the target is tracked.
    pub id: u32,
    /// "rectangle" or "circle".
    pub shape: String,
    /// Centre x (m), frame "map".
    pub center_x_m: f64,
    /// Centre y (m), frame "map".
    pub center_y_m: f64,
    /// Rectangle: extent along its own x axis (m); circle: the diameter.
    pub width_m: f64,
    /// Rectangle: extent along its own y axis (m); circle: the diameter.
    pub height_m: f64,
    /// Rectangle: rotation of its own x axis from the map's +x (rad, counter-clockwise); circle 0.
    pub yaw_rad: f64,
    /// Circle: radius (m); rectangle 0.
    pub radius_m: f64,
    /// Covariance of the parameters, row-major: rectangle (center_x_m, center_y_m, width_m,
    /// height_m, yaw_rad), 5 × 5; circle (center_x_m, center_y_m, radius_m), 3 × 3. SI units.
    pub covariance: Vec<f64>,
    /// Rectangle: sides the fit saw (1 to 4); circle 0.
    pub sides_seen: u32,
    /// Map updates this target has been tracked over.
    pub updates: u32,
    /// Root-mean-square distance of the supporting cells from the fitted outline (m).
    pub rms_residual_m: f64,
    /// Closed outline, counter-clockwise, last vertex not repeated (circles as a 64-gon), m.
    pub outline: Vec<Point>,
    /// Points sampled as the truth's are (rectangle: corners; circle: 0°, 90°, 180°, 270°), m.
    pub samples: Vec<Point>,
    /// Centres of the occupied cells the shape was fitted to, m.
    pub supporting_cells: Vec<Point>,
}

/// The map's extended targets as fitted shapes (`/map/targets`, one per map update).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct MapTargets {
    /// Stamp of the map the shapes were fitted to, frame "map".
    pub header: Header,
    /// The targets, in increasing id.
    #[serde(deserialize_with = "crate::visual::few_reserved")]
    pub targets: Vec<MapTarget>,
}

/// Per-step evaluation (`/metrics`): ET-GOPSA and GOSPA with their decompositions (each term is
/// the summed p-th power contribution, so the terms add up to the metric to the power p) and the
/// AGV position error.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Metrics {
    /// Stamp of the SLAM pose evaluated, frame "map".
    pub header: Header,
    /// ET-GOPSA (m).
    pub etgospa: f64,
    /// ET-GOPSA localisation term.
    pub etgospa_localisation: f64,
    /// ET-GOPSA confusion term.
    pub etgospa_confusion: f64,
    /// ET-GOPSA missed-slot term.
    pub etgospa_missed: f64,
    /// ET-GOPSA false-estimate term.
    pub etgospa_false: f64,
    /// GOSPA (m).
    pub gospa: f64,
    /// GOSPA localisation term.
    pub gospa_localisation: f64,
    /// GOSPA missed term.
    pub gospa_missed: f64,
    /// GOSPA false term.
    pub gospa_false: f64,
    /// Planar distance between the SLAM and the true AGV position (m).
    pub position_error_m: f64,
    /// Clusters in the segmented map.
    pub estimated_targets: u32,
    /// Estimate points fed to the metrics.
    pub estimate_points: u32,
}

/// One frame of raw OFDM sensing data (`/radar/echo`, `waveform` fidelity): the received
/// resource grids Y(k, m, n) of every antenna and the transmitted X(m, n) (paper eqs. (1)-(2)).
/// Complex values are interleaved (re, im) f64.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct RadarEcho {
    /// Stamp of the frame, frame "radar".
    pub header: Header,
    /// Array boresight relative to the AGV heading (rad).
    pub boresight_rad: f64,
    /// Carrier frequency f_c (Hz).
    pub carrier_frequency_hz: f64,
    /// Subcarrier spacing Δf (Hz).
    pub subcarrier_spacing_hz: f64,
    /// Whole OFDM symbol duration T (s).
    pub symbol_duration_s: f64,
    /// Element spacing d in wavelengths.
    pub antenna_spacing_wavelengths: f64,
    /// Per-element SNR of a unit echo (dB).
    pub snr_db: f64,
    /// Antennas K.
    pub antennas: u32,
    /// Symbols M.
    pub symbols: u32,
    /// Subcarriers N.
    pub subcarriers: u32,
    /// Y, index `((k * M + m) * N + n) * 2` (+1 for the imaginary part).
    pub received: Vec<f64>,
    /// X, index `(m * N + n) * 2` (+1 for the imaginary part).
    pub transmitted: Vec<f64>,
}

/// One frame's processed range × angle response (`/radar/spectrum`, `spectral` fidelity):
/// complex values interleaved (re, im), index `(range_bin * angle_bins + angle_bin) * 2`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct RadarSpectrum {
    /// Stamp of the frame, frame "radar".
    pub header: Header,
    /// Array boresight relative to the AGV heading (rad).
    pub boresight_rad: f64,
    /// Range of one range bin (m).
    pub range_bin_m: f64,
    /// Element spacing d in wavelengths (sets the angle of each angle bin).
    pub antenna_spacing_wavelengths: f64,
    /// Noise power per cell, in the units of |value|².
    pub noise_power: f64,
    /// Range bins.
    pub range_bins: u32,
    /// Angle bins.
    pub angle_bins: u32,
    /// The values.
    pub values: Vec<f64>,
}
