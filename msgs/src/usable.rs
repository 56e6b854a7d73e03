//! Whether a decoded message's values can be used: the receive path's check after
//! [`crate::cdr::decode`], which checks only the wire format.
//!
//! A peer (or a corrupted bag) can send well-formed CDR whose numbers are NaN, whose grid data
//! does not match its width × height, or whose radar frame is shorter than its dimensions say.
//! Nodes index and compute with these values, so [`crate::Message::check_usable`] refuses them
//! before a node sees them, with an [`Unusable`] reason small enough to count per topic.
//!
//! Field by field (every check is O(message size), no allocation):
//! - every header stamp (and `Clock`, `MapMetaData::map_load_time`): `nanosec` < 10⁹ (ROS'
//!   `builtin_interfaces/Time` range). A negative `sec` is accepted: [`crate::Time::as_nanos`]
//!   clamps it to 0.
//! - poses (`PoseStamped`, `Odometry`, `Keyframe`, `KeyframePoses`, grid origin): position and
//!   orientation finite, orientation not the zero quaternion (it has no yaw).
//! - `Odometry`: the twist finite. The two covariances may hold NaN (some ROS drivers mark an
//!   unknown covariance so; no node of the graph reads them) but not ±∞, which no convention
//!   uses (ROS marks unknown or unused dimensions with −1 or a large finite value).
//! - `OccupancyGrid`: resolution finite and > 0; `width × height` must not overflow and must
//!   equal `data.len()`; cells in −1..=100.
//! - detections (`Detections`, `Keyframe`): boresight, range, angle and the two standard
//!   deviations finite, range and deviations ≥ 0; `power_db` not NaN (±∞ are the ideal model's
//!   1/r⁴ law at r = 0 or ∞, and nothing computes with it).
//! - `KeyframePoses`: as many poses as ids; the three loop arrays may differ in length (the type
//!   says a reader zips them and ignores any excess); every loop information and pose
//!   covariance value finite (a reader uses `pose_covariances` only when it holds nine values per
//!   pose, and checks the variances itself).
//! - `Segments`: eps and points finite, one label per point, labels in −1..cluster_count.
//! - `TargetSet`: outlines and samples finite.
//! - `MapTargets`: shape "rectangle" or "circle"; centre, sizes, yaw, radius, residual, covariance
//!   and every point finite; sizes, radius and residual ≥ 0; the covariance 25 values for a
//!   rectangle, 9 for a circle.
//! - `RadarEcho`: boresight, carrier, subcarrier spacing, symbol duration, antenna spacing and
//!   SNR finite, the four physical ones > 0; `received.len() = 2·K·M·N`,
//!   `transmitted.len() = 2·M·N` (no overflow); every sample finite.
//! - `RadarSpectrum`: boresight, bin size (> 0), antenna spacing (> 0), noise power (≥ 0)
//!   finite; `values.len() = 2·range_bins·angle_bins`; every value finite.
//! - `PointCloud2`: every field's datatype in 1..=8 and its extent (`offset + count × size`)
//!   within `point_step`; `width × point_step ≤ row_step` and `data.len() = row_step × height`
//!   (no overflow). The point values are not read (a reader decodes them bounded by these sizes;
//!   NaN points are legal, `is_dense` says whether there are any).
//! - `RadarScan`: every return's range finite and ≥ 0, azimuth and elevation finite, amplitude
//!   not NaN; the Doppler velocity is not checked (nothing computes with it).
//! - `TFMessage`: every transform's stamp, translation finite, rotation finite and not zero.
//! - `Path`: its stamp and every pose as for `PoseStamped`.
//! - `MarkerArray`: every marker's stamp and lifetime nanoseconds < 10⁹, pose, scale and points
//!   finite (a zero quaternion is accepted: viewers draw it unrotated). Markers are drawn, not
//!   computed with, so colours and the texture are not checked.
//! - `Metrics` and `AssociationStats`: only the stamp. They are diagnostics that nodes record
//!   and nothing computes with; refusing a NaN there would hide the producer's fault from the
//!   report instead of showing it.

use crate::nrslam::*;
use crate::ros::*;
use crate::sensors::*;
use crate::visual::*;

/// Why a received message is not used. `Copy`, with a short [`Unusable::reason`] to use as a
/// counter key; the `&'static str` names the field.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, thiserror::Error)]
pub enum Unusable {
    /// The bytes did not decode as the topic's type (for the receive path to count decode
    /// failures under the same kind of key; [`crate::Message::check_usable`] never returns it).
    #[error("the payload is not valid CDR for the topic's type")]
    BadCdr,
    /// A number that is computed with is NaN or infinite.
    #[error("{0} is NaN or infinite")]
    NonFinite(&'static str),
    /// A length disagrees with the dimensions that describe it (or those overflow).
    #[error("{0}: length does not match the stated dimensions")]
    SizeMismatch(&'static str),
    /// A finite value outside its domain (a negative range, a cell of 101 %, a label past the
    /// cluster count, nanoseconds ≥ 10⁹).
    #[error("{0} is out of its range")]
    OutOfRange(&'static str),
}

impl Unusable {
    /// Short, stable key for counters and logs: `bad_cdr`, `non_finite`, `size_mismatch`,
    /// `out_of_range`.
    pub fn reason(&self) -> &'static str {
        match self {
            Unusable::BadCdr => "bad_cdr",
            Unusable::NonFinite(_) => "non_finite",
            Unusable::SizeMismatch(_) => "size_mismatch",
            Unusable::OutOfRange(_) => "out_of_range",
        }
    }

    /// The field concerned, if the reason is about one.
    pub fn field(&self) -> Option<&'static str> {
        match self {
            Unusable::BadCdr => None,
            Unusable::NonFinite(f) | Unusable::SizeMismatch(f) | Unusable::OutOfRange(f) => Some(f),
        }
    }
}

type Check = Result<(), Unusable>;

/// Implemented by every catalogue type; [`crate::Message::check_usable`] dispatches to it.
pub(crate) trait CheckUsable {
    fn check_usable(&self) -> Check;
}

fn finite(value: f64, field: &'static str) -> Check {
    if value.is_finite() {
        Ok(())
    } else {
        Err(Unusable::NonFinite(field))
    }
}

fn all_finite(values: &[f64], field: &'static str) -> Check {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(Unusable::NonFinite(field))
    }
}

/// `Ok` when `in_range`, else `field` is out of its range.
fn within(in_range: bool, field: &'static str) -> Check {
    if in_range {
        Ok(())
    } else {
        Err(Unusable::OutOfRange(field))
    }
}

/// Finite and > 0: a physical size or rate.
fn positive(value: f64, field: &'static str) -> Check {
    finite(value, field)?;
    within(value > 0.0, field)
}

/// Finite and ≥ 0: a distance, deviation or power.
fn non_negative(value: f64, field: &'static str) -> Check {
    finite(value, field)?;
    within(value >= 0.0, field)
}

fn time(time: &Time, field: &'static str) -> Check {
    within(time.nanosec < 1_000_000_000, field)
}

fn header(header: &Header) -> Check {
    time(&header.stamp, "header.stamp.nanosec")
}

fn point(p: &Point, field: &'static str) -> Check {
    all_finite(&[p.x, p.y, p.z], field)
}

fn points(ps: &[Point], field: &'static str) -> Check {
    ps.iter().try_for_each(|p| point(p, field))
}

fn pose(pose: &Pose, position: &'static str, orientation: &'static str) -> Check {
    point(&pose.position, position)?;
    let q = &pose.orientation;
    all_finite(&[q.x, q.y, q.z, q.w], orientation)?;
    if q.x == 0.0 && q.y == 0.0 && q.z == 0.0 && q.w == 0.0 {
        return Err(Unusable::OutOfRange(orientation));
    }
    Ok(())
}

fn detections(boresight_rad: f64, detections: &[Detection]) -> Check {
    finite(boresight_rad, "boresight_rad")?;
    for d in detections {
        non_negative(d.range_m, "detections.range_m")?;
        finite(d.angle_rad, "detections.angle_rad")?;
        non_negative(d.range_std_m, "detections.range_std_m")?;
        non_negative(d.angle_std_rad, "detections.angle_std_rad")?;
        if d.power_db.is_nan() {
            return Err(Unusable::NonFinite("detections.power_db"));
        }
    }
    Ok(())
}

/// `2 · Π dims` as a length, `None` on overflow.
fn interleaved_len(dims: &[u32]) -> Option<usize> {
    dims.iter()
        .try_fold(2usize, |n, &d| n.checked_mul(usize::try_from(d).ok()?))
}

fn length(actual: usize, expected: Option<usize>, field: &'static str) -> Check {
    if expected == Some(actual) {
        Ok(())
    } else {
        Err(Unusable::SizeMismatch(field))
    }
}

impl CheckUsable for Clock {
    fn check_usable(&self) -> Check {
        time(&self.clock, "clock.nanosec")
    }
}

impl CheckUsable for PoseStamped {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        pose(&self.pose, "pose.position", "pose.orientation")
    }
}

impl CheckUsable for Odometry {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        pose(
            &self.pose.pose,
            "pose.pose.position",
            "pose.pose.orientation",
        )?;
        let t = &self.twist.twist;
        all_finite(
            &[
                t.linear.x,
                t.linear.y,
                t.linear.z,
                t.angular.x,
                t.angular.y,
                t.angular.z,
            ],
            "twist.twist",
        )?;
        if self.pose.covariance.iter().any(|v| v.is_infinite()) {
            return Err(Unusable::NonFinite("pose.covariance"));
        }
        if self.twist.covariance.iter().any(|v| v.is_infinite()) {
            return Err(Unusable::NonFinite("twist.covariance"));
        }
        Ok(())
    }
}

impl CheckUsable for OccupancyGrid {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        let info = &self.info;
        time(&info.map_load_time, "info.map_load_time.nanosec")?;
        positive(f64::from(info.resolution), "info.resolution")?;
        pose(
            &info.origin,
            "info.origin.position",
            "info.origin.orientation",
        )?;
        let cells = usize::try_from(info.width)
            .ok()
            .zip(usize::try_from(info.height).ok())
            .and_then(|(w, h)| w.checked_mul(h));
        length(self.data.len(), cells, "data")?;
        within(self.data.iter().all(|&c| (-1..=100).contains(&c)), "data")
    }
}

impl CheckUsable for Detections {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        detections(self.boresight_rad, &self.detections)
    }
}

impl CheckUsable for Keyframe {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        pose(&self.pose, "pose.position", "pose.orientation")?;
        detections(self.boresight_rad, &self.detections)
    }
}

impl CheckUsable for KeyframePoses {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        if self.ids.len() != self.poses.len() {
            return Err(Unusable::SizeMismatch("poses"));
        }
        for p in &self.poses {
            pose(p, "poses.position", "poses.orientation")?;
        }
        for p in &self.loop_relatives {
            pose(p, "loop_relatives.position", "loop_relatives.orientation")?;
        }
        all_finite(&self.loop_informations, "loop_informations")?;
        all_finite(&self.pose_covariances, "pose_covariances")
    }
}

impl CheckUsable for Segments {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        finite(self.eps_m, "eps_m")?;
        points(&self.points, "points")?;
        if self.labels.len() != self.points.len() {
            return Err(Unusable::SizeMismatch("labels"));
        }
        let clusters = i64::from(self.cluster_count);
        let labelled = |&l: &i32| l == -1 || (0..clusters).contains(&i64::from(l));
        within(self.labels.iter().all(labelled), "labels")
    }
}

impl CheckUsable for TargetSet {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        for target in &self.targets {
            points(&target.outline, "targets.outline")?;
            points(&target.samples, "targets.samples")?;
        }
        Ok(())
    }
}

impl CheckUsable for MapTargets {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        for target in &self.targets {
            let parameters = match target.shape.as_str() {
                "rectangle" => 5,
                "circle" => 3,
                _ => return Err(Unusable::OutOfRange("targets.shape")),
            };
            finite(target.center_x_m, "targets.center_x_m")?;
            finite(target.center_y_m, "targets.center_y_m")?;
            finite(target.yaw_rad, "targets.yaw_rad")?;
            for (value, field) in [
                (target.width_m, "targets.width_m"),
                (target.height_m, "targets.height_m"),
                (target.radius_m, "targets.radius_m"),
                (target.rms_residual_m, "targets.rms_residual_m"),
            ] {
                non_negative(value, field)?;
            }
            if target.covariance.len() != parameters * parameters {
                return Err(Unusable::SizeMismatch("targets.covariance"));
            }
            all_finite(&target.covariance, "targets.covariance")?;
            points(&target.outline, "targets.outline")?;
            points(&target.samples, "targets.samples")?;
            points(&target.supporting_cells, "targets.supporting_cells")?;
        }
        Ok(())
    }
}

impl CheckUsable for Metrics {
    fn check_usable(&self) -> Check {
        header(&self.header)
    }
}

impl CheckUsable for DiagnosticArray {
    fn check_usable(&self) -> Check {
        header(&self.header)
    }
}

impl CheckUsable for AssociationStats {
    fn check_usable(&self) -> Check {
        header(&self.header)
    }
}

impl CheckUsable for RadarEcho {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        finite(self.boresight_rad, "boresight_rad")?;
        positive(self.carrier_frequency_hz, "carrier_frequency_hz")?;
        positive(self.subcarrier_spacing_hz, "subcarrier_spacing_hz")?;
        positive(self.symbol_duration_s, "symbol_duration_s")?;
        positive(
            self.antenna_spacing_wavelengths,
            "antenna_spacing_wavelengths",
        )?;
        finite(self.snr_db, "snr_db")?;
        length(
            self.received.len(),
            interleaved_len(&[self.antennas, self.symbols, self.subcarriers]),
            "received",
        )?;
        length(
            self.transmitted.len(),
            interleaved_len(&[self.symbols, self.subcarriers]),
            "transmitted",
        )?;
        all_finite(&self.received, "received")?;
        all_finite(&self.transmitted, "transmitted")
    }
}

impl CheckUsable for RadarSpectrum {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        finite(self.boresight_rad, "boresight_rad")?;
        positive(self.range_bin_m, "range_bin_m")?;
        positive(
            self.antenna_spacing_wavelengths,
            "antenna_spacing_wavelengths",
        )?;
        non_negative(self.noise_power, "noise_power")?;
        length(
            self.values.len(),
            interleaved_len(&[self.range_bins, self.angle_bins]),
            "values",
        )?;
        all_finite(&self.values, "values")
    }
}

impl CheckUsable for PointCloud2 {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        for field in &self.fields {
            let extent = PointField::datatype_size(field.datatype)
                .ok_or(Unusable::OutOfRange("fields.datatype"))
                .map(u64::from)?
                .checked_mul(u64::from(field.count))
                .and_then(|size| size.checked_add(u64::from(field.offset)));
            if extent.is_none_or(|end| end > u64::from(self.point_step)) {
                return Err(Unusable::OutOfRange("fields.offset"));
            }
        }
        if u64::from(self.width) * u64::from(self.point_step) > u64::from(self.row_step) {
            return Err(Unusable::SizeMismatch("row_step"));
        }
        let bytes = usize::try_from(self.row_step)
            .ok()
            .zip(usize::try_from(self.height).ok())
            .and_then(|(row, rows)| row.checked_mul(rows));
        length(self.data.len(), bytes, "data")
    }
}

impl CheckUsable for RadarScan {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        for r in &self.returns {
            non_negative(f64::from(r.range), "returns.range")?;
            finite(f64::from(r.azimuth), "returns.azimuth")?;
            finite(f64::from(r.elevation), "returns.elevation")?;
            if r.amplitude.is_nan() {
                return Err(Unusable::NonFinite("returns.amplitude"));
            }
        }
        Ok(())
    }
}

impl CheckUsable for TFMessage {
    fn check_usable(&self) -> Check {
        for t in &self.transforms {
            time(&t.header.stamp, "transforms.header.stamp.nanosec")?;
            let v = &t.transform.translation;
            all_finite(&[v.x, v.y, v.z], "transforms.transform.translation")?;
            let q = &t.transform.rotation;
            all_finite(&[q.x, q.y, q.z, q.w], "transforms.transform.rotation")?;
            if q.x == 0.0 && q.y == 0.0 && q.z == 0.0 && q.w == 0.0 {
                return Err(Unusable::OutOfRange("transforms.transform.rotation"));
            }
        }
        Ok(())
    }
}

impl CheckUsable for Path {
    fn check_usable(&self) -> Check {
        header(&self.header)?;
        for p in &self.poses {
            time(&p.header.stamp, "poses.header.stamp.nanosec")?;
            pose(&p.pose, "poses.pose.position", "poses.pose.orientation")?;
        }
        Ok(())
    }
}

impl CheckUsable for MarkerArray {
    fn check_usable(&self) -> Check {
        for m in &self.markers {
            time(&m.header.stamp, "markers.header.stamp.nanosec")?;
            if m.lifetime.nanosec >= 1_000_000_000 {
                return Err(Unusable::OutOfRange("markers.lifetime.nanosec"));
            }
            point(&m.pose.position, "markers.pose.position")?;
            let q = &m.pose.orientation;
            all_finite(&[q.x, q.y, q.z, q.w], "markers.pose.orientation")?;
            let s = &m.scale;
            all_finite(&[s.x, s.y, s.z], "markers.scale")?;
            points(&m.points, "markers.points")?;
        }
        Ok(())
    }
}
