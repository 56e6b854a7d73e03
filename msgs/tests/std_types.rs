//! The standard sensor and viewer types (`RadarScan`, `PointCloud2`, `TFMessage`, `Path`,
//! `MarkerArray`) against bytes and schemas written by code we did not write: payloads of a bag
//! written by rosbags 0.11.9, messages serialized by rosbags' ROS 2 Jazzy type store, and its
//! `ros2msg` texts. `tests/fixtures/make_std_golden.py` regenerates every file used here (see
//! tests/fixtures/README.md).

use nrslam_msgs::*;

fn hex_lines(text: &str) -> Vec<Vec<u8>> {
    text.lines()
        .filter(|l| !l.is_empty())
        .map(|line| {
            (0..line.len())
                .step_by(2)
                .map(|i| u8::from_str_radix(&line[i..i + 2], 16).unwrap())
                .collect()
        })
        .collect()
}

const FRAMES: [u32; 3] = [0, 10, 19];

#[test]
fn radar_scans_of_a_rosbags_bag_decode_to_the_wall_and_encode_to_the_same_bytes() {
    let payloads = hex_lines(include_str!("fixtures/bag_v9_plain_radar_scan.hex"));
    assert_eq!(payloads.len(), FRAMES.len());
    for (bytes, k) in payloads.iter().zip(FRAMES) {
        let message = Message::decode("radar_msgs/msg/RadarScan", bytes).unwrap();
        assert_eq!(message.check_usable(), Ok(()));
        assert_eq!(&message.encode().unwrap(), bytes, "frame {k}");
        let Message::RadarScan(scan) = message else {
            unreachable!()
        };
        assert_eq!(scan.header.frame_id, "radar");
        assert_eq!(
            scan.header.stamp,
            Time::from_seconds(100.0 + 0.5 * f64::from(k))
        );
        assert!(scan.returns.len() > 10, "{}", scan.returns.len());
        // Boresight +y of an AGV at (0.5 k, 0) heading +x: every return lies on y = 8 m at a
        // multiple of 0.25 m in x, within 20 m and ±60°.
        let agv_x_m = 0.5 * f64::from(k);
        for r in &scan.returns {
            let bearing = f64::from(r.azimuth) + std::f64::consts::FRAC_PI_2;
            let (x, y) = (
                agv_x_m + f64::from(r.range) * bearing.cos(),
                f64::from(r.range) * bearing.sin(),
            );
            assert!((y - 8.0).abs() < 1e-4, "y {y}");
            assert!(((x / 0.25) - (x / 0.25).round()).abs() < 1e-3, "x {x}");
            assert!(
                r.range <= 20.0 && f64::from(r.azimuth.abs()) <= std::f64::consts::FRAC_PI_3 + 1e-6
            );
            assert_eq!((r.elevation, r.amplitude), (0.0, 20.0));
        }
    }
}

#[test]
fn point_clouds_of_a_rosbags_bag_decode_and_encode_to_the_same_bytes() {
    let payloads = hex_lines(include_str!("fixtures/bag_v9_plain_radar_points.hex"));
    let scans = hex_lines(include_str!("fixtures/bag_v9_plain_radar_scan.hex"));
    for ((bytes, scan), k) in payloads.iter().zip(&scans).zip(FRAMES) {
        let message = Message::decode("sensor_msgs/msg/PointCloud2", bytes).unwrap();
        assert_eq!(message.check_usable(), Ok(()));
        assert_eq!(&message.encode().unwrap(), bytes, "frame {k}");
        let Message::PointCloud2(cloud) = message else {
            unreachable!()
        };
        let scan: RadarScan = cdr::decode(scan).unwrap();
        assert_eq!(cloud.header, scan.header);
        assert_eq!((cloud.height, cloud.width), (1, scan.returns.len() as u32));
        let layout: Vec<_> = cloud
            .fields
            .iter()
            .map(|f| (f.name.as_str(), f.offset, f.datatype, f.count))
            .collect();
        assert_eq!(
            layout,
            [("x", 0, 7, 1), ("y", 4, 7, 1), ("z", 8, 7, 1)],
            "float32 x, y, z"
        );
        assert!(!cloud.is_bigendian && cloud.is_dense);
        assert_eq!((cloud.point_step, cloud.row_step), (12, 12 * cloud.width));
        for point in cloud.data.chunks_exact(12) {
            let y = f32::from_le_bytes(point[4..8].try_into().unwrap());
            assert!((y - 8.0).abs() < 1e-4, "y {y}");
        }
    }
}

fn header(sec: i32, nanosec: u32, frame: &str) -> Header {
    Header {
        stamp: Time { sec, nanosec },
        frame_id: frame.into(),
    }
}

fn tf() -> TFMessage {
    let stamped =
        |parent: &str, child: &str, x: f64, y: f64, rotation: Quaternion| TransformStamped {
            header: header(12, 500, parent),
            child_frame_id: child.into(),
            transform: Transform {
                translation: Vector3 { x, y, z: 0.0 },
                rotation,
            },
        };
    TFMessage {
        transforms: vec![
            stamped(
                "map",
                "odom",
                1.5,
                -2.0,
                Quaternion {
                    x: 0.0,
                    y: 0.0,
                    z: 0.5,
                    w: 0.75,
                },
            ),
            stamped("odom", "base_link", 3.0, 4.0, Quaternion::default()),
        ],
    }
}

fn path() -> Path {
    Path {
        header: header(3, 0, "map"),
        poses: (0..3)
            .map(|k| PoseStamped {
                header: header(1, k, "map"),
                pose: Pose::from_planar(f64::from(k), 0.25, 0.0),
            })
            .collect(),
    }
}

fn markers() -> MarkerArray {
    let delete_all = Marker {
        header: header(7, 250, "map"),
        action: Marker::DELETEALL,
        ..Default::default()
    };
    let line = Marker {
        header: header(7, 250, "map"),
        ns: "targets".into(),
        id: 3,
        marker_type: Marker::LINE_STRIP,
        action: Marker::ADD,
        scale: Vector3 {
            x: 0.05,
            y: 0.0,
            z: 0.0,
        },
        color: ColorRGBA {
            r: 1.0,
            g: 0.5,
            b: 0.25,
            a: 1.0,
        },
        points: vec![Point::planar(0.0, 8.0), Point::planar(30.0, 8.0)],
        colors: vec![ColorRGBA {
            r: 0.0,
            g: 1.0,
            b: 0.0,
            a: 0.5,
        }],
        uv_coordinates: vec![UVCoordinate { u: 0.5, v: 0.25 }],
        text: "wall".into(),
        mesh_file: MeshFile {
            filename: String::new(),
            data: vec![1, 2, 3],
        },
        mesh_use_embedded_materials: true,
        ..Default::default()
    };
    MarkerArray {
        markers: vec![delete_all, line],
    }
}

#[test]
fn viewer_types_encode_to_the_bytes_rosbags_serializes_for_jazzy() {
    let cases: [(&str, Message, &str); 3] = [
        (
            "tf2_msgs/msg/TFMessage",
            tf().into(),
            include_str!("fixtures/tf2_msgs_msg_TFMessage.hex"),
        ),
        (
            "nav_msgs/msg/Path",
            path().into(),
            include_str!("fixtures/nav_msgs_msg_Path.hex"),
        ),
        (
            "visualization_msgs/msg/MarkerArray",
            markers().into(),
            include_str!("fixtures/visualization_msgs_msg_MarkerArray.hex"),
        ),
    ];
    for (name, message, golden) in cases {
        let golden = &hex_lines(golden)[0];
        assert_eq!(message.type_name(), name);
        assert_eq!(&message.encode().unwrap(), golden, "{name}");
        assert_eq!(Message::decode(name, golden).unwrap(), message, "{name}");
        assert_eq!(message.check_usable(), Ok(()), "{name}");
    }
    assert_eq!(
        tf().stamp(),
        Time {
            sec: 12,
            nanosec: 500
        }
    );
    assert_eq!(
        Message::from(markers()).stamp(),
        Time {
            sec: 7,
            nanosec: 250
        }
    );
}

#[test]
fn schemas_are_the_texts_rosbags_writes() {
    let cases = [
        (
            "radar_msgs/msg/RadarScan",
            include_str!("fixtures/radar_msgs_msg_RadarScan.ros2msg"),
        ),
        (
            "sensor_msgs/msg/PointCloud2",
            include_str!("fixtures/sensor_msgs_msg_PointCloud2.ros2msg"),
        ),
        (
            "tf2_msgs/msg/TFMessage",
            include_str!("fixtures/tf2_msgs_msg_TFMessage.ros2msg"),
        ),
        (
            "nav_msgs/msg/Path",
            include_str!("fixtures/nav_msgs_msg_Path.ros2msg"),
        ),
        (
            "visualization_msgs/msg/MarkerArray",
            include_str!("fixtures/visualization_msgs_msg_MarkerArray.ros2msg"),
        ),
    ];
    for (name, golden) in cases {
        assert_eq!(schema::ros2msg(name).unwrap(), golden, "{name}");
    }
}
