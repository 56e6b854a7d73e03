//! The one enum the runtime moves between nodes, with its encoding by ROS 2 type name.

use crate::cdr::{self, CdrError};
use crate::nrslam::*;
use crate::ros::*;
use crate::sensors::*;
use crate::usable::{CheckUsable, Unusable};
use crate::visual::*;

/// Why a message could not be decoded for a type name.
#[derive(Debug, thiserror::Error)]
pub enum MessageError {
    /// No variant of [`Message`] has this ROS 2 type name.
    #[error("unknown message type {0:?}")]
    UnknownType(String),
    /// The bytes are not valid CDR for the type.
    #[error("{type_name}: {source}")]
    Cdr {
        /// The ROS 2 type name decoded.
        type_name: String,
        /// What went wrong.
        source: CdrError,
    },
}

macro_rules! messages {
    ($($variant:ident => $type_name:literal, $stamp:expr;)*) => {
        /// A message of any type the graph carries.
        // Odometry carries two 6×6 covariances (≈740 bytes); boxing it would cost an allocation
        // per message on the hot path for no measured gain.
        #[allow(clippy::large_enum_variant)]
        #[derive(Debug, Clone, PartialEq)]
        pub enum Message {
            $(
                #[doc = concat!("`", $type_name, "`")]
                $variant($variant),
            )*
        }

        impl Message {
            /// The ROS 2 type name, e.g. `nav_msgs/msg/OccupancyGrid`.
            pub fn type_name(&self) -> &'static str {
                match self { $(Message::$variant(_) => $type_name,)* }
            }

            /// Every ROS 2 type name a [`Message`] can carry.
            pub const TYPE_NAMES: &'static [&'static str] = &[$($type_name,)*];

            /// The time of validity of the message (header stamp, or the clock value).
            pub fn stamp(&self) -> Time {
                match self { $(Message::$variant(m) => ($stamp)(m),)* }
            }

            /// Little-endian CDR with the encapsulation header.
            pub fn encode(&self) -> Result<Vec<u8>, CdrError> {
                match self { $(Message::$variant(m) => cdr::encode(m),)* }
            }

            /// Whether the values can be used by a node: numbers that are computed with are
            /// finite, lengths match the dimensions that describe them, values lie in their
            /// domain. Field-by-field rules in [`crate::usable`]; run it on
            /// every message received, after [`Message::decode`] (which checks only the wire
            /// format). O(message size), no allocation.
            pub fn check_usable(&self) -> Result<(), Unusable> {
                match self { $(Message::$variant(m) => m.check_usable(),)* }
            }

            /// Decodes CDR bytes of the ROS 2 type `type_name`.
            pub fn decode(type_name: &str, bytes: &[u8]) -> Result<Message, MessageError> {
                match type_name {
                    $($type_name => cdr::decode::<$variant>(bytes)
                        .map(Message::$variant)
                        .map_err(|source| MessageError::Cdr { type_name: type_name.to_owned(), source }),)*
                    other => Err(MessageError::UnknownType(other.to_owned())),
                }
            }
        }

        $(
            impl From<$variant> for Message {
                fn from(m: $variant) -> Self { Message::$variant(m) }
            }
        )*
    };
}

messages! {
    Clock => "rosgraph_msgs/msg/Clock", |m: &Clock| m.clock;
    Odometry => "nav_msgs/msg/Odometry", |m: &Odometry| m.header.stamp;
    PoseStamped => "geometry_msgs/msg/PoseStamped", |m: &PoseStamped| m.header.stamp;
    OccupancyGrid => "nav_msgs/msg/OccupancyGrid", |m: &OccupancyGrid| m.header.stamp;
    Detections => "nrslam_msgs/msg/Detections", |m: &Detections| m.header.stamp;
    Keyframe => "nrslam_msgs/msg/Keyframe", |m: &Keyframe| m.header.stamp;
    Segments => "nrslam_msgs/msg/Segments", |m: &Segments| m.header.stamp;
    TargetSet => "nrslam_msgs/msg/TargetSet", |m: &TargetSet| m.header.stamp;
    MapTargets => "nrslam_msgs/msg/MapTargets", |m: &MapTargets| m.header.stamp;
    Metrics => "nrslam_msgs/msg/Metrics", |m: &Metrics| m.header.stamp;
    RadarEcho => "nrslam_msgs/msg/RadarEcho", |m: &RadarEcho| m.header.stamp;
    RadarSpectrum => "nrslam_msgs/msg/RadarSpectrum", |m: &RadarSpectrum| m.header.stamp;
    KeyframePoses => "nrslam_msgs/msg/KeyframePoses", |m: &KeyframePoses| m.header.stamp;
    AssociationStats => "nrslam_msgs/msg/AssociationStats", |m: &AssociationStats| m.header.stamp;
    DiagnosticArray => "diagnostic_msgs/msg/DiagnosticArray", |m: &DiagnosticArray| m.header.stamp;
    RadarScan => "radar_msgs/msg/RadarScan", |m: &RadarScan| m.header.stamp;
    PointCloud2 => "sensor_msgs/msg/PointCloud2", |m: &PointCloud2| m.header.stamp;
    TFMessage => "tf2_msgs/msg/TFMessage", TFMessage::stamp;
    Path => "nav_msgs/msg/Path", |m: &Path| m.header.stamp;
    MarkerArray => "visualization_msgs/msg/MarkerArray", MarkerArray::stamp;
}

#[cfg(test)]
mod tests {
    use super::*;

    fn planar_pose() -> Pose {
        Pose::from_planar(1.0, 2.0, 0.3)
    }

    fn detection() -> Detection {
        Detection {
            range_m: 4.0,
            angle_rad: 0.2,
            range_std_m: 0.1,
            angle_std_rad: 0.01,
            power_db: -20.0,
        }
    }

    fn grid() -> OccupancyGrid {
        OccupancyGrid {
            header: Header::new(Time::from_seconds(1.0), "map"),
            info: MapMetaData {
                map_load_time: Time::from_seconds(1.0),
                resolution: 0.1,
                width: 3,
                height: 2,
                origin: planar_pose(),
            },
            data: vec![-1, 0, 100, 50, 0, 0],
        }
    }

    /// One valid message of every catalogue type.
    fn valid_messages() -> Vec<Message> {
        let header = Header::new(Time::from_seconds(2.5), "map");
        vec![
            Message::Clock(Clock {
                clock: Time::from_seconds(2.5),
            }),
            Message::Odometry(Odometry {
                header: header.clone(),
                pose: PoseWithCovariance {
                    pose: planar_pose(),
                    covariance: [f64::NAN; 36],
                },
                ..Default::default()
            }),
            Message::PoseStamped(PoseStamped {
                header: header.clone(),
                pose: planar_pose(),
            }),
            Message::OccupancyGrid(grid()),
            Message::Detections(Detections {
                header: header.clone(),
                boresight_rad: 1.5,
                detections: vec![
                    detection(),
                    Detection {
                        power_db: f64::INFINITY,
                        ..detection()
                    },
                ],
            }),
            Message::Keyframe(Keyframe {
                header: header.clone(),
                id: 3,
                pose: planar_pose(),
                boresight_rad: 1.5,
                detections: vec![detection()],
            }),
            Message::Segments(Segments {
                header: header.clone(),
                eps_m: 0.3,
                min_samples: 3,
                cluster_count: 2,
                points: vec![Point::planar(1.0, 1.0); 3],
                labels: vec![0, 1, -1],
            }),
            Message::TargetSet(TargetSet {
                header: header.clone(),
                targets: vec![Target {
                    id: 0,
                    shape: "circle".into(),
                    outline: vec![Point::planar(0.0, 1.0)],
                    samples: vec![Point::planar(0.5, 1.0)],
                }],
            }),
            Message::MapTargets(MapTargets {
                header: header.clone(),
                targets: vec![MapTarget {
                    id: 1,
                    shape: "circle".into(),
                    center_x_m: 2.0,
                    center_y_m: 3.0,
                    width_m: 1.0,
                    height_m: 1.0,
                    radius_m: 0.5,
                    covariance: vec![0.0; 9],
                    outline: vec![Point::planar(2.5, 3.0)],
                    samples: vec![Point::planar(2.5, 3.0)],
                    supporting_cells: vec![Point::planar(2.5, 3.1)],
                    ..Default::default()
                }],
            }),
            Message::Metrics(Metrics {
                header: header.clone(),
                etgospa: f64::NAN,
                ..Default::default()
            }),
            Message::RadarEcho(RadarEcho {
                header: header.clone(),
                boresight_rad: 1.5,
                carrier_frequency_hz: 28e9,
                subcarrier_spacing_hz: 120e3,
                symbol_duration_s: 8.9e-6,
                antenna_spacing_wavelengths: 0.5,
                snr_db: 10.0,
                antennas: 2,
                symbols: 1,
                subcarriers: 3,
                received: vec![0.5; 12],
                transmitted: vec![1.0; 6],
            }),
            Message::RadarSpectrum(RadarSpectrum {
                header: header.clone(),
                boresight_rad: 1.5,
                range_bin_m: 0.12,
                antenna_spacing_wavelengths: 0.5,
                noise_power: 0.0,
                range_bins: 2,
                angle_bins: 4,
                values: vec![0.25; 16],
            }),
            Message::KeyframePoses(KeyframePoses {
                header: header.clone(),
                revision: 1,
                ids: vec![0, 1],
                poses: vec![planar_pose(); 2],
                loop_from_ids: vec![0],
                loop_to_ids: vec![],
                loop_relatives: vec![planar_pose()],
                loop_informations: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 100.0],
                pose_covariances: vec![0.0; 18],
            }),
            Message::AssociationStats(AssociationStats {
                header: header.clone(),
                rms_residual_m: f64::INFINITY,
                ..Default::default()
            }),
            Message::RadarScan(RadarScan {
                header: header.clone(),
                returns: vec![RadarReturn {
                    range: 8.0,
                    azimuth: -0.3,
                    elevation: 0.0,
                    doppler_velocity: f32::NAN,
                    amplitude: 20.0,
                }],
            }),
            Message::PointCloud2(PointCloud2 {
                header: header.clone(),
                height: 2,
                width: 1,
                fields: vec![
                    PointField::scalar("x", 0, PointField::FLOAT32),
                    PointField::scalar("y", 4, PointField::FLOAT32),
                ],
                point_step: 8,
                row_step: 12,
                data: vec![0; 24],
                ..Default::default()
            }),
            Message::TFMessage(TFMessage {
                transforms: vec![TransformStamped {
                    header: header.clone(),
                    child_frame_id: "odom".into(),
                    transform: Transform::from_planar(1.0, 2.0, 0.3),
                }],
            }),
            Message::Path(Path {
                header: header.clone(),
                poses: vec![PoseStamped {
                    header: header.clone(),
                    pose: planar_pose(),
                }],
            }),
            Message::MarkerArray(MarkerArray {
                markers: vec![Marker {
                    header: header.clone(),
                    marker_type: Marker::LINE_STRIP,
                    pose: Pose {
                        orientation: Quaternion {
                            x: 0.0,
                            y: 0.0,
                            z: 0.0,
                            w: 0.0,
                        },
                        ..Pose::default()
                    },
                    points: vec![Point::planar(0.0, 8.0), Point::planar(30.0, 8.0)],
                    ..Default::default()
                }],
            }),
            Message::DiagnosticArray(DiagnosticArray {
                header,
                status: vec![DiagnosticStatus {
                    level: DiagnosticStatus::WARN,
                    name: "nrslam/mapper/receive".into(),
                    message: "dropped 1 sample".into(),
                    hardware_id: String::new(),
                    values: vec![KeyValue {
                        key: "/map bad_cdr".into(),
                        value: "1".into(),
                    }],
                }],
            }),
        ]
    }

    #[test]
    fn valid_messages_of_every_type_are_usable() {
        let messages = valid_messages();
        let mut names: Vec<_> = messages.iter().map(Message::type_name).collect();
        names.sort_unstable();
        let mut all = Message::TYPE_NAMES.to_vec();
        all.sort_unstable();
        assert_eq!(names, all);
        for message in &messages {
            assert_eq!(message.check_usable(), Ok(()), "{}", message.type_name());
        }
    }

    /// A boxed edit of the message of one variant, returning whether the message was of it.
    macro_rules! spoil {
        ($variant:ident, $m:ident => $body:block) => {
            Box::new(move |message: &mut Message| {
                if let Message::$variant($m) = message {
                    $body
                    true
                } else {
                    false
                }
            })
        };
    }

    type Spoil = Box<dyn Fn(&mut Message) -> bool>;

    /// Applies `spoil` to the valid message of its type and returns the verdict.
    fn spoiled(spoil: impl Fn(&mut Message) -> bool) -> Result<(), Unusable> {
        let mut hits = valid_messages()
            .into_iter()
            .filter_map(|mut m| spoil(&mut m).then_some(m));
        let message = hits.next().expect("a message of the spoiled type");
        message.check_usable()
    }

    /// Checks that each spoiled message is refused as `expected(field)`, for `reason`.
    fn all_refused(
        cases: Vec<(Spoil, &'static str)>,
        expected: fn(&'static str) -> Unusable,
        reason: &str,
    ) {
        for (spoil, field) in cases {
            let verdict = spoiled(spoil);
            assert_eq!(verdict, Err(expected(field)));
            assert_eq!(verdict.unwrap_err().reason(), reason);
        }
    }

    #[test]
    fn non_finite_numbers_that_are_computed_with_are_refused() {
        let nan = f64::NAN;
        let cases: Vec<(Spoil, &str)> = vec![
            (
                spoil!(PoseStamped, p => { p.pose.position.x = nan; }),
                "pose.position",
            ),
            (
                spoil!(PoseStamped, p => { p.pose.orientation.w = f64::INFINITY; }),
                "pose.orientation",
            ),
            (
                spoil!(Odometry, o => { o.twist.twist.angular.z = nan; }),
                "twist.twist",
            ),
            (
                spoil!(Odometry, o => { o.pose.covariance[35] = f64::INFINITY; }),
                "pose.covariance",
            ),
            (
                spoil!(Detections, d => { d.detections[1].angle_rad = nan; }),
                "detections.angle_rad",
            ),
            (
                spoil!(Detections, d => { d.detections[0].power_db = nan; }),
                "detections.power_db",
            ),
            (
                spoil!(Keyframe, k => { k.boresight_rad = f64::NEG_INFINITY; }),
                "boresight_rad",
            ),
            (
                spoil!(KeyframePoses, k => { k.loop_relatives[0].position.y = nan; }),
                "loop_relatives.position",
            ),
            (spoil!(Segments, s => { s.points[2].z = nan; }), "points"),
            (
                spoil!(TargetSet, t => { t.targets[0].samples[0].x = nan; }),
                "targets.samples",
            ),
            (
                spoil!(MapTargets, t => { t.targets[0].covariance[4] = nan; }),
                "targets.covariance",
            ),
            (
                spoil!(MapTargets, t => { t.targets[0].supporting_cells[0].y = nan; }),
                "targets.supporting_cells",
            ),
            (
                spoil!(RadarEcho, e => { e.received[11] = nan; }),
                "received",
            ),
            (
                spoil!(RadarSpectrum, s => { s.values[0] = f64::INFINITY; }),
                "values",
            ),
            (
                spoil!(OccupancyGrid, g => { g.info.origin.orientation.z = nan; }),
                "info.origin.orientation",
            ),
            (
                spoil!(RadarScan, r => { r.returns[0].azimuth = f32::NAN; }),
                "returns.azimuth",
            ),
            (
                spoil!(RadarScan, r => { r.returns[0].amplitude = f32::NAN; }),
                "returns.amplitude",
            ),
            (
                spoil!(TFMessage, t => { t.transforms[0].transform.translation.y = nan; }),
                "transforms.transform.translation",
            ),
            (
                spoil!(Path, p => { p.poses[0].pose.position.x = f64::INFINITY; }),
                "poses.pose.position",
            ),
            (
                spoil!(MarkerArray, m => { m.markers[0].points[1].y = nan; }),
                "markers.points",
            ),
        ];
        all_refused(cases, Unusable::NonFinite, "non_finite");
    }

    #[test]
    fn sizes_that_disagree_with_their_dimensions_are_refused() {
        let cases: Vec<(Spoil, &str)> = vec![
            (spoil!(OccupancyGrid, g => { g.data.pop(); }), "data"),
            (
                spoil!(OccupancyGrid, g => { g.info.width = u32::MAX; g.info.height = u32::MAX; }),
                "data",
            ),
            (spoil!(RadarEcho, e => { e.antennas = 3; }), "received"),
            (
                spoil!(RadarEcho, e => { e.transmitted.push(0.0); }),
                "transmitted",
            ),
            (
                spoil!(RadarEcho, e => { e.antennas = u32::MAX; e.symbols = u32::MAX; e.subcarriers = u32::MAX; }),
                "received",
            ),
            (spoil!(RadarSpectrum, s => { s.angle_bins = 8; }), "values"),
            (spoil!(KeyframePoses, k => { k.ids.push(2); }), "poses"),
            (spoil!(Segments, s => { s.labels.pop(); }), "labels"),
            (
                spoil!(MapTargets, t => { t.targets[0].shape = "rectangle".into(); }),
                "targets.covariance",
            ),
            (spoil!(PointCloud2, c => { c.data.pop(); }), "data"),
            (
                spoil!(PointCloud2, c => { c.row_step = u32::MAX; c.height = u32::MAX; }),
                "data",
            ),
            (spoil!(PointCloud2, c => { c.width = 2; }), "row_step"),
            (
                spoil!(PointCloud2, c => { c.width = u32::MAX; c.point_step = u32::MAX; }),
                "row_step",
            ),
        ];
        all_refused(cases, Unusable::SizeMismatch, "size_mismatch");
    }

    #[test]
    fn values_outside_their_domain_are_refused() {
        let cases: Vec<(Spoil, &str)> = vec![
            (spoil!(OccupancyGrid, g => { g.data[0] = 101; }), "data"),
            (spoil!(OccupancyGrid, g => { g.data[0] = -2; }), "data"),
            (
                spoil!(OccupancyGrid, g => { g.info.resolution = 0.0; }),
                "info.resolution",
            ),
            (
                spoil!(Clock, c => { c.clock.nanosec = 1_000_000_000; }),
                "clock.nanosec",
            ),
            (
                spoil!(Metrics, x => { x.header.stamp.nanosec = u32::MAX; }),
                "header.stamp.nanosec",
            ),
            (
                spoil!(Detections, d => { d.detections[0].range_m = -0.5; }),
                "detections.range_m",
            ),
            (
                spoil!(Keyframe, k => { k.detections[0].range_std_m = -1.0; }),
                "detections.range_std_m",
            ),
            (spoil!(Segments, s => { s.labels[0] = 2; }), "labels"),
            (spoil!(Segments, s => { s.labels[0] = -2; }), "labels"),
            (
                spoil!(MapTargets, t => { t.targets[0].shape = "ellipse".into(); }),
                "targets.shape",
            ),
            (
                spoil!(MapTargets, t => { t.targets[0].radius_m = -0.1; }),
                "targets.radius_m",
            ),
            (
                spoil!(PoseStamped, p => { p.pose.orientation = Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 0.0 }; }),
                "pose.orientation",
            ),
            (
                spoil!(RadarEcho, e => { e.carrier_frequency_hz = 0.0; }),
                "carrier_frequency_hz",
            ),
            (
                spoil!(RadarSpectrum, s => { s.noise_power = -1e-9; }),
                "noise_power",
            ),
            (
                spoil!(RadarScan, r => { r.returns[0].range = -1.0; }),
                "returns.range",
            ),
            (
                spoil!(PointCloud2, c => { c.fields[1].offset = 5; }),
                "fields.offset",
            ),
            (
                spoil!(PointCloud2, c => { c.fields[0].count = u32::MAX; }),
                "fields.offset",
            ),
            (
                spoil!(PointCloud2, c => { c.fields[0].offset = u32::MAX; }),
                "fields.offset",
            ),
            (
                spoil!(PointCloud2, c => { c.fields[0].datatype = 9; }),
                "fields.datatype",
            ),
            (
                spoil!(TFMessage, t => { t.transforms[0].transform.rotation.w = 0.0; t.transforms[0].transform.rotation.z = 0.0; }),
                "transforms.transform.rotation",
            ),
            (
                spoil!(MarkerArray, m => { m.markers[0].lifetime.nanosec = 1_000_000_000; }),
                "markers.lifetime.nanosec",
            ),
        ];
        all_refused(cases, Unusable::OutOfRange, "out_of_range");
    }

    #[test]
    fn reasons_are_short_distinct_keys() {
        let all = [
            Unusable::BadCdr,
            Unusable::NonFinite("x"),
            Unusable::SizeMismatch("x"),
            Unusable::OutOfRange("x"),
        ];
        let keys: std::collections::BTreeSet<_> = all.iter().map(Unusable::reason).collect();
        assert_eq!(keys.len(), all.len());
        assert!(keys
            .iter()
            .all(|k| k.len() <= 16 && k.bytes().all(|b| b.is_ascii_lowercase() || b == b'_')));
        assert_eq!(
            Unusable::NonFinite("pose.position").field(),
            Some("pose.position")
        );
        assert_eq!(Unusable::BadCdr.field(), None);
    }

    #[test]
    fn every_type_has_a_schema() {
        for name in Message::TYPE_NAMES {
            assert!(crate::schema::ros2msg(name).is_some(), "{name}");
        }
    }

    #[test]
    fn decoding_with_the_wrong_type_name_is_an_error_not_a_panic() {
        let bytes = Message::Clock(Clock {
            clock: Time::from_seconds(2.0),
        })
        .encode()
        .unwrap();
        assert!(Message::decode("nav_msgs/msg/OccupancyGrid", &bytes).is_err());
        assert!(matches!(
            Message::decode("foo/msg/Bar", &bytes),
            Err(MessageError::UnknownType(_))
        ));
    }
}
