//! What every run of one scene computes alike, kept for the runs of this process.
//!
//! A scene's truth does not depend on the seed: the AGV drives the same path in every Monte Carlo
//! trial, so at frame k every trial sees the same scatterers ([`observe`]) and, at `spectral`
//! fidelity, evaluates the same range and angle kernels around them
//! ([`nrslam_ofdm::spectral::Responses`]); only the noise, the echoes' random phases and the
//! odometry differ. [`SceneMemo`] keeps both per true pose, for the scene's targets and sensor,
//! and hands them to every [`crate::Simulator`] of that scene in the process (the trials of
//! `nrslam montecarlo` run in one process). Lookups are by the exact bits of the pose, and the
//! kept values are the ones the computation gives, so a run's output is the same bit for bit
//! whether it computed them or found them; a miss computes and keeps, within a budget.

use std::collections::HashMap;
use std::sync::{Arc, Mutex, PoisonError};

use nrslam_ofdm::spectral::{Responses, SpectralConfig};
use nrslam_ofdm::{OfdmError, OfdmParams, Scatterer};

use crate::geometry::Pose2;
use crate::scene::Target;
use crate::visibility::{observe, Sensor, Sighting};

/// Scenes (targets and sensor) kept at once; the least recently opened is dropped beyond.
const SCENES: usize = 4;
/// Poses whose sightings one scene keeps (a hall lap is 294 frames).
const MAX_POSES: usize = 100_000;
/// Bytes of kernel responses one scene keeps over all its OFDM settings (a hall lap at
/// paper-5g's settings is about 20 MB): 512 MB for the [`SCENES`] in all, so that a sizing
/// study (hundreds of settings, and random scene families) stays within a cluster's usual
/// 1 GB per CPU; a setting past the budget computes its responses, with the same values.
const MAX_RESPONSE_BYTES: usize = (512 << 20) / SCENES;

/// The exact bits of a pose: the lookup key.
type PoseKey = [u64; 3];

fn pose_key(pose: Pose2) -> PoseKey {
    [
        pose.x_m.to_bits(),
        pose.y_m.to_bits(),
        pose.yaw_rad.to_bits(),
    ]
}

/// The OFDM settings the kernel responses depend on, besides the geometry: the parameters, the
/// configuration and the bits of the platform's speed and the sensor's boresight (which give
/// each scatterer its radial velocity).
type ModelKey = (OfdmParams, SpectralConfig, [u64; 2]);

#[derive(Debug, Default)]
struct Kept {
    sightings: HashMap<PoseKey, Arc<Vec<Sighting>>>,
    responses: Vec<(ModelKey, HashMap<PoseKey, Arc<Responses>>)>,
    response_bytes: usize,
}

/// The sightings and kernel responses of one scene's targets seen by one sensor, by true pose.
#[derive(Debug)]
pub struct SceneMemo {
    targets: Vec<Target>,
    sensor: Sensor,
    kept: Mutex<Kept>,
}

/// The scenes of this process, most recently opened last.
static SCENES_KEPT: Mutex<Vec<Arc<SceneMemo>>> = Mutex::new(Vec::new());

impl SceneMemo {
    /// The memo of `targets` seen by `sensor`: the one this process keeps for equal targets and
    /// sensor, or a new one.
    pub fn open(targets: &[Target], sensor: &Sensor) -> Arc<SceneMemo> {
        let mut scenes = SCENES_KEPT.lock().unwrap_or_else(PoisonError::into_inner);
        let found = scenes
            .iter()
            .position(|m| m.sensor == *sensor && m.targets == targets);
        let memo = match found {
            Some(index) => scenes.remove(index),
            None => Arc::new(SceneMemo {
                targets: targets.to_vec(),
                sensor: *sensor,
                kept: Mutex::new(Kept::default()),
            }),
        };
        scenes.push(Arc::clone(&memo));
        if scenes.len() > SCENES {
            scenes.remove(0);
        }
        memo
    }

    fn kept(&self) -> std::sync::MutexGuard<'_, Kept> {
        self.kept.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// [`observe`] of the memo's targets and sensor from `pose`.
    pub fn observe(&self, pose: Pose2) -> Arc<Vec<Sighting>> {
        let key = pose_key(pose);
        if let Some(found) = self.kept().sightings.get(&key) {
            return Arc::clone(found);
        }
        let sightings = Arc::new(observe(&self.targets, &self.sensor, pose));
        let mut kept = self.kept();
        if kept.sightings.len() < MAX_POSES {
            kept.sightings.insert(key, Arc::clone(&sightings));
        }
        sightings
    }

    /// The kernel responses of `scatterers` (the sightings from `pose` as the spectral model
    /// sees them, with `speed_mps` and `boresight_rad` giving their radial velocities) for
    /// `ofdm` and `config`: [`Responses::new`], or the ones kept for that pose.
    /// [`nrslam_ofdm::spectral::synthesize_with`] re-evaluates any scatterer whose geometry
    /// differs from its kept response, so a stale entry could cost time, never a wrong map.
    pub fn responses(
        &self,
        pose: Pose2,
        model: (&OfdmParams, &SpectralConfig, f64, f64),
        scatterers: &[Scatterer],
    ) -> Result<Arc<Responses>, OfdmError> {
        let (ofdm, config, speed_mps, boresight_rad) = model;
        let model_key: ModelKey = (
            *ofdm,
            *config,
            [speed_mps.to_bits(), boresight_rad.to_bits()],
        );
        let key = pose_key(pose);
        {
            let kept = self.kept();
            let found = kept
                .responses
                .iter()
                .find(|(m, _)| *m == model_key)
                .and_then(|(_, by_pose)| by_pose.get(&key));
            if let Some(found) = found {
                return Ok(Arc::clone(found));
            }
        }
        let responses = Arc::new(Responses::new(ofdm, scatterers, config)?);
        let bytes = responses.heap_bytes();
        let mut kept = self.kept();
        if kept.response_bytes + bytes <= MAX_RESPONSE_BYTES {
            kept.response_bytes += bytes;
            let index = match kept.responses.iter().position(|(m, _)| *m == model_key) {
                Some(index) => index,
                None => {
                    kept.responses.push((model_key, HashMap::new()));
                    kept.responses.len() - 1
                }
            };
            kept.responses[index].1.insert(key, Arc::clone(&responses));
        }
        Ok(responses)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Params, Simulator};
    use nrslam_ofdm::Scatterer;
    use num_complex::Complex64;
    use std::path::Path;

    #[test]
    fn kept_values_are_what_the_computation_gives() {
        let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
        let sim = Simulator::from_params(&Params::default(), &workspace, 1).unwrap();
        let scene = sim.scene();
        let memo = SceneMemo::open(&scene.targets, sim.sensor());
        // Another opening of an equal scene finds the same memo.
        assert!(Arc::ptr_eq(
            &memo,
            &SceneMemo::open(&scene.targets, sim.sensor())
        ));
        let ofdm = OfdmParams::default();
        let config = SpectralConfig::default();
        for k in [0, 7, 7, 150] {
            let pose = sim.trajectory().pose_at_frame(k);
            let sightings = memo.observe(pose);
            assert_eq!(*sightings, observe(&scene.targets, sim.sensor(), pose));
            let scatterers: Vec<Scatterer> = sightings
                .iter()
                .map(|s| Scatterer {
                    range_m: s.range_m,
                    angle_rad: s.angle_rad,
                    radial_velocity_mps: 0.1,
                    amplitude: Complex64::new(1.0, 0.0),
                })
                .collect();
            let responses = memo
                .responses(pose, (&ofdm, &config, 1.0, 0.5), &scatterers)
                .unwrap();
            assert_eq!(
                *responses,
                Responses::new(&ofdm, &scatterers, &config).unwrap()
            );
        }
        let kept = memo.kept();
        assert!(kept.sightings.len() >= 3);
        assert!(kept.responses.iter().any(|(_, by_pose)| by_pose.len() >= 3));
    }
}
