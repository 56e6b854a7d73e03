//! The radar front end of nrslam: the industrial hall, the AGV's loop, what the radar sees, the
//! measurements it makes and the AGV's wheel odometry.
//!
//! It implements the simulation set-up of Jiang, Wei and Feng, "SLAM for Multiple Extended Targets
//! using 5G Signal": an AGV loops through an industrial hall with eight rectangular and two
//! circular extended targets (Sec. II-A) and senses them with a 32-element array; at the `ideal`
//! fidelity level (docs/design.md, "Fidelity levels") each visible scatterer is measured with Gaussian
//! range and angle errors ΔR, Δθ, the conditions of the paper's Fig. 3 (Sec. IV-A).
//!
//! The layers, each usable alone:
//!
//! | module | what |
//! |---|---|
//! | [`scene`] | targets (exact shape, outline, ET-GOPSA samples, scatterers), AGVs and fixed stations from a TOML file |
//! | [`random_scene`] | random scenes (irregular rectangles and circles, randomised loop) from a seed |
//! | [`trajectory`] | an AGV's path (a loop either way round, or waypoints), true pose per frame |
//! | [`visibility`] | range, field of view, facing and occlusion: which scatterers are seen |
//! | [`ideal`] | the `ideal` measurement model: true range/angle + N(0, ΔR²), N(0, Δθ²) |
//! | [`odometry`] | noisy wheel odometry, dead-reckoned |
//! | [`memo`] | the sightings and OFDM kernel responses of one scene by true pose, kept for the process's other runs of it (Monte Carlo trials) |
//! | [`sim`] | all of the above per frame for the sensor `sensor` names (an AGV, a station, none), reproducible from a seed |
//! | [`node`] | the source node publishing `/clock`, `/ground_truth/*`, `/odom`, `/radar/detections` |
//!
//! Geometry never depends on the measurement model, so the later `spectral` and `waveform`
//! levels reuse [`visibility::observe`] and replace only [`ideal`].
//!
//! ```
//! use std::path::Path;
//! use nrslam_radar::{Params, Simulator};
//!
//! let workspace = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
//! let params = Params { frames: 3, ..Params::default() };
//! let mut sim = Simulator::from_params(&params, &workspace, 42).unwrap();
//! assert_eq!(sim.scene().targets.len(), 10);
//! let frame = sim.next_frame().unwrap();
//! assert_eq!(frame.stamp_s, 1.0);
//! assert!(!frame.detections.is_empty());
//! assert_eq!(sim.count(), 2);
//! ```
#![warn(missing_docs)]

pub mod error;
pub mod geometry;
pub mod ideal;
pub mod memo;
pub mod node;
pub mod odometry;
pub mod params;
pub mod random_scene;
pub mod scene;
pub mod sim;
pub mod trajectory;
pub mod visibility;

pub use error::{FieldError, RadarError, SceneError};
pub use geometry::{Pose2, Vec2};
pub use node::{build, RadarNode};
pub use params::{Faults, Fidelity, OdomOrigin, Params, Role};
pub use scene::{Agv, Scene, Shape, Station, Target};
pub use sim::{Frame, Simulator};
pub use trajectory::Trajectory;
pub use visibility::{Sensor, Sighting};
