//! The fusion algorithm: several agents' keyframes into one pose graph and one map frame.
//!
//! The paper's SLAM system (its Fig. 2) names four modules; this is the one it leaves to future
//! work ("multi-point cooperative sensing will be adopted to improve the SLAM performance"). Each
//! agent is either an AGV, which runs its own chain (radar, estimator, association) and sends its
//! keyframes in its own frame, or a fixed sensing station, whose surveyed pose is in the map frame.
//!
//! - **Frames.** An AGV with a known start pose (the first `known_starts`) and every station are
//!   *aligned* from the start: their frame is the map's. Any other AGV's frame is unknown; it is
//!   found by place recognition and the AGV is merged once `confirmations` matches agree on it.
//! - **Place recognition.** Every `match_every_keyframes` keyframes, an AGV's query (its last
//!   `query_keyframes` keyframes in the middle one's frame, as the single-AGV loop closure builds
//!   it) is matched with the loop closure's correlative branch-and-bound search, ICP refinement and
//!   verification ([`nrslam_association::match_loop`]). An unaligned AGV searches the whole
//!   aligned map at once (every rotation, the map's extent): one search per query, however many
//!   agents and keyframes the map holds. An aligned AGV searches only other agents' points near
//!   its fused pose, within `local_radius_m`: these matches become inter-agent edges.
//! - **Re-checked merges.** A merged AGV searches the other agents' map for its newest place
//!   again every `verify_every_keyframes` keyframes. Where a hall repeats itself its first
//!   matches can all agree on a twin of its place; when later matches agree on another place
//!   where the AGV contradicts the others' map less (both ways: its detections on their free
//!   floor, their targets on its free floor), it is moved there and its inter-agent edges made
//!   at the twin are dropped.
//! - **Pose graph.** One graph over every aligned keyframe of every agent: each AGV's consecutive
//!   keyframes joined by the motion its own SLAM estimated (its intra-agent loops are already in
//!   that estimate, and are added as edges too), inter-agent and station edges from the matches,
//!   stations fixed at their surveyed poses and known-start AGVs' first keyframes fixed. It is
//!   re-solved ([`PoseGraph::optimise`]) when its structure changes (an edge, a merge, an agent's
//!   own loop closure); otherwise a new keyframe is chained onto its predecessor's fused pose.
//! - **Restarts.** An AGV whose SLAM started over ([`Fusion::start_new_session`]; the node
//!   tells it from a keyframe id not after the last at a later stamp): its keyframes so far
//!   become an agent of their own, kept in the map, and the AGV is merged again from an unknown
//!   frame ([`MAX_RESTARTS`] per AGV, then its inputs are refused).
//!
//! Everything is deterministic: agents are visited in index order and the matcher breaks ties.

use nrslam_association::pose_graph::RobustKernel;
use nrslam_association::{match_loop, Edge, EdgeKind, OptimiserSettings, Pose2, PoseGraph};

use crate::params::Params;

/// A query of an agent's newest keyframes: (anchor keyframe index, points in its frame, and for
/// each point the position of the sensor that saw it, in the same frame).
type Query = (usize, Vec<[f64; 2]>, Vec<[f64; 2]>);

/// What kind of sensing point an agent is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AgentKind {
    /// A moving AGV with its own SLAM; `known_start`: its frame is the map's.
    Agv {
        /// Its odometry starts at its true pose in the map frame.
        known_start: bool,
    },
    /// A fixed station at a surveyed pose in the map frame.
    Station,
}

/// One keyframe of one agent.
#[derive(Debug, Clone)]
struct AgentKeyframe {
    /// The agent's own id for it.
    local_id: u32,
    /// Its pose in the agent's frame, the agent's latest estimate.
    local_pose: Pose2,
    /// Detections in the sensor body frame (m).
    points_body_m: Vec<[f64; 2]>,
    /// Distance the agent had travelled at this keyframe, by its own estimate (m).
    travelled_m: f64,
    /// Its pose in the map frame once the agent is aligned.
    fused: Option<Pose2>,
    /// Its id in the fused graph once published.
    global_id: Option<u32>,
    /// Its pose as of the last published revision (what the map was last built with).
    published: Option<Pose2>,
    /// The pose it was integrated at into the whole-map search's occupancy grid.
    in_occupancy: Option<Pose2>,
}

/// A verified match between agents: an edge of the fused graph.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterEdge {
    /// Agent and keyframe index of the older end (the matched map's keyframe).
    pub from: (usize, usize),
    /// Agent and keyframe index of the query keyframe.
    pub to: (usize, usize),
    /// Pose of `to` in `from`'s frame.
    pub relative: Pose2,
}

/// A candidate frame of an unaligned agent, waiting for a second match to confirm it.
#[derive(Debug, Clone, Copy)]
struct Candidate {
    /// Map-from-agent transform the match implies.
    frame: Pose2,
    edge: InterEdge,
}

#[derive(Debug, Clone)]
struct Agent {
    kind: AgentKind,
    keyframes: Vec<AgentKeyframe>,
    /// Map-from-agent transform; `None` until aligned.
    frame: Option<Pose2>,
    candidates: Vec<Candidate>,
    /// An aligned agent's latest inter-agent match that disagreed with the graph, waiting for
    /// the next to confirm it: (correction in its query keyframe's frame, the edge).
    pending_local: Option<(Pose2, InterEdge)>,
    /// The agent's own loop edges: (older local id, newer local id, relative pose).
    loops: Vec<(u32, u32, Pose2)>,
    /// Keyframes added since the last query.
    since_query: u32,
    /// Merged by place recognition (not aligned from the start): its merge is re-checked.
    merged_by_search: bool,
    /// Keyframes added since its merge was last re-checked.
    since_verify: u32,
    /// Keyframes between its re-checks: `verify_every_keyframes`, doubled by each re-check that
    /// finds it where the graph holds it (up to [`MAX_VERIFY_BACKOFF`] times), back to
    /// `verify_every_keyframes` when one finds it elsewhere.
    verify_interval: u32,
    /// Re-check matches that put the agent elsewhere than the graph holds it, waiting for
    /// others to agree.
    rechecks: Vec<Candidate>,
    /// Station frames since the last station keyframe.
    station_frames: u32,
    /// Times its back end restarted (its earlier sessions are agents of their own).
    restarts: u32,
    /// It restarted more than [`MAX_RESTARTS`] times: every later input of it is refused.
    cut_off: bool,
}

impl Agent {
    fn new(kind: AgentKind, verify_interval: u32) -> Self {
        Agent {
            kind,
            keyframes: Vec::new(),
            frame: match kind {
                AgentKind::Agv { known_start: false } => None,
                _ => Some(Pose2::new(0.0, 0.0, 0.0)),
            },
            candidates: Vec::new(),
            pending_local: None,
            loops: Vec::new(),
            since_query: 0,
            merged_by_search: false,
            since_verify: 0,
            verify_interval,
            rechecks: Vec::new(),
            station_frames: 0,
            restarts: 0,
            cut_off: false,
        }
    }
}

/// Restarts of one AGV's back end that fusion follows; at the next, every later input of that
/// AGV is refused ([`FusionError::TooManyRestarts`]), so that a sender that keeps starting over
/// cannot grow the graph by a session a keyframe.
pub const MAX_RESTARTS: u32 = 16;

/// Counters of what fusion did, for the run's report and the benches.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct FusionStats {
    /// Whole-map searches of unaligned agents.
    pub global_searches: u64,
    /// Local searches of aligned agents for inter-agent edges.
    pub local_searches: u64,
    /// Query points scored against a submap, summed over searches (what the search costs).
    pub query_points_scored: u64,
    /// Verified matches of an unaligned agent (candidates of its frame).
    pub candidates: u64,
    /// Agents merged into the map frame by place recognition.
    pub merges: u64,
    /// Merges refused because the agent's detections fell on floor the map saw free.
    pub refused_merges: u64,
    /// Whole-map searches of merged agents, re-checking their merge.
    pub verify_searches: u64,
    /// Merges undone and made again elsewhere: confirmed matches put the agent somewhere its
    /// detections contradict the map less.
    pub remerges: u64,
    /// Confirmed merges put off because an earlier match named a place that fits the map
    /// better both ways.
    pub merges_deferred: u64,
    /// Verified matches refused because they paired detections seen from opposite sides.
    pub opposite_views: u64,
    /// Inter-agent (and station) edges in the graph.
    pub inter_edges: u64,
    /// Pose-graph solves.
    pub optimisations: u64,
    /// AGV back ends that started over ([`Fusion::start_new_session`]): each earlier session
    /// stays in the map and the new one is merged afresh.
    pub restarts: u64,
}

impl FusionStats {
    /// Every counter by name (the names of the fields), for reports.
    pub fn counters(&self) -> [(&'static str, u64); 13] {
        [
            ("global_searches", self.global_searches),
            ("local_searches", self.local_searches),
            ("query_points_scored", self.query_points_scored),
            ("candidates", self.candidates),
            ("merges", self.merges),
            ("refused_merges", self.refused_merges),
            ("verify_searches", self.verify_searches),
            ("remerges", self.remerges),
            ("merges_deferred", self.merges_deferred),
            ("opposite_views", self.opposite_views),
            ("inter_edges", self.inter_edges),
            ("optimisations", self.optimisations),
            ("restarts", self.restarts),
        ]
    }
}

/// What one input changed, for the node to publish.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Update {
    /// Keyframes newly placed in the map frame, (agent, keyframe index), in publication order.
    pub published: Vec<(usize, usize)>,
    /// The fused poses of earlier keyframes moved (the graph was re-solved).
    pub corrected: bool,
}

/// The fusion state.
#[derive(Debug, Clone)]
pub struct Fusion {
    params: Params,
    agents: Vec<Agent>,
    edges: Vec<InterEdge>,
    next_global_id: u32,
    /// Pose-graph solves so far: the published revision.
    revision: u32,
    stats: FusionStats,
    /// The occupancy grid of the aligned keyframes and how many of each agent's keyframes it
    /// holds; dropped when the graph is re-solved (every keyframe may have moved).
    occupied: Option<(nrslam_mapper::OccupancyMap, Vec<usize>)>,
}

/// Why an input was refused (the node drops and counts it).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FusionError {
    /// No agent with this index.
    #[error("no agent {0}")]
    UnknownAgent(usize),
    /// A pose or point is NaN or infinite.
    #[error("non-finite {0}")]
    NonFinite(&'static str),
    /// A keyframe id not after the agent's last one.
    #[error("keyframe id {id} is not after the agent's last one ({last})")]
    OutOfOrder {
        /// The refused id.
        id: u32,
        /// The last accepted id.
        last: u32,
    },
    /// The input is for the other kind of agent.
    #[error("agent {0} is not of the kind this input is for")]
    WrongKind(usize),
    /// An input of an AGV whose back end started over more than [`MAX_RESTARTS`] times.
    #[error("agent {0} started over more than {MAX_RESTARTS} times: its inputs are refused")]
    TooManyRestarts(usize),
}

impl Fusion {
    /// Fusion of `params.agvs` AGVs (agents 0..agvs) then `params.stations` stations.
    pub fn new(params: Params) -> Self {
        let agv = |i: u32| AgentKind::Agv {
            known_start: i < params.known_starts,
        };
        let agents = (0..params.agvs)
            .map(agv)
            .chain((0..params.stations).map(|_| AgentKind::Station))
            .map(|kind| Agent::new(kind, params.verify_every_keyframes))
            .collect();
        Fusion {
            params,
            agents,
            edges: Vec::new(),
            next_global_id: 0,
            revision: 0,
            stats: FusionStats::default(),
            occupied: None,
        }
    }

    /// The parameters.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Number of agents (AGVs then stations).
    pub fn agent_count(&self) -> usize {
        self.agents.len()
    }

    /// What fusion did so far.
    pub fn stats(&self) -> FusionStats {
        self.stats
    }

    /// Pose-graph revision: changes whenever published poses were corrected.
    pub fn revision(&self) -> u32 {
        self.revision
    }

    /// The inter-agent edges in the graph.
    pub fn inter_edges(&self) -> &[InterEdge] {
        &self.edges
    }

    /// Whether `agent`'s frame is known in the map frame.
    pub fn is_aligned(&self, agent: usize) -> bool {
        self.agents.get(agent).is_some_and(|a| a.frame.is_some())
    }

    /// Map-from-agent transform of `agent`, once aligned.
    pub fn frame_of(&self, agent: usize) -> Option<Pose2> {
        self.agents.get(agent).and_then(|a| a.frame)
    }

    /// Global id and fused pose of keyframe `index` of `agent`, once published.
    pub fn fused_keyframe(&self, agent: usize, index: usize) -> Option<(u32, Pose2)> {
        let k = self.agents.get(agent)?.keyframes.get(index)?;
        Some((k.global_id?, k.fused?))
    }

    /// Every published keyframe as (global id, fused pose), ascending id.
    pub fn fused_poses(&self) -> Vec<(u32, Pose2)> {
        let mut all: Vec<(u32, Pose2)> = self
            .agents
            .iter()
            .flat_map(|a| a.keyframes.iter())
            .filter_map(|k| Some((k.global_id?, k.fused?)))
            .collect();
        all.sort_by_key(|(id, _)| *id);
        all
    }

    /// Each inter-agent edge as (global id from, global id to, relative pose), once both ends are
    /// published.
    pub fn published_edges(&self) -> Vec<(u32, u32, Pose2)> {
        self.edges
            .iter()
            .filter_map(|e| {
                let (from, _) = self.fused_keyframe(e.from.0, e.from.1)?;
                let (to, _) = self.fused_keyframe(e.to.0, e.to.1)?;
                Some((from, to, e.relative))
            })
            .collect()
    }

    /// The agent's own id of its keyframe `index`.
    pub fn local_id(&self, agent: usize, index: usize) -> Option<u32> {
        Some(self.agents.get(agent)?.keyframes.get(index)?.local_id)
    }

    /// `local_pose` of `agent` (in its own frame, e.g. its latest SLAM pose) in the map frame:
    /// carried by the correction of its newest keyframe. `None` until the agent is aligned.
    pub fn corrected_pose(&self, agent: usize, local_pose: Pose2) -> Option<Pose2> {
        let a = self.agents.get(agent)?;
        if a.cut_off {
            return None;
        }
        let frame = a.frame?;
        match a.keyframes.iter().rev().find(|k| k.fused.is_some()) {
            Some(k) => Some(k.fused?.compose(&k.local_pose.between(&local_pose))),
            None => Some(frame.compose(&local_pose)),
        }
    }

    /// An AGV keyframe: `local_pose` in the agent's frame, detections in its body frame.
    pub fn add_keyframe(
        &mut self,
        agent: usize,
        local_id: u32,
        local_pose: Pose2,
        points_body_m: Vec<[f64; 2]>,
    ) -> Result<Update, FusionError> {
        let a = self.agent_of_kind(agent, false)?;
        check_input(&local_pose, &points_body_m)?;
        if let Some(last) = a.keyframes.last() {
            if local_id <= last.local_id {
                return Err(FusionError::OutOfOrder {
                    id: local_id,
                    last: last.local_id,
                });
            }
        }
        let mut update = Update::default();
        let index = self.push_keyframe(agent, local_id, local_pose, points_body_m);
        if self.agents[agent].frame.is_some() {
            self.place_new(agent, index, &mut update);
        }
        let a = &mut self.agents[agent];
        a.since_query += 1;
        let every = match a.frame {
            Some(_) => self.params.match_every_keyframes,
            None => self.params.global_every_keyframes,
        };
        if self.params.matching
            && a.since_query >= every
            && a.keyframes.len() >= self.params.query_keyframes as usize
        {
            a.since_query = 0;
            if a.frame.is_some() {
                self.match_aligned(agent, &mut update);
            } else {
                self.match_unaligned(agent, &mut update);
            }
        }
        let verify_every = self.params.verify_every_keyframes;
        let query_keyframes = self.params.query_keyframes as usize;
        let a = &mut self.agents[agent];
        if self.params.matching && verify_every > 0 && a.merged_by_search {
            a.since_verify += 1;
            if a.since_verify >= a.verify_interval && a.keyframes.len() >= query_keyframes {
                a.since_verify = 0;
                self.verify_merge(agent, &mut update);
            }
        }
        Ok(update)
    }

    /// The local id of `agent`'s newest keyframe (its current session's), if it has one.
    pub fn last_local_id(&self, agent: usize) -> Option<u32> {
        self.agents.get(agent)?.keyframes.last().map(|k| k.local_id)
    }

    /// Starts a new session of AGV `agent`, whose back end restarted (its keyframe ids began
    /// again; the node tells that from a keyframe id not after the last at a later stamp). Its
    /// keyframes so far become an agent of their own (returned: always the next index), which
    /// keeps their place in the map (if it had one), their global ids and every edge naming
    /// them, and gets no more input. The AGV starts again with no keyframe and an unknown
    /// frame, whatever its start was: a restarted SLAM starts from wherever its odometry is,
    /// and that frame is found by place recognition against the map, its own earlier session's
    /// included. `Ok(None)` when it had no keyframe yet (nothing to keep). Beyond
    /// [`MAX_RESTARTS`] the AGV is cut off: this and every later input of it is refused.
    pub fn start_new_session(&mut self, agent: usize) -> Result<Option<usize>, FusionError> {
        let a = self.agent_of_kind(agent, false)?;
        if a.restarts >= MAX_RESTARTS {
            self.agents[agent].cut_off = true;
            return Err(FusionError::TooManyRestarts(agent));
        }
        if a.keyframes.is_empty() {
            return Ok(None);
        }
        let slot = self.agents.len();
        let mut fresh = Agent::new(
            AgentKind::Agv { known_start: false },
            self.params.verify_every_keyframes,
        );
        fresh.restarts = self.agents[agent].restarts + 1;
        let mut earlier = std::mem::replace(&mut self.agents[agent], fresh);
        earlier.candidates.clear();
        earlier.pending_local = None;
        earlier.rechecks.clear();
        earlier.merged_by_search = false;
        // Every edge that names its keyframes now names the earlier session's: the graph's, and
        // those other agents hold as candidates or waiting matches.
        let repoint = |e: &mut InterEdge| {
            for end in [&mut e.from, &mut e.to] {
                if end.0 == agent {
                    end.0 = slot;
                }
            }
        };
        self.edges.iter_mut().for_each(repoint);
        for other in &mut self.agents {
            other
                .candidates
                .iter_mut()
                .chain(other.rechecks.iter_mut())
                .for_each(|c| repoint(&mut c.edge));
            if let Some((_, e)) = &mut other.pending_local {
                repoint(e);
            }
        }
        self.agents.push(earlier);
        // Its counts are per agent index: rebuilt with the new agent on the next search.
        self.occupied = None;
        self.stats.restarts += 1;
        tracing::info!(agent, session = slot, "an AGV's back end started over");
        Ok(Some(slot))
    }

    /// An AGV's own estimate of its keyframes (its `/slam/keyframe_poses`): local ids, poses and
    /// its loop edges (older id, newer id, relative pose). A changed estimate re-solves the graph.
    pub fn set_local_poses(
        &mut self,
        agent: usize,
        poses: &[(u32, Pose2)],
        loops: &[(u32, u32, Pose2)],
    ) -> Result<Update, FusionError> {
        self.agent_of_kind(agent, false)?;
        let a = &mut self.agents[agent];
        if poses.iter().any(|(_, p)| !p.is_finite()) || loops.iter().any(|(_, _, p)| !p.is_finite())
        {
            return Err(FusionError::NonFinite("keyframe pose"));
        }
        // A back end's estimate holds every keyframe it sent: one that ends before the agent's
        // newest is from a back end that started over (its keyframe 0 lost) or stale, and its
        // ids are not this session's.
        if let (Some(last), Some(newest)) = (a.keyframes.last(), poses.last()) {
            if newest.0 < last.local_id {
                return Err(FusionError::OutOfOrder {
                    id: newest.0,
                    last: last.local_id,
                });
            }
        }
        let mut moved = false;
        for (id, pose) in poses {
            if let Ok(i) = a.keyframes.binary_search_by_key(id, |k| k.local_id) {
                let k = &mut a.keyframes[i];
                if k.local_pose.distance_m(pose) > 1e-6 || k.local_pose.rotation_to_rad(pose) > 1e-9
                {
                    k.local_pose = *pose;
                    moved = true;
                }
            }
        }
        let loops_changed = a.loops != loops;
        a.loops = loops.to_vec();
        let mut update = Update::default();
        if (moved || loops_changed) && a.frame.is_some() {
            update.corrected = self.optimise();
        }
        Ok(update)
    }

    /// One frame of a station: its surveyed pose (map frame) and detections in its body frame.
    /// Every `station_keyframe_every` frames this is a keyframe, published at once (a station is
    /// aligned by its survey).
    pub fn add_station_frame(
        &mut self,
        agent: usize,
        pose: Pose2,
        points_body_m: Vec<[f64; 2]>,
    ) -> Result<Update, FusionError> {
        let every = self.params.station_keyframe_every;
        self.agent_of_kind(agent, true)?;
        check_input(&pose, &points_body_m)?;
        let a = &mut self.agents[agent];
        let mut update = Update::default();
        let due = a.station_frames.is_multiple_of(every);
        a.station_frames += 1;
        if due {
            let local_id = a.keyframes.last().map_or(0, |k| k.local_id + 1);
            let index = self.push_keyframe(agent, local_id, pose, points_body_m);
            self.place_new(agent, index, &mut update);
        }
        Ok(update)
    }

    /// Agent `agent`, if it is a station when `station`, else an AGV.
    fn agent_of_kind(&self, agent: usize, station: bool) -> Result<&Agent, FusionError> {
        let a = self
            .agents
            .get(agent)
            .ok_or(FusionError::UnknownAgent(agent))?;
        if (a.kind == AgentKind::Station) != station {
            return Err(FusionError::WrongKind(agent));
        }
        if a.cut_off {
            return Err(FusionError::TooManyRestarts(agent));
        }
        Ok(a)
    }

    fn push_keyframe(
        &mut self,
        agent: usize,
        local_id: u32,
        local_pose: Pose2,
        points_body_m: Vec<[f64; 2]>,
    ) -> usize {
        let a = &mut self.agents[agent];
        let travelled_m = a.keyframes.last().map_or(0.0, |k| {
            k.travelled_m + k.local_pose.distance_m(&local_pose)
        });
        a.keyframes.push(AgentKeyframe {
            local_id,
            local_pose,
            points_body_m,
            travelled_m,
            fused: None,
            global_id: None,
            published: None,
            in_occupancy: None,
        });
        a.keyframes.len() - 1
    }

    /// Places keyframe `index` of an aligned agent: chained onto its predecessor's fused pose.
    fn place_new(&mut self, agent: usize, index: usize, update: &mut Update) {
        let a = &mut self.agents[agent];
        let Some(frame) = a.frame else { return };
        let fused = match index.checked_sub(1).map(|p| &a.keyframes[p]) {
            Some(AgentKeyframe {
                fused: Some(prev_fused),
                local_pose: prev_local,
                ..
            }) if a.kind != AgentKind::Station => {
                prev_fused.compose(&prev_local.between(&a.keyframes[index].local_pose))
            }
            _ => frame.compose(&a.keyframes[index].local_pose),
        };
        let k = &mut a.keyframes[index];
        k.fused = Some(fused);
        k.published = Some(fused);
        k.global_id = Some(self.next_global_id);
        self.next_global_id += 1;
        update.published.push((agent, index));
    }

    /// The query of `agent`'s newest keyframes: (anchor keyframe index, points in its frame,
    /// and for each point the position of the sensor that saw it, in the same frame).
    fn query(&self, agent: usize) -> Query {
        let a = &self.agents[agent];
        let last = a.keyframes.len() - 1;
        let first = (last + 1).saturating_sub(self.params.query_keyframes as usize);
        let anchor = (first + last) / 2;
        let to_anchor = a.keyframes[anchor].local_pose.inverse();
        let (mut points, mut sensors) = (Vec::new(), Vec::new());
        for k in &a.keyframes[first..=last] {
            let pose = to_anchor.compose(&k.local_pose);
            for p in &k.points_body_m {
                points.push(pose.transform_point(*p));
                sensors.push([pose.x_m, pose.y_m]);
            }
        }
        (anchor, points, sensors)
    }

    /// Of a match placing the query's anchor at `relative` (map frame) against `points` of the
    /// keyframes `owners`: (pairs, of which seen from opposite sides). A pair is a query point
    /// within the matcher's `inlier_distance_m` of its nearest map point; opposite when the lines
    /// of sight from the two sensors to the two points are more than 90° apart.
    fn opposite_views(
        &self,
        query: &[[f64; 2]],
        sensors: &[[f64; 2]],
        relative: &Pose2,
        points: &[[f64; 2]],
        owners: &[(usize, usize)],
    ) -> (usize, usize) {
        let mut map = nrslam_association::PointMap::new();
        map.extend(points);
        // Inputs were checked finite; should a transformed point not be, indices would shift.
        if map.len() != points.len() {
            return (0, 0);
        }
        let inlier_m2 = self.params.matcher.inlier_distance_m.powi(2);
        let (mut pairs, mut opposite) = (0, 0);
        for (q, s) in query.iter().zip(sensors) {
            let q = relative.transform_point(*q);
            let Some((index, d2)) = map.nearest_index(&q) else {
                continue;
            };
            if d2 > inlier_m2 {
                continue;
            }
            let (owner, keyframe) = owners[index];
            let Some(seen_from) = self.agents[owner].keyframes[keyframe].fused else {
                continue;
            };
            let s = relative.transform_point(*s);
            let m = points[index];
            let sight_q = [q[0] - s[0], q[1] - s[1]];
            let sight_m = [m[0] - seen_from.x_m, m[1] - seen_from.y_m];
            pairs += 1;
            if sight_q[0] * sight_m[0] + sight_q[1] * sight_m[1] < 0.0 {
                opposite += 1;
            }
        }
        (pairs, opposite)
    }

    /// True when the match must be refused as pairing opposite faces (`max_opposite_ratio`).
    fn sees_opposite_faces(
        &mut self,
        agent: usize,
        anchor: usize,
        query: (&[[f64; 2]], &[[f64; 2]]),
        relative: &Pose2,
        submap: (&[[f64; 2]], &[(usize, usize)]),
    ) -> bool {
        if self.params.max_opposite_ratio >= 1.0 {
            return false;
        }
        let (pairs, opposite) = self.opposite_views(query.0, query.1, relative, submap.0, submap.1);
        let ratio = opposite as f64 / pairs.max(1) as f64;
        tracing::debug!(agent, anchor, pairs, opposite, "views of a match");
        if ratio > self.params.max_opposite_ratio {
            self.stats.opposite_views += 1;
            tracing::debug!(
                agent,
                anchor,
                pairs,
                opposite,
                "match refused: opposite faces"
            );
            return true;
        }
        false
    }

    /// Points of every aligned agent but `except`, map frame, each with its (agent, keyframe);
    /// only keyframes within `range_m` of `near` when given.
    fn aligned_points(
        &self,
        except: usize,
        near: Option<(Pose2, f64)>,
    ) -> (Vec<[f64; 2]>, Vec<(usize, usize)>) {
        let mut points = Vec::new();
        let mut owners = Vec::new();
        for (i, a) in self.agents.iter().enumerate() {
            if i == except || a.frame.is_none() {
                continue;
            }
            for (j, k) in a.keyframes.iter().enumerate() {
                let Some(fused) = k.fused else { continue };
                if let Some((centre, range_m)) = near {
                    if fused.distance_m(&centre) > range_m {
                        continue;
                    }
                }
                for p in &k.points_body_m {
                    points.push(fused.transform_point(*p));
                    owners.push((i, j));
                }
            }
        }
        (points, owners)
    }

    /// Of `candidates` (agent, keyframe index), the placed keyframe nearest to `pose` (map
    /// frame): the one an edge from a match there hangs on.
    fn nearest_keyframe(
        &self,
        candidates: impl IntoIterator<Item = (usize, usize)>,
        pose: &Pose2,
    ) -> Option<(usize, usize)> {
        let mut best: Option<(f64, (usize, usize))> = None;
        for (i, j) in candidates {
            let Some(fused) = self.agents[i].keyframes[j].fused else {
                continue;
            };
            let d = fused.distance_m(pose);
            if best.is_none_or(|(bd, _)| d < bd) {
                best = Some((d, (i, j)));
            }
        }
        best.map(|(_, owner)| owner)
    }

    fn matcher_scan_params(&self) -> nrslam_association::Params {
        nrslam_association::Params {
            max_correspondence_m: self.params.matcher.refine_correspondence_m,
            ..self.params.scan.clone()
        }
    }

    /// The occupied cells of an occupancy grid of every aligned keyframe, map frame. The grid
    /// is kept between searches and takes only the keyframes placed since.
    fn aligned_occupied(&mut self) -> Vec<[f64; 2]> {
        // A grid built at poses the graph has since moved by more than a search cell is rebuilt;
        // smaller moves do not change what the coarse search finds.
        let stale = self
            .agents
            .iter()
            .flat_map(|a| a.keyframes.iter())
            .filter_map(|k| Some((k.fused?, k.in_occupancy?)))
            .any(|(f, at)| f.distance_m(&at) > self.params.matcher.search_step_m);
        if stale {
            self.occupied = None;
            for k in self.agents.iter_mut().flat_map(|a| a.keyframes.iter_mut()) {
                k.in_occupancy = None;
            }
        }
        if self.occupied.is_none() {
            let Ok(map) = nrslam_mapper::OccupancyMap::new(&self.params.map) else {
                return Vec::new();
            };
            self.occupied = Some((map, vec![0; self.agents.len()]));
        }
        let Some((map, integrated)) = self.occupied.as_mut() else {
            return Vec::new();
        };
        for (a, done) in self.agents.iter_mut().zip(integrated.iter_mut()) {
            for k in &mut a.keyframes[*done..] {
                let Some(fused) = k.fused else { break };
                k.in_occupancy = Some(fused);
                integrate_keyframe(map, &fused, &k.points_body_m);
                *done += 1;
            }
        }
        occupied_cells(map, self.params.occupied_percent)
    }

    /// An occupancy grid of every aligned keyframe but `agent`'s, at their fused poses: what the
    /// others saw, against which `agent`'s merge is re-checked.
    fn occupancy_without(&self, agent: usize) -> Option<nrslam_mapper::OccupancyMap> {
        let keyframes = self
            .agents
            .iter()
            .enumerate()
            .filter(|(i, a)| *i != agent && a.frame.is_some())
            .flat_map(|(_, a)| a.keyframes.iter())
            .filter_map(|k| Some((k.fused?, &k.points_body_m[..])));
        self.occupancy(keyframes)
    }

    /// An occupancy grid of `keyframes` (pose in the map frame, detections in the body frame).
    fn occupancy<'k>(
        &self,
        keyframes: impl Iterator<Item = (Pose2, &'k [[f64; 2]])>,
    ) -> Option<nrslam_mapper::OccupancyMap> {
        let mut map = nrslam_mapper::OccupancyMap::new(&self.params.map).ok()?;
        for (pose, body) in keyframes {
            integrate_keyframe(&mut map, &pose, body);
        }
        Some(map)
    }

    /// `agent`'s keyframes placed by `place` (map frame), with their detections (body frame);
    /// those `place` leaves out are skipped.
    fn placed<'a>(
        &'a self,
        agent: usize,
        place: impl Fn(&AgentKeyframe) -> Option<Pose2> + 'a,
    ) -> impl Iterator<Item = (Pose2, &'a [[f64; 2]])> + 'a {
        self.agents[agent]
            .keyframes
            .iter()
            .filter_map(move |k| Some((place(k)?, &k.points_body_m[..])))
    }

    /// `agent`'s detections placed by `place`, map frame.
    fn placed_detections<'a>(
        &'a self,
        agent: usize,
        place: impl Fn(&AgentKeyframe) -> Option<Pose2> + 'a,
    ) -> impl Iterator<Item = [f64; 2]> + 'a {
        self.placed(agent, place)
            .flat_map(|(pose, body)| body.iter().map(move |p| pose.transform_point(*p)))
    }

    /// How well `agent` placed by `place` fits what the others saw (`others`, their grid, and
    /// `others_occupied`, its occupied cells), both ways: (support, conflict) of its detections
    /// in the others' grid plus those of the others' occupied cells in a grid of its own
    /// keyframes so placed. The second way catches what the first cannot: a look-alike place
    /// where the others saw a target the agent, so placed, looked straight through.
    fn fit_both_ways(
        &self,
        others: &nrslam_mapper::OccupancyMap,
        others_occupied: &[[f64; 2]],
        agent: usize,
        place: impl Fn(&AgentKeyframe) -> Option<Pose2> + Copy,
    ) -> (usize, usize) {
        let forward = self.free_space_check(others, self.placed_detections(agent, place));
        let Some(own) = self.occupancy(self.placed(agent, place)) else {
            return forward;
        };
        let reverse = self.free_space_check(&own, others_occupied.iter().copied());
        (forward.0 + reverse.0, forward.1 + reverse.1)
    }

    /// Of `points` (map frame) in `map`: (within `conflict_distance_m` of an occupied cell, on a
    /// cell seen free with no occupied cell that near). A 5G detection is blurred across its
    /// beam by a metre, so only a detection far from every outline the map holds contradicts
    /// it; cells nobody observed count neither way.
    fn free_space_check(
        &self,
        map: &nrslam_mapper::OccupancyMap,
        points: impl Iterator<Item = [f64; 2]>,
    ) -> (usize, usize) {
        let data = map.occupancy_data();
        let width = map.width_cells();
        let height = map.height_cells();
        let occupied = i8::try_from(self.params.occupied_percent).unwrap_or(i8::MAX);
        let free = i8::try_from(self.params.free_percent).unwrap_or(0);
        let reach = (self.params.conflict_distance_m / map.resolution_m()).ceil() as usize;
        let reach2 = (reach * reach) as i64;
        let near_occupied = |column: usize, row: usize| {
            let rows = row.saturating_sub(reach)..=(row + reach).min(height - 1);
            rows.into_iter().any(|r| {
                let columns = column.saturating_sub(reach)..=(column + reach).min(width - 1);
                columns.into_iter().any(|c| {
                    let (dc, dr) = (c as i64 - column as i64, r as i64 - row as i64);
                    dc * dc + dr * dr <= reach2 && data[r * width + c] >= occupied
                })
            })
        };
        let (mut support, mut conflict) = (0, 0);
        for [x, y] in points {
            let Some((column, row)) = map.cell_of(x, y) else {
                continue;
            };
            let percent = data[row * width + column];
            if percent < 0 {
                continue;
            }
            if near_occupied(column, row) {
                support += 1;
            } else if percent <= free {
                conflict += 1;
            }
        }
        (support, conflict)
    }

    /// The aligned keyframe nearest to `pose`, other than `except`'s.
    fn nearest_aligned(&self, except: usize, pose: &Pose2) -> Option<(usize, usize)> {
        let candidates = self
            .agents
            .iter()
            .enumerate()
            .filter(|(i, _)| *i != except)
            .flat_map(|(i, a)| (0..a.keyframes.len()).map(move |j| (i, j)));
        self.nearest_keyframe(candidates, pose)
    }

    /// Searches all of `points` (map frame: every heading, the map's extent) for `agent`'s
    /// newest place: (its query, where the match put the query's anchor), or `None` when no
    /// match is verified.
    fn search_whole_map(&mut self, agent: usize, points: &[[f64; 2]]) -> Option<(Query, Pose2)> {
        let (anchor, query, sensors) = self.query(agent);
        let (lo, hi) = bounds(points);
        let centre = Pose2::new(0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.0);
        let half_diagonal_m = 0.5 * ((hi[0] - lo[0]).hypot(hi[1] - lo[1]));
        let radius_m = (half_diagonal_m + self.params.submap_range_m)
            .min(self.params.max_global_radius_m)
            .max(self.params.matcher.search_step_m);
        let matcher = nrslam_association::LoopClosureParams {
            max_search_rotation_deg: 180.0,
            search_step_deg: self.params.global_step_deg,
            max_ambiguity: self.params.global_max_ambiguity,
            ..self.params.matcher.clone()
        };
        self.stats.query_points_scored += query.len() as u64;
        match match_loop(
            &query,
            points,
            centre,
            radius_m,
            &matcher,
            &self.matcher_scan_params(),
        ) {
            Ok(found) => Some(((anchor, query, sensors), found.relative)),
            Err(reason) => {
                tracing::debug!(agent, anchor, ?reason, "whole-map match rejected");
                None
            }
        }
    }

    /// The candidate frame of `agent` a match placing its keyframe `anchor` at `found` (map
    /// frame) implies, its edge hung on the nearest keyframe of the other agents.
    fn candidate(&self, agent: usize, anchor: usize, found: &Pose2) -> Option<Candidate> {
        let owner = self.nearest_aligned(agent, found)?;
        let owner_fused = self.agents[owner.0].keyframes[owner.1].fused?;
        let frame = found.compose(&self.agents[agent].keyframes[anchor].local_pose.inverse());
        Some(Candidate {
            frame,
            edge: InterEdge {
                from: owner,
                to: (agent, anchor),
                relative: owner_fused.between(found),
            },
        })
    }

    /// Of `earlier` candidates of `agent`'s frame, those that confirm `candidate`: the same
    /// frame, within `agree` (m, rad), from a place at least `confirm_separation_m` away along
    /// its path. Two queries that share keyframes, or see one corner of the hall, fail together
    /// where the hall repeats itself.
    fn confirming(
        &self,
        agent: usize,
        earlier: &[Candidate],
        candidate: &Candidate,
        agree: (f64, f64),
    ) -> Vec<Candidate> {
        let a = &self.agents[agent];
        let travelled = |index: usize| a.keyframes[index].travelled_m;
        earlier
            .iter()
            .filter(|c| {
                (travelled(candidate.edge.to.1) - travelled(c.edge.to.1)).abs()
                    >= self.params.confirm_separation_m
                    && within(&c.frame, &candidate.frame, agree)
            })
            .copied()
            .collect()
    }

    /// An unaligned agent searches the whole aligned map for its newest place.
    fn match_unaligned(&mut self, agent: usize, update: &mut Update) {
        let points = self.aligned_occupied();
        if points.is_empty() {
            return;
        }
        self.stats.global_searches += 1;
        let Some(((anchor, query, sensors), found)) = self.search_whole_map(agent, &points) else {
            return;
        };
        let Some(candidate) = self.candidate(agent, anchor, &found) else {
            return;
        };
        if self.params.max_opposite_ratio < 1.0 {
            let (points, owners) = self.aligned_points(agent, None);
            if self.sees_opposite_faces(
                agent,
                anchor,
                (&query, &sensors),
                &found,
                (&points, &owners),
            ) {
                return;
            }
        }
        let frame = candidate.frame;
        self.stats.candidates += 1;
        tracing::debug!(agent, anchor, ?frame, ?found, "frame candidate");
        let agree = self.params.agreement();
        let agreeing = self.confirming(agent, &self.agents[agent].candidates, &candidate, agree);
        push_bounded(&mut self.agents[agent].candidates, candidate);
        if agreeing.len() + 1 < self.params.confirmations as usize {
            return;
        }
        // Where a hall repeats itself, every match of one group of targets can agree on the
        // other group's place. What tells them apart is everything else the agent has seen: at
        // the wrong place its detections fall where the aligned agents saw free floor.
        let (support, conflict) = match self.occupied.as_ref() {
            Some((map, _)) => {
                let detections =
                    self.placed_detections(agent, move |k| Some(frame.compose(&k.local_pose)));
                self.free_space_check(map, detections)
            }
            None => (0, 0),
        };
        let conflict_ratio = conflict as f64 / (support + conflict).max(1) as f64;
        tracing::debug!(
            agent,
            support,
            conflict,
            conflict_ratio,
            "merge checked against free space"
        );
        if conflict_ratio > self.params.max_conflict_ratio {
            self.stats.refused_merges += 1;
            tracing::debug!(
                agent,
                ?frame,
                conflict_ratio,
                "merge refused: detections on free floor"
            );
            self.agents[agent].candidates.clear();
            return;
        }
        if let Some(better) = self.better_named_place(agent, &frame, &points) {
            self.stats.merges_deferred += 1;
            tracing::debug!(
                agent,
                ?frame,
                ?better,
                "merge deferred: an earlier match named a place that fits better both ways"
            );
            return;
        }
        // Merged: the agent's keyframes enter the map frame, the agreeing matches the graph.
        let a = &mut self.agents[agent];
        a.frame = Some(frame);
        a.candidates.clear();
        a.merged_by_search = true;
        a.since_verify = 0;
        a.verify_interval = self.params.verify_every_keyframes;
        self.stats.merges += 1;
        for c in agreeing.iter().chain(std::iter::once(&candidate)) {
            self.edges.push(c.edge);
            self.stats.inter_edges += 1;
        }
        for index in 0..self.agents[agent].keyframes.len() {
            self.place_new(agent, index, update);
        }
        update.corrected = self.optimise();
        tracing::info!(agent, ?frame, "agent merged into the map frame");
    }

    /// Another frame of `agent` an earlier match named (beyond the re-checks' agreement of
    /// `frame`) that fits the aligned map (`map_occupied`, its occupied cells) better both ways
    /// than `frame`: fewer conflicts, with at least half its support (a place that explains
    /// little of what the agent saw contradicts little too). Where the hall looks alike
    /// from an agent's views (the inner-aisle AGV's loop turned half round, for one), the
    /// matches of the look-alike can agree first; the merge then waits for the place that
    /// contradicts less to gather its own confirmations. `None` when there is none.
    fn better_named_place(
        &self,
        agent: usize,
        frame: &Pose2,
        map_occupied: &[[f64; 2]],
    ) -> Option<((usize, usize), (usize, usize))> {
        let (map, _) = self.occupied.as_ref()?;
        let agree = self.params.recheck_agreement();
        let differs = |a: &Pose2, b: &Pose2| !within(a, b, agree);
        let mut others: Vec<Pose2> = Vec::new();
        for c in &self.agents[agent].candidates {
            if differs(&c.frame, frame) && others.iter().all(|o| differs(o, &c.frame)) {
                others.push(c.frame);
            }
        }
        if others.is_empty() {
            return None;
        }
        let fit = |f: Pose2| {
            self.fit_both_ways(map, map_occupied, agent, move |k| {
                Some(f.compose(&k.local_pose))
            })
        };
        let here = fit(*frame);
        others
            .into_iter()
            .map(fit)
            .find(|there| 2 * there.0 >= here.0 && there.1 < here.1)
            .map(|there| (here, there))
    }

    /// A merged agent's merge re-checked: its newest place searched for over the others' map
    /// alone, as before its merge. Where a hall repeats itself the first matches of an agent can
    /// all agree on a twin of its place; later ones, where it sees what tells the twins apart,
    /// put it elsewhere. A frame elsewhere, confirmed as a merge is (`confirmations` matches
    /// `confirm_separation_m` apart), under which the agent's detections land on floor the
    /// others saw free less often than where the graph holds them (and at most
    /// `max_conflict_ratio`), takes the merge's place: the agent's inter-agent edges, made at
    /// the old place, are dropped for the new matches.
    fn verify_merge(&mut self, agent: usize, update: &mut Update) {
        let Some(map) = self.occupancy_without(agent) else {
            return;
        };
        let points = occupied_cells(&map, self.params.occupied_percent);
        if points.is_empty() {
            return;
        }
        self.stats.verify_searches += 1;
        let Some(((anchor, _, _), found)) = self.search_whole_map(agent, &points) else {
            return;
        };
        let Some(held) = self.agents[agent].keyframes[anchor].fused else {
            return;
        };
        let correction = held.between(&found);
        let every = self.params.verify_every_keyframes;
        let a = &mut self.agents[agent];
        if is_small(&correction, self.params.agreement()) {
            // Confirmed where the graph holds it: the next re-check can wait longer.
            a.verify_interval = (a.verify_interval * 2).min(every * MAX_VERIFY_BACKOFF);
            return;
        }
        a.verify_interval = every;
        let Some(candidate) = self.candidate(agent, anchor, &found) else {
            return;
        };
        tracing::debug!(
            agent,
            anchor,
            ?correction,
            "merge re-check found another place"
        );
        // Looser than a merge's agreement: the verdict is the fit below, and the matches only
        // have to name the same other place (a shared stretch with few targets places each
        // match a metre or two apart); the newest match's frame is the one taken.
        let agree = self.params.recheck_agreement();
        let agreeing = self.confirming(agent, &self.agents[agent].rechecks, &candidate, agree);
        push_bounded(&mut self.agents[agent].rechecks, candidate);
        if agreeing.len() + 1 < self.params.confirmations as usize {
            return;
        }
        let now = self.fit_both_ways(&map, &points, agent, |k| k.fused);
        let frame = candidate.frame;
        let there = self.fit_both_ways(&map, &points, agent, move |k| {
            Some(frame.compose(&k.local_pose))
        });
        // Both places explain part of what the agent saw (a twin is a twin); what tells them
        // apart is what contradicts them. The other place must contradict the map less, and
        // no more than a merge may.
        let conflict_ratio = there.1 as f64 / (there.0 + there.1).max(1) as f64;
        if !(there.1 < now.1 && conflict_ratio <= self.params.max_conflict_ratio) {
            tracing::debug!(
                agent,
                ?now,
                ?there,
                "merge kept: (support, conflict) both ways"
            );
            return;
        }
        tracing::info!(
            agent,
            ?frame,
            ?now,
            ?there,
            "merge moved: the agent was placed at a look-alike ((support, conflict) both ways)"
        );
        self.agents[agent].rechecks.clear();
        self.stats.remerges += 1;
        let dropped = self.edges.len();
        self.edges.retain(|e| e.from.0 != agent && e.to.0 != agent);
        tracing::debug!(
            agent,
            dropped = dropped - self.edges.len(),
            "inter-agent edges dropped"
        );
        for c in agreeing.iter().chain(std::iter::once(&candidate)) {
            self.edges.push(c.edge);
            self.stats.inter_edges += 1;
        }
        let a = &mut self.agents[agent];
        a.frame = Some(frame);
        a.pending_local = None;
        for k in &mut a.keyframes {
            k.fused = Some(frame.compose(&k.local_pose));
        }
        self.occupied = None;
        for k in self.agents.iter_mut().flat_map(|a| a.keyframes.iter_mut()) {
            k.in_occupancy = None;
        }
        update.corrected = self.optimise();
    }

    /// An aligned agent matches its newest place against the other agents' points near it.
    fn match_aligned(&mut self, agent: usize, update: &mut Update) {
        let (anchor, query, sensors) = self.query(agent);
        let Some(predicted) = self.agents[agent].keyframes[anchor].fused else {
            return;
        };
        let (points, owners) =
            self.aligned_points(agent, Some((predicted, self.params.submap_range_m)));
        if points.len() < self.params.matcher.min_points as usize {
            return;
        }
        self.stats.local_searches += 1;
        self.stats.query_points_scored += query.len() as u64;
        let found = match match_loop(
            &query,
            &points,
            predicted,
            self.params.local_radius_m,
            &self.params.matcher,
            &self.matcher_scan_params(),
        ) {
            Ok(found) => found,
            Err(reason) => {
                tracing::debug!(agent, anchor, ?reason, "inter-agent match rejected");
                return;
            }
        };
        if self.sees_opposite_faces(
            agent,
            anchor,
            (&query, &sensors),
            &found.relative,
            (&points, &owners),
        ) {
            return;
        }
        let Some(owner) = self.nearest_keyframe(owners.iter().copied(), &found.relative) else {
            return;
        };
        let owner_fused = self.agents[owner.0].keyframes[owner.1]
            .fused
            .expect("owners are fused");
        let edge = InterEdge {
            from: owner,
            to: (agent, anchor),
            relative: owner_fused.between(&found.relative),
        };
        // A match that moves the query by more than the agreement tolerance from where the graph
        // holds it is kept pending until the next match asks for the same correction: one
        // verified match can still be a neighbouring place that looks alike.
        let correction = predicted.between(&found.relative);
        let agree = self.params.agreement();
        let agrees = |c: &Pose2| is_small(c, agree);
        let mut accepted = Vec::new();
        if agrees(&correction) {
            accepted.push(edge);
        } else {
            let a = &mut self.agents[agent];
            match a.pending_local.take() {
                Some((previous, pending)) if agrees(&previous.between(&correction)) => {
                    accepted.extend([pending, edge]);
                }
                _ => {
                    tracing::debug!(agent, anchor, ?correction, "inter-agent match pending");
                    a.pending_local = Some((correction, edge));
                }
            }
        }
        if accepted.is_empty() {
            return;
        }
        for e in &accepted {
            tracing::debug!(from = ?e.from, to = ?e.to, ?correction, "inter-agent edge accepted");
        }
        self.stats.inter_edges += accepted.len() as u64;
        self.edges.extend(accepted);
        update.corrected = self.optimise();
    }

    /// Re-solves the graph of every aligned keyframe and stores the fused poses; true when that
    /// moved a published keyframe by more than `republish_m` or `republish_deg`, which starts a
    /// new revision (every revision costs each subscribed mapper a rebuild of its whole grid).
    fn optimise(&mut self) -> bool {
        let p = &self.params;
        let mut graph = PoseGraph::new();
        let mut node_of: Vec<Vec<Option<usize>>> = Vec::with_capacity(self.agents.len());
        for a in &self.agents {
            let nodes = a
                .keyframes
                .iter()
                .map(|k| k.fused.map(|f| graph.add_node(f)))
                .collect();
            node_of.push(nodes);
        }
        for (a, nodes) in self.agents.iter().zip(&node_of) {
            match a.kind {
                AgentKind::Station => {
                    for n in nodes.iter().flatten() {
                        graph.set_fixed(*n, true);
                    }
                }
                AgentKind::Agv { known_start } => {
                    if known_start {
                        if let Some(Some(first)) = nodes.first() {
                            graph.set_fixed(*first, true);
                        }
                    }
                    for (j, pair) in a.keyframes.windows(2).enumerate() {
                        let (Some(from), Some(to)) = (nodes[j], nodes[j + 1]) else {
                            continue;
                        };
                        let motion = pair[0].local_pose.between(&pair[1].local_pose);
                        let length_m = motion.x_m.hypot(motion.y_m);
                        let std_m = (p.chain_std_per_m * length_m).max(p.chain_min_std_m);
                        let std_deg = (p.chain_std_deg_per_m * length_m).max(p.chain_min_std_deg);
                        graph.add_edge(Edge::with_std(
                            from,
                            to,
                            motion,
                            std_m,
                            std_deg.to_radians(),
                            EdgeKind::Odometry,
                        ));
                    }
                    let by_id = |id: u32| {
                        a.keyframes
                            .binary_search_by_key(&id, |k| k.local_id)
                            .ok()
                            .and_then(|i| nodes[i])
                    };
                    let own_loops = if p.own_loop_edges { &a.loops[..] } else { &[] };
                    for (older, newer, relative) in own_loops {
                        if let (Some(from), Some(to)) = (by_id(*older), by_id(*newer)) {
                            graph.add_edge(Edge::with_std(
                                from,
                                to,
                                *relative,
                                p.inter_std_m,
                                p.inter_std_deg.to_radians(),
                                EdgeKind::Loop,
                            ));
                        }
                    }
                }
            }
        }
        for e in &self.edges {
            if let (Some(from), Some(to)) = (node_of[e.from.0][e.from.1], node_of[e.to.0][e.to.1]) {
                graph.add_edge(Edge::with_std(
                    from,
                    to,
                    e.relative,
                    p.inter_std_m,
                    p.inter_std_deg.to_radians(),
                    EdgeKind::Loop,
                ));
            }
        }
        // Without any fixed node the map frame would float: fix the first node (the first
        // aligned agent's first keyframe), which is where the map frame was defined.
        if !(0..graph.nodes().len()).any(|n| graph.is_fixed(n)) && !graph.nodes().is_empty() {
            graph.set_fixed(0, true);
        }
        let settings = OptimiserSettings {
            loop_kernel: RobustKernel::Cauchy,
            ..OptimiserSettings::default()
        };
        let report = graph.optimise(&settings);
        self.stats.optimisations += 1;
        tracing::debug!(?report, "fused graph solved");
        for (a, nodes) in self.agents.iter_mut().zip(&node_of) {
            for (k, n) in a.keyframes.iter_mut().zip(nodes) {
                if let Some(n) = n {
                    k.fused = Some(graph.nodes()[*n]);
                }
            }
            // The agent's frame follows its first keyframe, so that keyframes not yet placed
            // (none today) and its corrected pose stay consistent.
            if let (Some(first), Some(_)) = (a.keyframes.first(), a.frame) {
                if let Some(fused) = first.fused {
                    a.frame = Some(fused.compose(&first.local_pose.inverse()));
                }
            }
        }
        let (limit_m, limit_rad) = (
            self.params.republish_m,
            self.params.republish_deg.to_radians(),
        );
        let moved = self.max_unpublished_move();
        if moved.0 > limit_m || moved.1 > limit_rad {
            self.start_revision();
            return true;
        }
        false
    }

    /// The largest (distance m, rotation rad) of a keyframe from its published pose.
    fn max_unpublished_move(&self) -> (f64, f64) {
        self.agents
            .iter()
            .flat_map(|a| a.keyframes.iter())
            .filter_map(|k| Some((k.fused?, k.published?)))
            .fold((0.0, 0.0), |(m, r), (f, p)| {
                (
                    f64::max(m, f.distance_m(&p)),
                    f64::max(r, f.rotation_to_rad(&p)),
                )
            })
    }

    fn start_revision(&mut self) {
        for k in self.agents.iter_mut().flat_map(|a| a.keyframes.iter_mut()) {
            k.published = k.fused;
        }
        self.revision += 1;
    }

    /// At the end of the input: a last revision if any keyframe moved since the last one, so
    /// that the final map is built at the final poses. True when it started one.
    pub fn finish(&mut self) -> bool {
        let moved = self.max_unpublished_move();
        if moved.0 > 0.0 || moved.1 > 0.0 {
            self.start_revision();
            return true;
        }
        false
    }
}

/// A merged agent's re-checks are at most this many times `verify_every_keyframes` apart: each
/// re-check that finds it where the graph holds it doubles the wait for the next, so a merge
/// confirmed over and over costs ever fewer searches, and one found elsewhere is re-checked at
/// the full rate again.
const MAX_VERIFY_BACKOFF: u32 = 8;

/// Most matches waiting for confirmation an agent keeps: over a long run (hours) they would
/// otherwise grow without bound, and each new match is compared with every one kept.
const MAX_WAITING_MATCHES: usize = 64;

/// Appends `candidate`, dropping the oldest beyond [`MAX_WAITING_MATCHES`].
fn push_bounded(waiting: &mut Vec<Candidate>, candidate: Candidate) {
    if waiting.len() >= MAX_WAITING_MATCHES {
        waiting.remove(0);
    }
    waiting.push(candidate);
}

/// Whether poses `a` and `b` lie within `tolerance` (m, rad) of each other.
fn within(a: &Pose2, b: &Pose2, tolerance: (f64, f64)) -> bool {
    a.distance_m(b) <= tolerance.0 && a.rotation_to_rad(b) <= tolerance.1
}

/// Whether the motion `correction` is within `tolerance` (m, rad).
fn is_small(correction: &Pose2, tolerance: (f64, f64)) -> bool {
    correction.x_m.hypot(correction.y_m) <= tolerance.0 && correction.yaw_rad.abs() <= tolerance.1
}

/// Integrates one keyframe's detections (`body`, body frame) seen from `pose` into `map`.
fn integrate_keyframe(map: &mut nrslam_mapper::OccupancyMap, pose: &Pose2, body: &[[f64; 2]]) {
    let points: Vec<[f64; 2]> = body.iter().map(|p| pose.transform_point(*p)).collect();
    // Inputs were checked finite; a point that overflows is left out of the map.
    let _ = map.integrate_points([pose.x_m, pose.y_m], &points);
}

/// Centres of the cells of `map` occupied at `occupied_percent` and above, map frame.
fn occupied_cells(map: &nrslam_mapper::OccupancyMap, occupied_percent: u8) -> Vec<[f64; 2]> {
    let threshold = i8::try_from(occupied_percent).unwrap_or(i8::MAX);
    let data = map.occupancy_data();
    let width = map.width_cells();
    data.iter()
        .enumerate()
        .filter(|(_, &percent)| percent >= threshold)
        .map(|(cell, _)| map.cell_centre(cell % width, cell / width))
        .collect()
}

fn check_input(pose: &Pose2, points: &[[f64; 2]]) -> Result<(), FusionError> {
    if !pose.is_finite() {
        return Err(FusionError::NonFinite("pose"));
    }
    if points
        .iter()
        .any(|p| !(p[0].is_finite() && p[1].is_finite()))
    {
        return Err(FusionError::NonFinite("detection"));
    }
    Ok(())
}

/// Lower-left and upper-right corners of `points` (which is not empty).
fn bounds(points: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    points.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    )
}

/// The synthetic scenes of the fusion benches and integration tests.
#[cfg(test)]
#[path = "../benches/common/mod.rs"]
mod common;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_restart_moves_every_edge_naming_the_earlier_keyframes_to_their_new_agent() {
        let mut fusion = Fusion::new(Params {
            agvs: 2,
            known_starts: 2,
            ..Params::default()
        });
        let pose = |x_m: f64| Pose2::new(x_m, 0.0, 0.0);
        for k in 0..2 {
            for agent in 0..2 {
                fusion
                    .add_keyframe(agent, k, pose(f64::from(k)), vec![[1.0, 1.0]])
                    .unwrap();
            }
        }
        let edge = |from: (usize, usize), to: (usize, usize)| InterEdge {
            from,
            to,
            relative: pose(0.0),
        };
        // An edge of the graph, and what agv2 holds from its matches against agv1's keyframes.
        fusion.edges.push(edge((0, 1), (1, 0)));
        let b = &mut fusion.agents[1];
        b.candidates.push(Candidate {
            frame: pose(0.0),
            edge: edge((0, 0), (1, 1)),
        });
        b.rechecks.push(Candidate {
            frame: pose(0.0),
            edge: edge((0, 1), (1, 1)),
        });
        b.pending_local = Some((pose(0.0), edge((0, 0), (1, 1))));
        // agv1's SLAM starts over: its keyframes are agent 2's now.
        assert_eq!(fusion.start_new_session(0), Ok(Some(2)));
        fusion
            .add_keyframe(0, 0, pose(5.0), vec![[1.0, 1.0]])
            .unwrap();
        assert_eq!(fusion.edges, [edge((2, 1), (1, 0))]);
        let b = &fusion.agents[1];
        assert_eq!(b.candidates[0].edge, edge((2, 0), (1, 1)));
        assert_eq!(b.rechecks[0].edge, edge((2, 1), (1, 1)));
        assert_eq!(b.pending_local.unwrap().1, edge((2, 0), (1, 1)));
        assert_eq!(fusion.agents[2].keyframes.len(), 2);
        assert_eq!(fusion.agents[0].keyframes.len(), 1);
        assert!(!fusion.is_aligned(0), "a restarted SLAM's frame is unknown");
        assert!(fusion.is_aligned(2));
    }

    #[test]
    fn a_merge_waits_when_an_earlier_match_named_a_place_that_fits_better() {
        // agv1 (start known) drives the whole lap; agv2, whose start is unknown, a third of it
        // from the middle. Its whole-map searches are kept from running so that the candidates
        // are the test's own: its true frame, and the true frame 3 m off sideways.
        let scene = common::scene(0.0);
        let path = common::lap(5.0, 4.0, 36.0, 27.0, 1.0);
        let second = &path[path.len() / 2..path.len() / 2 + path.len() / 3];
        let truth = second[0];
        let mut fusion = Fusion::new(Params {
            agvs: 2,
            global_every_keyframes: 1000,
            ..Params::default()
        });
        for (k, pose) in path.iter().enumerate() {
            let seen = common::observe(&scene, pose);
            fusion.add_keyframe(0, k as u32, *pose, seen).unwrap();
        }
        for (k, pose) in second.iter().enumerate() {
            let seen = common::observe(&scene, pose);
            let local = truth.inverse().compose(pose);
            fusion.add_keyframe(1, k as u32, local, seen).unwrap();
        }
        assert!(fusion.frame_of(1).is_none(), "no search, no merge");
        let off = truth.compose(&Pose2::new(0.0, 3.0, 0.0));
        let named = |frame: Pose2| Candidate {
            frame,
            edge: InterEdge {
                from: (0, 0),
                to: (1, 0),
                relative: Pose2::new(0.0, 0.0, 0.0),
            },
        };
        let map_occupied = fusion.aligned_occupied();
        // The true frame named earlier: a merge at the place 3 m off waits.
        fusion.agents[1].candidates = vec![named(truth)];
        let (here, there) = fusion
            .better_named_place(1, &off, &map_occupied)
            .expect("the true frame fits better");
        assert!(
            there.1 < here.1 && 2 * there.0 >= here.0,
            "{here:?} {there:?}"
        );
        // The place 3 m off named earlier: a merge at the true frame goes ahead.
        fusion.agents[1].candidates = vec![named(off)];
        assert_eq!(fusion.better_named_place(1, &truth, &map_occupied), None);
        // A frame within the re-checks' agreement is the same place, not an alternative.
        fusion.agents[1].candidates = vec![named(truth.compose(&Pose2::new(0.0, 2.5, 0.0)))];
        assert_eq!(fusion.better_named_place(1, &off, &map_occupied), None);
    }
}
