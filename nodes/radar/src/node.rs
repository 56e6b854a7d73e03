//! The radar as a source node: one [`Simulator`] frame per tick, turned into messages.
//!
//! Per tick (frame k, stamp t0 + k·frame_period), in this order:
//! `/clock`, `/ground_truth/pose` (frame "map"), `/odom` (frame "odom", child "base_link"),
//! `/radar/detections` (frame "radar"; `ideal`) or `/radar/spectrum` (`spectral`) or
//! `/radar/echo` (`waveform`); the first tick publishes `/ground_truth/targets` (frame
//! "map", stamped t0) before anything else. The tick that publishes the last frame returns
//! [`Tick::Done`]. The node has no inputs.
//!
//! Faults ([`crate::params::Faults`]) are applied here, on the way out: a dropped frame's
//! measurement is not published, an empty frame's detections are cleared, an odometry spike
//! displaces that frame's odometry pose along the heading.
//!
//! Odometry covariance: the diagonal of the propagated (x, y, yaw) covariance of
//! [`crate::odometry`]; z, roll and pitch are exactly 0 on the hall's floor, so their variances
//! are 0. Twist: forward speed and yaw rate over the last frame, with their variances.

use nrslam_msgs::topics::{
    CLOCK, DETECTIONS, ECHO, GROUND_TRUTH_POSE, GROUND_TRUTH_TARGETS, ODOM, SPECTRUM,
};
use nrslam_msgs::{
    Clock, Detections, Header, Message, Odometry, Point, Pose, PoseStamped, PoseWithCovariance,
    RadarEcho, RadarSpectrum, Target as TargetMsg, TargetSet, Time, Twist, TwistWithCovariance,
    Vector3,
};
use nrslam_runtime::{Node, NodeContext, NodeError, NodeResult, Outbox, Tick};

use crate::error::RadarError;
use crate::geometry::Vec2;
use crate::params::{Fidelity, Params, Role};
use crate::scene::Scene;
use crate::sim::{Frame, Simulator};
use crate::trajectory::T0_S;

/// Frame of the ground truth and of the map.
pub const MAP_FRAME: &str = "map";
/// Frame of the dead-reckoned odometry pose.
pub const ODOM_FRAME: &str = "odom";
/// The AGV's body frame.
pub const BASE_FRAME: &str = "base_link";
/// The radar's frame (at the AGV centre, boresight at `boresight_rad` from the heading).
pub const RADAR_FRAME: &str = "radar";

/// The radar front end as a [`Node`].
pub struct RadarNode {
    sim: Simulator,
    ofdm: nrslam_ofdm::OfdmParams,
    targets_sent: bool,
    faults: crate::params::Faults,
}

fn interleave(values: &[num_complex::Complex64]) -> Vec<f64> {
    values.iter().flat_map(|v| [v.re, v.im]).collect()
}

/// A synthesised range × angle map as `/radar/spectrum`.
pub fn spectrum_message(
    header: Header,
    boresight_rad: f64,
    ofdm: &nrslam_ofdm::OfdmParams,
    spectrum: nrslam_ofdm::RangeAngleSpectrum,
) -> RadarSpectrum {
    RadarSpectrum {
        header,
        boresight_rad,
        range_bin_m: spectrum.range_bin_m,
        antenna_spacing_wavelengths: ofdm.antenna_spacing_wavelengths,
        noise_power: spectrum.noise_power,
        range_bins: spectrum.range_bins as u32,
        angle_bins: spectrum.angle_bins as u32,
        values: interleave(&spectrum.values),
    }
}

/// Synthesised resource grids as `/radar/echo`.
pub fn echo_message(
    header: Header,
    boresight_rad: f64,
    ofdm: &nrslam_ofdm::OfdmParams,
    grid: nrslam_ofdm::ResourceGrid,
) -> RadarEcho {
    RadarEcho {
        header,
        boresight_rad,
        carrier_frequency_hz: ofdm.carrier_frequency_hz,
        subcarrier_spacing_hz: ofdm.subcarrier_spacing_hz,
        symbol_duration_s: ofdm.symbol_duration_s,
        antenna_spacing_wavelengths: ofdm.antenna_spacing_wavelengths,
        snr_db: ofdm.snr_db,
        antennas: grid.antennas as u32,
        symbols: grid.symbols as u32,
        subcarriers: grid.subcarriers as u32,
        received: interleave(&grid.received),
        transmitted: interleave(&grid.transmitted),
    }
}

/// Builds the radar node: validates `params`, loads the scene (relative to `ctx.base_dir`) and
/// seeds its noise from `ctx.seed_for("radar")`.
pub fn build(params: Params, ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    params.validate()?;
    let ofdm = params.ofdm;
    let sim = Simulator::from_params(&params, &ctx.base_dir, ctx.seed_for("radar")).map_err(
        |e| match e {
            RadarError::Param(invalid) => NodeError::Params(invalid),
            RadarError::Scene(scene) => NodeError::algorithm(scene),
        },
    )?;
    let mut node = RadarNode::with_ofdm(sim, ofdm);
    node.faults = params.faults.clone();
    Ok(Box::new(node))
}

impl RadarNode {
    /// A node publishing the frames of `sim`.
    pub fn new(sim: Simulator) -> Self {
        Self::with_ofdm(sim, nrslam_ofdm::OfdmParams::default())
    }

    /// A node publishing the frames of `sim`, describing its OFDM frames with `ofdm`.
    pub fn with_ofdm(sim: Simulator, ofdm: nrslam_ofdm::OfdmParams) -> Self {
        Self {
            sim,
            ofdm,
            targets_sent: false,
            faults: crate::params::Faults::default(),
        }
    }

    /// The simulator (scene, frame count).
    pub fn simulator(&self) -> &Simulator {
        &self.sim
    }
}

impl Node for RadarNode {
    fn inputs(&self) -> Vec<&'static str> {
        Vec::new()
    }

    fn outputs(&self) -> Vec<&'static str> {
        if self.sim.role() == Role::NoSensor {
            return vec![GROUND_TRUTH_TARGETS, CLOCK];
        }
        let measurement = match self.sim.fidelity() {
            Fidelity::Ideal => DETECTIONS,
            Fidelity::Spectral => SPECTRUM,
            Fidelity::Waveform => ECHO,
        };
        vec![
            GROUND_TRUTH_TARGETS,
            CLOCK,
            GROUND_TRUTH_POSE,
            ODOM,
            measurement,
        ]
    }

    fn on_message(&mut self, topic: &str, _message: &Message, _outbox: &mut Outbox) -> NodeResult {
        Err(NodeError::invalid_input(
            topic,
            "the radar node subscribes to nothing",
        ))
    }

    fn tick(&mut self, outbox: &mut Outbox) -> Result<Tick, NodeError> {
        if !self.targets_sent {
            self.targets_sent = true;
            outbox.publish(
                GROUND_TRUTH_TARGETS,
                target_set(self.sim.scene(), Time::from_seconds(T0_S)),
            );
        }
        let Some(frame) = self.sim.try_next_frame().map_err(NodeError::algorithm)? else {
            return Ok(Tick::Done);
        };
        let boresight_rad = self.sim.sensor().boresight_rad;
        let stamp = Time::from_seconds(frame.stamp_s);
        let index = frame.index;
        let last = if index + 1 >= self.sim.frame_count() {
            Tick::Done
        } else {
            Tick::More
        };
        outbox.publish(CLOCK, Clock { clock: stamp });
        let odom_frame = match self.sim.role() {
            Role::Agv(_) => ODOM_FRAME,
            // A surveyed pose is in the map frame itself.
            Role::Station(_) => MAP_FRAME,
            Role::NoSensor => return Ok(last),
        };
        outbox.publish(GROUND_TRUTH_POSE, true_pose(&frame, stamp));
        let is = |frames: &[u32]| frames.iter().any(|&f| f as usize == index);
        let mut odom = odometry(&frame, stamp, odom_frame);
        if is(&self.faults.odometry_spike_frames) {
            let (x, y, yaw) = odom.pose.pose.planar();
            let spike = self.faults.odometry_spike_m;
            odom.pose.pose = Pose::from_planar(x + spike * yaw.cos(), y + spike * yaw.sin(), yaw);
        }
        outbox.publish(ODOM, odom);
        let header = Header::new(stamp, RADAR_FRAME);
        if is(&self.faults.drop_frames) {
            return Ok(last);
        }
        let detections = if is(&self.faults.empty_frames) {
            Vec::new()
        } else {
            frame.detections
        };
        match (frame.spectrum, frame.echo) {
            (Some(spectrum), _) => outbox.publish(
                SPECTRUM,
                spectrum_message(header, boresight_rad, &self.ofdm, spectrum),
            ),
            (_, Some(echo)) => {
                outbox.publish(ECHO, echo_message(header, boresight_rad, &self.ofdm, echo))
            }
            _ => outbox.publish(
                DETECTIONS,
                Detections {
                    header,
                    boresight_rad,
                    detections,
                },
            ),
        }
        Ok(last)
    }
}

/// The scene's targets as the `/ground_truth/targets` message.
pub fn target_set(scene: &Scene, stamp: Time) -> TargetSet {
    let point = |v: &Vec2| Point::planar(v.x, v.y);
    TargetSet {
        header: Header::new(stamp, MAP_FRAME),
        targets: scene
            .targets
            .iter()
            .map(|t| TargetMsg {
                id: t.id,
                shape: t.shape.kind_name().to_owned(),
                outline: t.shape.outline().iter().map(point).collect(),
                samples: t.shape.samples().iter().map(point).collect(),
            })
            .collect(),
    }
}

fn true_pose(frame: &Frame, stamp: Time) -> PoseStamped {
    let p = frame.true_pose;
    PoseStamped {
        header: Header::new(stamp, MAP_FRAME),
        pose: Pose::from_planar(p.x_m, p.y_m, p.yaw_rad),
    }
}

fn odometry(frame: &Frame, stamp: Time, frame_id: &str) -> Odometry {
    let o = &frame.odometry;
    // Row-major 6×6 over (x, y, z, roll, pitch, yaw): diagonal indices 0, 7, 14, 21, 28, 35.
    let mut pose_covariance = [0.0; 36];
    pose_covariance[0] = o.pose_variance[0];
    pose_covariance[7] = o.pose_variance[1];
    pose_covariance[35] = o.pose_variance[2];
    let mut twist_covariance = [0.0; 36];
    twist_covariance[0] = o.linear_variance;
    twist_covariance[35] = o.angular_variance;
    Odometry {
        header: Header::new(stamp, frame_id),
        child_frame_id: BASE_FRAME.to_owned(),
        pose: PoseWithCovariance {
            pose: Pose::from_planar(o.pose.x_m, o.pose.y_m, o.pose.yaw_rad),
            covariance: pose_covariance,
        },
        twist: TwistWithCovariance {
            twist: Twist {
                linear: Vector3 {
                    x: o.linear_mps,
                    y: 0.0,
                    z: 0.0,
                },
                angular: Vector3 {
                    x: 0.0,
                    y: 0.0,
                    z: o.angular_rps,
                },
            },
            covariance: twist_covariance,
        },
    }
}
