//! The mapper as a graph node: `/slam/keyframe` and `/slam/keyframe_poses` in, `/map` out.
//!
//! Each keyframe from data association (paper Sec. III-A: "we select key frames in the sensing
//! data to build the mapping data") is integrated into the [`OccupancyMap`] at the keyframe's SLAM
//! pose, and the whole grid is published as a `nav_msgs/OccupancyGrid` with the keyframe's stamp in
//! frame "map" (`map_load_time` = that stamp, origin from the parameters). Publishing the whole grid
//! each time keeps the segmenter stateless and lets any ROS tool show the latest map.
//!
//! Map rebuild after loop closure (paper Sec. III-A, loop detection): the mapper keeps every
//! keyframe's detections. `/slam/keyframe_poses` accompanies each keyframe with the current pose
//! of every keyframe and a revision number; when the revision changes, the back end has moved the
//! keyframes, and the grid is rebuilt from scratch with every stored keyframe at its corrected
//! pose, then published. The grid so always reflects the latest pose graph, not the poses the
//! keyframes had when they arrived. With `rebuild_on_correction = false` the node subscribes to
//! `/slam/keyframe` only (for back ends that publish no poses).

use nrslam_msgs::topics::{KEYFRAME, KEYFRAME_POSES, MAP};
use nrslam_msgs::{Keyframe, KeyframePoses, Message};
use nrslam_runtime::{Node, NodeContext, NodeError, NodeResult, Outbox};

use crate::{OccupancyMap, Params};

/// [`OccupancyMap`] bound to the node API.
#[derive(Debug, Clone)]
pub struct MapperNode {
    map: OccupancyMap,
    params: Params,
    /// Every keyframe received, by arrival (ids ascend), kept for rebuilds.
    keyframes: Vec<Keyframe>,
    /// Revision of the poses the grid was last built with.
    revision: u32,
    /// Rebuilds so far.
    rebuilds: u64,
    /// Keyframes integrated since the grid was last published, and the newest one's stamp.
    unpublished: Option<(u32, nrslam_msgs::Time)>,
}

/// Builds the mapper from `params` (validated here). The node draws no random numbers and reads no
/// files, so `ctx` is not used.
pub fn build(params: Params, _ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    Ok(Box::new(MapperNode::new(&params)?))
}

impl MapperNode {
    /// A node with an all-unknown map as `params` describe it.
    pub fn new(params: &Params) -> Result<Self, NodeError> {
        Ok(Self {
            map: OccupancyMap::new(params)?,
            params: params.clone(),
            keyframes: Vec::new(),
            revision: 0,
            rebuilds: 0,
            unpublished: None,
        })
    }

    /// Times the grid was rebuilt from corrected keyframe poses.
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }

    fn on_keyframe_poses(
        &mut self,
        poses: &KeyframePoses,
        outbox: &mut Outbox,
    ) -> Result<(), NodeError> {
        if poses.revision == self.revision {
            return Ok(());
        }
        if poses.ids.len() != poses.poses.len() {
            return Err(NodeError::invalid_input(
                KEYFRAME_POSES,
                format!("{} ids but {} poses", poses.ids.len(), poses.poses.len()),
            ));
        }
        // Corrected poses by id; keyframes the message does not name keep theirs.
        let mut corrected = self.keyframes.clone();
        for keyframe in &mut corrected {
            if let Ok(i) = poses.ids.binary_search(&keyframe.id) {
                keyframe.pose = poses.poses[i];
            }
        }
        let mut map = OccupancyMap::new(&self.params)?;
        map.integrate_keyframes(&corrected).map_err(|(index, e)| {
            NodeError::invalid_input(
                KEYFRAME_POSES,
                format!(
                    "keyframe {} at its corrected pose: {e}",
                    corrected[index].id
                ),
            )
        })?;
        self.map = map;
        self.keyframes = corrected;
        self.revision = poses.revision;
        self.rebuilds += 1;
        self.unpublished = None;
        tracing::debug!(
            revision = poses.revision,
            keyframes = self.keyframes.len(),
            "map rebuilt from corrected keyframes"
        );
        outbox.publish(MAP, self.map.to_occupancy_grid(poses.header.stamp));
        Ok(())
    }

    /// The map built so far.
    pub fn map(&self) -> &OccupancyMap {
        &self.map
    }

    fn on_keyframe(&mut self, keyframe: &Keyframe, outbox: &mut Outbox) -> Result<(), NodeError> {
        let report = self.map.integrate_keyframe(keyframe).map_err(|e| {
            NodeError::invalid_input(KEYFRAME, format!("keyframe {}: {e}", keyframe.id))
        })?;
        if report.out_of_grid > 0 {
            tracing::debug!(
                keyframe = keyframe.id,
                out_of_grid = report.out_of_grid,
                total_out_of_grid = self.map.out_of_grid_detections(),
                "detections outside the map ignored"
            );
        }
        tracing::debug!(
            keyframe = keyframe.id,
            detections = report.detections,
            hit_cells = report.hit_cells,
            free_cells = report.free_cells,
            "keyframe integrated"
        );
        if self.params.rebuild_on_correction {
            self.keyframes.push(keyframe.clone());
        }
        let waiting = self.unpublished.map_or(0, |(count, _)| count) + 1;
        if waiting >= self.params.publish_every_keyframes {
            self.unpublished = None;
            outbox.publish(MAP, self.map.to_occupancy_grid(keyframe.header.stamp));
        } else {
            self.unpublished = Some((waiting, keyframe.header.stamp));
        }
        Ok(())
    }
}

impl Node for MapperNode {
    fn inputs(&self) -> Vec<&'static str> {
        if self.params.rebuild_on_correction {
            // Keyframe first: a keyframe and the poses that include it share a stamp.
            vec![KEYFRAME, KEYFRAME_POSES]
        } else {
            vec![KEYFRAME]
        }
    }

    fn outputs(&self) -> Vec<&'static str> {
        vec![MAP]
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        match message {
            Message::Keyframe(keyframe) if topic == KEYFRAME => self.on_keyframe(keyframe, outbox),
            Message::KeyframePoses(poses) if topic == KEYFRAME_POSES => {
                self.on_keyframe_poses(poses, outbox)
            }
            other => Err(NodeError::unexpected(topic, other)),
        }
    }

    fn on_end(&mut self, outbox: &mut Outbox) -> Result<(), NodeError> {
        // The last keyframes are always in a published grid, whatever publish_every_keyframes.
        if let Some((_, stamp)) = self.unpublished.take() {
            outbox.publish(MAP, self.map.to_occupancy_grid(stamp));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{Detection, Header, OccupancyGrid, Pose, Time};

    fn params() -> Params {
        Params {
            resolution_m: 1.0,
            origin_x_m: -2.0,
            origin_y_m: -1.0,
            width_m: 6.0,
            height_m: 3.0,
            ..Params::default()
        }
    }

    fn keyframe(id: u32, stamp_s: f64, range_m: f64) -> Keyframe {
        Keyframe {
            header: Header::new(Time::from_seconds(stamp_s), "map"),
            id,
            pose: Pose::from_planar(-1.5, 0.5, 0.0),
            boresight_rad: 0.0,
            detections: vec![Detection {
                range_m,
                ..Detection::default()
            }],
        }
    }

    fn publish(node: &mut MapperNode, keyframe: Keyframe) -> OccupancyGrid {
        let mut outbox = Outbox::new();
        node.on_message(KEYFRAME, &Message::Keyframe(keyframe), &mut outbox)
            .unwrap();
        let mut published: Vec<_> = outbox.drain().collect();
        assert_eq!(published.len(), 1);
        match published.pop().unwrap() {
            (MAP, Message::OccupancyGrid(grid)) => grid,
            (topic, other) => panic!("unexpected {topic}: {other:?}"),
        }
    }

    #[test]
    fn each_keyframe_publishes_the_whole_grid_with_its_stamp() {
        let mut node = MapperNode::new(&params()).unwrap();
        let grid = publish(&mut node, keyframe(0, 2.0, 3.0));
        assert_eq!(grid.header, Header::new(Time::from_seconds(2.0), "map"));
        assert_eq!(grid.info.map_load_time, Time::from_seconds(2.0));
        assert_eq!(
            (grid.info.width, grid.info.height, grid.info.resolution),
            (6, 3, 1.0)
        );
        assert_eq!(grid.info.origin, Pose::from_planar(-2.0, -1.0, 0.0));
        // Row 1 (y 0..1): sensor cell and two more free, hit at x = 1.5 (column 3).
        #[rustfmt::skip]
        assert_eq!(grid.data, vec![
            -1, -1, -1, -1, -1, -1,
            40, 40, 40, 70, -1, -1,
            -1, -1, -1, -1, -1, -1,
        ]);
        // The second keyframe sees through column 3 to column 4: the map accumulates.
        let grid = publish(&mut node, keyframe(1, 3.0, 4.0));
        assert_eq!(grid.header.stamp, Time::from_seconds(3.0));
        assert_eq!(&grid.data[6..12], &[31, 31, 31, 61, 70, -1]);
    }

    #[test]
    fn publish_every_keyframes_skips_grids_but_never_the_last() {
        let mut node = MapperNode::new(&Params {
            publish_every_keyframes: 3,
            ..params()
        })
        .unwrap();
        let mut outbox = Outbox::new();
        let mut published = Vec::new();
        for k in 0..5 {
            let message = Message::Keyframe(keyframe(k, 1.0 + f64::from(k), 2.0));
            node.on_message(KEYFRAME, &message, &mut outbox).unwrap();
            published.push(outbox.drain().count());
        }
        // The third keyframe's grid only; the fifth's waits for the end.
        assert_eq!(published, vec![0, 0, 1, 0, 0]);
        node.on_end(&mut outbox).unwrap();
        let last: Vec<_> = outbox.drain().collect();
        match last.as_slice() {
            [(MAP, Message::OccupancyGrid(grid))] => {
                assert_eq!(grid.header.stamp, Time::from_seconds(5.0))
            }
            other => panic!("expected the last grid, got {other:?}"),
        }
        node.on_end(&mut outbox).unwrap();
        assert!(outbox.is_empty(), "nothing is published twice");
    }

    #[test]
    fn identical_inputs_give_identical_maps() {
        let run = || {
            let mut node = MapperNode::new(&params()).unwrap();
            (0..5)
                .map(|k| {
                    publish(
                        &mut node,
                        keyframe(k, 1.0 + f64::from(k), 2.0 + 0.7 * f64::from(k)),
                    )
                })
                .collect::<Vec<_>>()
        };
        assert_eq!(run(), run());
    }

    #[test]
    fn a_nan_keyframe_is_invalid_input_and_publishes_nothing() {
        let mut node = MapperNode::new(&params()).unwrap();
        let mut outbox = Outbox::new();
        let err = node
            .on_message(
                KEYFRAME,
                &Message::Keyframe(keyframe(4, 2.0, f64::NAN)),
                &mut outbox,
            )
            .unwrap_err();
        assert!(matches!(err, NodeError::InvalidInput { .. }), "{err}");
        assert!(err.to_string().contains("keyframe 4"), "{err}");
        assert!(outbox.is_empty());
        assert!(node.map().occupancy_data().iter().all(|&v| v == -1));
        let err = node
            .on_message(
                KEYFRAME,
                &Message::Clock(nrslam_msgs::Clock::default()),
                &mut outbox,
            )
            .unwrap_err();
        assert!(err.to_string().contains("Keyframe"), "{err}");
    }

    #[test]
    fn build_refuses_invalid_params_and_declares_the_topics() {
        let ctx = NodeContext::for_tests(1);
        let err = build(
            Params {
                resolution_m: 0.0,
                ..Params::default()
            },
            &ctx,
        )
        .err()
        .expect("zero resolution refused");
        assert!(err.to_string().contains("resolution_m"), "{err}");
        let node = build(Params::default(), &ctx).unwrap();
        assert_eq!(node.inputs(), vec![KEYFRAME, KEYFRAME_POSES]);
        let node = build(
            Params {
                rebuild_on_correction: false,
                ..Params::default()
            },
            &ctx,
        )
        .unwrap();
        assert_eq!(node.inputs(), vec![KEYFRAME]);
        assert_eq!(node.outputs(), vec![MAP]);
    }

    fn poses(revision: u32, stamp_s: f64, xs: &[f64]) -> Message {
        Message::KeyframePoses(KeyframePoses {
            header: Header::new(Time::from_seconds(stamp_s), "map"),
            revision,
            ids: (0..xs.len() as u32).collect(),
            poses: xs.iter().map(|&x| Pose::from_planar(x, 0.5, 0.0)).collect(),
            ..KeyframePoses::default()
        })
    }

    #[test]
    fn a_new_revision_rebuilds_the_grid_from_corrected_poses() {
        let mut node = MapperNode::new(&params()).unwrap();
        publish(&mut node, keyframe(0, 1.0, 3.0));
        let mut outbox = Outbox::new();
        // Same revision: nothing to do.
        node.on_message(KEYFRAME_POSES, &poses(0, 1.0, &[-1.5]), &mut outbox)
            .unwrap();
        assert!(outbox.is_empty());
        // The keyframe moved 1 m to the right: the rebuilt grid has the hit one cell further.
        node.on_message(KEYFRAME_POSES, &poses(1, 2.0, &[-0.5]), &mut outbox)
            .unwrap();
        let published: Vec<_> = outbox.drain().collect();
        assert_eq!(published.len(), 1);
        let (MAP, Message::OccupancyGrid(grid)) = &published[0] else {
            panic!("{published:?}")
        };
        assert_eq!(grid.header.stamp, Time::from_seconds(2.0));
        #[rustfmt::skip]
        assert_eq!(&grid.data[6..12], &[-1, 40, 40, 40, 70, -1]);
        assert_eq!(node.rebuilds(), 1);
        // The same as a fresh map given the keyframe at the corrected pose.
        let mut fresh = MapperNode::new(&params()).unwrap();
        let mut moved = keyframe(0, 1.0, 3.0);
        moved.pose = Pose::from_planar(-0.5, 0.5, 0.0);
        assert_eq!(publish(&mut fresh, moved).data, grid.data);
        // Mismatched lengths are invalid input.
        let Message::KeyframePoses(mut bad) = poses(2, 3.0, &[0.0]) else {
            unreachable!()
        };
        bad.ids.push(7);
        assert!(node
            .on_message(KEYFRAME_POSES, &Message::KeyframePoses(bad), &mut outbox)
            .is_err());
    }
}
