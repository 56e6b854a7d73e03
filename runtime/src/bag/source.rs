//! The `bag` source node: publishes a recorded bag's messages onto the graph, in recorded order,
//! one frame (all messages of one log time) per tick. `launch/replay.toml` feeds the back end with
//! it; the back end's nodes see the same per-topic streams as in the recorded run, so (their
//! inputs being merged by (stamp, input order)) they compute the same results.
//!
//! `time_offset_s` shifts every stamp the bag plays (headers, each transform's, marker's and path
//! pose's, the clock, a map's load time) by a constant: two sessions recorded on independent
//! clocks are put on one timeline when they replay together (`launch/multi-session.toml`).

use super::{Bag, BagError, Messages, ReadMode};
use crate::node::{Node, NodeError, Outbox, Tick};
use nrslam_msgs::{topics, Message, Time};
use serde::Deserialize;
use std::path::PathBuf;

/// Parameters of a `bag` node.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SourceParams {
    /// The bag folder. A relative path resolves against the current directory (it is usually given
    /// on the command line, `bag:=DIR`), not against the launch file.
    pub path: PathBuf,
    /// Topics to publish (each must be in the bag and in the topic catalogue); empty: every topic
    /// of the bag.
    #[serde(default)]
    pub topics: Vec<String>,
    /// Read a bag whose recorder was killed, up to its last complete chunk, skipping damaged
    /// chunks (each loss is logged).
    #[serde(default)]
    pub recover: bool,
    /// This bag stands in for a recorded run's front end: the launcher replaces the launch's
    /// other nodes by the back end recorded in the bag's `nrslam.nodes` (`launch/replay.toml`).
    /// The node itself plays the same either way.
    #[serde(default)]
    pub rebuild_recorded_back_end: bool,
    /// Seconds added to every stamp played (may be negative; default 0: as recorded). A stamp
    /// that the shift would put before 0 or past the last second a ROS `Time` holds stops the
    /// node with an error naming the parameter.
    #[serde(default)]
    pub time_offset_s: f64,
}

/// Largest |`time_offset_s`| (s): the range of a ROS `Time`'s seconds.
const MAX_TIME_OFFSET_S: f64 = i32::MAX as f64;

/// Publishes a bag's messages; see the module docs. The messages are streamed from the file (one
/// chunk in memory at a time) and decoded as they are published.
pub struct BagSource {
    outputs: Vec<&'static str>,
    messages: Messages,
    pending: Option<(&'static str, Message)>,
    /// `time_offset_s` in nanoseconds.
    offset_ns: i64,
}

impl BagSource {
    /// Opens the bag named by `params` and checks its topics (from the MCAP summary or
    /// metadata.yaml; a recovered bag without either is surveyed in one pass first).
    pub fn new(params: &SourceParams) -> Result<Self, BagError> {
        if params.path.as_os_str().is_empty() {
            return Err(BagError::NoPath);
        }
        let offset = params.time_offset_s;
        if !(offset.is_finite() && offset.abs() <= MAX_TIME_OFFSET_S) {
            return Err(BagError::Message {
                topic: "time_offset_s".into(),
                reason: format!(
                    "{offset} is not a shift of stamps (allowed: finite, at most {MAX_TIME_OFFSET_S} \
                     s either way)"
                ),
            });
        }
        let mode = if params.recover {
            ReadMode::Recover
        } else {
            ReadMode::Strict
        };
        let bag = Bag::open(&params.path, mode)?;
        let recorded = bag.known_topics()?;
        super::reader::check_topics(&params.topics, &recorded)?;
        let mut outputs: Vec<&'static str> = Vec::new();
        for topic in &recorded {
            if !params.topics.is_empty() && !params.topics.contains(&topic.name) {
                continue;
            }
            let spec = topics::spec(&topic.name).ok_or_else(|| BagError::Message {
                topic: topic.name.clone(),
                reason: "not a topic of the nrslam graph (see `nrslam topics`)".into(),
            })?;
            if spec.type_name != topic.type_name {
                return Err(BagError::Message {
                    topic: topic.name.clone(),
                    reason: format!(
                        "recorded as {}, the graph carries {}",
                        topic.type_name, spec.type_name
                    ),
                });
            }
            // The recorded name, under its namespace if any (/agv1/odom): the spec only
            // vouches for its type.
            let name = topics::intern(&topic.name);
            if !outputs.contains(&name) {
                outputs.push(name);
            }
        }
        let messages = bag.messages_on(&params.topics)?;
        Ok(Self {
            outputs,
            messages,
            pending: None,
            offset_ns: (offset * 1e9).round() as i64,
        })
    }

    /// The next message, decoded; `None` at the end of the bag.
    fn next_message(&mut self) -> Result<Option<(&'static str, Message)>, NodeError> {
        let Some(read) = self.messages.next() else {
            return Ok(None);
        };
        let message = read.map_err(NodeError::algorithm)?;
        let name = self
            .outputs
            .iter()
            .copied()
            .find(|name| *name == message.topic)
            .ok_or_else(|| {
                NodeError::invalid_input(&message.topic, "not among the topics checked at start")
            })?;
        let mut decoded = message
            .decode()
            .map_err(|e| NodeError::invalid_input(name, e.to_string()))?;
        if self.offset_ns != 0 {
            shift_stamps(&mut decoded, self.offset_ns).map_err(|stamp| {
                NodeError::invalid_input(
                    name,
                    format!(
                        "time_offset_s {} s moves stamp {} s out of a ROS Time's range (0 to \
                         {} s)",
                        self.offset_ns as f64 * 1e-9,
                        stamp.as_seconds(),
                        i32::MAX
                    ),
                )
            })?;
        }
        Ok(Some((name, decoded)))
    }
}

/// `stamp` moved by `offset_ns`; `Err(stamp)` when the result is before 0 or past `i32::MAX`
/// seconds.
fn shift(stamp: &mut Time, offset_ns: i64) -> Result<(), Time> {
    let nanos = i128::from(stamp.sec) * 1_000_000_000 + i128::from(stamp.nanosec);
    let moved = nanos + i128::from(offset_ns);
    if moved < 0 || moved / 1_000_000_000 > i128::from(i32::MAX) {
        return Err(*stamp);
    }
    *stamp = Time {
        sec: (moved / 1_000_000_000) as i32,
        nanosec: (moved % 1_000_000_000) as u32,
    };
    Ok(())
}

/// Every stamp of `message` moved by `offset_ns` (see [`shift`]). Every message type is listed,
/// so that a new one must say where its stamps are.
fn shift_stamps(message: &mut Message, offset_ns: i64) -> Result<(), Time> {
    let s = |stamp: &mut Time| shift(stamp, offset_ns);
    match message {
        Message::Clock(m) => s(&mut m.clock),
        Message::Odometry(m) => s(&mut m.header.stamp),
        Message::PoseStamped(m) => s(&mut m.header.stamp),
        Message::OccupancyGrid(m) => {
            s(&mut m.header.stamp)?;
            s(&mut m.info.map_load_time)
        }
        Message::Detections(m) => s(&mut m.header.stamp),
        Message::Keyframe(m) => s(&mut m.header.stamp),
        Message::Segments(m) => s(&mut m.header.stamp),
        Message::TargetSet(m) => s(&mut m.header.stamp),
        Message::MapTargets(m) => s(&mut m.header.stamp),
        Message::Metrics(m) => s(&mut m.header.stamp),
        Message::RadarEcho(m) => s(&mut m.header.stamp),
        Message::RadarSpectrum(m) => s(&mut m.header.stamp),
        Message::KeyframePoses(m) => s(&mut m.header.stamp),
        Message::AssociationStats(m) => s(&mut m.header.stamp),
        Message::DiagnosticArray(m) => s(&mut m.header.stamp),
        Message::RadarScan(m) => s(&mut m.header.stamp),
        Message::PointCloud2(m) => s(&mut m.header.stamp),
        Message::TFMessage(m) => m
            .transforms
            .iter_mut()
            .try_for_each(|t| s(&mut t.header.stamp)),
        Message::Path(m) => {
            s(&mut m.header.stamp)?;
            m.poses.iter_mut().try_for_each(|p| s(&mut p.header.stamp))
        }
        Message::MarkerArray(m) => m
            .markers
            .iter_mut()
            .try_for_each(|marker| s(&mut marker.header.stamp)),
    }
}

impl Node for BagSource {
    fn inputs(&self) -> Vec<&'static str> {
        Vec::new()
    }

    fn outputs(&self) -> Vec<&'static str> {
        self.outputs.clone()
    }

    fn on_message(&mut self, topic: &str, _: &Message, _: &mut Outbox) -> Result<(), NodeError> {
        Err(NodeError::invalid_input(
            topic,
            "a bag source has no inputs",
        ))
    }

    fn tick(&mut self, outbox: &mut Outbox) -> Result<Tick, NodeError> {
        let first = match self.pending.take() {
            Some(pending) => pending,
            None => match self.next_message()? {
                Some(message) => message,
                None => return Ok(Tick::Done),
            },
        };
        let stamp = first.1.stamp();
        outbox.publish(first.0, first.1);
        while let Some((topic, message)) = self.next_message()? {
            if message.stamp() != stamp {
                self.pending = Some((topic, message));
                return Ok(Tick::More);
            }
            outbox.publish(topic, message);
        }
        Ok(Tick::Done)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bag::{BagWriter, WriterOptions};
    use nrslam_msgs::{Clock, Header, Odometry, Time};

    #[test]
    fn publishes_one_frame_per_tick_in_recorded_order() {
        let dir = tempfile::tempdir().unwrap();
        let bag = dir.path().join("b");
        let mut writer = BagWriter::create(&bag, WriterOptions::default()).unwrap();
        for k in 1..=3 {
            let stamp = Time::from_seconds(k as f64);
            writer
                .write_message(topics::CLOCK, &Message::Clock(Clock { clock: stamp }))
                .unwrap();
            let odom = Odometry {
                header: Header::new(stamp, "odom"),
                ..Default::default()
            };
            writer
                .write_message(topics::ODOM, &Message::Odometry(odom))
                .unwrap();
        }
        writer.finish().unwrap();
        let mut source = BagSource::new(&SourceParams {
            path: bag.clone(),
            topics: vec![],
            recover: false,
            rebuild_recorded_back_end: false,
            time_offset_s: 0.0,
        })
        .unwrap();
        assert_eq!(source.outputs(), [topics::CLOCK, topics::ODOM]);
        let mut outbox = Outbox::new();
        let mut frames = Vec::new();
        loop {
            let tick = source.tick(&mut outbox).unwrap();
            let frame: Vec<(&str, f64)> = outbox
                .drain()
                .map(|(t, m)| (t, m.stamp().as_seconds()))
                .collect();
            if !frame.is_empty() {
                frames.push(frame);
            }
            if tick == Tick::Done {
                break;
            }
        }
        assert_eq!(frames.len(), 3);
        assert_eq!(frames[1], [(topics::CLOCK, 2.0), (topics::ODOM, 2.0)]);
        let only_odom = BagSource::new(&SourceParams {
            path: bag,
            topics: vec![topics::ODOM.into()],
            recover: false,
            rebuild_recorded_back_end: false,
            time_offset_s: 0.0,
        })
        .unwrap();
        assert_eq!(only_odom.outputs(), [topics::ODOM]);
    }

    /// Every stamp of each frame played, as seconds.
    fn played(source: &mut BagSource) -> Result<Vec<Vec<f64>>, NodeError> {
        let mut outbox = Outbox::new();
        let mut frames = Vec::new();
        loop {
            let tick = source.tick(&mut outbox)?;
            let frame: Vec<f64> = outbox
                .drain()
                .map(|(_, m)| m.stamp().as_seconds())
                .collect();
            if !frame.is_empty() {
                frames.push(frame);
            }
            if tick == Tick::Done {
                return Ok(frames);
            }
        }
    }

    #[test]
    fn time_offset_shifts_every_stamp_and_refuses_to_leave_the_time_range() {
        let dir = tempfile::tempdir().unwrap();
        let bag = dir.path().join("b");
        let mut writer = BagWriter::create(&bag, WriterOptions::default()).unwrap();
        for k in 1..=2 {
            let stamp = Time::from_seconds(k as f64 + 0.25);
            writer
                .write_message(topics::CLOCK, &Message::Clock(Clock { clock: stamp }))
                .unwrap();
            let path = nrslam_msgs::Path {
                header: Header::new(stamp, "map"),
                poses: vec![nrslam_msgs::PoseStamped {
                    header: Header::new(stamp, "map"),
                    ..Default::default()
                }],
            };
            writer
                .write_message(topics::SLAM_PATH, &Message::Path(path))
                .unwrap();
        }
        writer.finish().unwrap();
        let params = |time_offset_s: f64| SourceParams {
            path: bag.clone(),
            topics: vec![],
            recover: false,
            rebuild_recorded_back_end: false,
            time_offset_s,
        };
        let mut later = BagSource::new(&params(86_400.5)).unwrap();
        assert_eq!(
            played(&mut later).unwrap(),
            [[86_401.75, 86_401.75], [86_402.75, 86_402.75]]
        );
        // A path's poses move with it.
        let mut one = BagSource::new(&params(-1.0)).unwrap();
        let mut outbox = Outbox::new();
        one.tick(&mut outbox).unwrap();
        let (_, Message::Path(path)) = outbox.drain().nth(1).unwrap() else {
            panic!("the second message of a frame is the path");
        };
        assert_eq!(path.poses[0].header.stamp, Time::from_seconds(0.25));
        // Before 0: refused when the stamp is played, naming the parameter.
        let mut early = BagSource::new(&params(-1.5)).unwrap();
        let error = played(&mut early).unwrap_err().to_string();
        assert!(error.contains("time_offset_s -1.5"), "{error}");
        for bad in [f64::NAN, f64::INFINITY, 3.0e9] {
            let error = BagSource::new(&params(bad)).err().unwrap().to_string();
            assert!(error.starts_with("time_offset_s: "), "{error}");
        }
    }
}
