//! What the interop tests share: the nrslam binary and its runs, loopback ports, ros2-client
//! contexts on zenoh, nrslam's bags.

#![allow(dead_code)] // each test binary uses part of this module

pub mod msgs;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus};
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

use ros2_client::zenoh::{Context, ContextOptions};

/// The nrslam binary: `$NRSLAM_BIN`, else `../../target/release/nrslam` from this crate.
pub fn nrslam_bin() -> PathBuf {
    let bin = std::env::var_os("NRSLAM_BIN")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../target/release/nrslam")
        });
    assert!(
        bin.is_file(),
        "no nrslam binary at {} (build it with `cargo build --release` at the repository root, \
         or point NRSLAM_BIN at one)",
        bin.display()
    );
    bin
}

/// The repository root (launch files are given relative to it).
pub fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../..")
        .canonicalize()
        .expect("repository root")
}

/// One nrslam run at a time: each test spawns a whole graph and the machine may have 2 cores.
pub fn serial() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A loopback TCP port that was free a moment ago.
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("bind a loopback port")
        .port()
}

/// A spawned nrslam, killed if still running when dropped (a failing test leaves nothing
/// behind). Its stdout and stderr go to a file of the test's temporary folder, shown on failure.
pub struct Nrslam {
    child: Child,
    log: PathBuf,
    what: String,
}

impl Nrslam {
    pub fn spawn(args: &[String], log: PathBuf) -> Nrslam {
        let stderr = std::fs::File::create(&log).expect("create the nrslam log");
        let child = Command::new(nrslam_bin())
            .args(args)
            .current_dir(repo_root())
            .env("RUST_LOG", "warn")
            .stdout(stderr.try_clone().expect("clone the log file"))
            .stderr(stderr)
            .spawn()
            .expect("spawn nrslam");
        Nrslam {
            child,
            log,
            what: format!("nrslam {}", args.join(" ")),
        }
    }

    /// The end of its log, for failure messages.
    pub fn log_tail(&self) -> String {
        let text = std::fs::read_to_string(&self.log).unwrap_or_default();
        let lines: Vec<&str> = text.lines().collect();
        lines[lines.len().saturating_sub(30)..].join("\n")
    }

    pub fn is_running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    /// Waits at most `limit` for it to exit; panics (after killing it) if it does not, or if it
    /// fails.
    pub fn wait_success(&mut self, limit: Duration) -> ExitStatus {
        let status = self.wait(limit);
        assert!(
            status.success(),
            "{} failed ({status}); its log ends:\n{}",
            self.what,
            self.log_tail()
        );
        status
    }

    /// Waits at most `limit` for it to exit; panics (after killing it) if it does not.
    pub fn wait(&mut self, limit: Duration) -> ExitStatus {
        let deadline = Instant::now() + limit;
        loop {
            if let Some(status) = self.child.try_wait().expect("poll nrslam") {
                return status;
            }
            if Instant::now() > deadline {
                let _ = self.child.kill();
                let _ = self.child.wait();
                panic!(
                    "{} still running after {limit:?}; killed. Its log ends:\n{}",
                    self.what,
                    self.log_tail()
                );
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Nrslam {
    fn drop(&mut self) {
        if matches!(self.child.try_wait(), Ok(None)) {
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Waits until `port` on 127.0.0.1 accepts connections (nrslam listens), at most `limit`.
pub fn wait_listening(port: u16, nrslam: &mut Nrslam, limit: Duration) {
    let deadline = Instant::now() + limit;
    let addr = std::net::SocketAddr::from(([127, 0, 0, 1], port));
    while std::net::TcpStream::connect_timeout(&addr, Duration::from_millis(200)).is_err() {
        assert!(
            nrslam.is_running(),
            "nrslam exited before listening on {port}; its log ends:\n{}",
            nrslam.log_tail()
        );
        assert!(
            Instant::now() < deadline,
            "nrslam not listening on 127.0.0.1:{port} after {limit:?}; its log ends:\n{}",
            nrslam.log_tail()
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A ros2-client context on zenoh in ROS domain `domain`: a peer that connects to nrslam's
/// `tcp/127.0.0.1:port` (retrying every 100–500 ms until nrslam listens, so the context may be
/// made before nrslam starts and miss nothing), listens nowhere, scouts nothing.
pub fn context(domain: u16, port: u16) -> Context {
    let mut config = zenoh::Config::default();
    for (key, value) in [
        ("mode", "\"peer\"".to_owned()),
        ("scouting/multicast/enabled", "false".to_owned()),
        ("listen/endpoints", "[]".to_owned()),
        ("connect/endpoints", format!("[\"tcp/127.0.0.1:{port}\"]")),
        (
            "connect/retry",
            "{period_init_ms: 100, period_max_ms: 500, period_increase_factor: 2}".to_owned(),
        ),
    ] {
        config
            .insert_json5(key, &value)
            .unwrap_or_else(|e| panic!("zenoh config {key}={value}: {e}"));
    }
    Context::with_options(ContextOptions::new().domain_id(domain).zenoh_config(config))
        .expect("open a ros2-client zenoh context")
}

/// Whether the context's session has a transport to another zenoh session (nrslam's): the proof
/// that a test which sees nothing was connected all along.
pub fn connected_peers(ctx: &Context) -> usize {
    use zenoh::Wait;
    ctx.session().info().peers_zid().wait().count()
}

/// The run's summary.json.
pub fn summary(out: &Path) -> serde_json::Value {
    let path = out.join("summary.json");
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{} is not JSON: {e}", path.display()))
}

/// One message of a bag: topic, log time (ns), CDR payload.
pub struct BagMessage {
    pub topic: String,
    pub log_time_ns: u64,
    pub data: Vec<u8>,
}

/// Every message of an nrslam bag (a rosbag2 folder: metadata.yaml and one MCAP file), in log
/// order, with the type of each topic as its MCAP schema names it.
pub fn read_bag(dir: &Path) -> (Vec<BagMessage>, BTreeMap<String, String>) {
    assert!(
        dir.join("metadata.yaml").is_file(),
        "{} has no metadata.yaml",
        dir.display()
    );
    let mcaps: Vec<PathBuf> = std::fs::read_dir(dir)
        .expect("read the bag folder")
        .map(|e| e.expect("bag folder entry").path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    assert_eq!(
        mcaps.len(),
        1,
        "expected one MCAP file in {}, found {mcaps:?}",
        dir.display()
    );
    let bytes = std::fs::read(&mcaps[0]).expect("read the MCAP file");
    let mut messages = Vec::new();
    let mut types = BTreeMap::new();
    for message in mcap::MessageStream::new(&bytes).expect("an MCAP file") {
        let message = message.expect("an MCAP message");
        let schema = message
            .channel
            .schema
            .as_ref()
            .map(|s| s.name.clone())
            .unwrap_or_default();
        types.insert(message.channel.topic.clone(), schema);
        messages.push(BagMessage {
            topic: message.channel.topic.clone(),
            log_time_ns: message.log_time,
            data: message.data.into_owned(),
        });
    }
    messages.sort_by_key(|m| m.log_time_ns); // stable: equal times keep the file's order
    (messages, types)
}

/// `pkg/msg/Type` → `pkg::msg::dds_::Type_` (rmw_zenoh's type names, as the graph shows them).
pub fn dds_type(ros_type: &str) -> String {
    let parts: Vec<&str> = ros_type.split('/').collect();
    assert_eq!(parts.len(), 3, "not a pkg/msg/Type name: {ros_type}");
    format!("{}::{}::dds_::{}_", parts[0], parts[1], parts[2])
}

/// Polls `done` every 50 ms until it holds or `limit` passes; returns whether it held.
pub fn wait_until(limit: Duration, mut done: impl FnMut() -> bool) -> bool {
    let deadline = Instant::now() + limit;
    loop {
        if done() {
            return true;
        }
        if Instant::now() > deadline {
            return false;
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}
