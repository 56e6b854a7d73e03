//! Occupied cells of an occupancy grid, as points for DBSCAN.
//!
//! The paper clusters "the mapping of the environment" (the red points of Fig. 3, Sec. IV-A); in
//! nrslam the map is a `nav_msgs/OccupancyGrid` published by the mapper, and the points handed to
//! DBSCAN are the centres of the cells whose occupancy reaches a threshold. This module does that
//! conversion on the grid's raw parts, so it is usable without the message types.

use crate::SegmentError;

/// Where a grid lies in the map frame: the ROS `MapMetaData` fields that locate cells.
///
/// Cell (i, j) (column i, row j) covers `[i·r, (i+1)·r) × [j·r, (j+1)·r)` in the grid's own frame,
/// whose origin is the corner of cell (0, 0) at `(origin_x_m, origin_y_m)` rotated by
/// `origin_yaw_rad` in the map frame (ROS `MapMetaData.origin`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridGeometry {
    /// Cell edge, metres; finite and > 0.
    pub resolution_m: f64,
    /// Cells along the grid's x axis.
    pub width_cells: u32,
    /// Cells along the grid's y axis.
    pub height_cells: u32,
    /// Map-frame x of the outer corner of cell (0, 0), metres.
    pub origin_x_m: f64,
    /// Map-frame y of the outer corner of cell (0, 0), metres.
    pub origin_y_m: f64,
    /// Rotation of the grid's x axis from the map's +x, radians counter-clockwise.
    pub origin_yaw_rad: f64,
}

impl GridGeometry {
    /// Number of cells, `width × height`.
    pub fn cell_count(&self) -> usize {
        self.width_cells as usize * self.height_cells as usize
    }

    /// Map-frame centre of cell (`column`, `row`), metres.
    pub fn cell_centre(&self, column: u32, row: u32) -> [f64; 2] {
        let u = (f64::from(column) + 0.5) * self.resolution_m;
        let v = (f64::from(row) + 0.5) * self.resolution_m;
        let (sin, cos) = self.origin_yaw_rad.sin_cos();
        [
            self.origin_x_m + cos * u - sin * v,
            self.origin_y_m + sin * u + cos * v,
        ]
    }

    fn check(&self, data_len: usize) -> Result<(), SegmentError> {
        let valid = self.resolution_m.is_finite()
            && self.resolution_m > 0.0
            && self.origin_x_m.is_finite()
            && self.origin_y_m.is_finite()
            && self.origin_yaw_rad.is_finite();
        if !valid {
            return Err(SegmentError::InvalidGridGeometry {
                reason: format!(
                    "resolution must be finite and > 0 and the origin finite; got resolution \
                     {} m, origin ({}, {}) m, yaw {} rad",
                    self.resolution_m, self.origin_x_m, self.origin_y_m, self.origin_yaw_rad
                ),
            });
        }
        if data_len != self.cell_count() {
            return Err(SegmentError::InvalidGridGeometry {
                reason: format!(
                    "data holds {data_len} cells but width × height = {} × {} = {}",
                    self.width_cells,
                    self.height_cells,
                    self.cell_count()
                ),
            });
        }
        Ok(())
    }
}

/// Centres (map frame, metres) of the cells whose value is `≥ occupied_threshold` percent.
///
/// `data` is ROS layout: row-major from cell (0, 0), x (column) fastest; values 0..=100 or −1
/// (unknown). Unknown cells are never occupied whatever the threshold. The points come out in data
/// order, so DBSCAN's cluster numbering follows rows from the origin.
///
/// # Errors
/// [`SegmentError::InvalidGridGeometry`] if the resolution is not finite and positive, the origin is
/// not finite, or `data.len() != width × height`.
pub fn occupied_cell_centres(
    geometry: &GridGeometry,
    data: &[i8],
    occupied_threshold: u8,
) -> Result<Vec<[f64; 2]>, SegmentError> {
    geometry.check(data.len())?;
    let width = geometry.width_cells as usize;
    // Above 127 no cell (at most 100 %) is occupied; −1 (unknown) is below every threshold ≥ 0.
    let Ok(threshold) = i8::try_from(occupied_threshold) else {
        return Ok(Vec::new());
    };
    if width == 0 {
        return Ok(Vec::new());
    }
    let mut centres = Vec::new();
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: this CPU has AVX2.
        unsafe { occupied_into_avx2(geometry, data, width, threshold, &mut centres) };
        return Ok(centres);
    }
    occupied_into(geometry, data, width, threshold, &mut centres);
    Ok(centres)
}

/// The scan of [`occupied_cell_centres`] on checked inputs, into `centres`. Most of a map is
/// free or unknown: a block is looked into only if some cell of it is occupied, a test the
/// compiler turns into a few vector compares per 64 cells.
#[inline(always)]
fn occupied_into(
    geometry: &GridGeometry,
    data: &[i8],
    width: usize,
    threshold: i8,
    centres: &mut Vec<[f64; 2]>,
) {
    const BLOCK: usize = 64;
    for (row, cells) in data.chunks_exact(width).enumerate() {
        for (block_index, block) in cells.chunks(BLOCK).enumerate() {
            if !block.iter().fold(false, |any, &v| any | (v >= threshold)) {
                continue;
            }
            for (k, &value) in block.iter().enumerate() {
                if value >= threshold {
                    // column < width and row < height, both u32.
                    let column = (block_index * BLOCK + k) as u32;
                    centres.push(geometry.cell_centre(column, row as u32));
                }
            }
        }
    }
}

/// [`occupied_into`] compiled for AVX2 (the build targets plain x86_64, whose SSE2 compares 16
/// cells at a time; AVX2 compares 32): the same integer tests and the same arithmetic for the
/// centres, so the same points.
///
/// # Safety
///
/// The CPU must have AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
unsafe fn occupied_into_avx2(
    geometry: &GridGeometry,
    data: &[i8],
    width: usize,
    threshold: i8,
    centres: &mut Vec<[f64; 2]>,
) {
    occupied_into(geometry, data, width, threshold, centres);
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry(width_cells: u32, height_cells: u32) -> GridGeometry {
        GridGeometry {
            resolution_m: 0.5,
            width_cells,
            height_cells,
            origin_x_m: -1.0,
            origin_y_m: 2.0,
            origin_yaw_rad: 0.0,
        }
    }

    #[test]
    fn the_avx2_scan_finds_what_the_portable_scan_finds() {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") {
            // A 130 × 7 grid (rows of two whole blocks and a part), sparse pseudo-random values
            // from −1 to 100, a rotated origin.
            let g = GridGeometry {
                resolution_m: 0.1,
                width_cells: 130,
                height_cells: 7,
                origin_x_m: -3.0,
                origin_y_m: 1.5,
                origin_yaw_rad: 0.3,
            };
            let mut state = 12345u64;
            let data: Vec<i8> = (0..130 * 7)
                .map(|_| {
                    state = state.wrapping_mul(6364136223846793005).wrapping_add(1);
                    let r = (state >> 33) % 1000;
                    if r < 900 {
                        -1
                    } else {
                        (r % 102) as i8 - 1
                    }
                })
                .collect();
            for threshold in [0, 50, 65, 100] {
                let mut portable = Vec::new();
                occupied_into(&g, &data, 130, threshold, &mut portable);
                let mut avx2 = Vec::new();
                // SAFETY: checked above.
                unsafe { occupied_into_avx2(&g, &data, 130, threshold, &mut avx2) };
                let bits = |v: &[[f64; 2]]| -> Vec<[u64; 2]> {
                    v.iter().map(|p| [p[0].to_bits(), p[1].to_bits()]).collect()
                };
                assert!(threshold == 100 || !portable.is_empty());
                assert_eq!(bits(&portable), bits(&avx2), "threshold {threshold}");
            }
        }
    }

    #[test]
    fn occupied_cells_are_centres_in_row_major_order() {
        // 3 columns × 2 rows; row 0 is the bottom row (nearest the origin).
        let data = [65, -1, 64, 0, 100, 90];
        let points = occupied_cell_centres(&geometry(3, 2), &data, 65).unwrap();
        assert_eq!(points, vec![[-0.75, 2.25], [-0.25, 2.75], [0.25, 2.75]]);
    }

    #[test]
    fn threshold_is_inclusive_and_unknown_is_never_occupied() {
        let data = [-1, 0, 1, 100];
        let g = geometry(4, 1);
        assert_eq!(occupied_cell_centres(&g, &data, 0).unwrap().len(), 3);
        assert_eq!(occupied_cell_centres(&g, &data, 1).unwrap().len(), 2);
        assert_eq!(occupied_cell_centres(&g, &data, 100).unwrap().len(), 1);
        assert_eq!(occupied_cell_centres(&g, &data, 101).unwrap().len(), 0);
        assert_eq!(occupied_cell_centres(&g, &data, 255).unwrap().len(), 0);
    }

    #[test]
    fn rotated_origin_rotates_the_centres() {
        let g = GridGeometry {
            origin_yaw_rad: std::f64::consts::FRAC_PI_2,
            ..geometry(2, 1)
        };
        let points = occupied_cell_centres(&g, &[100, 100], 50).unwrap();
        // The grid's x axis points along the map's +y.
        for (p, expected) in points.iter().zip([[-1.25, 2.25], [-1.25, 2.75]]) {
            assert!((p[0] - expected[0]).abs() < 1e-12 && (p[1] - expected[1]).abs() < 1e-12);
        }
    }

    #[test]
    fn bad_geometry_is_refused() {
        assert!(matches!(
            occupied_cell_centres(&geometry(3, 2), &[0; 5], 65),
            Err(SegmentError::InvalidGridGeometry { .. })
        ));
        let g = GridGeometry {
            resolution_m: 0.0,
            ..geometry(1, 1)
        };
        assert!(occupied_cell_centres(&g, &[100], 65).is_err());
        let g = GridGeometry {
            origin_x_m: f64::NAN,
            ..geometry(1, 1)
        };
        assert!(occupied_cell_centres(&g, &[100], 65).is_err());
    }

    #[test]
    fn empty_grid_gives_no_points() {
        assert!(occupied_cell_centres(&geometry(0, 0), &[], 65)
            .unwrap()
            .is_empty());
    }

    proptest::proptest! {
        /// The block skipping finds exactly the cells the definition names, in row-major order,
        /// for any width (blocks straddling row ends), value and threshold.
        #[test]
        fn every_cell_at_or_above_the_threshold_and_no_other(
            width in 1u32..200,
            height in 1u32..6,
            threshold in 0u8..=255,
            seed in proptest::prelude::any::<u64>(),
            sparse in proptest::prelude::any::<bool>(),
        ) {
            let n = (width * height) as usize;
            let mut state = seed | 1;
            let data: Vec<i8> = (0..n)
                .map(|_| {
                    state ^= state << 13;
                    state ^= state >> 7;
                    state ^= state << 17;
                    let v = (state % 102) as i8 - 1;
                    if sparse && state % 97 != 0 { -1 } else { v }
                })
                .collect();
            let g = geometry(width, height);
            let expected: Vec<[f64; 2]> = (0..n)
                .filter(|&i| data[i] >= 0 && i16::from(data[i]) >= i16::from(threshold))
                .map(|i| g.cell_centre(i as u32 % width, i as u32 / width))
                .collect();
            proptest::prop_assert_eq!(occupied_cell_centres(&g, &data, threshold).unwrap(), expected);
        }
    }
}
