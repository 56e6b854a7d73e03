//! The segmenter as a graph node: `/map` in, `/map/segments` out.
//!
//! Each occupancy grid the mapper publishes (one per keyframe) is segmented whole: the centres of
//! its occupied cells are clustered with DBSCAN (paper Sec. IV-A, Fig. 3 right) and published as
//! [`Segments`] with the map's stamp in frame "map", for the evaluator's ET-GOPSA. The node keeps
//! no state between maps: each map already holds everything seen so far.

use nrslam_msgs::topics::{MAP, SEGMENTS};
use nrslam_msgs::{Header, Message, OccupancyGrid, Point, Segments};
use nrslam_runtime::{Node, NodeContext, NodeError, NodeResult, Outbox};

use crate::{occupied_cell_centres, Dbscan, GridGeometry, Params};

/// Frame of the published segments.
pub const MAP_FRAME: &str = "map";

/// DBSCAN on occupied cells, bound to the node API.
#[derive(Debug, Clone)]
pub struct SegmenterNode {
    params: Params,
    dbscan: Dbscan,
}

/// Builds the segmenter from `params` (validated here). The node draws no random numbers and reads
/// no files, so `ctx` is not used.
pub fn build(params: Params, _ctx: &NodeContext) -> Result<Box<dyn Node>, NodeError> {
    Ok(Box::new(SegmenterNode::new(params)?))
}

impl SegmenterNode {
    /// A node with `params`, which must pass [`Params::validate`].
    pub fn new(params: Params) -> Result<Self, NodeError> {
        params.validate()?;
        // validate() has checked both; the error path is for a min_samples beyond usize.
        let min_samples = usize::try_from(params.min_samples).map_err(NodeError::algorithm)?;
        let dbscan = Dbscan::new(params.eps_m, min_samples).map_err(NodeError::algorithm)?;
        Ok(Self { params, dbscan })
    }

    /// The parameters in use.
    pub fn params(&self) -> &Params {
        &self.params
    }

    /// Segments one map: the message the node publishes for it.
    ///
    /// # Errors
    /// [`NodeError::InvalidInput`] on [`MAP`] if the grid's metadata does not describe its data
    /// (wrong data length, non-finite or non-positive resolution, non-finite origin).
    pub fn segment(&self, grid: &OccupancyGrid) -> Result<Segments, NodeError> {
        let (origin_x_m, origin_y_m, origin_yaw_rad) = grid.info.origin.planar();
        let geometry = GridGeometry {
            resolution_m: f64::from(grid.info.resolution),
            width_cells: grid.info.width,
            height_cells: grid.info.height,
            origin_x_m,
            origin_y_m,
            origin_yaw_rad,
        };
        let invalid = |e: crate::SegmentError| NodeError::invalid_input(MAP, e.to_string());
        let centres = occupied_cell_centres(&geometry, &grid.data, self.params.occupied_threshold)
            .map_err(invalid)?;
        // Cell centres of a valid grid are finite, so this fails only on absurd grids.
        let clustering = self.dbscan.fit(&centres).map_err(invalid)?;
        tracing::debug!(
            stamp_s = grid.header.stamp.as_seconds(),
            occupied_cells = centres.len(),
            clusters = clustering.cluster_count,
            noise = clustering.noise_count(),
            "segmented map"
        );
        Ok(Segments {
            header: Header::new(grid.header.stamp, MAP_FRAME),
            eps_m: self.params.eps_m,
            min_samples: self.params.min_samples,
            // cluster_count ≤ number of points ≤ i32::MAX (checked by fit).
            cluster_count: clustering.cluster_count as u32,
            points: centres
                .iter()
                .map(|&[x_m, y_m]| Point::planar(x_m, y_m))
                .collect(),
            labels: clustering.labels,
        })
    }
}

impl Node for SegmenterNode {
    fn inputs(&self) -> Vec<&'static str> {
        vec![MAP]
    }

    fn outputs(&self) -> Vec<&'static str> {
        vec![SEGMENTS]
    }

    fn on_message(&mut self, topic: &str, message: &Message, outbox: &mut Outbox) -> NodeResult {
        match message {
            Message::OccupancyGrid(grid) if topic == MAP => {
                outbox.publish(SEGMENTS, self.segment(grid)?);
                Ok(())
            }
            other => Err(NodeError::unexpected(topic, other)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{MapMetaData, Pose, Time};

    /// A 6 × 3 grid of 0.5 m cells at (−1, −1): two occupied blobs and one lone occupied cell.
    fn grid() -> OccupancyGrid {
        #[rustfmt::skip]
        let data = vec![
            90, 90, -1,  0, 97, 97,
            90, 90,  0, 20, 97, 97,
            -1, 10,  0, 64, 10, 70,
        ];
        OccupancyGrid {
            header: Header::new(Time::from_seconds(7.25), "map"),
            info: MapMetaData {
                map_load_time: Time::from_seconds(7.25),
                resolution: 0.5,
                width: 6,
                height: 3,
                origin: Pose::from_planar(-1.0, -1.0, 0.0),
            },
            data,
        }
    }

    fn node(eps_m: f64, min_samples: u32) -> SegmenterNode {
        SegmenterNode::new(Params {
            eps_m,
            min_samples,
            ..Params::default()
        })
        .unwrap()
    }

    #[test]
    fn publishes_labelled_occupied_cells_with_the_map_stamp() {
        let mut node = node(0.6, 3);
        let mut outbox = Outbox::new();
        node.on_message(MAP, &Message::OccupancyGrid(grid()), &mut outbox)
            .unwrap();
        let published: Vec<_> = outbox.drain().collect();
        assert_eq!(published.len(), 1);
        let (topic, Message::Segments(segments)) = &published[0] else {
            panic!("expected Segments, got {:?}", published[0].1);
        };
        assert_eq!(*topic, SEGMENTS);
        assert_eq!(
            segments.header,
            Header::new(Time::from_seconds(7.25), "map")
        );
        assert_eq!((segments.eps_m, segments.min_samples), (0.6, 3));
        // Occupied (≥ 65) in data order: row 0: columns 0, 1, 4, 5; row 1: 0, 1, 4, 5; row 2: 5.
        let expected_points = [
            (-0.75, -0.75),
            (-0.25, -0.75),
            (1.25, -0.75),
            (1.75, -0.75),
            (-0.75, -0.25),
            (-0.25, -0.25),
            (1.25, -0.25),
            (1.75, -0.25),
            (1.75, 0.25),
        ];
        let points: Vec<(f64, f64)> = segments.points.iter().map(|p| (p.x, p.y)).collect();
        assert_eq!(points, expected_points);
        // Neighbours within 0.6 m: the 4-neighbours (0.5 m), not diagonals (0.71 m). Every blob
        // cell has 3 with itself; the lone cell (1.75, 0.25) touches (1.75, −0.25) only, so it is a
        // border point of the right blob.
        assert_eq!(segments.labels, vec![0, 0, 1, 1, 0, 0, 1, 1, 1]);
        assert_eq!(segments.cluster_count, 2);
    }

    #[test]
    fn a_stricter_min_samples_turns_cells_into_noise() {
        let segments = node(0.6, 4).segment(&grid()).unwrap();
        // With 4 needed, only (1.75, −0.25) (itself, left, below, above) is core.
        assert_eq!(segments.labels, vec![-1, -1, -1, 0, -1, -1, 0, 0, 0]);
        assert_eq!(segments.cluster_count, 1);
    }

    #[test]
    fn an_empty_map_gives_empty_segments() {
        let mut empty = grid();
        empty.data = vec![-1; 18];
        let segments = node(0.5, 4).segment(&empty).unwrap();
        assert!(segments.points.is_empty() && segments.labels.is_empty());
        assert_eq!(segments.cluster_count, 0);
    }

    #[test]
    fn a_malformed_grid_or_a_wrong_message_is_invalid_input() {
        let mut node = node(0.5, 4);
        let mut bad = grid();
        bad.data.pop();
        let mut outbox = Outbox::new();
        let err = node
            .on_message(MAP, &Message::OccupancyGrid(bad), &mut outbox)
            .unwrap_err();
        assert!(matches!(err, NodeError::InvalidInput { .. }), "{err}");
        let err = node
            .on_message(
                MAP,
                &Message::Clock(nrslam_msgs::Clock::default()),
                &mut outbox,
            )
            .unwrap_err();
        assert!(err.to_string().contains("OccupancyGrid"), "{err}");
        assert!(outbox.is_empty());
    }

    #[test]
    fn build_refuses_invalid_params_and_declares_the_topics() {
        let ctx = NodeContext::for_tests(1);
        let err = build(
            Params {
                eps_m: -1.0,
                ..Params::default()
            },
            &ctx,
        )
        .err()
        .expect("negative eps refused");
        assert!(err.to_string().contains("eps_m"), "{err}");
        let node = build(Params::default(), &ctx).unwrap();
        assert_eq!(node.inputs(), vec![MAP]);
        assert_eq!(node.outputs(), vec![SEGMENTS]);
    }
}
