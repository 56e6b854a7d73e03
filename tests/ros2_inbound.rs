//! ROS 2 publishers feeding nrslam (issue 42, inbound): `launch/standard-input.toml
//! source:=external` takes /radar/points and /odom from a zenoh session that publishes as an
//! rmw_zenoh node would (rmw_zenoh's key expressions with the type hash, the 33-byte attachment;
//! Odometry under the all-zero placeholder hash that the `ros2-client` crate sends for types it
//! has no hash for), and builds a map; in another ROS domain it hears nothing.
//!
//! The sequence is the fixture bag v9_plain (tests/fixtures/ros2/bags): 20 PointCloud2 scans of
//! a wall and the vehicle's poses, each pose sent as the Odometry a ROS 2 driver would publish.

mod common;

use common::*;
use nrslam_msgs::{Header, Message, TFMessage, Transform, TransformStamped};
use nrslam_runtime::bag::{Bag, ReadMode};
use nrslam_runtime::rmw_zenoh;
use std::path::Path;
use std::process::{Child, Stdio};
use std::time::{Duration, Instant};
use zenoh::Wait;

const POINTS_TYPE: &str = "sensor_msgs/msg/PointCloud2";

/// How the test's driver publishes the vehicle pose.
#[derive(Clone, Copy, PartialEq)]
enum PoseAs {
    /// nav_msgs/msg/Odometry on /odom (zero placeholder hash, as ros2-client sends it).
    Odometry,
    /// The odom → base_link transform on /tf (tf2_msgs/msg/TFMessage, real hash), beside a
    /// map → odom one the adapter must ignore.
    Tf,
}

impl PoseAs {
    fn topic(self) -> &'static str {
        match self {
            PoseAs::Odometry => "/odom",
            PoseAs::Tf => "/tf",
        }
    }
}

/// (topic, CDR) of the fixture's scans and poses (as odometry or /tf), in stamp order (a pose
/// before the scan of its stamp, as a driver's odometry would come).
fn sequence(pose_as: PoseAs) -> Vec<(&'static str, Vec<u8>)> {
    let bag = Bag::open(
        &root().join("tests/fixtures/ros2/bags/v9_plain"),
        ReadMode::Strict,
    )
    .unwrap();
    let mut out = Vec::new();
    for message in bag
        .messages_on(&["/radar/points".to_owned(), "/slam/pose".to_owned()])
        .unwrap()
    {
        let message = message.unwrap();
        match message.decode().unwrap() {
            Message::PointCloud2(cloud) => {
                out.push((cloud.header.stamp, 1, "/radar/points", message.data))
            }
            Message::PoseStamped(pose) => {
                let message = match pose_as {
                    PoseAs::Odometry => Message::from(nrslam_sensor_adapter::odometry_of(&pose)),
                    PoseAs::Tf => {
                        let (x, y, yaw) = pose.pose.planar();
                        let transform =
                            |parent: &str, child: &str, t: Transform| TransformStamped {
                                header: Header::new(pose.header.stamp, parent),
                                child_frame_id: child.to_owned(),
                                transform: t,
                            };
                        Message::TFMessage(TFMessage {
                            transforms: vec![
                                transform("map", "odom", Transform::from_planar(0.0, 0.0, 0.0)),
                                transform("odom", "base_link", Transform::from_planar(x, y, yaw)),
                            ],
                        })
                    }
                };
                out.push((
                    pose.header.stamp,
                    0,
                    pose_as.topic(),
                    message.encode().unwrap(),
                ));
            }
            other => panic!("unexpected {}", other.type_name()),
        }
    }
    out.sort_by_key(|(stamp, order, _, _)| (stamp.sec, stamp.nanosec, *order));
    assert_eq!(out.len(), 40);
    out.into_iter().map(|(_, _, t, b)| (t, b)).collect()
}

/// `nrslam launch launch/standard-input.toml source:=external input:=point_cloud2` in ROS domain
/// `domain`, listening on `port`, writing into `out`; stderr into `out/stderr.txt`.
fn launch(domain: u32, port: u16, out: &Path, start_timeout_s: u64, pose_as: PoseAs) -> Child {
    let stderr = std::fs::File::create(out.join("stderr.txt")).unwrap();
    nrslam()
        .args([
            "launch",
            "launch/standard-input.toml",
            "source:=external",
            "input:=point_cloud2",
            "viz:=false",
            if pose_as == PoseAs::Tf {
                "pose:=tf"
            } else {
                "pose:=odom"
            },
            "--ros-domain-id",
            &domain.to_string(),
            "--listen",
            &format!("tcp/127.0.0.1:{port}"),
            "--external-idle-s",
            "2",
            "--start-timeout-s",
            &start_timeout_s.to_string(),
            "--out",
            out.to_str().unwrap(),
        ])
        .stdout(Stdio::null())
        .stderr(stderr)
        .spawn()
        .expect("nrslam launches")
}

/// A session connected to the launcher on `port`, once the launcher listens.
fn connect(port: u16) -> zenoh::Session {
    wait_listening(port, || {});
    zenoh_peer(&[], &[format!("tcp/127.0.0.1:{port}")])
}

/// Waits until the graph's subscription tokens (`MS`) of /radar/points and /odom are seen in
/// `domain`: the subscribers behind them are declared by then.
fn wait_for_subscriptions(session: &zenoh::Session, domain: u32, pose_as: PoseAs) {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        let replies = session
            .liveliness()
            .get(format!("@ros2_lv/{domain}/**"))
            .wait()
            .unwrap();
        let mut tokens = Vec::new();
        while let Ok(reply) = replies.recv() {
            if let Ok(sample) = reply.result() {
                tokens.push(sample.key_expr().as_str().to_owned());
            }
        }
        let subscribed = |topic: &str| {
            tokens
                .iter()
                .any(|t| t.contains("/MS/") && t.contains(topic))
        };
        let pose_token = format!("/{}/", pose_as.topic().replace('/', "%"));
        if subscribed("/%radar%points/") && subscribed(&pose_token) {
            return;
        }
        assert!(
            Instant::now() < deadline,
            "no MS tokens of /radar/points and /odom in domain {domain}: {tokens:?}"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Publishes the sequence in ROS domain 0 as an rmw_zenoh publisher would, plus one scan under
/// another type's hash (to be dropped and counted).
fn publish(session: &zenoh::Session, pose_as: PoseAs) {
    let points_key = rmw_zenoh::key_expr(0, "/radar/points", POINTS_TYPE).unwrap();
    let pose_key = match pose_as {
        PoseAs::Odometry => rmw_zenoh::key_expr_with_hash(
            0,
            "/odom",
            "nav_msgs/msg/Odometry",
            rmw_zenoh::PLACEHOLDER_TYPE_HASH,
        ),
        PoseAs::Tf => rmw_zenoh::key_expr(0, "/tf", "tf2_msgs/msg/TFMessage").unwrap(),
    };
    let wrong_key = rmw_zenoh::key_expr(0, "/radar/points", "nav_msgs/msg/Odometry")
        .unwrap()
        .replace(
            "nav_msgs::msg::dds_::Odometry_",
            "sensor_msgs::msg::dds_::PointCloud2_",
        );
    let gid = [0x42; rmw_zenoh::GID_LEN];
    let mut sequence_number = 0;
    let mut put = |key: &str, bytes: Vec<u8>| {
        sequence_number += 1;
        session
            .put(key.to_owned(), bytes)
            .attachment(rmw_zenoh::attachment(sequence_number, 0, &gid))
            .congestion_control(zenoh::qos::CongestionControl::Block)
            .wait()
            .unwrap();
    };
    for (index, (topic, bytes)) in sequence(pose_as).into_iter().enumerate() {
        if index == 3 {
            put(&wrong_key, bytes.clone());
        }
        put(
            if topic == pose_as.topic() {
                &pose_key
            } else {
                &points_key
            },
            bytes,
        );
        // A sensor's rate, roughly: the samples are not all in flight at once.
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn wait(child: &mut Child, limit: Duration) -> std::process::ExitStatus {
    let deadline = Instant::now() + limit;
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            return status;
        }
        if Instant::now() > deadline {
            let _ = child.kill();
            panic!("the launch did not end within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

#[test]
fn ros2_publishers_in_the_domain_feed_the_graph_with_odometry_or_tf_and_others_are_not_heard() {
    // Domain 0: the graph takes the sequence and maps the wall.
    let summary = inbound_summary(PoseAs::Odometry);
    let keyframes = summary["keyframes"].as_u64().unwrap();
    assert!(keyframes > 0, "no keyframes: {summary}");
    assert!(
        summary["occupied_cells"].as_u64().unwrap_or(0) > 0,
        "{summary}"
    );
    assert_eq!(
        summary["dropped"]["nrslam/launch/external"]["/radar/points"]["type_hash_mismatch"], 1,
        "{summary}"
    );

    // The same poses as odom -> base_link on /tf (with a map -> odom the adapter must skip): the
    // same keyframes and map as with Odometry on /odom.
    let tf = inbound_summary(PoseAs::Tf);
    for field in ["keyframes", "occupied_cells", "estimated_targets"] {
        assert_eq!(tf[field], summary[field], "{field}: {tf} vs {summary}");
    }

    // Domain 1: the same publications (in domain 0) reach nothing, and the run says so.
    let out = temp();
    let port = free_port();
    let mut child = launch(1, port, out.path(), 5, PoseAs::Odometry);
    let session = connect(port);
    wait_for_subscriptions(&session, 1, PoseAs::Odometry);
    publish(&session, PoseAs::Odometry);
    let status = wait(&mut child, Duration::from_secs(60));
    let stderr = read(&out.path().join("stderr.txt"));
    assert!(!status.success(), "domain 1 heard domain 0: {stderr}");
    assert!(
        stderr.contains("no message on the external topics (/radar/points, /odom) within 5 s"),
        "{stderr}"
    );
    assert!(!out.path().join("summary.json").exists());
    let _ = session.close().wait();
}

/// Runs standard-input with the pose published `pose_as` in domain 0; its summary.json.
fn inbound_summary(pose_as: PoseAs) -> serde_json::Value {
    let out = temp();
    let port = free_port();
    let mut child = launch(0, port, out.path(), 60, pose_as);
    let session = connect(port);
    wait_for_subscriptions(&session, 0, pose_as);
    publish(&session, pose_as);
    let status = wait(&mut child, Duration::from_secs(120));
    let stderr = read(&out.path().join("stderr.txt"));
    assert!(status.success(), "launch failed: {stderr}");
    let _ = session.close().wait();
    summary(out.path())
}

#[test]
fn a_processes_launch_in_a_ros_domain_ends_and_matches_the_plain_one() {
    // Each node process speaks rmw_zenoh (the launcher hears only rmw_zenoh keys then), and the
    // streams end through nrslam's end-of-stream key: the run ends, with the same summary.
    let run = |extra: &[&str]| {
        let out = temp();
        let mut args = vec![
            "launch",
            "launch/paper-ideal.toml",
            "frames:=20",
            "--mode",
            "processes",
            "--out",
            out.path().to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        run_ok(&args);
        read(&out.path().join("summary.json"))
    };
    let ros = run(&["--ros-domain-id", "7"]);
    assert!(ros.contains("\"frames\": 20"), "{ros}");
    assert_eq!(ros, run(&[]));
}
