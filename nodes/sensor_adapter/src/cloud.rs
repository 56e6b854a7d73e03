//! Bounded reading of `sensor_msgs/msg/PointCloud2` points: any field layout, any of the eight
//! datatypes, either byte order.
//!
//! A cloud's sizes come from the sender: nothing here trusts `width`, `height`, `point_step`,
//! `row_step` or a field's offset beyond the bytes actually present. [`CloudReader::new`] checks,
//! in u64 arithmetic that cannot overflow, that every point's fields lie inside `data`, so the
//! loop over points runs at most `data.len()` times (a point is at least one byte, the `x`
//! field's) and reads with checked slices.

use nrslam_msgs::{PointCloud2, PointField};

/// Why a cloud cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CloudError {
    /// A field the reader needs is not in `fields`.
    #[error("the cloud has no field {0:?} (fields: {1})")]
    MissingField(String, String),
    /// A field's datatype is not one of PointField's eight, or it has no element.
    #[error("field {name:?}: datatype {datatype} with count {count} is not a readable scalar")]
    BadDatatype {
        /// Field name.
        name: String,
        /// Its datatype.
        datatype: u8,
        /// Its count.
        count: u32,
    },
    /// A field reaches past the end of a point.
    #[error("field {name:?} ends at byte {end} of a point of point_step {point_step} bytes")]
    FieldOutsidePoint {
        /// Field name.
        name: String,
        /// First byte after the field's first element.
        end: u64,
        /// Bytes of one point.
        point_step: u32,
    },
    /// The points the sizes describe do not fit in the data.
    #[error(
        "{width} x {height} points of {point_step} bytes in rows of {row_step} need {needed} \
         bytes, the data has {present}"
    )]
    Truncated {
        /// Points per row.
        width: u32,
        /// Rows.
        height: u32,
        /// Bytes per point.
        point_step: u32,
        /// Bytes per row.
        row_step: u32,
        /// Bytes the sizes need.
        needed: u64,
        /// Bytes present.
        present: usize,
    },
}

/// Where one scalar lies in a point.
#[derive(Debug, Clone, Copy)]
struct Scalar {
    offset: usize,
    datatype: u8,
    size: usize,
}

/// Reads chosen scalar fields of every point of a cloud, as f64.
#[derive(Debug)]
pub struct CloudReader<'a> {
    cloud: &'a PointCloud2,
    scalars: Vec<Scalar>,
}

impl<'a> CloudReader<'a> {
    /// A reader of the fields `names` (each must exist, hold a scalar of a known datatype and
    /// lie inside a point) of `cloud`, whose every point must lie inside its data.
    pub fn new(cloud: &'a PointCloud2, names: &[&str]) -> Result<Self, CloudError> {
        let mut scalars = Vec::with_capacity(names.len());
        for &name in names {
            let field = cloud
                .fields
                .iter()
                .find(|f| f.name == name)
                .ok_or_else(|| {
                    let known: Vec<&str> = cloud.fields.iter().map(|f| f.name.as_str()).collect();
                    CloudError::MissingField(name.to_owned(), known.join(", "))
                })?;
            let size = PointField::datatype_size(field.datatype)
                .filter(|_| field.count >= 1)
                .ok_or_else(|| CloudError::BadDatatype {
                    name: name.to_owned(),
                    datatype: field.datatype,
                    count: field.count,
                })?;
            let end = u64::from(field.offset) + u64::from(size);
            if end > u64::from(cloud.point_step) {
                return Err(CloudError::FieldOutsidePoint {
                    name: name.to_owned(),
                    end,
                    point_step: cloud.point_step,
                });
            }
            // end ≤ point_step ≤ u32::MAX, so both fit a usize on every supported target.
            scalars.push(Scalar {
                offset: field.offset as usize,
                datatype: field.datatype,
                size: size as usize,
            });
        }
        let (width, height) = (u64::from(cloud.width), u64::from(cloud.height));
        // The last point's end: (height − 1)·row_step + width·point_step, at most ~2^96: u128.
        let needed = if width == 0 || height == 0 {
            0
        } else {
            u128::from(height - 1) * u128::from(cloud.row_step)
                + u128::from(width) * u128::from(cloud.point_step)
        };
        // Rows must not overlap and a point must take a byte, so that the points number at most
        // the bytes present.
        let rows_overlap =
            height > 1 && width * u64::from(cloud.point_step) > u64::from(cloud.row_step);
        let empty_points = cloud.point_step == 0 && width * height > 0;
        if needed > cloud.data.len() as u128 || rows_overlap || empty_points {
            return Err(CloudError::Truncated {
                width: cloud.width,
                height: cloud.height,
                point_step: cloud.point_step,
                row_step: cloud.row_step,
                needed: u64::try_from(needed).unwrap_or(u64::MAX),
                present: cloud.data.len(),
            });
        }
        Ok(Self { cloud, scalars })
    }

    /// Points in the cloud (`width × height`, which [`CloudReader::new`] bounded by the data).
    pub fn len(&self) -> usize {
        self.cloud.width as usize * self.cloud.height as usize
    }

    /// No points.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Calls `visit` with the chosen fields of every point, row by row, as f64 (in the order of
    /// the names given to [`CloudReader::new`]).
    pub fn for_each(&self, mut visit: impl FnMut(&[f64])) {
        let cloud = self.cloud;
        let mut values = vec![0.0; self.scalars.len()];
        for row in 0..cloud.height as usize {
            for column in 0..cloud.width as usize {
                // In range: checked by new() (needed ≤ data.len()).
                let start = row * cloud.row_step as usize + column * cloud.point_step as usize;
                for (value, scalar) in values.iter_mut().zip(&self.scalars) {
                    let at = start + scalar.offset;
                    *value = cloud
                        .data
                        .get(at..at + scalar.size)
                        .map_or(f64::NAN, |bytes| {
                            read(bytes, scalar.datatype, cloud.is_bigendian)
                        });
                }
                visit(&values);
            }
        }
    }
}

/// One scalar of `datatype` from exactly its bytes.
fn read(bytes: &[u8], datatype: u8, big_endian: bool) -> f64 {
    macro_rules! num {
        ($t:ty) => {{
            let raw: [u8; std::mem::size_of::<$t>()] = match bytes.try_into() {
                Ok(raw) => raw,
                Err(_) => return f64::NAN,
            };
            if big_endian {
                <$t>::from_be_bytes(raw) as f64
            } else {
                <$t>::from_le_bytes(raw) as f64
            }
        }};
    }
    match datatype {
        PointField::INT8 => num!(i8),
        PointField::UINT8 => num!(u8),
        PointField::INT16 => num!(i16),
        PointField::UINT16 => num!(u16),
        PointField::INT32 => num!(i32),
        PointField::UINT32 => num!(u32),
        PointField::FLOAT32 => num!(f32),
        PointField::FLOAT64 => num!(f64),
        _ => f64::NAN,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::Header;

    /// Two rows of two points: float64 x at 8, float32 y at 0, int16 power at 4; 16-byte points
    /// in 40-byte rows (8 bytes of row padding).
    fn cloud(big_endian: bool) -> PointCloud2 {
        let mut data = Vec::new();
        for row in 0..2 {
            for column in 0..2 {
                let (x, y, p) = (
                    row as f64 + 0.5,
                    column as f32 - 1.0,
                    -3i16 * (row + column),
                );
                let mut point = [0u8; 16];
                if big_endian {
                    point[0..4].copy_from_slice(&y.to_be_bytes());
                    point[4..6].copy_from_slice(&p.to_be_bytes());
                    point[8..16].copy_from_slice(&x.to_be_bytes());
                } else {
                    point[0..4].copy_from_slice(&y.to_le_bytes());
                    point[4..6].copy_from_slice(&p.to_le_bytes());
                    point[8..16].copy_from_slice(&x.to_le_bytes());
                }
                data.extend_from_slice(&point);
            }
            data.extend_from_slice(&[0xAA; 8]);
        }
        PointCloud2 {
            header: Header::default(),
            height: 2,
            width: 2,
            fields: vec![
                PointField::scalar("y", 0, PointField::FLOAT32),
                PointField::scalar("power", 4, PointField::INT16),
                PointField::scalar("x", 8, PointField::FLOAT64),
            ],
            is_bigendian: big_endian,
            point_step: 16,
            row_step: 40,
            data,
            is_dense: true,
        }
    }

    fn read_all(cloud: &PointCloud2, names: &[&str]) -> Result<Vec<Vec<f64>>, CloudError> {
        let reader = CloudReader::new(cloud, names)?;
        let mut out = Vec::new();
        reader.for_each(|v| out.push(v.to_vec()));
        assert_eq!(out.len(), reader.len());
        Ok(out)
    }

    #[test]
    fn reads_any_layout_datatype_and_byte_order() {
        let expected = vec![
            vec![0.5, -1.0, 0.0],
            vec![0.5, 0.0, -3.0],
            vec![1.5, -1.0, -3.0],
            vec![1.5, 0.0, -6.0],
        ];
        for big_endian in [false, true] {
            let points = read_all(&cloud(big_endian), &["x", "y", "power"]).unwrap();
            assert_eq!(points, expected, "big endian {big_endian}");
        }
    }

    #[test]
    fn the_last_row_needs_no_padding() {
        let mut c = cloud(false);
        c.data.truncate(40 + 32);
        assert_eq!(read_all(&c, &["x"]).unwrap().len(), 4);
        c.data.pop();
        assert!(matches!(
            read_all(&c, &["x"]),
            Err(CloudError::Truncated {
                needed: 72,
                present: 71,
                ..
            })
        ));
    }

    #[test]
    fn sizes_beyond_the_data_are_refused_before_any_loop() {
        let mut c = cloud(false);
        c.width = u32::MAX;
        c.height = u32::MAX;
        c.row_step = u32::MAX;
        assert!(matches!(
            read_all(&c, &["x"]),
            Err(CloudError::Truncated { .. })
        ));
        let mut c = cloud(false);
        c.row_step = 8; // rows overlapping each other
        assert!(matches!(
            read_all(&c, &["x"]),
            Err(CloudError::Truncated { .. })
        ));
    }

    #[test]
    fn bad_fields_are_named() {
        let c = cloud(false);
        let err = read_all(&c, &["z"]).unwrap_err();
        assert!(
            err.to_string().contains("\"z\"") && err.to_string().contains("y, power, x"),
            "{err}"
        );
        let mut c = cloud(false);
        c.fields[2].offset = 12;
        assert!(matches!(
            read_all(&c, &["x"]),
            Err(CloudError::FieldOutsidePoint { end: 20, .. })
        ));
        c.fields[2].offset = u32::MAX;
        assert!(matches!(
            read_all(&c, &["x"]),
            Err(CloudError::FieldOutsidePoint { .. })
        ));
        let mut c = cloud(false);
        c.fields[0].datatype = 0;
        assert!(matches!(
            read_all(&c, &["y"]),
            Err(CloudError::BadDatatype { .. })
        ));
        c.fields[0].datatype = PointField::FLOAT32;
        c.fields[0].count = 0;
        assert!(matches!(
            read_all(&c, &["y"]),
            Err(CloudError::BadDatatype { .. })
        ));
    }

    #[test]
    fn an_empty_cloud_has_no_points() {
        let mut c = cloud(false);
        c.width = 0;
        c.data.clear();
        assert!(read_all(&c, &["x", "y"]).unwrap().is_empty());
    }
}
