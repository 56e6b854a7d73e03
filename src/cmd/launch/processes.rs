//! The processes-mode run: one OS process per node over zenoh, supervised, with the launcher as
//! their router.

use super::build::Built;
use super::recorder::Recorder;
use super::{progress, LaunchArgs};
use crate::flags;
use crate::report::{Reporter, REPORTED};
use anyhow::{anyhow, bail, Context, Result};
use indicatif::ProgressBar;
use nrslam_msgs::{topics, Message};
use nrslam_runtime::compose::{anyhow_free, Observer};
use nrslam_runtime::launch::{Launch, NodeDecl};
use nrslam_runtime::receive::Inbox;
use nrslam_runtime::supervised::{receive_supervised, NodeTopics};
use nrslam_runtime::supervisor::{Event, ProcessSpec, RestartPolicy, Supervisor};
use nrslam_runtime::transport::{self, SessionMode, TopicPublisher};
use nrslam_runtime::wiring::check_respawnable;
use nrslam_runtime::Node;
use std::ffi::OsString;
use std::path::Path;
use std::time::Duration;

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
        ("--seed", args.seed().to_string()),
        ("--connect", endpoint.to_owned()),
        ("--namespace", args.transport.namespace.clone()),
        ("--rate", args.pacing.rate.to_string()),
        ("--start-timeout-s", args.start_timeout_s.to_string()),
        ("--on-bad-input", args.transport.on_bad_input.clone()),
    ] {
        out.extend([flag.into(), value.into()]);
    }
    // The node process builds the node as the launcher did: under its namespace, remapped.
    if !decl.namespace.is_empty() {
        out.extend(["--node-namespace".into(), decl.namespace.clone().into()]);
    }
    for (from, to) in &decl.remap {
        out.extend(["--remap".into(), format!("{from}:={to}").into()]);
    }
    if let Some(domain_id) = args.ros_domain_id {
        // Each node process is then a ROS 2 node on rmw_zenoh, and so are its topics' keys.
        out.extend(["--ros-domain-id".into(), domain_id.to_string().into()]);
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
        check_respawnable(&decl.name, node)?;
    }
    Ok(RestartPolicy {
        respawn: decl.respawn,
        respawn_delay: flags::seconds("respawn_delay_s", decl.respawn_delay_s)?,
        max_restarts: decl.max_restarts,
        on_exit: decl.on_exit,
    })
}

pub(super) fn run_processes(
    args: &LaunchArgs,
    launch: &Launch,
    built: Built,
    out: &Path,
    mut recorder: Option<Recorder>,
) -> Result<Reporter> {
    let (mut listened, policies) = listened_topics(launch, &built, &recorder)?;
    let open: Vec<&'static str> = listened.clone();
    listened.push(topics::DIAGNOSTICS);
    let topics = NodeTopics {
        inputs: built
            .nodes
            .iter()
            .map(|(name, node)| (name.clone(), node.inputs()))
            .collect(),
        outputs: built
            .nodes
            .iter()
            .map(|(name, node)| (name.clone(), node.outputs()))
            .collect(),
    };
    drop(built.nodes);
    let port = free_loopback_port()?;
    let endpoint = format!("tcp/127.0.0.1:{port}");
    let mut transport_args = args.transport.clone();
    transport_args.listen.push(endpoint.clone());
    let session = transport::open(&transport_args.config(SessionMode::Router))
        .context("opening the launcher's zenoh router")?;
    let mut inbox = Inbox::subscribe_styled(
        &session,
        &args.transport.namespace,
        &listened,
        args.transport.inbox_options()?,
        crate::args::key_style(args.ros_domain_id),
    )?;
    let specs = process_specs(args, launch, policies, out, &endpoint)?;
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
    // Ends the streams of a node that died for good while the graph goes on without it. Declared
    // only then: with --ros-domain-id a publisher is a ROS node of the graph, and a run without
    // such a death should not show one more.
    let mut ender: Option<TopicPublisher> = None;
    let mut end = |topic: &'static str| -> Result<(), transport::TransportError> {
        let publisher = match &mut ender {
            Some(publisher) => publisher,
            None => ender.insert(TopicPublisher::with_style(
                &session,
                &args.transport.namespace,
                &[],
                crate::args::key_style(args.ros_domain_id),
            )?),
        };
        publisher.end(topic)
    };
    let mut reporter = receive(
        &mut inbox,
        &mut supervisor,
        &topics,
        open,
        &bar,
        &mut recorder,
        &mut end,
    )?;
    bar.finish_and_clear();
    if !supervisor.wait_all(Duration::from_secs(60))? {
        bail!("node processes still running 60 s after their topics ended");
    }
    reporter.restarts = supervisor.restarts();
    reporter.exited = supervisor.exited();
    reporter.note_drops("nrslam/launch/receive", inbox.drops());
    let _ = zenoh::Wait::wait(session.close());
    if let Some(recorder) = recorder {
        recorder.finish()?;
    }
    Ok(reporter)
}

/// The catalogue topics whose namespaced copies (`/agv1/slam/pose`) the report takes per agent:
/// the poses of its agent tracks, and the keyframes whose stamps score the inter-agent edges
/// (src/report/agents.rs).
const AGENT_TOPICS: [&str; 4] = [
    topics::GROUND_TRUTH_POSE,
    topics::SLAM_POSE,
    topics::FUSION_POSE,
    topics::KEYFRAME,
];

/// The topics the launcher listens to, sorted (without /diagnostics), and each node's restart
/// policy in launch order.
fn listened_topics(
    launch: &Launch,
    built: &Built,
    recorder: &Option<Recorder>,
) -> Result<(Vec<&'static str>, Vec<RestartPolicy>)> {
    // Topics to listen to: the reporter's, those recorded, and the inputs of respawnable nodes
    // (a respawned node is told which of them have ended). Each ends with the node that
    // publishes it; topics no node publishes are not waited for.
    let mut listened: Vec<&'static str> = REPORTED.to_vec();
    if let Some(recorder) = recorder {
        listened.extend(recorder.topics.iter().copied());
    }
    // Each agent's poses and keyframes under its namespace, which the report's agent tracks
    // take (src/report/agents.rs), as the in-process observer sees them.
    for (_, node) in &built.nodes {
        listened.extend(node.outputs().into_iter().filter(|t| {
            topics::split_namespace(t).is_some_and(|(_, spec)| AGENT_TOPICS.contains(&spec.name))
        }));
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
    // A reported topic that no node publishes and nobody feeds from outside would never end: a
    // launch without an evaluator (or whose nodes run under namespaces, /agv1/metrics) waited
    // for /metrics forever.
    listened.retain(|t| {
        built.nodes.iter().any(|(_, n)| n.outputs().contains(t))
            || (REPORTED.contains(t) && built.externals.contains(t))
    });
    listened.sort_unstable();
    listened.dedup();
    Ok((listened, policies))
}

/// One process per node of the launch, its parameters written to `out/params/<name>.toml`, its
/// namespace and remaps passed as `--node-namespace` and `--remap`.
fn process_specs(
    args: &LaunchArgs,
    launch: &Launch,
    policies: Vec<RestartPolicy>,
    out: &Path,
    endpoint: &str,
) -> Result<Vec<ProcessSpec>> {
    let params_dir = out.join("params");
    std::fs::create_dir_all(&params_dir)
        .with_context(|| format!("cannot create {}", params_dir.display()))?;
    let exe = std::env::current_exe().context("locating the nrslam executable")?;
    let mut specs = Vec::new();
    for (decl, restart) in launch.nodes.iter().zip(policies) {
        // A node under a namespace (agv1/radar) gets params/agv1/radar.toml.
        let file = params_dir.join(format!("{}.toml", decl.name));
        if let Some(folder) = file.parent() {
            std::fs::create_dir_all(folder)
                .with_context(|| format!("cannot create {}", folder.display()))?;
        }
        std::fs::write(&file, toml::to_string(&decl.params)?)
            .with_context(|| format!("cannot write {}", file.display()))?;
        // An included node's relative paths resolve against its own file's folder.
        let base_dir = std::fs::canonicalize(&decl.base_dir)
            .with_context(|| format!("resolving {}", decl.base_dir.display()))?;
        specs.push(ProcessSpec {
            name: decl.name.clone(),
            program: exe.clone(),
            args: node_args(decl, &file, &base_dir, endpoint, args, false)?,
            restart_args: node_args(decl, &file, &base_dir, endpoint, args, true)?,
            restart,
        });
    }
    Ok(specs)
}

/// What the launcher does with each message of the node processes: the progress bar, the
/// report, the recording.
struct Taker<'a> {
    reporter: Reporter,
    bar: &'a ProgressBar,
    recorder: &'a mut Option<Recorder>,
}

impl Observer for Taker<'_> {
    fn observe(&mut self, topic: &'static str, message: &Message) -> anyhow_free::Result {
        if topic == topics::CLOCK {
            self.bar.inc(1);
        }
        self.reporter.take(topic, message);
        if let Some(recorder) = self.recorder {
            recorder.take(topic, message)?;
        }
        Ok(())
    }
}

/// Takes what the node processes publish until every `open` topic has ended, restarting nodes
/// that die (as their policies allow).
fn receive(
    inbox: &mut Inbox,
    supervisor: &mut Supervisor,
    topics: &NodeTopics,
    open: Vec<&'static str>,
    bar: &ProgressBar,
    recorder: &mut Option<Recorder>,
    end: &mut dyn FnMut(&'static str) -> Result<(), transport::TransportError>,
) -> Result<Reporter> {
    let mut taker = Taker {
        reporter: Reporter::default(),
        bar,
        recorder,
    };
    receive_supervised(
        inbox,
        supervisor,
        topics,
        open,
        &mut taker,
        end,
        &mut |event| match event {
            Event::Restarted { name, status, .. } => {
                bar.println(format!("node {name} died ({status}) and was restarted"))
            }
            Event::Exited { name, status } => bar.println(format!(
                "node {name} died ({status}); on_exit = \"continue\": its streams were ended \
                 and the graph goes on without it"
            )),
        },
    )?;
    Ok(taker.reporter)
}
