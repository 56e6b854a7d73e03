//! Parameters of the fusion node.

use nrslam_association::LoopClosureParams;
use nrslam_runtime::InvalidParam;
use serde::{Deserialize, Serialize};

/// Most agents of each kind one fusion node takes (its inputs grow linearly with them).
pub const MAX_AGENTS: u32 = 32;

/// Fusion parameters (TOML table of the node in the launch file).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Params {
    /// AGVs fused, namespaces `agv1` … `agvN` (0–32). Each sends `/agvN/slam/keyframe`,
    /// `/agvN/slam/keyframe_poses` and `/agvN/slam/pose`.
    pub agvs: u32,
    /// Fixed sensing stations fused, namespaces `station1` … `stationM` (0–32). Each sends
    /// `/stationM/radar/detections` and its surveyed pose on `/stationM/odom`.
    pub stations: u32,
    /// The first this many AGVs (`agv1` … `agvK`) start at a known pose: their odometry starts
    /// at their true pose in the map frame, so their frame is the map's. The others' start is
    /// unknown to everyone and found by place recognition. Default 1: the first AGV defines the
    /// map frame, as the single-AGV runs do; with stations, 0 lets the surveyed stations alone
    /// anchor the map. 0 to `agvs`, and with no station at least 1 (something must anchor the
    /// map frame).
    pub known_starts: u32,
    /// A station's detections become a keyframe every this many of its frames (1–1000): a fixed
    /// sensor sees the same place every frame, and every keyframe costs the mapper an update.
    pub station_keyframe_every: u32,
    /// Match agents against each other (default true). False: no inter-agent edge and no merge,
    /// so every AGV's start must be known (`known_starts = agvs`): the fused true-pose oracle,
    /// whose agents' poses are exact and must stay so.
    pub matching: bool,
    /// An AGV's keyframes are matched against the other agents every this many keyframes
    /// (1–1000): fewer searches and less CPU against fewer inter-agent edges. Default 3: on the
    /// hall (20 seeds each) 2 → 3 cost 10–20 % less CPU and made no map worse (4 AGVs, no
    /// station: −2.65 ± 3.18 ET-GOPSA, wrong edges 179 → 107; docs/cooperative.md, "Cost").
    pub match_every_keyframes: u32,
    /// An AGV not yet merged searches the whole aligned map every this many keyframes
    /// (1–1000): the whole-map search is the costliest step of fusion, and its matches must
    /// come 10 m apart to confirm each other anyway. Default 6: on the hall (20 seeds each)
    /// 4 → 6 cost 5–13 % less CPU, and the maps changed by +0.10 ± 1.17 to +1.59 ± 2.14
    /// ET-GOPSA (docs/cooperative.md, "Cost").
    pub global_every_keyframes: u32,
    /// Rotation step of the whole-map search (degrees, 0.05–45): it covers every heading, so
    /// its cost is inversely proportional to this; the match is refined finer afterwards (ICP
    /// and the matcher's fine search).
    pub global_step_deg: f64,
    /// The whole-map search's ambiguity test (0–1; 1: off): its match is refused when the best
    /// placement at least the matcher's `ambiguity_distance_m` away scores more than this
    /// fraction of its best. A whole hall searched at every heading holds many look-alike
    /// placements, so the single-AGV loop closure's `max_ambiguity` refuses most of them; the
    /// merge's confirmations, its free-space check and the re-checks are what refuse a wrong
    /// place here. Local searches for inter-agent edges keep `matcher.max_ambiguity`.
    pub global_max_ambiguity: f64,
    /// Keyframes of an AGV that make one query (1–50): the newest and those before it.
    pub query_keyframes: u32,
    /// Widest translation an unaligned AGV's global search covers about the centre of the
    /// aligned map (m, 1–200): the map's half-diagonal plus a sensor range, capped here.
    pub max_global_radius_m: f64,
    /// Translation window of an aligned AGV's search for inter-agent edges about its fused
    /// pose (m, 0.25–20).
    pub local_radius_m: f64,
    /// Points of other agents within this distance of an aligned query's pose make its submap
    /// (m, 1–200): about the sensor's maximum range.
    pub submap_range_m: f64,
    /// Matches of an unaligned AGV that must agree on its frame before it is merged (1–10):
    /// one verified match can still be wrong where the hall repeats itself.
    pub confirmations: u32,
    /// Matches confirm each other only when their query keyframes are at least this far apart
    /// along the agent's path (m, 0–1000): matches of one place fail together.
    pub confirm_separation_m: f64,
    /// Two alignments agree when their frames differ by at most this (m, > 0) …
    pub agree_m: f64,
    /// … and this (degrees, > 0).
    pub agree_deg: f64,
    /// A merged AGV (one whose start was unknown) searches the others' map for its newest
    /// place again every this many keyframes (0: never; 0–1000). When matches confirm another
    /// place (as a merge is confirmed) where it contradicts the others' map less than where the
    /// graph holds it (fewer of its detections on floor they saw free, and fewer of their
    /// targets on floor it saw free), it moves there (docs/cooperative.md, "Merges
    /// re-checked"). Where a hall repeats itself its first matches can all agree on a twin of
    /// its place. Each re-check costs a whole-map search and a grid of the others' keyframes;
    /// on the hall 4 and 8 gave the same result for every seed, on the repeated structure 4
    /// moved more wrong merges. Each re-check that finds the agent where the graph holds it
    /// doubles the wait for the next, up to 8 times this.
    pub verify_every_keyframes: u32,
    /// Re-check matches of a merged AGV name the same other place when their frames differ by
    /// at most this (m, > 0; default 2) …
    pub recheck_agree_m: f64,
    /// … and this (degrees, > 0; default 8). Looser than a merge's `agree_m`, `agree_deg`: the
    /// move is decided by how both places fit the others' map, and a shared stretch with few
    /// targets places each match a metre or two apart. On the repeated-structure scene
    /// (20 seeds) 2 m and 8° moved 16 of the 17 twin merges, 0.5 m and 2° 10; on the hall and on
    /// 10 random scenes no run changed (docs/cooperative.md, "No false merges").
    pub recheck_agree_deg: f64,
    /// A re-solved graph starts a new revision (subscribers rebuild their maps) only when it
    /// moved a published keyframe by more than this (m, ≥ 0; default 0.1, the cooperative
    /// map's cell) …
    pub republish_m: f64,
    /// … or this (degrees, ≥ 0; default 1); smaller moves wait for a larger one or the end of
    /// the run. Only the live map depends on them: the final map is always built at the final
    /// poses, and the fused poses never wait. On the 4-AGV, 2-station hall (5 seeds) 0.05 m and
    /// 0.5° made 191 map rebuilds, 0.1 m and 1° 102, 0.2 m and 2° 52, every final summary.json
    /// the same (docs/cooperative.md, "Cost").
    pub republish_deg: f64,
    /// Add each AGV's own loop edges to the fused graph (default true). Its chain edges are taken
    /// from its own optimised poses, which already hold those loops, so true counts them twice:
    /// a recorded 5G session replayed alone through fusion scored 40.84 instead of its own 39.64
    /// with them, exactly its own without. Yet on the hall with 2 stations false scored 3.1 to
    /// 4.8 ET-GOPSA worse (2–4 AGVs, 20 seeds each, the CIs excluding 0), elsewhere within noise
    /// (docs/cooperative.md, "The fusion node", 5).
    pub own_loop_edges: bool,
    /// Std of an inter-agent or station edge's translation (m, > 0).
    pub inter_std_m: f64,
    /// Std of an inter-agent or station edge's heading (degrees, > 0).
    pub inter_std_deg: f64,
    /// Std of the motion between an AGV's consecutive keyframes, per metre between them and at
    /// least `chain_min_std_m` (fraction, > 0): how much fusion may bend an agent's own map.
    pub chain_std_per_m: f64,
    /// Floor of that std (m, > 0).
    pub chain_min_std_m: f64,
    /// Heading std of the motion between consecutive keyframes, per metre (degrees/m, > 0).
    pub chain_std_deg_per_m: f64,
    /// Floor of that heading std (degrees, > 0).
    pub chain_min_std_deg: f64,
    /// The occupancy grid an unaligned agent's whole-map search runs against: its occupied cells
    /// (≥ `occupied_percent`), where free space seen by other keyframes has carved away the
    /// angle blur that a 5G array leaves in raw detections (against the raw points of every
    /// aligned keyframe every placement scores about the same). The mapper's parameters.
    pub map: nrslam_mapper::Params,
    /// A cell of that grid is occupied at this probability and above (percent, 1–100).
    pub occupied_percent: u8,
    /// A cell of that grid was seen free at this probability and below (percent, 0–100, below
    /// `occupied_percent`).
    pub free_percent: u8,
    /// A placed detection supports a merge within this distance of an occupied cell (m, > 0):
    /// about the blur of a detection across its beam.
    pub conflict_distance_m: f64,
    /// A merge is refused when more than this fraction of the agent's detections, placed in the
    /// map frame, land on cells seen free rather than occupied (0–1): the agreeing matches found
    /// a place that looks alike, not the place. A re-check moves an agent only to a place within
    /// it too. Merges at the true place score 0–2 % on the hall; default 0.03. At 0.2, with the
    /// whole-map search's looser ambiguity test, three matches agreed on a place 25 m off at
    /// 5 %, and the re-checks moved the AGV only 40 s later (hall, 3 AGVs and 2 stations, seed
    /// 20; docs/cooperative.md).
    pub max_conflict_ratio: f64,
    /// An inter-agent match is refused when more than this fraction of its pairs (a query point
    /// within the matcher's `inlier_distance_m` of another agent's point) pair detections seen
    /// from opposite sides, their two sensors' lines of sight more than 90° apart (0–1; 1: never
    /// refused). A 5G detection is the near face of a target: an AGV in an inner aisle sees the
    /// inner faces of the targets the others see from outside, and a match of one face onto the
    /// other is off by the target's depth. On the hall, matches between AGVs that see the same
    /// faces paired 5–40 % of their points from opposite sides (a thin target's two faces lie
    /// within a metre), the inner-aisle AGV's matches with the others 50–93 %. Default 1 (off):
    /// at 0.6 the 4-AGV hall's wrong edges fell by two thirds and fewer AGVs ended worse than
    /// alone, but the fused map lost most of the inner faces and scored 2–4 ET-GOPSA worse
    /// (docs/cooperative.md, "Both sides of a target").
    pub max_opposite_ratio: f64,
    /// The matcher and its verification (the single-AGV loop closure's; `enabled`, the search
    /// radii and candidate selection are not used here: fusion chooses its own windows).
    pub matcher: LoopClosureParams,
    /// The scan-matching parameters the matcher's ICP refinement takes (the association's).
    pub scan: nrslam_association::Params,
}

impl Default for Params {
    fn default() -> Self {
        let association = nrslam_association::Params::default();
        let matcher = LoopClosureParams {
            // Inter-agent views of one place come from different directions and distances more
            // often than one AGV's revisit does; the 5G launch's looser verification is used.
            inlier_distance_m: 1.0,
            min_inlier_ratio: 0.40,
            ..association.loop_closure.clone()
        };
        Self {
            agvs: 1,
            stations: 0,
            known_starts: 1,
            matching: true,
            station_keyframe_every: 10,
            match_every_keyframes: 3,
            global_every_keyframes: 6,
            global_step_deg: 1.0,
            global_max_ambiguity: 0.95,
            verify_every_keyframes: 4,
            recheck_agree_m: 2.0,
            recheck_agree_deg: 8.0,
            query_keyframes: 5,
            max_global_radius_m: 40.0,
            local_radius_m: 2.0,
            submap_range_m: 25.0,
            confirmations: 2,
            confirm_separation_m: 10.0,
            agree_m: 0.5,
            agree_deg: 2.0,
            republish_m: 0.1,
            republish_deg: 1.0,
            own_loop_edges: true,
            inter_std_m: 0.15,
            inter_std_deg: 1.0,
            chain_std_per_m: 0.02,
            chain_min_std_m: 0.02,
            chain_std_deg_per_m: 0.3,
            chain_min_std_deg: 0.2,
            map: nrslam_mapper::Params::default(),
            occupied_percent: 65,
            free_percent: 25,
            conflict_distance_m: 1.5,
            max_conflict_ratio: 0.03,
            max_opposite_ratio: 1.0,
            matcher,
            scan: association,
        }
    }
}

impl Params {
    /// A merge's agreement: (`agree_m`, `agree_deg` in radians).
    pub fn agreement(&self) -> (f64, f64) {
        (self.agree_m, self.agree_deg.to_radians())
    }

    /// A re-check's agreement: (`recheck_agree_m`, `recheck_agree_deg` in radians).
    pub fn recheck_agreement(&self) -> (f64, f64) {
        (self.recheck_agree_m, self.recheck_agree_deg.to_radians())
    }

    /// Checks every field; the error names it and its allowed range.
    pub fn validate(&self) -> Result<(), InvalidParam> {
        InvalidParam::check_count("agvs", self.agvs, 0, MAX_AGENTS)?;
        InvalidParam::check_count("stations", self.stations, 0, MAX_AGENTS)?;
        if self.agvs + self.stations == 0 {
            return Err(InvalidParam::new(
                "agvs",
                "0 AGVs and 0 stations",
                "at least one agent (agvs + stations >= 1)",
            ));
        }
        InvalidParam::check_count("known_starts", self.known_starts, 0, self.agvs)?;
        if self.known_starts == 0 && self.stations == 0 {
            return Err(InvalidParam::new(
                "known_starts",
                "0 with no station: nothing anchors the map frame",
                ">= 1 when stations = 0",
            ));
        }
        if !self.matching && self.known_starts < self.agvs {
            return Err(InvalidParam::new(
                "matching",
                format!(
                    "false with {} of {} AGVs starting at a known pose: the others could never \
                     be merged",
                    self.known_starts, self.agvs
                ),
                "true, or known_starts = agvs",
            ));
        }
        InvalidParam::check_count(
            "station_keyframe_every",
            self.station_keyframe_every,
            1,
            1000,
        )?;
        InvalidParam::check_count("match_every_keyframes", self.match_every_keyframes, 1, 1000)?;
        InvalidParam::check_count(
            "global_every_keyframes",
            self.global_every_keyframes,
            1,
            1000,
        )?;
        InvalidParam::check_range("global_step_deg", self.global_step_deg, 0.05, 45.0)?;
        InvalidParam::check_range("global_max_ambiguity", self.global_max_ambiguity, 0.0, 1.0)?;
        InvalidParam::check_count(
            "verify_every_keyframes",
            self.verify_every_keyframes,
            0,
            1000,
        )?;
        InvalidParam::check_count("query_keyframes", self.query_keyframes, 1, 50)?;
        InvalidParam::check_range("max_global_radius_m", self.max_global_radius_m, 1.0, 200.0)?;
        InvalidParam::check_range("local_radius_m", self.local_radius_m, 0.25, 20.0)?;
        InvalidParam::check_range("submap_range_m", self.submap_range_m, 1.0, 200.0)?;
        InvalidParam::check_count("confirmations", self.confirmations, 1, 10)?;
        InvalidParam::check_range(
            "confirm_separation_m",
            self.confirm_separation_m,
            0.0,
            1000.0,
        )?;
        InvalidParam::check_range("republish_m", self.republish_m, 0.0, 100.0)?;
        InvalidParam::check_range("republish_deg", self.republish_deg, 0.0, 180.0)?;
        for (field, value) in [
            ("agree_m", self.agree_m),
            ("agree_deg", self.agree_deg),
            ("recheck_agree_m", self.recheck_agree_m),
            ("recheck_agree_deg", self.recheck_agree_deg),
            ("inter_std_m", self.inter_std_m),
            ("inter_std_deg", self.inter_std_deg),
            ("chain_std_per_m", self.chain_std_per_m),
            ("chain_min_std_m", self.chain_min_std_m),
            ("chain_std_deg_per_m", self.chain_std_deg_per_m),
            ("chain_min_std_deg", self.chain_min_std_deg),
        ] {
            if !(value.is_finite() && value > 0.0) {
                return Err(InvalidParam::new(
                    field,
                    format!("{value}"),
                    "finite and > 0",
                ));
            }
        }
        self.map.validate().map_err(|e| InvalidParam {
            field: format!("map.{}", e.field),
            ..e
        })?;
        InvalidParam::check_count("occupied_percent", self.occupied_percent, 1, 100)?;
        InvalidParam::check_count(
            "free_percent",
            self.free_percent,
            0,
            self.occupied_percent - 1,
        )?;
        InvalidParam::check_range("conflict_distance_m", self.conflict_distance_m, 0.01, 20.0)?;
        InvalidParam::check_range("max_conflict_ratio", self.max_conflict_ratio, 0.0, 1.0)?;
        InvalidParam::check_range("max_opposite_ratio", self.max_opposite_ratio, 0.0, 1.0)?;
        self.scan.validate().map_err(|e| InvalidParam {
            field: format!("scan.{}", e.field),
            ..e
        })?;
        let matcher = nrslam_association::Params {
            loop_closure: self.matcher.clone(),
            ..self.scan.clone()
        };
        matcher.validate().map_err(|e| InvalidParam {
            field: e.field.replacen("loop_closure.", "matcher.", 1),
            ..e
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        Params::default().validate().unwrap();
    }

    #[test]
    fn each_bad_field_is_named() {
        let cases = nrslam_runtime::one_bad_field!(Params {
            agvs: [33],
            stations: [33],
            known_starts: [2],
            station_keyframe_every: [0],
            match_every_keyframes: [0],
            query_keyframes: [0, 51],
            global_every_keyframes: [0],
            verify_every_keyframes: [1001],
            global_step_deg: [0.0, 90.0],
            global_max_ambiguity: [-0.1, 1.5, f64::NAN],
            max_global_radius_m: [0.5, f64::NAN],
            local_radius_m: [0.0],
            submap_range_m: [f64::INFINITY],
            confirmations: [0],
            confirm_separation_m: [-1.0, f64::NAN],
            agree_m: [0.0],
            free_percent: [65],
            max_conflict_ratio: [1.5],
            max_opposite_ratio: [-0.1, f64::NAN],
            republish_m: [-0.1, f64::NAN],
            republish_deg: [181.0],
            agree_deg: [-1.0],
            recheck_agree_m: [0.0, f64::NAN],
            recheck_agree_deg: [-2.0],
            inter_std_m: [f64::NAN],
            inter_std_deg: [0.0],
            chain_std_per_m: [0.0],
            chain_min_std_m: [0.0],
            chain_std_deg_per_m: [0.0],
            chain_min_std_deg: [0.0],
        });
        nrslam_runtime::config::assert_each_refused_by_name(cases, Params::validate);
    }

    #[test]
    fn no_matching_needs_every_start_known() {
        let p = Params {
            agvs: 2,
            known_starts: 1,
            matching: false,
            ..Params::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("matching"));
        Params {
            known_starts: 2,
            ..p
        }
        .validate()
        .unwrap();
    }

    #[test]
    fn no_agent_at_all_is_refused() {
        let p = Params {
            agvs: 0,
            stations: 0,
            known_starts: 0,
            ..Params::default()
        };
        assert!(p.validate().unwrap_err().to_string().contains("agvs"));
    }
}
