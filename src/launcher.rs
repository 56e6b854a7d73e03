//! `nrslam launch` and `nrslam run`: a graph in one process or one process per node, supervised.

use crate::flags::{self, Real, Whole};
use crate::registry;
use crate::report::{Reporter, REPORTED};
use crate::TransportArgs;
use anyhow::{anyhow, bail, Context, Result};
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use nrslam_msgs::{topics, Message};
use nrslam_runtime::bag::{self, BagWriter, WriterOptions};
use nrslam_runtime::compose::{anyhow_free, Graph, Observer};
use nrslam_runtime::launch::{Launch, Mode, NodeDecl};
use nrslam_runtime::receive::{Delivery, Inbox};
use nrslam_runtime::supervisor::{Event, ProcessSpec, RestartPolicy, Supervisor};
use nrslam_runtime::transport::{
    self, KeyStyle, Pacer, RosNode, SessionMode, TopicPublisher, TransportConfig,
};
use nrslam_runtime::{Node, NodeContext};
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// `nrslam launch`.
#[derive(Args, Debug)]
pub struct LaunchArgs {
    /// Launch file (TOML), e.g. launch/paper-ideal.toml.
    pub file: PathBuf,
    /// Launch arguments as name:=value, e.g. range_std_m:=0.1 angle_std_deg:=5, and node
    /// parameters as node.param:=value (nested: node.table.key:=value; the value is read as
    /// TOML, e.g. association.scan_matching:=false mapper.resolution_m:=0.2). See docs/launch.md.
    #[arg(value_name = "NAME:=VALUE")]
    pub assignments: Vec<String>,
    /// Run seed: every random stream of every node derives from it (0 to 2^64 − 1).
    #[arg(long, default_value_t = 1, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: u64,
    /// Output folder (created): summary.json, metrics.csv, map.png, segments.png, run.json.
    /// Default: out/<launch file name>.
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// in-process: all nodes in this process; processes: one OS process per node over zenoh.
    /// Default: the launch file's mode.
    #[arg(long, value_name = "MODE")]
    pub mode: Option<Mode>,
    /// Real-time factor R: simulated seconds per wall-clock second (2 = twice real time), from
    /// 1e-6 to 1e6. 0 (default): as fast as the nodes go. Nothing is dropped either way.
    #[arg(
        long,
        value_name = "R",
        default_value_t = 0.0,
        value_parser = flags::RATE.parser(),
        allow_hyphen_values = true
    )]
    pub rate: f64,
    /// How long node processes may take to come up, in seconds, 1 to 604800 (a week)
    /// (processes mode).
    #[arg(long, value_name = "SECONDS", default_value_t = 30, value_parser = flags::TIMEOUT_S.parser::<u64>(), allow_hyphen_values = true)]
    pub start_timeout_s: u64,
    /// Record the run into this new rosbag2 folder (metadata.yaml + MCAP, log times = simulated
    /// clock); `launch/replay.toml bag:=DIR` replays it.
    #[arg(long, value_name = "DIR")]
    pub record: Option<PathBuf>,
    /// With --record: topics to record (default: every topic the launch publishes).
    #[arg(long, value_name = "TOPIC", num_args = 1..)]
    pub record_topics: Vec<String>,
    #[command(flatten)]
    pub chunk: crate::bag::ChunkArgs,
    /// With --record: chunk compression and file splitting, as `nrslam bag record`.
    #[command(flatten)]
    pub storage: crate::bag::StorageArgs,
    /// With --listen/--connect: publish the mirrored topics as rmw_zenoh does in this ROS domain
    /// (key `<domain>/<topic>/<type>/<RIHS01 hash>` plus rmw_zenoh's attachment), so ROS 2 nodes on
    /// rmw_zenoh receive them without a bridge (in-process mode). 0 to 232, ROS 2's range.
    #[arg(long, value_name = "DOMAIN_ID", value_parser = ROS_DOMAIN_ID.parser::<u32>(), allow_hyphen_values = true)]
    pub ros_domain_id: Option<u32>,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// `nrslam run`.
#[derive(Args, Debug)]
pub struct RunArgs {
    /// Node kind: radar, estimator, association, mapper, segmenter, evaluator.
    pub kind: String,
    /// The node's parameters (TOML, the fields of the node's Params at top level). Default: the
    /// paper's defaults.
    #[arg(long, value_name = "FILE")]
    pub params: Option<PathBuf>,
    /// Instance name (readiness key nrslam/ready/<name>). Default: the kind.
    #[arg(long)]
    pub name: Option<String>,
    /// Run seed (must match the other nodes' for reproducible runs; 0 to 2^64 − 1).
    #[arg(long, default_value_t = 1, value_parser = flags::SEED.parser::<u64>(), allow_hyphen_values = true)]
    pub seed: u64,
    /// Folder that relative paths in the parameters resolve against. Default: the params file's folder.
    #[arg(long, value_name = "DIR")]
    pub base_dir: Option<PathBuf>,
    /// zenoh role of this process: peer, or client (of a router or listening peer).
    #[arg(long, default_value = "peer", value_name = "ROLE")]
    pub zenoh_mode: String,
    /// Declare readiness and, for a source, wait for the launcher's start signal (used by `launch --mode processes`).
    #[arg(long)]
    pub start_barrier: bool,
    /// With --start-barrier: how long to wait for the start signal, in seconds, 1 to 604800
    /// (a week).
    #[arg(long, value_name = "SECONDS", default_value_t = 60, value_parser = flags::TIMEOUT_S.parser::<u64>(), allow_hyphen_values = true)]
    pub start_timeout_s: u64,
    /// Without --start-barrier: seconds a source waits before its first frame, so subscribers can
    /// come up, 0 to 3600 s.
    #[arg(long, value_name = "SECONDS", default_value_t = 1.0, value_parser = STARTUP_DELAY_S.parser(), allow_hyphen_values = true)]
    pub startup_delay_s: f64,
    /// Real-time factor for a source, 1e-6 to 1e6 (0: as fast as possible).
    #[arg(
        long,
        value_name = "R",
        default_value_t = 0.0,
        value_parser = flags::RATE.parser(),
        allow_hyphen_values = true
    )]
    pub rate: f64,
    /// An input topic whose stream already ended (repeatable): the launcher passes these when it
    /// respawns a node, so it does not wait for ends it missed.
    #[arg(long, value_name = "TOPIC")]
    pub ended: Vec<String>,
    #[command(flatten)]
    pub transport: TransportArgs,
}

/// ROS 2 domain ids.
pub(crate) const ROS_DOMAIN_ID: Whole = Whole::new(0, 232, "0 to 232 (ROS 2 domain ids)");
/// Delay before a source's first frame.
const STARTUP_DELAY_S: Real = Real::closed(0.0, 3600.0, "0 to 3600 s");

impl LaunchArgs {
    /// Checks every numeric flag against its range (clap's parsers check them too; this covers
    /// `LaunchArgs` built in code, e.g. by `nrslam reproduce`). The error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check("--rate", flags::RATE.check(self.rate))?;
        flags::check(
            "--start-timeout-s",
            flags::TIMEOUT_S.check(self.start_timeout_s),
        )?;
        if let Some(id) = self.ros_domain_id {
            flags::check("--ros-domain-id", ROS_DOMAIN_ID.check(id))?;
        }
        self.chunk.bytes()?;
        Ok(())
    }
}

impl RunArgs {
    /// Checks every numeric flag against its range; the error names the flag.
    pub fn validate(&self) -> Result<()> {
        flags::check("--rate", flags::RATE.check(self.rate))?;
        flags::check(
            "--start-timeout-s",
            flags::TIMEOUT_S.check(self.start_timeout_s),
        )?;
        flags::check(
            "--startup-delay-s",
            STARTUP_DELAY_S.check(self.startup_delay_s),
        )?;
        Ok(())
    }
}

/// The nodes of a launch, built and wired.
pub(crate) struct Built {
    /// (instance name, node) in launch order.
    pub nodes: Vec<(String, Box<dyn Node>)>,
    /// Frames the radar will produce, when known.
    pub expected_frames: Option<u64>,
}

/// Builds every node of the launch (validating all parameters) and checks the wiring against the
/// topic catalogue.
pub(crate) fn build_all(launch: &Launch, seed: u64) -> Result<Built> {
    let mut nodes = Vec::new();
    let mut expected_frames = None;
    for decl in &launch.nodes {
        let ctx = NodeContext {
            name: decl.name.clone(),
            seed,
            base_dir: decl.base_dir.clone(),
        };
        let node = registry::build(&decl.kind, decl.params.clone(), &ctx).map_err(|e| {
            anyhow!(
                "{}: {}: {e}",
                launch.path.display(),
                decl.describe(&launch.path)
            )
        })?;
        expected_frames =
            expected_frames.or_else(|| registry::expected_frames(&decl.kind, &decl.params, &ctx));
        nodes.push((decl.name.clone(), node));
    }
    for (name, node) in &nodes {
        for topic in node.inputs().into_iter().chain(node.outputs()) {
            if topics::spec(topic).is_none() {
                bail!(
                    "{}: node {name}: topic {topic} is not in the catalogue",
                    launch.path.display()
                );
            }
        }
        for topic in node.inputs() {
            if !nodes
                .iter()
                .any(|(_, other)| other.outputs().contains(&topic))
            {
                bail!(
                    "{}: node {name} subscribes to {topic}, which no node of the launch publishes",
                    launch.path.display()
                );
            }
        }
    }
    Ok(Built {
        nodes,
        expected_frames,
    })
}

fn progress(frames: Option<u64>) -> ProgressBar {
    let bar = match frames {
        Some(n) => ProgressBar::new(n),
        None => ProgressBar::new_spinner(),
    };
    bar.set_style(
        ProgressStyle::with_template(
            "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} frames  ETA {eta}  {msg}",
        )
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// The reporter plus what a run shows while it goes: progress, an optional zenoh mirror and an
/// optional bag recording.
struct RunObserver {
    reporter: Reporter,
    bar: ProgressBar,
    mirror: Option<TopicPublisher>,
    pacer: Pacer,
    recorder: Option<Recorder>,
}

/// A bag being recorded from a run, with the topics it takes.
pub(crate) struct Recorder {
    writer: BagWriter,
    topics: Vec<&'static str>,
}

impl Recorder {
    fn take(&mut self, topic: &'static str, message: &Message) -> Result<()> {
        if self.topics.contains(&topic) {
            self.writer.write_message(topic, message)?;
        }
        Ok(())
    }

    fn finish(self) -> Result<()> {
        let dir = self.writer.dir().to_owned();
        let info = self.writer.finish()?;
        eprintln!(
            "recorded {} messages on {} topic(s) into {}",
            info.message_count,
            info.topics_with_message_count.len(),
            dir.display()
        );
        Ok(())
    }
}

impl Observer for RunObserver {
    fn observe(&mut self, topic: &'static str, message: &Message) -> anyhow_free::Result {
        self.reporter.take(topic, message);
        if topic == topics::CLOCK {
            self.bar.inc(1);
            self.pacer.pace(message.stamp().as_seconds());
        }
        if let (topics::METRICS, Message::Metrics(m)) = (topic, message) {
            self.bar.set_message(format!(
                "ET-GOPSA {:.2}  pos err {:.2} m",
                m.etgospa, m.position_error_m
            ));
        }
        if let Some(mirror) = &mut self.mirror {
            mirror.publish(topic, message)?;
        }
        if let Some(recorder) = &mut self.recorder {
            recorder.take(topic, message).map_err(
                |e| -> Box<dyn std::error::Error + Send + Sync> { format!("{e:#}").into() },
            )?;
        }
        Ok(())
    }

    fn end(&mut self, topic: &'static str) {
        self.reporter.ended.push(topic);
        if let Some(mirror) = &mut self.mirror {
            let _ = mirror.end(topic);
        }
    }
}

/// `nrslam launch`.
pub fn launch(args: LaunchArgs) -> Result<()> {
    args.validate()?;
    let launch = Launch::load(&args.file, &args.assignments)?;
    let mode = args.mode.unwrap_or(launch.mode);
    let out = args.out.clone().unwrap_or_else(|| {
        PathBuf::from("out").join(
            args.file
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "run".into()),
        )
    });
    if args.ros_domain_id.is_some() && mode == Mode::Processes {
        bail!(
            "--ros-domain-id: only in-process launches mirror their topics (use --mode in-process)"
        );
    }
    let built = build_all(&launch, args.seed)?;
    let recorder = match &args.record {
        Some(dir) => Some(recorder(&args, &launch, &built, dir)?),
        None => None,
    };
    let replayed = replayed_run(&launch)?;
    let started = Instant::now();
    let reporter = match mode {
        Mode::InProcess => run_in_process(&args, built, recorder)?,
        Mode::Processes => run_processes(&args, &launch, built, &out, recorder)?,
    };
    let mut summary = reporter.summary(
        &launch.arguments,
        args.seed,
        &launch.path.display().to_string(),
    );
    if let Some((_, identity)) = &replayed {
        identity.apply(&mut summary);
    }
    reporter.write_all(&out, &summary)?;
    let mut run_info = serde_json::json!({
        "mode": match mode { Mode::InProcess => "in-process", Mode::Processes => "processes" },
        "wall_time_s": started.elapsed().as_secs_f64(),
        "rate": args.rate,
    });
    if let Some((bag, _)) = &replayed {
        run_info["replayed_bag"] = serde_json::Value::from(bag.display().to_string());
        run_info["replay_launch"] = serde_json::Value::from(launch.path.display().to_string());
    }
    std::fs::write(
        out.join("run.json"),
        serde_json::to_string_pretty(&run_info)? + "\n",
    )
    .with_context(|| format!("cannot write {}", out.join("run.json").display()))?;
    if summary.metric_steps == 0 {
        // No evaluator (a real sensor's bag): say what was built rather than a row of n/a.
        outln!(
            "{} keyframes, {} occupied map cells, no /metrics (no ground truth to score against); wrote {}",
            summary.keyframes,
            summary.occupied_cells.unwrap_or(0),
            out.display()
        );
        return Ok(());
    }
    outln!(
        "{} frames, final ET-GOPSA {}, GOSPA {}, pose RMSE {} m (final keyframe trajectory {} m); wrote {}",
        summary.frames,
        fmt_opt(summary.etgospa),
        fmt_opt(summary.gospa),
        fmt_opt(summary.pose_rmse_m),
        fmt_opt(summary.keyframe_rmse_m),
        out.display()
    );
    Ok(())
}

fn fmt_opt(value: Option<f64>) -> String {
    value.map_or_else(|| "n/a".into(), |v| format!("{v:.3}"))
}

fn transport_config(mode: SessionMode, args: &TransportArgs) -> TransportConfig {
    args.config(mode)
}

/// The identity (launch, arguments, seed) of a recorded run, from its bag's `custom_data`.
struct RecordedRun {
    launch: String,
    arguments: std::collections::BTreeMap<String, serde_json::Value>,
    seed: u64,
}

impl RecordedRun {
    /// The recorded run's summary is reproduced: it names the recorded launch, not the replay.
    fn apply(&self, summary: &mut crate::report::Summary) {
        summary.launch = self.launch.clone();
        summary.arguments = self.arguments.clone();
        summary.seed = self.seed;
    }
}

/// `custom_data` identifying the run of `launch` with `seed`.
fn run_identity(launch: &Launch, seed: u64) -> Result<std::collections::BTreeMap<String, String>> {
    let summary =
        Reporter::default().summary(&launch.arguments, seed, &launch.path.display().to_string());
    Ok(std::collections::BTreeMap::from([
        (bag::RUN_LAUNCH_KEY.to_owned(), summary.launch),
        (
            bag::RUN_ARGUMENTS_KEY.to_owned(),
            serde_json::to_string(&summary.arguments)?,
        ),
        (bag::RUN_SEED_KEY.to_owned(), seed.to_string()),
    ]))
}

/// For a launch that replays a bag (a node of kind `bag`): the bag and its recorded run.
fn replayed_run(launch: &Launch) -> Result<Option<(PathBuf, RecordedRun)>> {
    let Some(decl) = launch.nodes.iter().find(|n| n.kind == "bag") else {
        return Ok(None);
    };
    let Some(path) = decl.params.get("path").and_then(|p| p.as_str()) else {
        return Ok(None);
    };
    let recover = decl
        .params
        .get("recover")
        .and_then(|r| r.as_bool())
        .unwrap_or(false);
    let dir = PathBuf::from(path);
    let custom = bag::custom_data(&dir, recover)?;
    let identity = match (
        custom.get(bag::RUN_LAUNCH_KEY),
        custom.get(bag::RUN_ARGUMENTS_KEY),
        custom.get(bag::RUN_SEED_KEY),
    ) {
        (Some(launch), Some(arguments), Some(seed)) => RecordedRun {
            launch: launch.clone(),
            arguments: serde_json::from_str(arguments).with_context(|| {
                format!("{}: custom_data {}", dir.display(), bag::RUN_ARGUMENTS_KEY)
            })?,
            seed: seed
                .parse()
                .with_context(|| format!("{}: custom_data {}", dir.display(), bag::RUN_SEED_KEY))?,
        },
        // A bag recorded from a live graph does not know its run: the replay names itself.
        _ => return Ok(None),
    };
    Ok(Some((dir, identity)))
}

/// A recorder for `launch --record DIR`: the topics asked for (default: every topic the launch
/// publishes) and the run's identity in `custom_data`.
fn recorder(args: &LaunchArgs, launch: &Launch, built: &Built, dir: &Path) -> Result<Recorder> {
    let published: Vec<&'static str> = topics::CATALOGUE
        .iter()
        .map(|t| t.name)
        .filter(|t| built.nodes.iter().any(|(_, n)| n.outputs().contains(t)))
        .collect();
    let topics = if args.record_topics.is_empty() {
        published
    } else {
        crate::bag::catalogue_topics(&args.record_topics)?
    };
    let writer = BagWriter::create_with(
        dir,
        WriterOptions {
            chunk_size_bytes: args.chunk.bytes()?,
            custom_data: run_identity(launch, args.seed)?,
        },
        args.storage.options()?,
    )
    .context("--record")?;
    Ok(Recorder { writer, topics })
}

fn run_in_process(args: &LaunchArgs, built: Built, recorder: Option<Recorder>) -> Result<Reporter> {
    let session = if args.transport.listen.is_empty()
        && args.transport.connect.is_empty()
        && args.transport.ros_router.is_none()
    {
        None
    } else {
        Some(
            transport::open(&transport_config(SessionMode::Peer, &args.transport))
                .context("opening the zenoh session")?,
        )
    };
    let mirror = match &session {
        Some(session) => {
            let all: Vec<&'static str> = topics::CATALOGUE.iter().map(|t| t.name).collect();
            let namespace = &args.transport.namespace;
            let publisher = match args.ros_domain_id {
                // Every node of the graph is a ROS 2 node on rmw_zenoh (tokens, GIDs).
                Some(domain_id) => {
                    let nodes = built.nodes.iter().map(|(name, node)| {
                        RosNode::from_catalogue(name, &node.outputs(), &node.inputs())
                    });
                    let nodes = nodes.collect::<Result<Vec<_>, _>>()?;
                    TopicPublisher::with_ros_nodes(session, namespace, domain_id, &nodes)?
                }
                None => TopicPublisher::with_style(session, namespace, &all, KeyStyle::Nrslam)?,
            };
            // Give outside subscribers that are already connected a moment to be matched.
            std::thread::sleep(Duration::from_millis(500));
            Some(publisher)
        }
        None => None,
    };
    let mut observer = RunObserver {
        reporter: Reporter::default(),
        bar: progress(built.expected_frames),
        mirror,
        pacer: Pacer::new(args.rate),
        recorder,
    };
    let result = Graph::new(built.nodes).run(&mut observer);
    observer.bar.finish_and_clear();
    result?;
    if let Some(recorder) = observer.recorder.take() {
        recorder.finish()?;
    }
    if let Some(session) = session {
        let _ = zenoh::Wait::wait(session.close());
    }
    Ok(observer.reporter)
}

fn free_loopback_port() -> Result<u16> {
    let listener =
        std::net::TcpListener::bind("127.0.0.1:0").context("finding a free loopback port")?;
    Ok(listener.local_addr()?.port())
}

/// The command line of node `decl` as a process of this launch (`restart`: without waiting for
/// the start signal, which was given long ago).
fn node_args(
    decl: &NodeDecl,
    params_file: &Path,
    base_dir: &Path,
    endpoint: &str,
    args: &LaunchArgs,
    restart: bool,
) -> Result<Vec<OsString>> {
    let mut out: Vec<OsString> = [
        "run",
        &decl.kind,
        "--name",
        &decl.name,
        "--zenoh-mode",
        "client",
    ]
    .iter()
    .map(OsString::from)
    .collect();
    if !restart {
        out.push("--start-barrier".into());
    }
    out.extend([
        "--params".into(),
        params_file.as_os_str().to_owned(),
        "--base-dir".into(),
        base_dir.as_os_str().to_owned(),
    ]);
    for (flag, value) in [
        ("--seed", args.seed.to_string()),
        ("--connect", endpoint.to_owned()),
        ("--namespace", args.transport.namespace.clone()),
        ("--rate", args.rate.to_string()),
        ("--start-timeout-s", args.start_timeout_s.to_string()),
        ("--on-bad-input", args.transport.on_bad_input.clone()),
    ] {
        out.extend([flag.into(), value.into()]);
    }
    if let Some(file) = &args.transport.zenoh_config {
        out.push("--zenoh-config".into());
        out.push(
            std::fs::canonicalize(file)
                .with_context(|| format!("--zenoh-config {}", file.display()))?
                .into_os_string(),
        );
    }
    Ok(out)
}

/// The restart policy of `decl`, refused for a node that cannot pick up a stream halfway: a
/// source (it would start its stream over) or a node with a latched input (published once, at
/// the start).
fn restart_policy(decl: &NodeDecl, node: &dyn Node) -> Result<RestartPolicy> {
    if decl.respawn {
        if node.inputs().is_empty() {
            bail!("node {}: respawn = true, but it is a source: a respawned source would start its stream over", decl.name);
        }
        let latched = node.inputs().into_iter().find(|t| {
            topics::spec(t).is_some_and(|s| s.qos.durability == topics::Durability::TransientLocal)
        });
        if let Some(topic) = latched {
            bail!("node {}: respawn = true, but its input {topic} is published once at the start: a respawned node would wait for it forever", decl.name);
        }
    }
    Ok(RestartPolicy {
        respawn: decl.respawn,
        respawn_delay: flags::seconds("respawn_delay_s", decl.respawn_delay_s)?,
        max_restarts: decl.max_restarts,
    })
}

fn run_processes(
    args: &LaunchArgs,
    launch: &Launch,
    built: Built,
    out: &Path,
    mut recorder: Option<Recorder>,
) -> Result<Reporter> {
    // Topics to listen to: the reporter's, those recorded, and the inputs of respawnable nodes
    // (a respawned node is told which of them have ended). Each ends with the node that
    // publishes it; topics no node publishes are not waited for.
    let mut listened: Vec<&'static str> = REPORTED.to_vec();
    if let Some(recorder) = &recorder {
        listened.extend(recorder.topics.iter().copied());
    }
    let mut policies = Vec::new();
    for decl in &launch.nodes {
        let node = built
            .nodes
            .iter()
            .find(|(name, _)| *name == decl.name)
            .map(|(_, node)| node.as_ref())
            .ok_or_else(|| anyhow!("node {} was not built", decl.name))?;
        let policy = restart_policy(decl, node)?;
        if policy.respawn {
            listened.extend(node.inputs());
        }
        policies.push(policy);
    }
    listened.retain(|t| {
        built.nodes.iter().any(|(_, n)| n.outputs().contains(t)) || REPORTED.contains(t)
    });
    listened.sort_unstable();
    listened.dedup();
    let mut open: Vec<&'static str> = listened.clone();
    listened.push(topics::DIAGNOSTICS);
    let inputs: std::collections::BTreeMap<String, Vec<&'static str>> = built
        .nodes
        .iter()
        .map(|(name, node)| (name.clone(), node.inputs()))
        .collect();
    drop(built.nodes);
    let port = free_loopback_port()?;
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut transport_args = args.transport.clone();
    transport_args.listen.push(endpoint.clone());
    let session = transport::open(&transport_config(SessionMode::Router, &transport_args))
        .context("opening the launcher's zenoh router")?;
    let mut inbox = Inbox::subscribe(
        &session,
        &args.transport.namespace,
        &listened,
        args.transport.inbox_options()?,
    )?;
    let params_dir = out.join("params");
    std::fs::create_dir_all(&params_dir)
        .with_context(|| format!("cannot create {}", params_dir.display()))?;
    let exe = std::env::current_exe().context("locating the nrslam executable")?;
    let mut specs = Vec::new();
    for (decl, restart) in launch.nodes.iter().zip(policies) {
        let file = params_dir.join(format!("{}.toml", decl.name));
        std::fs::write(&file, toml::to_string(&decl.params)?)
            .with_context(|| format!("cannot write {}", file.display()))?;
        // An included node's relative paths resolve against its own file's folder.
        let base_dir = std::fs::canonicalize(&decl.base_dir)
            .with_context(|| format!("resolving {}", decl.base_dir.display()))?;
        specs.push(ProcessSpec {
            name: decl.name.clone(),
            program: exe.clone(),
            args: node_args(decl, &file, &base_dir, &endpoint, args, false)?,
            restart_args: node_args(decl, &file, &base_dir, &endpoint, args, true)?,
            restart,
        });
    }
    let mut supervisor = Supervisor::start(specs)?;
    let names: Vec<String> = launch.nodes.iter().map(|n| n.name.clone()).collect();
    // The barrier adds the timeout to the clock: check here that it can.
    let start_timeout = Duration::from_secs(args.start_timeout_s);
    flags::deadline("--start-timeout-s", start_timeout)?;
    transport::start_barrier(
        &session,
        &args.transport.namespace,
        &names,
        start_timeout,
        || supervisor.poll().map(drop).map_err(|e| e.to_string()),
    )
    .map_err(|e| anyhow!("{e}"))?;
    let bar = progress(built.expected_frames);
    let mut reporter = Reporter::default();
    let mut last_poll = Instant::now();
    let mut all_finished = false;
    while !open.is_empty() {
        match inbox.recv_timeout(Duration::from_millis(200))? {
            Some(Delivery::End { topic }) => open.retain(|t| *t != topic),
            Some(Delivery::Message { topic, message, .. }) => {
                if topic == topics::CLOCK {
                    bar.inc(1);
                }
                reporter.take(topic, &message);
                if let Some(recorder) = &mut recorder {
                    recorder.take(topic, &message)?;
                }
            }
            // Every process had ended and nothing more came for 200 ms: that was all there is.
            None if all_finished => bail!(
                "every node process ended but topics {} never ended",
                open.join(", ")
            ),
            None => {}
        }
        if last_poll.elapsed() >= Duration::from_millis(200) {
            last_poll = Instant::now();
            // A respawned node is told which of its inputs ended while it was down.
            let ended = |name: &str| -> Vec<OsString> {
                inputs
                    .get(name)
                    .into_iter()
                    .flatten()
                    .filter(|t| !open.contains(t))
                    .flat_map(|t| [OsString::from("--ended"), OsString::from(*t)])
                    .collect()
            };
            for event in supervisor.poll_with(&ended)? {
                let Event::Restarted { name, status, .. } = event;
                bar.println(format!("node {name} died ({status}) and was restarted"));
            }
            all_finished = supervisor.all_finished();
        }
    }
    bar.finish_and_clear();
    if !supervisor.wait_all(Duration::from_secs(60))? {
        bail!("node processes still running 60 s after their topics ended");
    }
    reporter.restarts = supervisor.restarts();
    reporter.note_drops("nrslam/launch/receive", inbox.drops());
    let _ = zenoh::Wait::wait(session.close());
    if let Some(recorder) = recorder {
        recorder.finish()?;
    }
    Ok(reporter)
}

/// `nrslam run`.
pub fn run(args: RunArgs) -> Result<()> {
    args.validate()?;
    let table: toml::Table = match &args.params {
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("{}: cannot read", path.display()))?;
            toml::from_str(&text).map_err(|e| anyhow!("{}: {}", path.display(), e.message()))?
        }
        None => toml::Table::new(),
    };
    let base_dir = args
        .base_dir
        .clone()
        .or_else(|| {
            args.params
                .as_ref()
                .and_then(|p| p.parent().map(Path::to_owned))
        })
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or_else(|| PathBuf::from("."));
    let name = args.name.clone().unwrap_or_else(|| args.kind.clone());
    let ctx = NodeContext {
        name: name.clone(),
        seed: args.seed,
        base_dir,
    };
    let source = args
        .params
        .as_ref()
        .map_or_else(|| "defaults".to_owned(), |p| p.display().to_string());
    let node = registry::build(&args.kind, table, &ctx)
        .map_err(|e| anyhow!("{source}: node {name}: {e}"))?;
    let mode = match args.zenoh_mode.as_str() {
        "peer" => SessionMode::Peer,
        "client" => SessionMode::Client,
        other => bail!("--zenoh-mode: unknown role {other:?} (allowed: peer, client)"),
    };
    let session = transport::open(&transport_config(mode, &args.transport))
        .context("opening the zenoh session")?;
    if node.inputs().is_empty() && !args.start_barrier && args.startup_delay_s > 0.0 {
        std::thread::sleep(flags::seconds("--startup-delay-s", args.startup_delay_s)?);
    }
    // run_node adds the timeout to the clock: check here that it can.
    let start_timeout = Duration::from_secs(args.start_timeout_s);
    flags::deadline("--start-timeout-s", start_timeout)?;
    let ended = args
        .ended
        .iter()
        .map(|t| {
            topics::spec(t)
                .map(|s| s.name)
                .ok_or_else(|| anyhow!("--ended: {t} is not in the topic catalogue"))
        })
        .collect::<Result<Vec<_>>>()?;
    let run = transport::NodeRun {
        wait_for_start: args.start_barrier,
        start_timeout,
        rate: args.rate,
        inbox: args.transport.inbox_options()?,
        ended,
    };
    let drops = transport::run_node_with(&session, &args.transport.namespace, &name, node, run)
        .map_err(|e| anyhow!("node '{name}' failed: {e}"))?;
    if !drops.is_empty() {
        tracing::warn!(
            node = name,
            dropped = drops.total(),
            "unusable input samples were dropped"
        );
    }
    // Let the last publications leave before the session closes.
    std::thread::sleep(Duration::from_millis(200));
    let _ = zenoh::Wait::wait(session.close());
    Ok(())
}
