//! ROS 2 → nrslam: a native run's sensor data, recorded, converted to standard ROS 2 messages
//! and published by ros2-client's zenoh backend into `launch/standard-input.toml
//! source:=external`, which must then map as well as the native run did.

mod common;

use std::path::Path;
use std::time::{Duration, Instant};

use common::msgs::{
    self, Detections, Header, Odometry, PointCloud2, PointField, PoseStamped, TargetSet, FLOAT32,
};
use common::{context, free_port, Nrslam};
use ros2_client::zenoh::{Context, Node, Publisher, Subscription};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
use serde::Serialize;

/// Radar frames of the native run (0.5 s apart: 60 s of the hall's lap of 294 frames).
const FRAMES: u32 = 120;
/// Longest any one run may take.
const RUN_LIMIT: Duration = Duration::from_secs(300);
/// In the control (nothing answers): the pause after each published frame, so that nrslam
/// listens through a play of some seconds (120 × 40 ms), within its 20 s wait for a first
/// message.
const FRAME_PAUSE: Duration = Duration::from_millis(40);
/// Longest the player waits for nrslam's /slam/pose of a frame it published.
const FRAME_LIMIT: Duration = Duration::from_secs(60);
/// Frames the player may publish ahead of nrslam's last /slam/pose.
const FRAMES_IN_FLIGHT: usize = 4;

/// The four inputs of standard-input's external source, with their ROS types.
const INPUTS: [(&str, &str); 4] = [
    ("/radar/points", "sensor_msgs/msg/PointCloud2"),
    ("/odom", "nav_msgs/msg/Odometry"),
    ("/ground_truth/targets", "nrslam_msgs/msg/TargetSet"),
    ("/ground_truth/pose", "geometry_msgs/msg/PoseStamped"),
];

/// A native run's recorded inputs, decoded.
struct Recorded {
    /// In log order, as the graph saw them.
    messages: Vec<Input>,
    /// The radar's boresight relative to the vehicle (rad): one for the whole run.
    boresight_rad: f64,
    /// The detections' range and angle standard deviations: one pair for the whole run.
    range_std_m: f64,
    angle_std_rad: f64,
    frames: usize,
}

enum Input {
    Cloud(PointCloud2),
    Odom(Box<Odometry>),
    Targets(TargetSet),
    Pose(PoseStamped),
}

/// The detections as a PointCloud2 in the sensor frame (x along the boresight, y to its left):
/// float32 x, y, z = 0 and `power` (dB), one row, little-endian, as a radar driver publishes.
fn point_cloud(d: &Detections) -> PointCloud2 {
    let field = |name: &str, offset: u32| PointField {
        name: name.to_owned(),
        offset,
        datatype: FLOAT32,
        count: 1,
    };
    let mut data = Vec::with_capacity(16 * d.detections.len());
    for det in &d.detections {
        let (sin, cos) = det.angle_rad.sin_cos();
        for v in [det.range_m * cos, det.range_m * sin, 0.0, det.power_db] {
            data.extend_from_slice(&(v as f32).to_le_bytes());
        }
    }
    PointCloud2 {
        header: Header {
            stamp: d.header.stamp,
            frame_id: d.header.frame_id.clone(),
        },
        height: 1,
        width: d.detections.len() as u32,
        fields: vec![
            field("x", 0),
            field("y", 4),
            field("z", 8),
            field("power", 12),
        ],
        is_bigendian: false,
        point_step: 16,
        row_step: 16 * d.detections.len() as u32,
        data,
        is_dense: true,
    }
}

fn read_native(bag: &Path) -> Recorded {
    let (bag, types) = common::read_bag(bag);
    for (topic, ty) in [
        ("/radar/detections", "nrslam_msgs/msg/Detections"),
        ("/odom", "nav_msgs/msg/Odometry"),
        ("/ground_truth/targets", "nrslam_msgs/msg/TargetSet"),
        ("/ground_truth/pose", "geometry_msgs/msg/PoseStamped"),
    ] {
        assert_eq!(
            types.get(topic).map(String::as_str),
            Some(ty),
            "the native bag's {topic}"
        );
    }
    let mut messages = Vec::new();
    let (mut boresights, mut stds) = (Vec::new(), Vec::new());
    let mut frames = 0;
    for m in &bag {
        let decode_error = |e: String| -> ! { panic!("{} in the native bag: {e}", m.topic) };
        let input = match m.topic.as_str() {
            "/radar/detections" => {
                let d: Detections = msgs::from_cdr(&m.data).unwrap_or_else(|e| decode_error(e));
                boresights.push(d.boresight_rad);
                stds.extend(
                    d.detections
                        .iter()
                        .map(|x| (x.range_std_m, x.angle_std_rad)),
                );
                frames += 1;
                Input::Cloud(point_cloud(&d))
            }
            "/odom" => Input::Odom(Box::new(
                msgs::from_cdr(&m.data).unwrap_or_else(|e| decode_error(e)),
            )),
            "/ground_truth/targets" => {
                Input::Targets(msgs::from_cdr(&m.data).unwrap_or_else(|e| decode_error(e)))
            }
            "/ground_truth/pose" => {
                Input::Pose(msgs::from_cdr(&m.data).unwrap_or_else(|e| decode_error(e)))
            }
            _ => continue,
        };
        messages.push(input);
    }
    boresights.dedup();
    stds.sort_by(|a, b| a.partial_cmp(b).unwrap());
    stds.dedup();
    assert_eq!(
        boresights.len(),
        1,
        "the radar's boresight changed: {boresights:?}"
    );
    assert_eq!(stds.len(), 1, "the detections' stds vary: {stds:?}");
    Recorded {
        messages,
        boresight_rad: boresights[0],
        range_std_m: stds[0].0,
        angle_std_rad: stds[0].1,
        frames,
    }
}

struct Player {
    node: Node,
    points: Publisher<PointCloud2>,
    odom: Publisher<Odometry>,
    targets: Publisher<TargetSet>,
    pose: Publisher<PoseStamped>,
}

fn publisher<M: Serialize>(node: &Node, topic: &str, ros_type: &str) -> Publisher<M> {
    let parts: Vec<&str> = ros_type.split('/').collect();
    let topic = node.create_topic(
        &Name::parse(topic).expect("topic name"),
        MessageTypeName::new(parts[0], parts[2]),
        &QosProfile::publisher_default(),
    );
    node.create_publisher(&topic, None)
        .expect("a ros2-client publisher")
}

impl Player {
    fn new(ctx: &Context) -> Player {
        let node = ctx
            .new_node(
                NodeName::new("/", "interop_player").expect("node name"),
                NodeOptions::new()
                    .enable_rosout(false)
                    .start_parameter_services(false),
            )
            .expect("a ros2-client node");
        Player {
            points: publisher(&node, INPUTS[0].0, INPUTS[0].1),
            odom: publisher(&node, INPUTS[1].0, INPUTS[1].1),
            targets: publisher(&node, INPUTS[2].0, INPUTS[2].1),
            pose: publisher(&node, INPUTS[3].0, INPUTS[3].1),
            node,
        }
    }

    /// Waits (at most `limit`) until ros2-client's graph shows a subscription on each input.
    fn wait_for_nrslam(&self, nrslam: &mut Nrslam, limit: Duration) {
        let all = || {
            INPUTS
                .iter()
                .all(|(t, _)| self.node.subscription_count(t) > 0)
        };
        let deadline = Instant::now() + limit;
        while !all() {
            assert!(
                nrslam.is_running(),
                "nrslam exited before subscribing; its log ends:\n{}",
                nrslam.log_tail()
            );
            let missing: Vec<_> = INPUTS
                .iter()
                .filter(|(t, _)| self.node.subscription_count(t) == 0)
                .collect();
            assert!(
                Instant::now() < deadline,
                "ros2-client saw no subscription on {missing:?} after {limit:?}; nrslam's log \
                 ends:\n{}",
                nrslam.log_tail()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Publishes the recorded inputs in order. With `lockstep` (a ros2-client subscription to
    /// nrslam's /slam/pose, and nrslam for failure messages) at most FRAMES_IN_FLIGHT frames are
    /// sent ahead of the last /slam/pose nrslam published: the inbound graph queues each topic
    /// with a bounded depth (64, msgs/src/topics.rs) and drops what overflows, so the player must
    /// not outrun it, however slow the build; and it orders the external topics by stamp, so a
    /// frame may wait for the next one's messages (a window of one frame would deadlock).
    /// Without, it pauses FRAME_PAUSE after each frame.
    fn play(
        &self,
        recorded: &Recorded,
        mut lockstep: Option<(&Subscription<PoseStamped>, &mut Nrslam)>,
    ) {
        let mut in_flight = std::collections::VecDeque::new();
        let mut latest_pose: Option<msgs::Time> = None;
        for input in &recorded.messages {
            let result = match input {
                Input::Cloud(c) => self.points.publish(c.clone()).map_err(|e| e.to_string()),
                Input::Odom(o) => self.odom.publish((**o).clone()).map_err(|e| e.to_string()),
                Input::Targets(t) => self.targets.publish(t.clone()).map_err(|e| e.to_string()),
                Input::Pose(p) => self.pose.publish(p.clone()).map_err(|e| e.to_string()),
            };
            result.unwrap_or_else(|e| panic!("ros2-client could not publish: {e}"));
            let Input::Cloud(cloud) = input else { continue };
            let Some((poses, nrslam)) = lockstep.as_mut() else {
                std::thread::sleep(FRAME_PAUSE);
                continue;
            };
            in_flight.push_back(cloud.header.stamp);
            if in_flight.len() <= FRAMES_IN_FLIGHT {
                continue;
            }
            let stamp = in_flight.pop_front().unwrap();
            let deadline = Instant::now() + FRAME_LIMIT;
            while latest_pose.is_none_or(|t| t < stamp) {
                match poses.try_take() {
                    Ok(Some((pose, _))) => latest_pose = Some(pose.header.stamp),
                    Ok(None) => std::thread::sleep(Duration::from_millis(2)),
                    Err(e) => panic!(
                        "ros2-client could not take nrslam's /slam/pose (waiting for the frame \
                         at {stamp:?}): {e:?}; nrslam running: {}, its log ends:\n{}",
                        nrslam.is_running(),
                        nrslam.log_tail()
                    ),
                }
                assert!(
                    Instant::now() < deadline,
                    "no /slam/pose from nrslam for the frame at {stamp:?} within \
                     {FRAME_LIMIT:?}; nrslam running: {}, its log ends:\n{}",
                    nrslam.is_running(),
                    nrslam.log_tail()
                );
            }
        }
    }

    /// A subscription to nrslam's /slam/pose (geometry_msgs/PoseStamped) on the player's node.
    fn slam_poses(&self) -> Subscription<PoseStamped> {
        let topic = self.node.create_topic(
            &Name::parse("/slam/pose").expect("topic name"),
            MessageTypeName::new("geometry_msgs", "PoseStamped"),
            &QosProfile::default(),
        );
        self.node
            .create_subscription(&topic, None)
            .expect("a ros2-client subscription")
    }
}

/// `nrslam launch launch/standard-input.toml source:=external ...` on ROS domain `domain`,
/// listening on `port`, its sensor adapter set to the native radar's mounting and noise.
fn inbound_args(domain: u16, port: u16, recorded: &Recorded, out: &Path) -> Vec<String> {
    vec![
        "launch".into(),
        "launch/standard-input.toml".into(),
        "source:=external".into(),
        "input:=point_cloud2".into(),
        "evaluate:=true".into(),
        // The native graph's tracking: scan matching on top of the odometry (paper-ideal's
        // association default), not standard-input's default of exact poses.
        "scan_matching:=true".into(),
        // The simulated radar sits at the vehicle's centre, looking along its boresight.
        "x_m:=0".into(),
        "y_m:=0".into(),
        format!("yaw_rad:={}", recorded.boresight_rad),
        format!(
            "sensor_adapter_external.range_std_m:={}",
            recorded.range_std_m
        ),
        format!(
            "sensor_adapter_external.angle_std_rad:={}",
            recorded.angle_std_rad
        ),
        "sensor_adapter_external.power_field:=\"power\"".into(),
        "--ros-domain-id".into(),
        domain.to_string(),
        "--listen".into(),
        format!("tcp/127.0.0.1:{port}"),
        "--external-idle-s".into(),
        "3".into(),
        "--out".into(),
        out.display().to_string(),
    ]
}

/// Largest |inbound − native| of the final ET-GOSPA accepted. The two runs see the same
/// detections but for float32 rounding of the points (≤ 2e-6 m at the hall's ranges) and of
/// the power: measured, the two ET-GOSPA agree to every printed digit (42.501419869702 both, at
/// the commit that added this test) and the SLAM positions to 1e-7 m. The smallest real change
/// tried, the native run without its last frame (frames:=119), moves ET-GOSPA by 0.0019;
/// another seed, by 2 to 13. 1e-3 is above rounding and below the loss of one frame.
const ETGOSPA_TOLERANCE: f64 = 1e-3;
/// Largest |inbound − native| of the pose RMSE accepted (m): 1e-7 m measured, 0.06 m the RMSE
/// itself.
const POSE_RMSE_TOLERANCE_M: f64 = 1e-4;

fn number(summary: &serde_json::Value, key: &str, which: &str) -> f64 {
    summary[key]
        .as_f64()
        .unwrap_or_else(|| panic!("no {key} in the {which} summary: {summary}"))
}

#[test]
fn ros2_client_inputs_map_as_well_as_the_native_run() {
    let _serial = common::serial();
    let tmp = tempfile::tempdir().expect("temporary folder");
    let (native_out, bag) = (tmp.path().join("native"), tmp.path().join("bag"));

    // 1. The native run, recorded.
    let args: Vec<String> = [
        "launch",
        "launch/paper-ideal.toml",
        &format!("frames:={FRAMES}"),
        // The paper's ΔR = 0.1 m condition: the sensor adapter attaches one range std > 0 to
        // every detection, and this makes it the one the native detections carry.
        "range_std_m:=0.1",
        "--record",
        &bag.display().to_string(),
        "--out",
        &native_out.display().to_string(),
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    Nrslam::spawn(&args, tmp.path().join("native.log")).wait_success(RUN_LIMIT);
    let native = common::summary(&native_out);
    let recorded = read_native(&bag);
    assert_eq!(recorded.frames, FRAMES as usize, "native radar frames");

    // 2. The same inputs through ros2-client into the external source, ROS domain 0.
    let port = free_port();
    let ctx = context(0, port);
    let player = Player::new(&ctx);
    let slam_poses = player.slam_poses();
    let inbound_out = tmp.path().join("inbound");
    let mut nrslam = Nrslam::spawn(
        &inbound_args(0, port, &recorded, &inbound_out),
        tmp.path().join("inbound.log"),
    );
    player.wait_for_nrslam(&mut nrslam, Duration::from_secs(60));
    let started = Instant::now();
    player.play(&recorded, Some((&slam_poses, &mut nrslam)));
    eprintln!(
        "published {} messages ({} frames) in {:.1} s",
        recorded.messages.len(),
        recorded.frames,
        started.elapsed().as_secs_f64()
    );
    nrslam.wait_success(RUN_LIMIT);
    let inbound = common::summary(&inbound_out);
    eprintln!("native summary: {native}\ninbound summary: {inbound}");
    let dropped = inbound.get("dropped").cloned().unwrap_or_default();
    assert!(
        dropped.is_null() || dropped.as_object().is_some_and(|d| d.is_empty()),
        "the inbound run dropped samples: {dropped}"
    );
    for key in ["keyframes", "metric_steps", "estimated_targets"] {
        assert_eq!(
            inbound[key], native[key],
            "{key}: inbound (ros2-client) vs native"
        );
    }
    let (native_etgospa, inbound_etgospa) = (
        number(&native, "etgospa", "native"),
        number(&inbound, "etgospa", "inbound"),
    );
    eprintln!(
        "ET-GOSPA native {native_etgospa}, inbound {inbound_etgospa}, |Δ| {:e}",
        (inbound_etgospa - native_etgospa).abs()
    );
    assert!(
        (inbound_etgospa - native_etgospa).abs() <= ETGOSPA_TOLERANCE,
        "ET-GOSPA through ros2-client {inbound_etgospa} vs native {native_etgospa}: differ by \
         more than {ETGOSPA_TOLERANCE}"
    );
    let (native_rmse, inbound_rmse) = (
        number(&native, "pose_rmse_m", "native"),
        number(&inbound, "pose_rmse_m", "inbound"),
    );
    assert!(
        (inbound_rmse - native_rmse).abs() <= POSE_RMSE_TOLERANCE_M,
        "pose RMSE through ros2-client {inbound_rmse} m vs native {native_rmse} m"
    );
    drop((slam_poses, player, ctx));

    // 3. Control: nrslam on domain 1 gets nothing of what ros2-client publishes on domain 0.
    let port = free_port();
    let ctx = context(0, port);
    let player = Player::new(&ctx);
    let other_out = tmp.path().join("other-domain");
    let mut args = inbound_args(1, port, &recorded, &other_out);
    // How long nrslam waits for a first external message: longer than the play (~5 s).
    args.extend(["--start-timeout-s".into(), "20".into()]);
    let mut nrslam = Nrslam::spawn(&args, tmp.path().join("other-domain.log"));
    common::wait_listening(port, &mut nrslam, Duration::from_secs(60));
    assert!(
        common::wait_until(Duration::from_secs(10), || common::connected_peers(&ctx)
            > 0),
        "ros2-client never connected to nrslam: the control would be vacuous"
    );
    player.play(&recorded, None);
    assert!(
        nrslam.is_running(),
        "nrslam on domain 1 ended while ros2-client was still publishing on domain 0; its log \
         ends:\n{}",
        nrslam.log_tail()
    );
    assert_eq!(
        INPUTS
            .iter()
            .map(|(t, _)| player.node.subscription_count(t))
            .sum::<usize>(),
        0,
        "ros2-client on domain 0 sees subscriptions of nrslam's domain 1"
    );
    let status = nrslam.wait(RUN_LIMIT);
    let log = nrslam.log_tail();
    assert!(
        !status.success() && log.contains("no message on the external topics"),
        "nrslam on domain 1 should have given up for lack of input ({status}); its log \
         ends:\n{log}"
    );
    let keyframes = std::fs::read_to_string(other_out.join("summary.json"))
        .ok()
        .and_then(|s| serde_json::from_str::<serde_json::Value>(&s).ok())
        .and_then(|s| s["keyframes"].as_u64())
        .unwrap_or(0);
    assert_eq!(keyframes, 0, "nrslam on domain 1 made keyframes");
}
