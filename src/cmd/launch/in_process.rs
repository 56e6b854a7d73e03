//! The in-process run: every node in this process, with an optional zenoh mirror of the topics
//! and, for a launch with `[[external]]` topics, a source node that feeds them from zenoh.

use super::build::Built;
use super::recorder::Recorder;
use super::{progress, LaunchArgs};
use crate::report::Reporter;
use anyhow::{bail, Context, Result};
use indicatif::ProgressBar;
use nrslam_msgs::{topics, Message};
use nrslam_runtime::compose::{anyhow_free, Graph, Observer};
use nrslam_runtime::external::{ExternalSource, ExternalTimeouts};
use nrslam_runtime::receive::Inbox;
use nrslam_runtime::transport::{self, KeyStyle, Pacer, RosNode, SessionMode, TopicPublisher};
use std::time::Duration;

/// The reporter plus what a run shows while it goes: progress, an optional zenoh mirror and an
/// optional bag recording.
struct RunObserver {
    reporter: Reporter,
    bar: ProgressBar,
    mirror: Option<TopicPublisher>,
    pacer: Pacer,
    recorder: Option<Recorder>,
    /// Topics fed from outside: not mirrored back onto the keys they came from.
    externals: Vec<&'static str>,
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
            if !self.externals.contains(&topic) {
                mirror.publish(topic, message)?;
            }
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
            if !self.externals.contains(&topic) {
                let _ = mirror.end(topic);
            }
        }
    }
}

pub(super) fn run_in_process(
    args: &LaunchArgs,
    built: Built,
    recorder: Option<Recorder>,
) -> Result<Reporter> {
    let session = if args.transport.listen.is_empty()
        && args.transport.connect.is_empty()
        && args.transport.ros_router.is_none()
    {
        if !built.externals.is_empty() {
            bail!(
                "the launch takes {} from outside ([[external]]): give --listen ENDPOINT, \
                 --connect ENDPOINT or --ros-router ENDPOINT for its publishers to reach it",
                built.externals.join(", ")
            );
        }
        None
    } else {
        Some(
            transport::open(&args.transport.config(SessionMode::Peer))
                .context("opening the zenoh session")?,
        )
    };
    // Subscribed before the ROS tokens are declared: whoever sees a subscription token (MS) may
    // publish at once.
    let external = match &session {
        Some(session) if !built.externals.is_empty() => {
            let inbox = Inbox::subscribe_styled(
                session,
                &args.transport.namespace,
                &built.externals,
                args.transport.inbox_options()?,
                crate::args::key_style(args.ros_domain_id),
            )?;
            let timeouts = ExternalTimeouts {
                first: crate::flags::seconds("--start-timeout-s", args.start_timeout_s as f64)?,
                idle: crate::flags::seconds("--external-idle-s", args.external_idle_s)?,
            };
            Some(ExternalSource::new(
                inbox,
                built.externals.clone(),
                timeouts,
            ))
        }
        _ => None,
    };
    let mirror = match &session {
        Some(session) => {
            // The catalogue, and what the graph publishes under namespaces (/agv1/odom).
            let mut all: Vec<&'static str> = topics::CATALOGUE.iter().map(|t| t.name).collect();
            for (_, node) in &built.nodes {
                for topic in node.outputs() {
                    if !all.contains(&topic) {
                        all.push(topic);
                    }
                }
            }
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
    let mut nodes = built.nodes;
    let mut external_drops = None;
    if let Some(source) = external {
        external_drops = Some(source.drops());
        nodes.push((EXTERNAL_NODE.to_owned(), Box::new(source)));
    }
    let mut observer = RunObserver {
        reporter: Reporter::default(),
        bar: progress(built.expected_frames),
        mirror,
        pacer: Pacer::new(args.pacing.rate),
        recorder,
        externals: built.externals,
    };
    let result = Graph::new(nodes).run(&mut observer);
    observer.bar.finish_and_clear();
    result?;
    if let Some(drops) = external_drops {
        let drops = drops.lock().map(|d| d.clone()).unwrap_or_default();
        observer
            .reporter
            .note_drops("nrslam/launch/external", &drops);
    }
    if let Some(recorder) = observer.recorder.take() {
        recorder.finish()?;
    }
    if let Some(session) = session {
        let _ = zenoh::Wait::wait(session.close());
    }
    Ok(observer.reporter)
}

/// The instance name of the source node of the external topics (in errors).
const EXTERNAL_NODE: &str = "external";
