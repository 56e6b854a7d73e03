//! From a sensor's returns to nrslam's detections: each return is placed in the vehicle frame
//! with the sensor's mounting pose, then expressed as range and angle about the vehicle's
//! reference point with the boresight set to the sensor's heading (docs/conventions.md: the
//! graph's detections are taken from the vehicle's centre).
//!
//! With a sensor mounted at the centre (`x_m = y_m = 0`) this is exact: range and azimuth pass
//! through unchanged. With an offset the points (what the association matches and the mapper
//! marks occupied) are still exact; the mapper's free-space rays then start at the vehicle's
//! centre instead of at the sensor, a difference of the offset at the ray's start.

use nrslam_msgs::{Detection, Detections, Header, PointCloud2, RadarScan};

use crate::cloud::{CloudError, CloudReader};
use crate::params::Params;

/// Frame of the published detections (the graph's sensor frame).
pub const RADAR_FRAME: &str = "radar";

/// The sensor's mounting and the noise attached to its detections.
#[derive(Debug, Clone, PartialEq)]
pub struct Converter {
    x_m: f64,
    y_m: f64,
    yaw_rad: f64,
    range_std_m: f64,
    angle_std_rad: f64,
    min_range_m: f64,
    max_range_m: f64,
    power_field: String,
    power_db: f64,
}

/// What one conversion did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counts {
    /// Returns or points in the input.
    pub returns: usize,
    /// Dropped: a non-finite coordinate (a PointCloud2's invalid point) or power.
    pub non_finite: usize,
    /// Dropped: outside `min_range_m..=max_range_m` from the sensor.
    pub out_of_range: usize,
}

impl Converter {
    /// A converter from validated parameters.
    pub fn new(params: &Params) -> Self {
        Self {
            x_m: params.x_m,
            y_m: params.y_m,
            yaw_rad: params.yaw_rad,
            range_std_m: params.range_std_m,
            angle_std_rad: params.angle_std_rad,
            min_range_m: params.min_range_m,
            max_range_m: params.max_range_m,
            power_field: params.power_field.clone(),
            power_db: params.power_db,
        }
    }

    /// The detection of a point at (`x`, `y`) m in the sensor frame (x along its boresight), or
    /// why it is dropped.
    fn detection(&self, x: f64, y: f64, power_db: f64, counts: &mut Counts) -> Option<Detection> {
        counts.returns += 1;
        if !(x.is_finite() && y.is_finite()) || power_db.is_nan() {
            counts.non_finite += 1;
            return None;
        }
        let sensor_range_m = x.hypot(y);
        if !(self.min_range_m..=self.max_range_m).contains(&sensor_range_m) {
            counts.out_of_range += 1;
            return None;
        }
        let (sin, cos) = self.yaw_rad.sin_cos();
        let (vx, vy) = (self.x_m + cos * x - sin * y, self.y_m + sin * x + cos * y);
        let angle = vy.atan2(vx) - self.yaw_rad;
        Some(Detection {
            range_m: vx.hypot(vy),
            // Back to (−π, π]: the sensor's heading and the bearing both lie in [−π, π].
            angle_rad: angle.sin().atan2(angle.cos()),
            range_std_m: self.range_std_m,
            angle_std_rad: self.angle_std_rad,
            power_db,
        })
    }

    fn detections(&self, header: &Header, detections: Vec<Detection>) -> Detections {
        Detections {
            header: Header::new(header.stamp, RADAR_FRAME),
            boresight_rad: self.yaw_rad,
            detections,
        }
    }

    /// The detections of a radar scan: each return's range projected on the horizontal plane
    /// (`range · cos(elevation)`), its azimuth, its amplitude as the power.
    pub fn radar_scan(&self, scan: &RadarScan) -> (Detections, Counts) {
        let mut counts = Counts::default();
        let detections = scan
            .returns
            .iter()
            .filter_map(|r| {
                let planar_m = f64::from(r.range) * f64::from(r.elevation).cos();
                let azimuth = f64::from(r.azimuth);
                let (x, y) = (planar_m * azimuth.cos(), planar_m * azimuth.sin());
                self.detection(x, y, f64::from(r.amplitude), &mut counts)
            })
            .collect();
        (self.detections(&scan.header, detections), counts)
    }

    /// The detections of a point cloud: each point's `x` and `y` fields (`z` is ignored: the
    /// points are projected on the horizontal plane), with `power_field` as the power if set.
    pub fn point_cloud(&self, cloud: &PointCloud2) -> Result<(Detections, Counts), CloudError> {
        let mut names = vec!["x", "y"];
        if !self.power_field.is_empty() {
            names.push(&self.power_field);
        }
        let reader = CloudReader::new(cloud, &names)?;
        let mut counts = Counts::default();
        let mut detections = Vec::with_capacity(reader.len().min(1 << 16));
        reader.for_each(|v| {
            let power_db = v.get(2).copied().unwrap_or(self.power_db);
            if let Some(d) = self.detection(v[0], v[1], power_db, &mut counts) {
                detections.push(d);
            }
        });
        Ok((self.detections(&cloud.header, detections), counts))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nrslam_msgs::{PointField, RadarReturn, Time};
    use std::f64::consts::FRAC_PI_2;

    fn converter(x_m: f64, y_m: f64, yaw_rad: f64) -> Converter {
        Converter::new(&Params {
            x_m,
            y_m,
            yaw_rad,
            min_range_m: 0.5,
            max_range_m: 50.0,
            ..Params::default()
        })
    }

    fn scan(returns: &[(f32, f32, f32)]) -> RadarScan {
        RadarScan {
            header: Header::new(Time::from_seconds(100.5), "front_radar"),
            returns: returns
                .iter()
                .map(|&(range, azimuth, elevation)| RadarReturn {
                    range,
                    azimuth,
                    elevation,
                    doppler_velocity: 0.0,
                    amplitude: 12.0,
                })
                .collect(),
        }
    }

    /// Where the graph places a detection on a vehicle at the origin heading +x
    /// (docs/conventions.md).
    fn vehicle_point(d: &Detections, i: usize) -> (f64, f64) {
        let det = &d.detections[i];
        let bearing = d.boresight_rad + det.angle_rad;
        (det.range_m * bearing.cos(), det.range_m * bearing.sin())
    }

    #[test]
    fn a_centred_sensor_passes_range_and_azimuth_through() {
        let (d, counts) = converter(0.0, 0.0, FRAC_PI_2).radar_scan(&scan(&[(8.0, -0.25, 0.0)]));
        assert_eq!(
            counts,
            Counts {
                returns: 1,
                ..Counts::default()
            }
        );
        assert_eq!(
            d.header,
            Header::new(Time::from_seconds(100.5), RADAR_FRAME)
        );
        assert_eq!(d.boresight_rad, FRAC_PI_2);
        let det = d.detections[0];
        assert!((det.range_m - 8.0).abs() < 1e-6 && (det.angle_rad + 0.25).abs() < 1e-6);
        assert_eq!((det.range_std_m, det.power_db), (0.1, 12.0));
    }

    #[test]
    fn an_offset_sensor_places_points_where_they_are_on_the_vehicle() {
        // A sensor 2 m forward, 1 m left, looking left: a return 3 m ahead of it is at (2, 4).
        let c = converter(2.0, 1.0, FRAC_PI_2);
        let (d, _) = c.radar_scan(&scan(&[(3.0, 0.0, 0.0), (5.0, 0.6435011, 0.0)]));
        let (x, y) = vehicle_point(&d, 0);
        assert!(
            (x - 2.0).abs() < 1e-6 && (y - 4.0).abs() < 1e-6,
            "({x}, {y})"
        );
        // 5 m at atan(3/4) left of the boresight: 4 m along it, 3 m to its left (−x).
        let (x, y) = vehicle_point(&d, 1);
        assert!(
            (x + 1.0).abs() < 1e-5 && (y - 5.0).abs() < 1e-5,
            "({x}, {y})"
        );
    }

    #[test]
    fn elevation_projects_and_ranges_outside_the_window_drop() {
        let c = converter(0.0, 0.0, 0.0);
        let (d, counts) = c.radar_scan(&scan(&[
            (10.0, 0.0, std::f32::consts::FRAC_PI_3), // 60° up: 5 m on the plane
            (0.2, 0.0, 0.0),
            (80.0, 0.0, 0.0),
            (f32::NAN, 0.0, 0.0),
        ]));
        assert_eq!(
            counts,
            Counts {
                returns: 4,
                non_finite: 1,
                out_of_range: 2
            }
        );
        assert!((d.detections[0].range_m - 5.0).abs() < 1e-5);
    }

    #[test]
    fn point_clouds_give_the_same_detections_as_scans() {
        let returns = [(8.0f32, -0.5f32), (12.0, 0.25), (9.5, 1.0)];
        let mut data = Vec::new();
        for &(r, a) in &returns {
            for v in [r * a.cos(), r * a.sin(), 0.0, 7.0] {
                data.extend_from_slice(&v.to_le_bytes());
            }
        }
        data.extend_from_slice(&[f32::NAN.to_le_bytes(), [0; 4], [0; 4], [0; 4]].concat());
        let cloud = PointCloud2 {
            header: scan(&[]).header,
            height: 1,
            width: 4,
            fields: ["x", "y", "z", "intensity"]
                .iter()
                .enumerate()
                .map(|(i, n)| PointField::scalar(n, 4 * i as u32, PointField::FLOAT32))
                .collect(),
            point_step: 16,
            row_step: 64,
            data,
            ..PointCloud2::default()
        };
        let mut c = converter(0.3, -0.2, 0.4);
        let (from_scan, _) = c.radar_scan(&scan(
            &returns
                .iter()
                .map(|&(r, a)| (r, a, 0.0))
                .collect::<Vec<_>>(),
        ));
        c.power_field = "intensity".into();
        let (from_cloud, counts) = c.point_cloud(&cloud).unwrap();
        assert_eq!(
            counts,
            Counts {
                returns: 4,
                non_finite: 1,
                out_of_range: 0
            }
        );
        assert_eq!(from_cloud.detections.len(), 3);
        for (a, b) in from_cloud.detections.iter().zip(&from_scan.detections) {
            assert!(
                (a.range_m - b.range_m).abs() < 1e-5 && (a.angle_rad - b.angle_rad).abs() < 1e-5
            );
            assert_eq!(a.power_db, 7.0);
        }
        c.power_field = "rcs".into();
        assert!(matches!(
            c.point_cloud(&cloud),
            Err(CloudError::MissingField(..))
        ));
    }
}
