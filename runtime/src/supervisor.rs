//! Supervision of a graph's node processes, as ROS 2 launch does it: each process is watched;
//! one declared `respawn = true` that dies is started again after `respawn_delay_s`, at most
//! `max_restarts` times; one that is not respawnable (or has used up its restarts) stops the
//! graph with its name, exit status and last line on stderr, unless it is declared
//! `on_exit = "continue"` ([`OnExit::Continue`]): then it is reported ([`Event::Exited`]) and
//! the graph goes on without it (the launcher ends its output streams for it).
//!
//! A process that exits with status 0 has finished its work and is never restarted. Every line a
//! process writes to stderr is forwarded to ours prefixed `[name]`, and the last one is kept for
//! the error report.

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::io::BufRead;
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// What a process's death does to the graph once it may not (or may no more) be restarted
/// (`on_exit` of a launch file's node or include).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Deserialize, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum OnExit {
    /// The graph stops, naming the process (the default: a node the graph needs is gone).
    #[default]
    Stop,
    /// The graph goes on without it: one agent of several, whose loss the others survive.
    Continue,
}

/// What to do when a process dies.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RestartPolicy {
    /// Start it again when it dies (exits with a nonzero status or by a signal).
    pub respawn: bool,
    /// Wait this long before starting it again.
    pub respawn_delay: Duration,
    /// Restarts allowed; past them, a death stops the graph (or, with [`OnExit::Continue`],
    /// ends the process's part in it).
    pub max_restarts: u32,
    /// What a death that is not restarted does.
    pub on_exit: OnExit,
}

impl Default for RestartPolicy {
    fn default() -> Self {
        Self {
            respawn: false,
            respawn_delay: Duration::from_secs(1),
            max_restarts: 3,
            on_exit: OnExit::Stop,
        }
    }
}

/// One process to run.
#[derive(Debug, Clone)]
pub struct ProcessSpec {
    /// Name in reports (the node's instance name).
    pub name: String,
    /// Executable.
    pub program: PathBuf,
    /// Arguments of the first start.
    pub args: Vec<OsString>,
    /// Arguments of a restart (e.g. without waiting for a start signal already given).
    pub restart_args: Vec<OsString>,
    /// Restart policy.
    pub restart: RestartPolicy,
}

/// Why supervision stopped the graph.
#[derive(Debug, thiserror::Error)]
pub enum SupervisorError {
    /// A process could not be started.
    #[error("starting node process {name}: {source}")]
    Spawn {
        /// Node name.
        name: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// A process died and may not (or may no more) be restarted.
    #[error("node '{name}' exited with {status}{restarts}: {last_line}")]
    Died {
        /// Node name.
        name: String,
        /// Its exit status.
        status: ExitStatus,
        /// ", after N restarts" when it had been restarted.
        restarts: String,
        /// Its last line on stderr.
        last_line: String,
    },
}

/// Something supervision did that the run should report.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Event {
    /// A respawnable process died and was started again.
    Restarted {
        /// Node name.
        name: String,
        /// How it died, e.g. "signal: 9 (SIGKILL)".
        status: String,
        /// Restarts so far, this one included.
        restarts: u32,
    },
    /// A process declared [`OnExit::Continue`] died and is not restarted: the graph goes on
    /// without it.
    Exited {
        /// Node name.
        name: String,
        /// How it died, e.g. "signal: 9 (SIGKILL)".
        status: String,
    },
}

struct Supervised {
    spec: ProcessSpec,
    child: Option<Child>,
    last_line: Arc<Mutex<String>>,
    restarts: u32,
    /// When a dead respawnable process is due to start again.
    restart_at: Option<(Instant, String)>,
    finished: bool,
    /// How it died, when it died for good and the graph went on ([`OnExit::Continue`]).
    exited: Option<String>,
}

/// The processes of a graph under supervision.
pub struct Supervisor {
    processes: Vec<Supervised>,
}

impl std::fmt::Debug for Supervisor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Supervisor")
            .field("processes", &self.processes.len())
            .finish()
    }
}

fn start(
    spec: &ProcessSpec,
    args: &[OsString],
    last_line: &Arc<Mutex<String>>,
) -> std::io::Result<Child> {
    let mut child = Command::new(&spec.program)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()?;
    if let Some(stderr) = child.stderr.take() {
        let last = last_line.clone();
        let prefix = spec.name.clone();
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(stderr)
                .lines()
                .map_while(Result::ok)
            {
                eprintln!("[{prefix}] {line}");
                *last.lock().unwrap_or_else(|e| e.into_inner()) = line;
            }
        });
    }
    Ok(child)
}

impl Supervisor {
    /// Starts every process; if one cannot start, the ones started are killed.
    pub fn start(specs: Vec<ProcessSpec>) -> Result<Self, SupervisorError> {
        let mut supervisor = Self {
            processes: Vec::new(),
        };
        for spec in specs {
            let last_line = Arc::new(Mutex::new(String::new()));
            match start(&spec, &spec.args, &last_line) {
                Ok(child) => supervisor.processes.push(Supervised {
                    spec,
                    child: Some(child),
                    last_line,
                    restarts: 0,
                    restart_at: None,
                    finished: false,
                    exited: None,
                }),
                Err(source) => {
                    supervisor.kill_all();
                    return Err(SupervisorError::Spawn {
                        name: spec.name,
                        source,
                    });
                }
            }
        }
        Ok(supervisor)
    }

    /// Looks at every process once, without blocking: restarts the respawnable ones that died
    /// (once their delay has passed) and reports a death that must stop the graph.
    pub fn poll(&mut self) -> Result<Vec<Event>, SupervisorError> {
        self.poll_with(&|_| Vec::new())
    }

    /// [`Supervisor::poll`], adding `extra(name)` to a restart's arguments (what the process
    /// must know of the run so far, e.g. which of its inputs have already ended).
    pub fn poll_with(
        &mut self,
        extra: &dyn Fn(&str) -> Vec<OsString>,
    ) -> Result<Vec<Event>, SupervisorError> {
        let mut events = Vec::new();
        for process in &mut self.processes {
            if let Some(child) = &mut process.child {
                let Ok(Some(status)) = child.try_wait() else {
                    continue;
                };
                process.child = None;
                if status.success() {
                    process.finished = true;
                    continue;
                }
                let policy = process.spec.restart;
                let gone = !policy.respawn || process.restarts >= policy.max_restarts;
                if gone && policy.on_exit == OnExit::Continue {
                    // Done with, as one that finished: the graph goes on without it.
                    process.finished = true;
                    process.exited = Some(status.to_string());
                    tracing::warn!(
                        node = process.spec.name,
                        "node process died ({status}); on_exit = \"continue\": the graph goes on \
                         without it"
                    );
                    events.push(Event::Exited {
                        name: process.spec.name.clone(),
                        status: status.to_string(),
                    });
                    continue;
                }
                if gone {
                    // Let the stderr forwarder catch the last line.
                    std::thread::sleep(Duration::from_millis(50));
                    let last_line = process
                        .last_line
                        .lock()
                        .unwrap_or_else(|e| e.into_inner())
                        .clone();
                    return Err(SupervisorError::Died {
                        name: process.spec.name.clone(),
                        status,
                        restarts: if process.restarts > 0 {
                            format!(", after {} restarts", process.restarts)
                        } else {
                            String::new()
                        },
                        last_line,
                    });
                }
                let due = Instant::now()
                    .checked_add(policy.respawn_delay)
                    .unwrap_or_else(Instant::now);
                process.restart_at = Some((due, status.to_string()));
            }
            if let Some((due, status)) = process.restart_at.clone() {
                if Instant::now() < due {
                    continue;
                }
                process.restart_at = None;
                let mut args = process.spec.restart_args.clone();
                args.extend(extra(&process.spec.name));
                let child = start(&process.spec, &args, &process.last_line).map_err(|source| {
                    SupervisorError::Spawn {
                        name: process.spec.name.clone(),
                        source,
                    }
                })?;
                process.child = Some(child);
                process.restarts += 1;
                tracing::warn!(
                    node = process.spec.name,
                    restarts = process.restarts,
                    "node process died ({status}); restarted"
                );
                events.push(Event::Restarted {
                    name: process.spec.name.clone(),
                    status,
                    restarts: process.restarts,
                });
            }
        }
        Ok(events)
    }

    /// Processes that died for good while the graph went on ([`OnExit::Continue`]), and how.
    pub fn exited(&self) -> BTreeMap<String, String> {
        self.processes
            .iter()
            .filter_map(|p| Some((p.spec.name.clone(), p.exited.clone()?)))
            .collect()
    }

    /// Whether every process has finished: with status 0, or died for good with
    /// [`OnExit::Continue`].
    pub fn all_finished(&self) -> bool {
        self.processes.iter().all(|p| p.finished)
    }

    /// Polls until every process has finished (or `timeout` passes: then `Ok(false)`).
    pub fn wait_all(&mut self, timeout: Duration) -> Result<bool, SupervisorError> {
        let deadline = Instant::now().checked_add(timeout);
        loop {
            self.poll()?;
            if self.all_finished() {
                return Ok(true);
            }
            if deadline.is_some_and(|d| Instant::now() >= d) {
                return Ok(false);
            }
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    /// Restarts per process name (only those restarted).
    pub fn restarts(&self) -> BTreeMap<String, u32> {
        self.processes
            .iter()
            .filter(|p| p.restarts > 0)
            .map(|p| (p.spec.name.clone(), p.restarts))
            .collect()
    }

    /// The OS process id of `name`'s current process, if it runs.
    pub fn pid(&self, name: &str) -> Option<u32> {
        self.processes
            .iter()
            .find(|p| p.spec.name == name)
            .and_then(|p| p.child.as_ref())
            .map(Child::id)
    }

    /// Kills every process still running and reaps it.
    pub fn kill_all(&mut self) {
        for process in &mut self.processes {
            process.restart_at = None;
            if let Some(mut child) = process.child.take() {
                let _ = child.kill();
                let _ = child.wait();
            }
        }
    }
}

impl Drop for Supervisor {
    fn drop(&mut self) {
        self.kill_all();
    }
}

#[cfg(all(test, unix))]
mod tests {
    use super::*;

    fn shell(
        name: &str,
        script: &str,
        restart_script: &str,
        restart: RestartPolicy,
    ) -> ProcessSpec {
        ProcessSpec {
            name: name.into(),
            program: "/bin/sh".into(),
            args: vec!["-c".into(), script.into()],
            restart_args: vec!["-c".into(), restart_script.into()],
            restart,
        }
    }

    #[test]
    fn a_respawnable_process_that_dies_is_restarted_and_the_graph_goes_on() {
        let respawn = RestartPolicy {
            respawn: true,
            respawn_delay: Duration::from_millis(50),
            max_restarts: 2,
            ..RestartPolicy::default()
        };
        let mut supervisor = Supervisor::start(vec![
            shell("flaky", "echo dying >&2; kill -9 $$", "exit 0", respawn),
            shell("steady", "sleep 0.3", "exit 1", RestartPolicy::default()),
        ])
        .unwrap();
        assert!(supervisor.wait_all(Duration::from_secs(10)).unwrap());
        assert_eq!(supervisor.restarts(), BTreeMap::from([("flaky".into(), 1)]));
    }

    #[test]
    fn a_process_that_may_not_respawn_stops_the_graph_with_its_name_and_status() {
        let mut supervisor = Supervisor::start(vec![
            shell(
                "mapper",
                "echo 'cannot map' >&2; exit 3",
                "",
                RestartPolicy::default(),
            ),
            shell("slow", "sleep 30", "", RestartPolicy::default()),
        ])
        .unwrap();
        let started = Instant::now();
        let error = supervisor.wait_all(Duration::from_secs(10)).unwrap_err();
        assert!(
            started.elapsed() < Duration::from_secs(2),
            "{:?}",
            started.elapsed()
        );
        let text = error.to_string();
        assert!(
            text.starts_with("node 'mapper' exited with exit status: 3"),
            "{text}"
        );
        assert!(text.ends_with("cannot map"), "{text}");
        supervisor.kill_all();
        assert_eq!(supervisor.pid("slow"), None);
    }

    #[test]
    fn a_process_that_may_continue_is_reported_and_the_graph_goes_on() {
        let go_on = RestartPolicy {
            on_exit: OnExit::Continue,
            ..RestartPolicy::default()
        };
        let respawn_then_go_on = RestartPolicy {
            respawn: true,
            respawn_delay: Duration::ZERO,
            max_restarts: 1,
            on_exit: OnExit::Continue,
        };
        let mut supervisor = Supervisor::start(vec![
            shell("agent", "kill -9 $$", "", go_on),
            shell("flaky", "exit 4", "exit 5", respawn_then_go_on),
            shell("steady", "sleep 0.3", "", RestartPolicy::default()),
        ])
        .unwrap();
        let mut events = Vec::new();
        let deadline = Instant::now() + Duration::from_secs(10);
        while !supervisor.all_finished() && Instant::now() < deadline {
            events.extend(supervisor.poll().unwrap());
            std::thread::sleep(Duration::from_millis(20));
        }
        assert!(supervisor.all_finished());
        assert!(
            events.contains(&Event::Exited {
                name: "agent".into(),
                status: "signal: 9 (SIGKILL)".into()
            }),
            "{events:?}"
        );
        // Restarted once, then gone for good with its restart's status.
        assert_eq!(supervisor.restarts(), BTreeMap::from([("flaky".into(), 1)]));
        assert_eq!(
            supervisor.exited(),
            BTreeMap::from([
                ("agent".into(), "signal: 9 (SIGKILL)".into()),
                ("flaky".into(), "exit status: 5".into()),
            ])
        );
    }

    #[test]
    fn restarts_are_limited() {
        let respawn = RestartPolicy {
            respawn: true,
            respawn_delay: Duration::ZERO,
            max_restarts: 2,
            ..RestartPolicy::default()
        };
        let mut supervisor =
            Supervisor::start(vec![shell("crashy", "exit 7", "exit 7", respawn)]).unwrap();
        let error = supervisor.wait_all(Duration::from_secs(10)).unwrap_err();
        assert!(
            error
                .to_string()
                .contains("exit status: 7, after 2 restarts"),
            "{error}"
        );
    }

    #[test]
    fn a_program_that_cannot_start_is_named() {
        let error = Supervisor::start(vec![ProcessSpec {
            name: "ghost".into(),
            program: "/nonexistent/nrslam".into(),
            args: Vec::new(),
            restart_args: Vec::new(),
            restart: RestartPolicy::default(),
        }])
        .unwrap_err();
        assert!(
            error.to_string().starts_with("starting node process ghost"),
            "{error}"
        );
    }
}
