//! Keyframe selection.
//!
//! The paper (Sec. III-A, *Data association*) "select\[s\] key frames in the sensing data to build
//! the mapping data": not every frame joins the map, only frames taken after the AGV has moved or
//! turned enough since the last keyframe. That bounds the map's growth while the AGV stands still
//! and keeps successive keyframes distinct views of the scene.

use crate::pose::Pose2;

/// Slack on the thresholds, metres or radians. Poses accumulated from many small increments land
/// a few ulps short of round thresholds (ten steps of 0.1 m sum to 0.9999999999999999 m); the
/// slack makes "≥ 1 m" mean what it says without changing any meaningful decision.
const THRESHOLD_SLACK: f64 = 1e-9;

/// Decides which frames are keyframes and numbers them 0, 1, 2, …
///
/// The first frame offered is a keyframe. A later frame is one when its pose is at least
/// `distance_m` from the last keyframe's position (straight-line displacement) or its heading
/// differs from the last keyframe's by at least `rotation_rad`.
#[derive(Debug, Clone)]
pub struct KeyframeSelector {
    distance_m: f64,
    rotation_rad: f64,
    last: Option<Pose2>,
    next_id: u32,
}

impl KeyframeSelector {
    /// A selector with the given thresholds (metres, radians).
    pub fn new(distance_m: f64, rotation_rad: f64) -> Self {
        KeyframeSelector {
            distance_m,
            rotation_rad,
            last: None,
            next_id: 0,
        }
    }

    /// True if a frame at `pose` would be a keyframe.
    pub fn is_keyframe(&self, pose: &Pose2) -> bool {
        match &self.last {
            None => true,
            Some(last) => {
                last.distance_m(pose) + THRESHOLD_SLACK >= self.distance_m
                    || last.rotation_to_rad(pose) + THRESHOLD_SLACK >= self.rotation_rad
            }
        }
    }

    /// Offers the frame at `pose`: its keyframe id if it is a keyframe (and it becomes the
    /// reference for the next decision), else `None`.
    pub fn offer(&mut self, pose: &Pose2) -> Option<u32> {
        if !self.is_keyframe(pose) {
            return None;
        }
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1);
        self.last = Some(*pose);
        Some(id)
    }

    /// Makes the frame at `pose` a keyframe whatever the thresholds say (e.g. its view overlaps
    /// too little with the last keyframe's); returns its id.
    pub fn force(&mut self, pose: &Pose2) -> Option<u32> {
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1);
        self.last = Some(*pose);
        Some(id)
    }

    /// Moves the reference of the next decision to `pose` (the last keyframe's corrected pose
    /// after a loop closure) without counting a keyframe.
    pub fn rebase(&mut self, pose: &Pose2) {
        if self.last.is_some() {
            self.last = Some(*pose);
        }
    }

    /// The pose of the last keyframe, if any.
    pub fn last_keyframe(&self) -> Option<Pose2> {
        self.last
    }

    /// Number of keyframes selected so far.
    pub fn count(&self) -> u32 {
        self.next_id
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn selector() -> KeyframeSelector {
        KeyframeSelector::new(1.0, 15f64.to_radians())
    }

    fn ids(selector: &mut KeyframeSelector, poses: &[Pose2]) -> Vec<Option<u32>> {
        poses.iter().map(|p| selector.offer(p)).collect()
    }

    #[test]
    fn first_frame_is_a_keyframe_even_at_rest() {
        let mut s = selector();
        let p = Pose2::new(3.0, -2.0, 1.0);
        assert_eq!(ids(&mut s, &[p, p, p]), vec![Some(0), None, None]);
        assert_eq!(s.count(), 1);
    }

    #[test]
    fn distance_rule() {
        let mut s = selector();
        let poses: Vec<Pose2> = [0.0, 0.5, 0.99, 1.0, 1.5, 2.2, 2.3]
            .iter()
            .map(|&x| Pose2::new(x, 0.0, 0.0))
            .collect();
        assert_eq!(
            ids(&mut s, &poses),
            vec![Some(0), None, None, Some(1), None, Some(2), None]
        );
    }

    #[test]
    fn distance_is_displacement_not_path_length() {
        // Out 0.6 m and back: 1.2 m travelled, 0 m from the keyframe.
        let mut s = selector();
        let poses = [
            Pose2::new(0.0, 0.0, 0.0),
            Pose2::new(0.6, 0.0, 0.0),
            Pose2::new(0.0, 0.0, 0.0),
            Pose2::new(0.6, 0.8, 0.0),
        ];
        assert_eq!(ids(&mut s, &poses), vec![Some(0), None, None, Some(1)]);
    }

    #[test]
    fn accumulated_steps_reach_the_threshold() {
        let mut s = selector();
        assert_eq!(s.offer(&Pose2::IDENTITY), Some(0));
        let mut x = 0.0;
        let mut last = None;
        for _ in 0..10 {
            x += 0.1;
            last = s.offer(&Pose2::new(x, 0.0, 0.0));
        }
        assert!(x < 1.0, "the sum is short of 1 by rounding");
        assert_eq!(last, Some(1));
    }

    #[test]
    fn rotation_rule_wraps_across_pi() {
        let mut s = selector();
        let deg = |d: f64| Pose2::new(0.0, 0.0, d.to_radians());
        assert_eq!(
            ids(
                &mut s,
                &[deg(0.0), deg(14.0), deg(15.0), deg(20.0), deg(-15.0)]
            ),
            vec![Some(0), None, Some(1), None, Some(2)]
        );
        // 175° → −175° is a 10° turn, not 350°.
        let mut s = selector();
        assert_eq!(
            ids(&mut s, &[deg(175.0), deg(-175.0), deg(-169.0)]),
            vec![Some(0), None, Some(1)]
        );
    }

    #[test]
    fn zero_thresholds_make_every_frame_a_keyframe() {
        let mut s = KeyframeSelector::new(0.0, 0.0);
        let p = Pose2::IDENTITY;
        assert_eq!(ids(&mut s, &[p, p, p]), vec![Some(0), Some(1), Some(2)]);
    }
}
