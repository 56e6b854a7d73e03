//! Fuzzing support shared by `tests/fuzz_decode.rs`, `tests/decode_allocation.rs` and
//! `examples/fuzz_decode.rs`: a seeded generator of valid messages of every catalogue type, and
//! mutations of their encodings aimed at a CDR decoder (bit flips, truncation, length fields
//! overwritten with huge values, insertions, deletions). Deterministic for a given seed, so a
//! failure found by the long run reproduces.
#![allow(dead_code)] // each including target uses a part

use nrslam_msgs::*;

/// SplitMix64: small, fast, good enough to drive a fuzzer, no dependency.
pub struct Rng(u64);

impl Rng {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Self {
        Self(seed)
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `0..n` (`n` > 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }

    /// True with probability 1/`n`.
    pub fn one_in(&mut self, n: usize) -> bool {
        self.below(n) == 0
    }

    fn f64(&mut self) -> f64 {
        match self.below(8) {
            0 => 0.0,
            1 => f64::from_bits(self.next_u64()), // any bit pattern, NaN included
            _ => (self.next_u64() as i64 as f64) * 1e-15,
        }
    }

    /// Up to `max_len` items drawn by `item` (the length drawn first).
    fn vec<T>(&mut self, max_len: usize, mut item: impl FnMut(&mut Self) -> T) -> Vec<T> {
        let n = self.below(max_len + 1);
        (0..n).map(|_| item(self)).collect()
    }

    fn f64s(&mut self, max_len: usize) -> Vec<f64> {
        self.vec(max_len, Self::f64)
    }

    fn u32(&mut self) -> u32 {
        match self.below(4) {
            0 => 0,
            1 => self.next_u64() as u32,
            _ => self.below(10) as u32,
        }
    }

    fn string(&mut self) -> String {
        const ALPHABET: [&str; 8] = ["m", "a", "p", "_", "/", "é", "∞", "\0"];
        let n = self.below(10);
        (0..n)
            .map(|_| ALPHABET[self.below(ALPHABET.len())])
            .collect()
    }

    fn time(&mut self) -> Time {
        Time {
            sec: self.next_u64() as i32,
            nanosec: self.below(1_000_000_000) as u32,
        }
    }

    fn header(&mut self) -> Header {
        Header {
            stamp: self.time(),
            frame_id: self.string(),
        }
    }

    fn point(&mut self) -> Point {
        Point {
            x: self.f64(),
            y: self.f64(),
            z: self.f64(),
        }
    }

    fn points(&mut self, max_len: usize) -> Vec<Point> {
        self.vec(max_len, Self::point)
    }

    fn vector3(&mut self) -> Vector3 {
        Vector3 {
            x: self.f64(),
            y: self.f64(),
            z: self.f64(),
        }
    }

    fn pose(&mut self) -> Pose {
        Pose {
            position: self.point(),
            orientation: Quaternion {
                x: self.f64(),
                y: self.f64(),
                z: self.f64(),
                w: self.f64(),
            },
        }
    }

    fn poses(&mut self, max_len: usize) -> Vec<Pose> {
        self.vec(max_len, Self::pose)
    }

    fn u32s(&mut self, max_len: usize) -> Vec<u32> {
        self.vec(max_len, Self::u32)
    }

    fn detections(&mut self, max_len: usize) -> Vec<Detection> {
        self.vec(max_len, |r| Detection {
            range_m: r.f64(),
            angle_rad: r.f64(),
            range_std_m: r.f64(),
            angle_std_rad: r.f64(),
            power_db: r.f64(),
        })
    }

    fn color(&mut self) -> ColorRGBA {
        ColorRGBA {
            r: self.f64() as f32,
            g: self.f64() as f32,
            b: self.f64() as f32,
            a: self.f64() as f32,
        }
    }

    fn bytes(&mut self, max_len: usize) -> Vec<u8> {
        self.vec(max_len, |r| r.next_u64() as u8)
    }

    fn marker(&mut self) -> Marker {
        Marker {
            header: self.header(),
            ns: self.string(),
            id: self.next_u64() as i32,
            marker_type: self.below(13) as i32,
            action: self.below(4) as i32,
            pose: self.pose(),
            scale: self.vector3(),
            color: self.color(),
            lifetime: Duration {
                sec: self.next_u64() as i32,
                nanosec: self.below(1_000_000_000) as u32,
            },
            frame_locked: self.one_in(2),
            points: self.points(4),
            colors: (0..self.below(3)).map(|_| self.color()).collect(),
            texture_resource: self.string(),
            texture: CompressedImage {
                header: self.header(),
                format: self.string(),
                data: self.bytes(8),
            },
            uv_coordinates: (0..self.below(3))
                .map(|_| UVCoordinate {
                    u: self.f64() as f32,
                    v: self.f64() as f32,
                })
                .collect(),
            text: self.string(),
            mesh_resource: self.string(),
            mesh_file: MeshFile {
                filename: self.string(),
                data: self.bytes(8),
            },
            mesh_use_embedded_materials: self.one_in(2),
        }
    }

    fn covariance(&mut self) -> [f64; 36] {
        std::array::from_fn(|_| self.f64())
    }
}

/// A random message of the catalogue type `type_name` (one of [`Message::TYPE_NAMES`]), every
/// field drawn, sequences up to a few elements.
pub fn random_message(type_name: &str, rng: &mut Rng) -> Message {
    let r = rng;
    match type_name {
        "rosgraph_msgs/msg/Clock" => Message::Clock(Clock { clock: r.time() }),
        "nav_msgs/msg/Odometry" => Message::Odometry(Odometry {
            header: r.header(),
            child_frame_id: r.string(),
            pose: PoseWithCovariance {
                pose: r.pose(),
                covariance: r.covariance(),
            },
            twist: TwistWithCovariance {
                twist: Twist {
                    linear: r.vector3(),
                    angular: r.vector3(),
                },
                covariance: r.covariance(),
            },
        }),
        "geometry_msgs/msg/PoseStamped" => Message::PoseStamped(PoseStamped {
            header: r.header(),
            pose: r.pose(),
        }),
        "nav_msgs/msg/OccupancyGrid" => {
            let (width, height) = (r.below(6) as u32, r.below(6) as u32);
            let cells = if r.one_in(4) {
                r.below(40)
            } else {
                (width * height) as usize
            };
            Message::OccupancyGrid(OccupancyGrid {
                header: r.header(),
                info: MapMetaData {
                    map_load_time: r.time(),
                    resolution: r.f64() as f32,
                    width,
                    height,
                    origin: r.pose(),
                },
                data: (0..cells).map(|_| r.next_u64() as i8).collect(),
            })
        }
        "nrslam_msgs/msg/Detections" => Message::Detections(Detections {
            header: r.header(),
            boresight_rad: r.f64(),
            detections: r.detections(5),
        }),
        "nrslam_msgs/msg/Keyframe" => Message::Keyframe(Keyframe {
            header: r.header(),
            id: r.u32(),
            pose: r.pose(),
            boresight_rad: r.f64(),
            detections: r.detections(5),
        }),
        "nrslam_msgs/msg/Segments" => Message::Segments(Segments {
            header: r.header(),
            eps_m: r.f64(),
            min_samples: r.u32(),
            cluster_count: r.u32(),
            points: r.points(6),
            labels: r.u32s(6).into_iter().map(|v| v as i32).collect(),
        }),
        "nrslam_msgs/msg/TargetSet" => {
            let n = r.below(4);
            Message::TargetSet(TargetSet {
                header: r.header(),
                targets: (0..n)
                    .map(|_| Target {
                        id: r.u32(),
                        shape: r.string(),
                        outline: r.points(5),
                        samples: r.points(4),
                    })
                    .collect(),
            })
        }
        "nrslam_msgs/msg/MapTargets" => {
            let n = r.below(3);
            Message::MapTargets(MapTargets {
                header: r.header(),
                targets: (0..n)
                    .map(|_| MapTarget {
                        id: r.u32(),
                        shape: r.string(),
                        center_x_m: r.f64(),
                        center_y_m: r.f64(),
                        width_m: r.f64(),
                        height_m: r.f64(),
                        yaw_rad: r.f64(),
                        radius_m: r.f64(),
                        covariance: r.f64s(26),
                        sides_seen: r.u32(),
                        updates: r.u32(),
                        rms_residual_m: r.f64(),
                        outline: r.points(5),
                        samples: r.points(4),
                        supporting_cells: r.points(6),
                    })
                    .collect(),
            })
        }
        "nrslam_msgs/msg/Metrics" => Message::Metrics(Metrics {
            header: r.header(),
            etgospa: r.f64(),
            etgospa_localisation: r.f64(),
            etgospa_confusion: r.f64(),
            etgospa_missed: r.f64(),
            etgospa_false: r.f64(),
            gospa: r.f64(),
            gospa_localisation: r.f64(),
            gospa_missed: r.f64(),
            gospa_false: r.f64(),
            position_error_m: r.f64(),
            estimated_targets: r.u32(),
            estimate_points: r.u32(),
        }),
        "nrslam_msgs/msg/RadarEcho" => Message::RadarEcho(RadarEcho {
            header: r.header(),
            boresight_rad: r.f64(),
            carrier_frequency_hz: r.f64(),
            subcarrier_spacing_hz: r.f64(),
            symbol_duration_s: r.f64(),
            antenna_spacing_wavelengths: r.f64(),
            snr_db: r.f64(),
            antennas: r.u32(),
            symbols: r.u32(),
            subcarriers: r.u32(),
            received: r.f64s(12),
            transmitted: r.f64s(6),
        }),
        "nrslam_msgs/msg/RadarSpectrum" => Message::RadarSpectrum(RadarSpectrum {
            header: r.header(),
            boresight_rad: r.f64(),
            range_bin_m: r.f64(),
            antenna_spacing_wavelengths: r.f64(),
            noise_power: r.f64(),
            range_bins: r.u32(),
            angle_bins: r.u32(),
            values: r.f64s(12),
        }),
        "nrslam_msgs/msg/KeyframePoses" => Message::KeyframePoses(KeyframePoses {
            header: r.header(),
            revision: r.u32(),
            ids: r.u32s(4),
            poses: r.poses(4),
            loop_from_ids: r.u32s(2),
            loop_to_ids: r.u32s(2),
            loop_relatives: r.poses(2),
            loop_informations: r.f64s(18),
            pose_covariances: r.f64s(36),
        }),
        "nrslam_msgs/msg/AssociationStats" => Message::AssociationStats(AssociationStats {
            header: r.header(),
            detections: r.u32(),
            associated: r.u32(),
            inliers: r.u32(),
            inlier_ratio: r.f64(),
            rms_residual_m: r.f64(),
            icp_status: r.string(),
            icp_iterations: r.u32(),
            correction_m: r.f64(),
            correction_rad: r.f64(),
            odometry_rejected: r.one_in(2),
            keyframe_id: r.next_u64() as i32,
            keyframe_overlap: r.f64(),
            loop_closed: r.one_in(2),
            loop_closures: r.u32(),
        }),
        "diagnostic_msgs/msg/DiagnosticArray" => Message::DiagnosticArray(DiagnosticArray {
            header: r.header(),
            status: (0..r.below(3))
                .map(|_| DiagnosticStatus {
                    level: r.next_u64() as u8,
                    name: r.string(),
                    message: r.string(),
                    hardware_id: r.string(),
                    values: (0..r.below(3))
                        .map(|_| KeyValue {
                            key: r.string(),
                            value: r.string(),
                        })
                        .collect(),
                })
                .collect(),
        }),
        "radar_msgs/msg/RadarScan" => Message::RadarScan(RadarScan {
            header: r.header(),
            returns: (0..r.below(5))
                .map(|_| RadarReturn {
                    range: r.f64() as f32,
                    azimuth: r.f64() as f32,
                    elevation: r.f64() as f32,
                    doppler_velocity: r.f64() as f32,
                    amplitude: r.f64() as f32,
                })
                .collect(),
        }),
        "sensor_msgs/msg/PointCloud2" => Message::PointCloud2(PointCloud2 {
            header: r.header(),
            height: r.u32(),
            width: r.u32(),
            fields: (0..r.below(4))
                .map(|_| PointField {
                    name: r.string(),
                    offset: r.u32(),
                    datatype: r.below(10) as u8,
                    count: r.u32(),
                })
                .collect(),
            is_bigendian: r.one_in(2),
            point_step: r.u32(),
            row_step: r.u32(),
            data: (0..r.below(40)).map(|_| r.next_u64() as u8).collect(),
            is_dense: r.one_in(2),
        }),
        "tf2_msgs/msg/TFMessage" => Message::TFMessage(TFMessage {
            transforms: (0..r.below(4))
                .map(|_| {
                    let pose = r.pose();
                    TransformStamped {
                        header: r.header(),
                        child_frame_id: r.string(),
                        transform: Transform {
                            translation: Vector3 {
                                x: pose.position.x,
                                y: pose.position.y,
                                z: pose.position.z,
                            },
                            rotation: pose.orientation,
                        },
                    }
                })
                .collect(),
        }),
        "nav_msgs/msg/Path" => Message::Path(Path {
            header: r.header(),
            poses: (0..r.below(4))
                .map(|_| PoseStamped {
                    header: r.header(),
                    pose: r.pose(),
                })
                .collect(),
        }),
        "visualization_msgs/msg/MarkerArray" => Message::MarkerArray(MarkerArray {
            markers: (0..r.below(3)).map(|_| r.marker()).collect(),
        }),
        other => panic!("no generator for {other}: add one for every Message::TYPE_NAMES entry"),
    }
}

/// Values a length or count field is overwritten with.
fn hostile_u32(rng: &mut Rng, bytes_total: usize, at: usize) -> u32 {
    let left = bytes_total.saturating_sub(at + 4) as u32;
    match rng.below(8) {
        0 => u32::MAX,
        1 => 0x8000_0000,
        2 => 0x7fff_ffff,
        3 => 0x0001_0000,
        4 => left,
        5 => left.wrapping_add(1),
        6 => 0,
        _ => rng.next_u64() as u32,
    }
}

/// One mutation of `bytes` (which may be empty).
pub fn mutate_once(bytes: &mut Vec<u8>, rng: &mut Rng) {
    let len = bytes.len();
    match rng.below(7) {
        0 if len > 0 => {
            let bit = rng.below(len * 8);
            bytes[bit / 8] ^= 1 << (bit % 8);
        }
        1 => bytes.truncate(rng.below(len + 1)),
        2 if len >= 8 => {
            // A 4-aligned word of the body: where length and count prefixes sit.
            let at = 4 + 4 * rng.below((len - 4) / 4);
            let value = hostile_u32(rng, len, at);
            bytes[at..at + 4].copy_from_slice(&value.to_le_bytes());
        }
        3 => {
            let at = rng.below(len + 1);
            let n = 1 + rng.below(16);
            let insert: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
            bytes.splice(at..at, insert);
        }
        4 if len > 0 => {
            let from = rng.below(len);
            let to = (from + 1 + rng.below(16)).min(len);
            bytes.drain(from..to);
        }
        5 if len > 0 => {
            let at = rng.below(len);
            bytes[at] = rng.next_u64() as u8;
        }
        _ if len > 0 => {
            // Repeat a slice at the end.
            let from = rng.below(len);
            let to = (from + 1 + rng.below(32)).min(len);
            bytes.extend_from_within(from..to);
        }
        _ => bytes.push(rng.next_u64() as u8),
    }
}

/// One fuzz input: a type name of the catalogue and bytes to decode as it. A quarter are random
/// bytes (most behind a valid encapsulation header, so they reach the message body); the rest
/// are valid encodings of random messages of that type with one to four mutations.
pub fn fuzz_input(rng: &mut Rng) -> (&'static str, Vec<u8>) {
    let type_name = Message::TYPE_NAMES[rng.below(Message::TYPE_NAMES.len())];
    if rng.one_in(4) {
        let n = rng.below(256);
        let mut bytes: Vec<u8> = (0..n).map(|_| rng.next_u64() as u8).collect();
        if !rng.one_in(4) && n >= 4 {
            bytes[..4].copy_from_slice(&[0, 1, 0, 0]);
        }
        return (type_name, bytes);
    }
    let mut bytes = random_message(type_name, rng)
        .encode()
        .expect("every generated message encodes");
    for _ in 0..1 + rng.below(4) {
        mutate_once(&mut bytes, rng);
    }
    (type_name, bytes)
}

/// Decodes `bytes` as `type_name` and, when that succeeds, checks the values: the receive path.
/// Returns whether the message decoded.
pub fn receive(type_name: &str, bytes: &[u8]) -> bool {
    match Message::decode(type_name, bytes) {
        Ok(message) => {
            let _ = message.check_usable();
            true
        }
        Err(_) => false,
    }
}
