//! Target identities across map updates: the issue's "recursive estimator per target, associated
//! across map updates", in the form that keeps the covariance honest.
//!
//! **Why the estimate is the current fit, not a fusion of fits.** The occupancy map is
//! cumulative and is rebuilt from scratch whenever the pose graph corrects, so each segment
//! already holds all the evidence so far. Fusing successive fits as independent measurements (a
//! Kalman update per map) would count the same cells again at every update and shrink the
//! covariance without new information. A track's estimate is therefore the fit of its current
//! segment: it improves, and its covariance shrinks, exactly as the segment grows (a second side
//! seen replaces the depth prior by a measured side). What is recursive is the track's identity
//! and its kind belief.
//!
//! **Association.** Each update fits every segment and pairs fits with tracks one-to-one,
//! greedily by increasing centre distance, within `gate_m` (the last reported centre of the
//! track). Unpaired fits start new tracks with fresh ids (never reused); tracks left unpaired
//! count a miss, keep their id for `max_missed_updates` updates (a segment that vanishes while
//! the map is rebuilt comes back under its id) and are then dropped. Only tracks paired in this
//! update are reported: a missed track's shape belongs to a map that no longer exists.
//!
//! **Kind with hysteresis.** A track keeps a smoothed circle probability
//! p ← a·p + (1 − a)·p_fit (a = `kind_smoothing`, p_fit from the fit's BICs). It changes kind
//! only when p for the other kind exceeds `kind_switch_probability`; until then the fit of the
//! track's kind is reported (both models are fitted on every segment), so a target does not flip
//! between circle and rectangle on every update. The smoothing is a low-pass on a belief, not a
//! product of likelihoods, for the same reason as above: successive fits are not independent.
//!
//! **Unchanged segments are not fitted again.** Between two keyframes the radar adds cells to
//! the one or two targets in view; every other segment comes back cell for cell. A segment equal
//! to one of the previous update's (same points, same order) takes that update's fit: the fit is
//! a function of the points and the viewpoints, and a viewpoint added since that saw no new cell
//! of the target only shifts the one-sided depth vote it has no evidence for. On the hall this
//! skips most fits (docs/shapes.md gives the measured cost).

use std::collections::HashMap;
use std::hash::{Hash, Hasher};

use serde::Serialize;

use crate::fit::fit_candidates;
use crate::shape::{FittedShape, ShapeKind};
use crate::Params;

/// One target reported by the tracker.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TrackedTarget {
    /// Stable id: the same target keeps it across updates; ids are never reused.
    pub id: u32,
    /// The current estimate: the fit of this update's segment, of the track's kind.
    pub shape: FittedShape,
    /// Updates in which the track was paired with a segment (1 at birth).
    pub updates: u32,
    /// Smoothed probability that the target is a circle (module doc).
    pub circle_probability: f64,
    /// Index of the segment (in this update's input) the shape was fitted to.
    pub segment: usize,
}

#[derive(Debug, Clone)]
struct Track {
    id: u32,
    kind: ShapeKind,
    circle_probability: f64,
    center_m: [f64; 2],
    updates: u32,
    missed: u32,
}

/// Keeps target ids across map updates (module doc).
#[derive(Debug, Clone)]
pub struct ShapeTracker {
    params: Params,
    tracks: Vec<Track>,
    next_id: u32,
    /// The previous update's fits by the hash of their segment's points.
    previous_fits: FitCache,
}

/// Fits of one update by the hash of their segment's points (segment points, fits).
type FitCache = HashMap<u64, Vec<(Vec<[f64; 2]>, crate::Candidates)>>;

/// Hash of a segment's points, bit for bit.
fn segment_hash(points: &[[f64; 2]]) -> u64 {
    let mut hasher = std::collections::hash_map::DefaultHasher::new();
    for p in points {
        p[0].to_bits().hash(&mut hasher);
        p[1].to_bits().hash(&mut hasher);
    }
    hasher.finish()
}

/// Circle probabilities are kept away from 0 and 1 so that one decisive fit cannot pin a track.
const PROBABILITY_CLAMP: f64 = 0.01;

impl ShapeTracker {
    /// A tracker with no targets. `params` should be valid ([`Params::validate`]); with invalid
    /// parameters every fit fails and no target is ever reported.
    pub fn new(params: Params) -> Self {
        Self {
            params,
            tracks: Vec::new(),
            next_id: 0,
            previous_fits: HashMap::new(),
        }
    }

    /// Tracks alive (reported or coasting).
    pub fn track_count(&self) -> usize {
        self.tracks.len()
    }

    /// One map update: `segments` are the points of every segment (label ≥ 0), `viewpoints` the
    /// sensor positions so far. Returns the targets of this update, by segment index; segments
    /// that cannot be fitted (too few points, non-finite coordinates) are skipped.
    pub fn update(
        &mut self,
        segments: &[Vec<[f64; 2]>],
        viewpoints: &[[f64; 2]],
    ) -> Vec<TrackedTarget> {
        let mut this_update = FitCache::new();
        let mut fits: Vec<(usize, crate::Candidates)> = Vec::with_capacity(segments.len());
        for (i, points) in segments.iter().enumerate() {
            let hash = segment_hash(points);
            let cached = self
                .previous_fits
                .get(&hash)
                .and_then(|same_hash| same_hash.iter().find(|(p, _)| p == points))
                .map(|(_, candidates)| candidates.clone());
            let Some(candidates) =
                cached.or_else(|| fit_candidates(points, viewpoints, &self.params).ok())
            else {
                continue;
            };
            this_update
                .entry(hash)
                .or_default()
                .push((points.clone(), candidates.clone()));
            fits.push((i, candidates));
        }
        self.previous_fits = this_update;
        let pairs = self.associate(&fits);
        let mut paired_track = vec![false; self.tracks.len()];
        let mut out = Vec::with_capacity(fits.len());
        for (f, (segment, candidates)) in fits.iter().enumerate() {
            let track_index = match pairs.iter().find(|(pf, _)| *pf == f) {
                Some(&(_, t)) => {
                    paired_track[t] = true;
                    t
                }
                None => {
                    self.tracks.push(Track {
                        id: self.next_id,
                        kind: candidates.selected,
                        circle_probability: candidates
                            .best()
                            .circle_probability
                            .clamp(PROBABILITY_CLAMP, 1.0 - PROBABILITY_CLAMP),
                        center_m: candidates.best().center_m,
                        updates: 0,
                        missed: 0,
                    });
                    self.next_id = self.next_id.wrapping_add(1);
                    paired_track.push(true);
                    self.tracks.len() - 1
                }
            };
            let fresh = self.tracks[track_index].updates == 0;
            let shape = self.update_track(track_index, candidates, fresh);
            let track = &self.tracks[track_index];
            out.push(TrackedTarget {
                id: track.id,
                shape,
                updates: track.updates,
                circle_probability: track.circle_probability,
                segment: *segment,
            });
        }
        for (track, paired) in self.tracks.iter_mut().zip(&paired_track) {
            if !paired {
                track.missed += 1;
            }
        }
        let max_missed = self.params.max_missed_updates;
        self.tracks.retain(|t| t.missed <= max_missed);
        out
    }

    /// Greedy one-to-one pairs (fit index, track index) within the gate, nearest first.
    fn associate(&self, fits: &[(usize, crate::Candidates)]) -> Vec<(usize, usize)> {
        let fit_centres: Vec<[f64; 2]> = fits.iter().map(|(_, c)| c.best().center_m).collect();
        let track_centres: Vec<[f64; 2]> = self.tracks.iter().map(|t| t.center_m).collect();
        crate::evaluate::match_to_truth(&fit_centres, &track_centres, self.params.gate_m)
    }

    /// Updates the kind belief of a paired track and returns the shape to report.
    fn update_track(
        &mut self,
        index: usize,
        candidates: &crate::Candidates,
        fresh: bool,
    ) -> FittedShape {
        let (a, switch) = (
            self.params.kind_smoothing,
            self.params.kind_switch_probability,
        );
        let track = &mut self.tracks[index];
        let p_fit = candidates.best().circle_probability;
        if !fresh {
            track.circle_probability = (a * track.circle_probability + (1.0 - a) * p_fit)
                .clamp(PROBABILITY_CLAMP, 1.0 - PROBABILITY_CLAMP);
        }
        let other_wins = match track.kind {
            ShapeKind::Rectangle => track.circle_probability > switch,
            ShapeKind::Circle => 1.0 - track.circle_probability > switch,
        };
        if other_wins {
            track.kind = match track.kind {
                ShapeKind::Rectangle => ShapeKind::Circle,
                ShapeKind::Circle => ShapeKind::Rectangle,
            };
        }
        // The fit of the track's kind when there is one; else the kind follows the fit.
        let shape = match candidates.get(track.kind) {
            Some(s) => s.clone(),
            None => {
                track.kind = candidates.selected;
                candidates.best().clone()
            }
        };
        track.center_m = shape.center_m;
        track.updates += 1;
        track.missed = 0;
        shape
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::{arc_samples, rectangle_samples};

    fn circle(center: [f64; 2], radius: f64, from: f64, to: f64) -> Vec<[f64; 2]> {
        arc_samples(center, radius, from, to)
    }

    fn rectangle(sides: &[usize]) -> Vec<[f64; 2]> {
        rectangle_samples([5.0, 5.0], [3.0, 2.0], 0.4, sides)
    }

    #[test]
    fn ids_are_stable_as_segments_grow_and_new_targets_get_new_ids() {
        let mut tracker = ShapeTracker::new(Params::default());
        let views = [[5.0, -5.0], [20.0, 5.0]];
        let c = [20.0, 20.0];
        let first = tracker.update(&[rectangle(&[0]), circle(c, 1.5, -2.0, -1.0)], &views);
        assert_eq!(first.len(), 2);
        let (rect_id, circle_id) = (first[0].id, first[1].id);
        assert_ne!(rect_id, circle_id);
        // The segments grow (and come in another order): same ids, the estimate follows.
        let second = tracker.update(&[circle(c, 1.5, -2.5, 0.5), rectangle(&[0, 1])], &views);
        assert_eq!((second[0].id, second[1].id), (circle_id, rect_id));
        assert_eq!(second[1].shape.sides_seen, 2);
        assert_eq!(second[0].shape.kind, ShapeKind::Circle);
        assert_eq!(second[1].updates, 2);
        // The rectangle's centre is far better known with two sides than with one.
        let var = |t: &TrackedTarget| {
            let c = t.shape.center_covariance();
            c[0][0] + c[1][1]
        };
        assert!(var(&second[1]) < var(&first[0]) / 4.0);
        // A new target far from both: a new id.
        let third = tracker.update(
            &[
                rectangle(&[0, 1, 2, 3]),
                circle(c, 1.5, 0.0, 6.0),
                circle([40.0, 0.0], 1.0, 0.0, 6.0),
            ],
            &views,
        );
        assert_eq!(third[0].id, rect_id);
        assert_eq!(third[1].id, circle_id);
        assert!(third[2].id != rect_id && third[2].id != circle_id);
        assert_eq!(third[2].updates, 1);
    }

    #[test]
    fn missed_tracks_keep_their_id_for_a_while_then_go() {
        let params = Params {
            max_missed_updates: 2,
            ..Params::default()
        };
        let mut tracker = ShapeTracker::new(params);
        let id = tracker.update(&[rectangle(&[0, 1])], &[])[0].id;
        assert!(tracker.update(&[], &[]).is_empty());
        assert!(tracker.update(&[], &[]).is_empty());
        assert_eq!(tracker.update(&[rectangle(&[0, 1])], &[])[0].id, id);
        for _ in 0..3 {
            tracker.update(&[], &[]);
        }
        assert_eq!(tracker.track_count(), 0);
        assert_ne!(tracker.update(&[rectangle(&[0, 1])], &[])[0].id, id);
    }

    #[test]
    fn kind_changes_only_with_hysteresis() {
        let mut tracker = ShapeTracker::new(Params::default());
        let views = [[5.0, -5.0]];
        let square = rectangle_samples([5.0, 5.0], [2.0, 2.0], 0.0, &[0, 1, 2, 3]);
        let round = arc_samples([5.0, 5.0], 1.0, 0.0, 6.2);
        let first = tracker.update(std::slice::from_ref(&square), &views);
        assert_eq!(first[0].shape.kind, ShapeKind::Rectangle);
        // One update that looks like a circle does not flip the track ...
        let second = tracker.update(std::slice::from_ref(&round), &views);
        assert_eq!(second[0].id, first[0].id);
        assert_eq!(second[0].shape.kind, ShapeKind::Rectangle);
        // ... but a persistent circle does, within a few updates.
        let mut kinds = Vec::new();
        for _ in 0..5 {
            kinds.push(
                tracker.update(std::slice::from_ref(&round), &views)[0]
                    .shape
                    .kind,
            );
        }
        assert_eq!(kinds.last(), Some(&ShapeKind::Circle), "{kinds:?}");
        // Unfittable segments are skipped, not reported.
        assert!(tracker.update(&[vec![[0.0, 0.0]]], &views).is_empty());
    }
}
