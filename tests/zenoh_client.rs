//! An outside zenoh client, in this test process, receives the map and pose topics of a running
//! `nrslam launch`, decoding them as documented (key = topic name without its leading '/',
//! payload = ROS 2 CDR).

mod common;
use common::*;
use nrslam_msgs::{Message, OccupancyGrid, PoseStamped};
use std::sync::mpsc;
use std::time::Duration;
use zenoh::Wait;

/// Samples as (key, payload).
type Samples = mpsc::Receiver<(String, Vec<u8>)>;

fn subscribe(session: &zenoh::Session) -> (Vec<zenoh::pubsub::Subscriber<()>>, Samples) {
    let (sender, receiver) = mpsc::channel();
    let subscribers = ["map", "slam/pose"]
        .into_iter()
        .map(|key| {
            let sender = sender.clone();
            session
                .declare_subscriber(key)
                .callback(move |sample| {
                    let _ = sender.send((
                        sample.key_expr().as_str().to_owned(),
                        sample.payload().to_bytes().into_owned(),
                    ));
                })
                .wait()
                .unwrap()
        })
        .collect();
    (subscribers, receiver)
}

/// Collects until the pose stream ends (empty payload) or 60 s pass; returns (maps, poses).
fn collect(receiver: &Samples) -> (Vec<OccupancyGrid>, Vec<PoseStamped>) {
    let (mut maps, mut poses) = (Vec::new(), Vec::new());
    while let Ok((key, bytes)) = receiver.recv_timeout(Duration::from_secs(60)) {
        if bytes.is_empty() {
            if key == "slam/pose" {
                break;
            }
            continue;
        }
        match key.as_str() {
            "map" => maps.push(
                nrslam_msgs::cdr::decode::<OccupancyGrid>(&bytes)
                    .expect("map decodes as nav_msgs/OccupancyGrid"),
            ),
            "slam/pose" => {
                match Message::decode("geometry_msgs/msg/PoseStamped", &bytes).unwrap() {
                    Message::PoseStamped(p) => poses.push(p),
                    other => panic!("unexpected {other:?}"),
                }
            }
            _ => {}
        }
    }
    (maps, poses)
}

#[test]
fn client_listening_where_launch_connects_receives_every_pose() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let session = zenoh_peer(std::slice::from_ref(&endpoint), &[]);
    let (_subscribers, receiver) = subscribe(&session);
    let dir = temp();
    let output = run(&[
        "launch",
        "launch/paper-ideal.toml",
        "frames:=30",
        "--connect",
        &endpoint,
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let (maps, poses) = collect(&receiver);
    assert_eq!(poses.len(), 30, "every SLAM pose arrives");
    assert!(poses
        .windows(2)
        .all(|w| w[0].header.stamp < w[1].header.stamp));
    assert!(!maps.is_empty());
    let map = maps.last().unwrap();
    assert_eq!(map.header.frame_id, "map");
    assert_eq!(map.data.len(), (map.info.width * map.info.height) as usize);
    assert!(
        map.data.iter().any(|&v| v > 50),
        "the map has occupied cells"
    );
}

#[test]
fn client_connecting_to_launch_listen_endpoint_receives_map_and_pose() {
    let endpoint = format!("tcp/127.0.0.1:{}", free_port());
    let dir = temp();
    let mut child = nrslam()
        .args([
            "launch",
            "launch/paper-ideal.toml",
            "frames:=40",
            "--rate",
            "4",
            "--listen",
            &endpoint,
            "--out",
            dir.path().to_str().unwrap(),
        ])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let session = zenoh_peer(&[], std::slice::from_ref(&endpoint));
    let (_subscribers, receiver) = subscribe(&session);
    let (maps, poses) = collect(&receiver);
    assert!(child.wait().unwrap().success());
    assert!(poses.len() >= 10, "only {} poses arrived", poses.len());
    assert!(!maps.is_empty(), "no map arrived");
    assert!(poses
        .windows(2)
        .all(|w| w[0].header.stamp < w[1].header.stamp));
}
