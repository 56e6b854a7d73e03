//! A processes-mode graph on loopback among hostile neighbours: another process floods every
//! topic with malformed payloads, and node processes are killed with SIGKILL mid-run. The graph
//! drops and counts what it cannot use (summary.json `dropped`, gathered over `/diagnostics`),
//! respawns what may respawn, and names what may not.

mod common;
use common::*;
use std::io::Read;
use std::process::{Child, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};
use zenoh::Wait;

fn launch(launch_file: &str, out: &std::path::Path, extra: &[&str]) -> Child {
    let mut command = nrslam();
    command
        .args(["launch", launch_file, "frames:=40", "--mode", "processes"])
        .args(["--rate", "8", "--seed", "3", "--out"])
        .arg(out)
        .args(extra)
        .stdout(Stdio::null())
        .stderr(Stdio::piped());
    command.spawn().expect("nrslam launch starts")
}

fn finish(mut child: Child, within: Duration) -> (std::process::ExitStatus, String) {
    let started = Instant::now();
    loop {
        if let Some(status) = child.try_wait().unwrap() {
            let mut stderr = String::new();
            child
                .stderr
                .take()
                .unwrap()
                .read_to_string(&mut stderr)
                .unwrap();
            return (status, stderr);
        }
        if started.elapsed() > within {
            let _ = child.kill();
            panic!("nrslam launch still running after {within:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn summary(out: &std::path::Path) -> serde_json::Map<String, serde_json::Value> {
    let text = read(&out.join("summary.json"));
    match serde_json::from_str(&text).unwrap() {
        serde_json::Value::Object(map) => map,
        other => panic!("summary.json is not an object: {other}"),
    }
}

/// Payloads no decoder may accept: a foreign encapsulation, and CDR whose first stamp has
/// nanoseconds ≥ 10⁹ (every type starts with one) or that ends inside it. Never an empty
/// payload: that is the end-of-stream mark, which the protocol cannot authenticate (see
/// docs/security.md for access control).
fn malformed(k: u64) -> Vec<u8> {
    let n = (k % 64) as usize;
    if k.is_multiple_of(3) {
        let mut bytes = vec![0x42, 0x13, 0, 0];
        bytes.extend((0..n).map(|i| (i as u64 * 31 + k) as u8));
        bytes
    } else {
        let mut bytes = vec![0, 1, 0, 0];
        bytes.extend(std::iter::repeat_n(0xff, n));
        bytes
    }
}

#[test]
fn malformed_payloads_on_every_topic_are_dropped_counted_and_change_nothing() {
    let dir = temp();
    let clean = dir.path().join("clean");
    let (status, stderr) = finish(
        launch("launch/paper-ideal.toml", &clean, &[]),
        Duration::from_secs(120),
    );
    assert!(status.success(), "{stderr}");

    let port = free_port();
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let attacked = dir.path().join("attacked");
    let child = launch(
        "launch/paper-ideal.toml",
        &attacked,
        &["--listen", &endpoint],
    );
    let stop = Arc::new(AtomicBool::new(false));
    let sent = Arc::new(AtomicU64::new(0));
    let injector = {
        let (stop, sent) = (stop.clone(), sent.clone());
        std::thread::spawn(move || {
            let mut config = zenoh::Config::default();
            config.insert_json5("mode", "\"client\"").unwrap();
            config
                .insert_json5("scouting/multicast/enabled", "false")
                .unwrap();
            config
                .insert_json5("connect/endpoints", &format!("[\"{endpoint}\"]"))
                .unwrap();
            config.insert_json5("connect/timeout_ms", "20000").unwrap();
            let session = zenoh::open(config).wait().expect("the injector connects");
            let mut k = 0u64;
            while !stop.load(Ordering::SeqCst) {
                for spec in nrslam_msgs::topics::CATALOGUE {
                    let key = nrslam_msgs::topics::key_expr("", spec.name);
                    // Skewed so that every topic gets every kind.
                    session.put(key, malformed(k + k / 7)).wait().unwrap();
                    k += 1;
                }
                sent.store(k, Ordering::SeqCst);
                std::thread::sleep(Duration::from_millis(5));
            }
            let _ = session.close().wait();
        })
    };
    let (status, stderr) = finish(child, Duration::from_secs(120));
    stop.store(true, Ordering::SeqCst);
    injector.join().unwrap();
    assert!(status.success(), "{stderr}");
    assert!(
        sent.load(Ordering::SeqCst) > 1000,
        "{} sent",
        sent.load(Ordering::SeqCst)
    );

    let (mut clean, mut attacked) = (summary(&clean), summary(&attacked));
    let dropped = attacked
        .remove("dropped")
        .expect("summary.json counts the drops");
    assert!(clean.remove("dropped").is_none());
    // Every metric the same as without the attack.
    assert_eq!(attacked, clean);
    let components = dropped.as_object().unwrap();
    let total = |component: &str| -> u64 {
        components
            .get(component)
            .and_then(|topics| topics.as_object())
            .map_or(0, |topics| {
                topics
                    .values()
                    .flat_map(|reasons| reasons.as_object().unwrap().values())
                    .map(|n| n.as_u64().unwrap())
                    .sum()
            })
    };
    // The launcher's own receive path, and node processes reporting over /diagnostics.
    assert!(total("nrslam/launch/receive") > 0, "{dropped}");
    for node in ["association", "mapper", "segmenter", "evaluator"] {
        assert!(
            total(&format!("nrslam/{node}/receive")) > 0,
            "{node}: {dropped}"
        );
    }
    let reasons = serde_json::to_string(&dropped).unwrap();
    assert!(
        reasons.contains("bad_cdr") && reasons.contains("out_of_range"),
        "{reasons}"
    );
}

fn kill_when_running(parent: u32, name: &str) -> Instant {
    let deadline = Instant::now() + Duration::from_secs(60);
    while Instant::now() < deadline {
        if let Some(pid) = node_pid(parent, name) {
            // Let the run get going first.
            std::thread::sleep(Duration::from_millis(1500));
            let status = std::process::Command::new("kill")
                .args(["-9", &pid.to_string()])
                .status()
                .unwrap();
            assert!(status.success());
            return Instant::now();
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    panic!("no process for node {name}");
}

#[cfg(target_os = "linux")]
#[test]
fn a_killed_respawnable_node_comes_back_and_a_killed_other_one_stops_the_graph_by_name() {
    let dir = temp();
    let text = read(&root().join("launch/paper-ideal.toml")).replace(
        "name = \"segmenter\"\nkind = \"segmenter\"\n",
        "name = \"segmenter\"\nkind = \"segmenter\"\nrespawn = true\nrespawn_delay_s = 0.2\n",
    );
    assert!(text.contains("respawn = true"));
    // Written elsewhere, so the scene is named explicitly.
    let file = dir.path().join("respawn.toml");
    std::fs::write(&file, text).unwrap();
    let file_arg = file.to_string_lossy().into_owned();
    let scene = format!("scene:={}", root().join("config/hall.toml").display());

    let out = dir.path().join("respawn");
    let child = launch(&file_arg, &out, &[&scene]);
    kill_when_running(child.id(), "segmenter");
    let (status, stderr) = finish(child, Duration::from_secs(120));
    assert!(status.success(), "{stderr}");
    assert!(stderr.contains("segmenter"), "{stderr}");
    let restarts = summary(&out).remove("restarts").expect("restarts reported");
    assert_eq!(restarts, serde_json::json!({ "segmenter": 1 }));

    let out = dir.path().join("fatal");
    let child = launch(&file_arg, &out, &[&scene]);
    let killed = kill_when_running(child.id(), "mapper");
    let (status, stderr) = finish(child, Duration::from_secs(60));
    assert!(!status.success());
    assert!(
        killed.elapsed() < Duration::from_secs(2),
        "{:?}",
        killed.elapsed()
    );
    assert!(
        stderr.contains("error: node 'mapper' exited with signal: 9"),
        "{stderr}"
    );
}
