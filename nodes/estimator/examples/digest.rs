//! Bit-level digest of the estimator's outputs (detections, noise floor, range-angle map) over a
//! set of grids and configurations: run before and after a change to check that the outputs are
//! bit-identical. `cargo run --release -p nrslam-estimator --example digest`
#[path = "../tests/common/mod.rs"]
mod common;
use common::{grid, params, twenty_echoes};
use nrslam_estimator::{Detector, Estimator, EstimatorConfig, Refinement};
use std::collections::hash_map::DefaultHasher;
use std::hash::Hasher;

fn main() {
    let configs = [
        EstimatorConfig::default(),
        EstimatorConfig {
            refinement: Refinement::Interpolation,
            ..Default::default()
        },
        EstimatorConfig {
            detector: Detector::Cfar,
            ..Default::default()
        },
        EstimatorConfig {
            max_range_m: Some(20.0),
            ..Default::default()
        },
        EstimatorConfig {
            zero_padding_angle: 3,
            refinement: Refinement::ZeroPadding { factor: 2 },
            ..Default::default()
        },
        EstimatorConfig {
            threshold_db: 3.0,
            sidelobe_margin_db: None,
            dynamic_range_db: 400.0,
            max_detections: 65536,
            ..Default::default()
        },
    ];
    let mut total = DefaultHasher::new();
    for &(n, k, m) in &[
        (10240, 32, 1),
        (1000, 7, 1),
        (512, 8, 4),
        (1, 1, 1),
        (3, 2, 1),
    ] {
        let p = params(n, k, m);
        let echoes = twenty_echoes(&p);
        for (gi, snr) in [Some(p.snr_db), Some(-20.0), None, Some(300.0)]
            .into_iter()
            .enumerate()
        {
            let g = grid(&p, &echoes, snr, 7 + gi as u64);
            for (ci, cfg) in configs.iter().enumerate() {
                let mut h = DefaultHasher::new();
                let Ok(mut est) = Estimator::new(&p, cfg.clone()) else {
                    continue;
                };
                match est.process_grid(&g) {
                    Ok(d) => {
                        for x in &d {
                            h.write_u64(x.range_m.to_bits());
                            h.write_u64(x.angle_rad.to_bits());
                            h.write_u64(x.power_db.to_bits());
                            h.write_usize(x.range_bin);
                            h.write_usize(x.angle_bin);
                        }
                        h.write_usize(d.len());
                    }
                    Err(e) => h.write(e.to_string().as_bytes()),
                }
                h.write_u64(est.noise_floor().to_bits());
                if let Ok(map) = est.range_angle_map(&g) {
                    for v in &map.values {
                        h.write_u64(v.re.to_bits());
                        h.write_u64(v.im.to_bits());
                    }
                    h.write_u64(map.noise_power.to_bits());
                }
                let v = h.finish();
                println!("n{n} k{k} m{m} grid{gi} cfg{ci}: {v:016x}");
                total.write_u64(v);
            }
        }
    }
    println!("total {:016x}", total.finish());
}
