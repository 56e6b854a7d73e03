//! CDR round trips: every message type decodes to exactly what was encoded, whatever the values
//! (NaN excluded: NaN != NaN), string lengths and sequence lengths, and through `Message` by its
//! ROS 2 type name. `bytes_round_trip_with_any_bits` covers NaN payloads, non-ASCII and NUL
//! characters in strings, and padding after the message, by comparing bytes instead of values.

mod common;

use nrslam_msgs::*;
use proptest::prelude::*;

fn time() -> impl Strategy<Value = Time> {
    (any::<i32>(), 0u32..1_000_000_000).prop_map(|(sec, nanosec)| Time { sec, nanosec })
}

fn header() -> impl Strategy<Value = Header> {
    (time(), "[a-z_/]{0,12}").prop_map(|(stamp, frame_id)| Header { stamp, frame_id })
}

fn finite() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<f64>().prop_filter("finite", |v| v.is_finite()),
        Just(0.0),
        Just(-0.0),
        Just(f64::INFINITY)
    ]
}

fn point() -> impl Strategy<Value = Point> {
    (finite(), finite(), finite()).prop_map(|(x, y, z)| Point { x, y, z })
}

fn pose() -> impl Strategy<Value = Pose> {
    (point(), finite(), finite(), finite(), finite()).prop_map(|(position, x, y, z, w)| Pose {
        position,
        orientation: Quaternion { x, y, z, w },
    })
}

fn detection() -> impl Strategy<Value = Detection> {
    (finite(), finite(), finite(), finite(), finite()).prop_map(
        |(range_m, angle_rad, range_std_m, angle_std_rad, power_db)| Detection {
            range_m,
            angle_rad,
            range_std_m,
            angle_std_rad,
            power_db,
        },
    )
}

fn round_trip(message: Message) -> Result<(), TestCaseError> {
    let bytes = message.encode().unwrap();
    prop_assert_eq!(&bytes[..4], &[0u8, 1, 0, 0]);
    let back = Message::decode(message.type_name(), &bytes).unwrap();
    prop_assert_eq!(back, message);
    Ok(())
}

proptest! {
    #[test]
    fn pose_stamped(header in header(), pose in pose()) {
        round_trip(Message::PoseStamped(PoseStamped { header, pose }))?;
    }

    #[test]
    fn odometry(header in header(), child in "[a-z]{0,9}", pose in pose(), covariance in proptest::array::uniform32(finite()), v in finite()) {
        let mut full = [0.0; 36];
        full[..32].copy_from_slice(&covariance);
        full[35] = v;
        let twist = Twist { linear: Vector3 { x: v, y: -v, z: 0.0 }, angular: Vector3::default() };
        round_trip(Message::Odometry(Odometry {
            header,
            child_frame_id: child,
            pose: PoseWithCovariance { pose, covariance: full },
            twist: TwistWithCovariance { twist, covariance: full },
        }))?;
    }

    #[test]
    fn occupancy_grid(header in header(), load in time(), resolution in any::<f32>().prop_filter("finite", |v| v.is_finite()), width in 0u32..20, height in 0u32..20, origin in pose(), data in proptest::collection::vec(any::<i8>(), 0..300)) {
        round_trip(Message::OccupancyGrid(OccupancyGrid {
            header,
            info: MapMetaData { map_load_time: load, resolution, width, height, origin },
            data,
        }))?;
    }

    #[test]
    fn detections_and_keyframes(header in header(), boresight in finite(), detections in proptest::collection::vec(detection(), 0..20), id in any::<u32>(), pose in pose()) {
        round_trip(Message::Detections(Detections { header: header.clone(), boresight_rad: boresight, detections: detections.clone() }))?;
        round_trip(Message::Keyframe(Keyframe { header, id, pose, boresight_rad: boresight, detections }))?;
    }

    #[test]
    fn segments_targets_metrics(header in header(), points in proptest::collection::vec(point(), 0..30), labels in proptest::collection::vec(any::<i32>(), 0..30), values in proptest::collection::vec(finite(), 11)) {
        round_trip(Message::Segments(Segments { header: header.clone(), eps_m: values[0], min_samples: 4, cluster_count: 2, points: points.clone(), labels }))?;
        let target = Target { id: 3, shape: "circle".into(), outline: points.clone(), samples: points };
        round_trip(Message::TargetSet(TargetSet { header: header.clone(), targets: vec![target.clone(), target] }))?;
        round_trip(Message::Metrics(Metrics {
            header,
            etgospa: values[0], etgospa_localisation: values[1], etgospa_confusion: values[2], etgospa_missed: values[3],
            etgospa_false: values[4], gospa: values[5], gospa_localisation: values[6], gospa_missed: values[7],
            gospa_false: values[8], position_error_m: values[9], estimated_targets: 7, estimate_points: 28,
        }))?;
    }

    #[test]
    fn radar_frames(header in header(), values in proptest::collection::vec(finite(), 0..64), clock in time()) {
        round_trip(Message::RadarSpectrum(RadarSpectrum { header: header.clone(), boresight_rad: 1.0, range_bin_m: 0.122, antenna_spacing_wavelengths: 0.5, noise_power: 0.1, range_bins: 4, angle_bins: 8, values: values.clone() }))?;
        round_trip(Message::RadarEcho(RadarEcho { header, received: values.clone(), transmitted: values, antennas: 2, symbols: 1, subcarriers: 3, ..Default::default() }))?;
        round_trip(Message::Clock(Clock { clock }))?;
    }
}

proptest! {
    #[test]
    fn keyframe_poses_and_association_stats(header in header(), revision in any::<u32>(), poses in proptest::collection::vec(pose(), 0..20), values in proptest::collection::vec(finite(), 5), counts in proptest::array::uniform4(any::<u32>()), flags in proptest::array::uniform2(any::<bool>()), status in "[a-z_]{0,24}", keyframe_id in any::<i32>()) {
        let ids = (0..poses.len() as u32).collect();
        let loops = poses.len() / 2;
        let loop_from_ids = (0..loops as u32).collect();
        let loop_to_ids = (0..loops as u32).map(|k| k + 10).collect();
        let loop_relatives = poses[..loops].to_vec();
        let loop_informations = (0..9 * loops).map(|k| k as f64 * 0.5).collect();
        let pose_covariances = (0..9 * poses.len()).map(|k| k as f64 * 0.25).collect();
        round_trip(Message::KeyframePoses(KeyframePoses { header: header.clone(), revision, ids, poses, loop_from_ids, loop_to_ids, loop_relatives, loop_informations, pose_covariances }))?;
        round_trip(Message::AssociationStats(AssociationStats {
            header,
            detections: counts[0], associated: counts[1], inliers: counts[2],
            inlier_ratio: values[0], rms_residual_m: values[1], icp_status: status,
            icp_iterations: counts[3], correction_m: values[2], correction_rad: values[3],
            odometry_rejected: flags[0], keyframe_id, keyframe_overlap: values[4],
            loop_closed: flags[1], loop_closures: counts[0] / 2,
        }))?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1000, ..ProptestConfig::default() })]

    /// encode → decode → encode gives the same bytes for random messages of every type, any f64
    /// bit pattern (NaN included) and strings with non-ASCII characters and NULs; up to 3 bytes
    /// of padding after the message (as ROS 2 writers may add) change nothing.
    #[test]
    fn bytes_round_trip_with_any_bits(name in proptest::sample::select(Message::TYPE_NAMES), seed in any::<u64>(), padding in 0usize..4) {
        let message = common::random_message(name, &mut common::Rng::new(seed));
        let mut bytes = message.encode().unwrap();
        let encoded_len = bytes.len();
        bytes.resize(encoded_len + padding, 0);
        let back = Message::decode(name, &bytes).unwrap();
        prop_assert_eq!(back.type_name(), name);
        prop_assert_eq!(&back.encode().unwrap()[..], &bytes[..encoded_len]);
    }
}
