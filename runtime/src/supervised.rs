//! The launcher's side of a graph of node processes: it takes what they publish until every
//! awaited topic has ended, polling their [`Supervisor`] as it goes, so that a node that dies is
//! restarted (as its policy allows) and told which of its inputs ended while it was down, and a
//! node that dies for good with `on_exit = "continue"` has its output streams ended for it (the
//! nodes downstream finish what they have instead of waiting for it forever).

use crate::compose::Observer;
use crate::receive::{Delivery, Inbox, ReceiveError};
use crate::supervisor::{Event, Supervisor, SupervisorError};
use crate::transport::TransportError;
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::time::{Duration, Instant};

/// How long the loop waits for a sample, and how often it polls the processes.
const POLL_PERIOD: Duration = Duration::from_millis(200);

/// Why receiving from the node processes stopped before every awaited topic ended.
#[derive(Debug, thiserror::Error)]
pub enum SupervisedError {
    /// The receive path failed.
    #[error(transparent)]
    Receive(#[from] ReceiveError),
    /// A process could not be restarted, or died without a restart left.
    #[error(transparent)]
    Supervisor(#[from] SupervisorError),
    /// The observer refused a message (e.g. a recording that cannot be written).
    #[error(transparent)]
    Observer(Box<dyn std::error::Error + Send + Sync>),
    /// Every process ended, yet these topics never did.
    #[error("every node process ended but topics {} never ended", .0.join(", "))]
    NeverEnded(Vec<&'static str>),
    /// The end of a dead node's output stream could not be published.
    #[error("ending the streams of node {name}, which died: {source}")]
    EndStreams {
        /// Node name.
        name: String,
        /// The transport's error.
        source: TransportError,
    },
}

/// Each node process's topics, by instance name.
#[derive(Debug, Clone, Default)]
pub struct NodeTopics {
    /// Its inputs: restarted, it gets `--ended TOPIC` for each of them that has ended.
    pub inputs: BTreeMap<String, Vec<&'static str>>,
    /// Its outputs: ended for it when it dies for good and the graph goes on without it.
    pub outputs: BTreeMap<String, Vec<&'static str>>,
}

/// Hands every message of the node processes to `observer` until every `open` topic has ended.
/// `topics` are each node's input and output topics, by instance name: a restarted node gets
/// `--ended TOPIC` for each of its inputs that has ended; a node that died for good while the
/// graph goes on ([`Event::Exited`]) has each of its outputs ended by `end` (the launcher's
/// publisher's [`crate::transport::TopicPublisher::end`], in the graph's key style), and they
/// are no longer waited for.
/// `on_event` is told of each restart and exit.
pub fn receive_supervised(
    inbox: &mut Inbox,
    supervisor: &mut Supervisor,
    topics: &NodeTopics,
    mut open: Vec<&'static str>,
    observer: &mut dyn Observer,
    end: &mut dyn FnMut(&'static str) -> Result<(), TransportError>,
    on_event: &mut dyn FnMut(&Event),
) -> Result<(), SupervisedError> {
    let inputs = &topics.inputs;
    let mut last_poll = Instant::now();
    let mut all_finished = false;
    while !open.is_empty() {
        match inbox.recv_timeout(POLL_PERIOD)? {
            Some(Delivery::End { topic }) => open.retain(|t| *t != topic),
            Some(Delivery::Message { topic, message, .. }) => observer
                .observe(topic, &message)
                .map_err(SupervisedError::Observer)?,
            // Every process had ended and nothing more came for a poll period: that was all.
            None if all_finished => return Err(SupervisedError::NeverEnded(open)),
            None => {}
        }
        if last_poll.elapsed() >= POLL_PERIOD {
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
                if let Event::Exited { name, .. } = &event {
                    for &topic in topics.outputs.get(name).into_iter().flatten() {
                        end(topic).map_err(|source| SupervisedError::EndStreams {
                            name: name.clone(),
                            source,
                        })?;
                        open.retain(|t| *t != topic);
                    }
                }
                on_event(&event);
            }
            all_finished = supervisor.all_finished();
        }
    }
    Ok(())
}
