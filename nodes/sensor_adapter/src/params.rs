//! Parameters of the sensor adapter: which standard message comes in on which topic, where the
//! sensor sits on the vehicle, and the measurement noise to attach to each detection.

use nrslam_msgs::topics;
use nrslam_runtime::InvalidParam;
use serde::{Deserialize, Serialize};

/// The standard message the adapter takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Input {
    /// `radar_msgs/msg/RadarScan`: range, azimuth, elevation, amplitude per return.
    RadarScan,
    /// `sensor_msgs/msg/PointCloud2` with fields `x`, `y` (and usually `z`).
    PointCloud2,
}

impl Input {
    /// The ROS 2 type of this input.
    pub fn type_name(self) -> &'static str {
        match self {
            Input::RadarScan => "radar_msgs/msg/RadarScan",
            Input::PointCloud2 => "sensor_msgs/msg/PointCloud2",
        }
    }
}

/// Sensor-adapter parameters (the node's TOML table in a launch file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// `radar_scan` or `point_cloud2`. Default `radar_scan`.
    pub input: Input,
    /// Topic of the sensor messages: a catalogue topic of the input's type (`/radar/scan` for
    /// `radar_scan`, `/radar/points` or `/radar/detections_cloud` for `point_cloud2`). Empty: the
    /// input's usual topic (`/radar/scan`, `/radar/points`). Default empty.
    pub topic: String,
    /// The vehicle's pose, republished as `/odom` for the association: a
    /// `geometry_msgs/msg/PoseStamped` topic (e.g. `/ground_truth/pose`), or `/tf`
    /// (`tf2_msgs/msg/TFMessage`), whose transforms with child frame `tf_child_frame` are taken as
    /// the pose (their parent frame as the odometry frame); empty: the adapter publishes no
    /// odometry (another node must). Default empty.
    pub pose_topic: String,
    /// With `pose_topic = "/tf"`: the vehicle's frame, whose transform from its parent is the
    /// pose (REP 105's `base_link`, child of `odom`). Default `base_link`.
    pub tf_child_frame: String,
    /// Sensor position on the vehicle, forward of the vehicle's reference point (m), |x| ≤ 100.
    /// Default 0.
    pub x_m: f64,
    /// Sensor position on the vehicle, left of the reference point (m), |y| ≤ 100. Default 0.
    pub y_m: f64,
    /// Sensor heading (its x axis) relative to the vehicle's, counter-clockwise (rad), in
    /// [−π, π]. Default 0.
    pub yaw_rad: f64,
    /// Range standard deviation attached to every detection (m), finite, > 0. Default 0.1.
    pub range_std_m: f64,
    /// Angle standard deviation attached to every detection (rad), finite, > 0. Default 0.0175
    /// (1°).
    pub angle_std_rad: f64,
    /// Returns closer than this to the sensor are dropped (m), finite, ≥ 0. Default 0.
    pub min_range_m: f64,
    /// Returns farther than this from the sensor are dropped (m), > `min_range_m` (may be
    /// infinite). Default infinite.
    pub max_range_m: f64,
    /// PointCloud2 only: a field read as each point's power (dB), e.g. `intensity`; empty: every
    /// point gets `power_db`. Default empty.
    pub power_field: String,
    /// Power of a detection when the input does not carry one (dB), finite. Default 0.
    pub power_db: f64,
}

impl Default for Params {
    fn default() -> Self {
        Self {
            input: Input::RadarScan,
            topic: String::new(),
            pose_topic: String::new(),
            tf_child_frame: "base_link".to_owned(),
            x_m: 0.0,
            y_m: 0.0,
            yaw_rad: 0.0,
            range_std_m: 0.1,
            angle_std_rad: 1f64.to_radians(),
            min_range_m: 0.0,
            max_range_m: f64::INFINITY,
            power_field: String::new(),
            power_db: 0.0,
        }
    }
}

/// Largest mounting offset accepted (m): a sensor 100 m from the vehicle is a typo.
const MAX_OFFSET_M: f64 = 100.0;

fn invalid(field: &str, value: impl std::fmt::Display, allowed: &str) -> InvalidParam {
    InvalidParam::new(field, value.to_string(), allowed)
}

impl Params {
    /// The input topic, resolved against the catalogue (a `&'static` name for the node API).
    pub fn input_topic(&self) -> Result<&'static str, InvalidParam> {
        let name = match (self.topic.as_str(), self.input) {
            ("", Input::RadarScan) => topics::RADAR_SCAN,
            ("", Input::PointCloud2) => topics::RADAR_POINTS,
            (name, _) => name,
        };
        match topics::spec(name) {
            Some(spec) if spec.type_name == self.input.type_name() => Ok(spec.name),
            _ => Err(invalid(
                "topic",
                format!("{name:?}"),
                &format!("a catalogue topic of type {}", self.input.type_name()),
            )),
        }
    }

    /// The pose topic, resolved against the catalogue; `None` when empty.
    pub fn pose_input(&self) -> Result<Option<&'static str>, InvalidParam> {
        if self.pose_topic.is_empty() {
            return Ok(None);
        }
        match topics::spec(&self.pose_topic) {
            Some(spec) if spec.type_name == "geometry_msgs/msg/PoseStamped" => Ok(Some(spec.name)),
            Some(spec) if spec.name == topics::TF => Ok(Some(spec.name)),
            _ => Err(invalid(
                "pose_topic",
                format!("{:?}", self.pose_topic),
                "empty, /tf, or a catalogue topic of type geometry_msgs/msg/PoseStamped \
                 (/ground_truth/pose)",
            )),
        }
    }

    /// Checks every field against its allowed range; the error names the field.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        self.input_topic()?;
        self.pose_input()?;
        if self.tf_child_frame.is_empty() || self.tf_child_frame.len() > 256 {
            return Err(invalid(
                "tf_child_frame",
                format!("{:?}", self.tf_child_frame),
                "a frame name of 1 to 256 bytes (base_link)",
            ));
        }
        for (field, value) in [("x_m", self.x_m), ("y_m", self.y_m)] {
            if !(value.is_finite() && value.abs() <= MAX_OFFSET_M) {
                return Err(invalid(field, format!("{value} m"), "-100..=100 (metres)"));
            }
        }
        if !(self.yaw_rad.is_finite() && self.yaw_rad.abs() <= std::f64::consts::PI) {
            return Err(invalid(
                "yaw_rad",
                format!("{} rad", self.yaw_rad),
                "-pi..=pi (radians)",
            ));
        }
        for (field, value, unit) in [
            ("range_std_m", self.range_std_m, "metres"),
            ("angle_std_rad", self.angle_std_rad, "radians"),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(invalid(field, value, &format!("finite and > 0 ({unit})")));
            }
        }
        if !(self.min_range_m.is_finite() && self.min_range_m >= 0.0) {
            return Err(invalid(
                "min_range_m",
                format!("{} m", self.min_range_m),
                "finite and >= 0 (metres)",
            ));
        }
        if self.max_range_m.is_nan() || self.max_range_m <= self.min_range_m {
            return Err(invalid(
                "max_range_m",
                format!("{} m", self.max_range_m),
                "> min_range_m (metres; may be inf)",
            ));
        }
        if !self.power_field.is_empty() && self.input != Input::PointCloud2 {
            return Err(invalid(
                "power_field",
                format!("{:?}", self.power_field),
                "empty unless input = \"point_cloud2\"",
            ));
        }
        if !self.power_db.is_finite() {
            return Err(invalid("power_db", self.power_db, "finite (dB)"));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_take_the_usual_topics() {
        let p = Params::default();
        p.validate().unwrap();
        assert_eq!(p.input_topic().unwrap(), topics::RADAR_SCAN);
        assert_eq!(p.pose_input().unwrap(), None);
        let cloud = Params {
            input: Input::PointCloud2,
            ..Params::default()
        };
        assert_eq!(cloud.input_topic().unwrap(), topics::RADAR_POINTS);
    }

    #[test]
    fn each_bad_field_is_named() {
        let mut cases = nrslam_runtime::one_bad_field!(Params {
            topic: ["/radar/points".into(), "/nowhere".into()],
            pose_topic: ["/odom".into()],
            x_m: [100.5],
            y_m: [f64::NAN],
            yaw_rad: [3.2],
            range_std_m: [0.0],
            angle_std_rad: [f64::INFINITY],
            min_range_m: [-1.0],
        });
        // The one check across two fields: an empty range is blamed on its upper end.
        let empty_range = Params {
            min_range_m: 5.0,
            max_range_m: 5.0,
            ..Params::default()
        };
        cases.push((empty_range, "max_range_m"));
        cases.extend(nrslam_runtime::one_bad_field!(Params {
            power_field: ["intensity".into()],
            power_db: [f64::NAN],
        }));
        nrslam_runtime::config::assert_each_refused_by_name(cases, Params::validate);
    }

    #[test]
    fn unknown_fields_and_inputs_are_refused() {
        let parse = |text: &str| toml::from_str::<Params>(text);
        assert!(parse("inputs = \"radar_scan\"").is_err());
        assert!(parse("input = \"lidar\"").is_err());
        let p = parse(
            "input = \"point_cloud2\"\nyaw_rad = 1.5707963\npose_topic = \"/ground_truth/pose\"",
        )
        .unwrap();
        p.validate().unwrap();
        assert_eq!(p.pose_input().unwrap(), Some(topics::GROUND_TRUTH_POSE));
    }
}
