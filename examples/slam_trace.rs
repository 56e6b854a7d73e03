//! Traces the SLAM back end on the hall at ideal fidelity: per keyframe the estimate against the
//! ground truth, and each loop closure with the error of its measured relative pose. A
//! development aid, not a test:
//!
//! ```text
//! cargo run --release --example slam_trace -- RANGE_STD_M ANGLE_STD_DEG SEED [LOOP_CLOSURE \
//!     LOCAL_MAP_M COVARIANCE_WEIGHTING OVERLAP_DISTANCE_M MIN_INLIER_RATIO RADIUS_PER_M MAX_RADIUS_M
//!     LOOP_STD_DEG QUERY_KEYFRAMES SUBMAP_KEYFRAMES MAX_AMBIGUITY]
//! ```
//!
//! The scan matcher's parameters come from the environment where set: `CELL` (`cell_m`), `NEIGH`
//! (`cell_neighbours`), `CORR` (`max_correspondence_m`), `ROBUST` (`robust_sigma`), `PRIOR_M`,
//! `PRIOR_DEG` (the prior's floors), `MAPSTD` (`map_std_m`) and `MAXIT` (`max_iterations`);
//! `ALL=1` prints every frame; `SCENE=FILE` replaces the hall. `FIDELITY=spectral` runs the 5G
//! chain instead of the ideal radar (the range × angle map of Table I and the estimator of
//! `launch/paper-5g.toml`: bin centres, or refined with `REFINE=interpolation`; the positional
//! noise arguments are then ignored), `QUANT=1` moves each detection to the centre of its 5G
//! resolution cell (one per cell: the grid's quantisation without the spectral map), and
//! `ORACLEMAP=1` (or `full`) also matches every frame against a map built at the true poses
//! (`OracleTracking`: how well one frame measures its pose when the map is right). `DISTORT=1` prints
//! how far each loop's query and submap keyframes are from their true placement; `TRUECLOUD=1`
//! re-matches each loop's query and submap, built at the true poses and at the estimated ones,
//! from the true relative pose (2 m radius) and from the back end's own prediction and radius
//! (is a wrong loop the clouds' fault, the data's, or the search's start?), and `DUMP=DIR`
//! writes the true-pose clouds as
//! `DIR/cloud_OLD_NEW.csv` (`s` submap, `q` query at the truth, `m` query where it matched).
//! `LOOP='KEY = VALUE; …'` overrides loop closure parameters by name (TOML values;
//! `scripts/loop_truth_clouds.py` passes it on). `TRUTHS=FILE` writes each keyframe's true pose
//! (`x_m y_m yaw_rad` per line, keyframe order),
//! which `scripts/loop_match_errors.py` pairs with the debug log's accepted and pending loop
//! matches (`NRSLAM_LOG=nrslam_association=debug`). It also prints the keyframes' NEES under
//! their published covariance and their RMSE once the best rigid motion has aligned them to the
//! truth; `ALIGNINFO=1` prints that motion and the
//! first keyframes' errors.

use nrslam_association::{
    detection_to_agv_m, wrap_angle_rad, Association, LoopMatch, Params, Pose2,
};

fn main() -> anyhow::Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_env("NRSLAM_LOG"))
        .with_writer(std::io::stderr)
        .init();
    let args: Vec<String> = std::env::args().collect();
    let (radar, seed, params) = configure(&args)?;
    let ctx = nrslam_runtime::NodeContext::for_tests(seed);
    let mut sim = nrslam_radar::Simulator::from_params(
        &radar,
        std::path::Path::new("."),
        ctx.seed_for("radar"),
    )?;
    let boresight = sim.scene().sensor.boresight_rad;
    let mut spectral = spectral_estimator(&radar)?;
    let mut oracle = std::env::var("ORACLEMAP")
        .ok()
        .map(|mode| OracleTracking::new(&params, mode == "full"));
    let quantise = std::env::var("QUANT").is_ok();
    let mut slam = Association::new(params)?;
    let mut truths: Vec<Pose2> = Vec::new();
    // The online error when each keyframe was taken, beside its final error after every closure.
    let mut online_at_keyframe: Vec<f64> = Vec::new();
    let mut sum2 = 0.0;
    let mut n = 0.0;
    while let Some(frame) = sim.try_next_frame()? {
        let o = frame.odometry.pose;
        slam.on_odometry_at(frame.stamp_s, Pose2::new(o.x_m, o.y_m, o.yaw_rad))?;
        let detections = match (&mut spectral, &frame.spectrum) {
            (Some(estimator), Some(map)) => estimated_detections(estimator, &radar, map)?,
            _ => frame.detections.clone(),
        };
        let detections = if quantise {
            quantised(&detections, &radar)
        } else {
            detections
        };
        let scan: Vec<[f64; 2]> = detections
            .iter()
            .map(|d| detection_to_agv_m(d.range_m, d.angle_rad, boresight))
            .collect();
        let std: Vec<[f64; 2]> = detections
            .iter()
            .map(|d| [d.range_std_m, d.angle_std_rad])
            .collect();
        // The keyframe poses before this frame's closure moved them: what the loop search saw.
        let mut before: Vec<Pose2> = slam.keyframe_records().iter().map(|r| r.pose).collect();
        let at_last_closure_m = slam.travelled_at_last_closure_m();
        if let Some(oracle) = &mut oracle {
            let t = frame.true_pose;
            oracle.frame((
                Pose2::new(t.x_m, t.y_m, t.yaw_rad),
                Pose2::new(o.x_m, o.y_m, o.yaw_rad),
                scan.clone(),
                std.clone(),
            ));
        }
        let out = slam.on_scan_with_std(&scan, Some(&std))?;
        let t = frame.true_pose;
        let truth = Pose2::new(t.x_m, t.y_m, t.yaw_rad);
        let err = out.pose.distance_m(&truth);
        sum2 += err * err;
        n += 1.0;
        if let Some(id) = out.keyframe_id {
            truths.push(truth);
            online_at_keyframe.push(err);
            if let Some(m) = &out.loop_match {
                // The new keyframe joined at the tracked pose (the prediction if tracking failed).
                before.push(if out.icp.pose.is_finite() {
                    out.icp.pose
                } else {
                    out.predicted
                });
                trace_loop(&slam, &truths, &before, at_last_closure_m, m)?;
                let true_rel = truths[m.candidate].between(&truths[m.query]);
                println!(
                    "frame {:3} kf {:3} LOOP with kf {:3}: relative error {:.2} m {:.2}°, inliers {:.2}, score {:.2}/{:.2}",
                    frame.index,
                    id,
                    m.candidate,
                    m.relative.distance_m(&true_rel),
                    m.relative.rotation_to_rad(&true_rel).to_degrees(),
                    m.inlier_ratio,
                    m.score,
                    m.runner_up
                );
            }
        }
        if std::env::var("ALL").is_ok() || frame.index % 20 == 0 || out.loop_match.is_some() {
            println!(
                "frame {:3} err {:.2} m yaw {:+.2}°  icp {:?} assoc {}/{} inl {} overlap {:.2}",
                frame.index,
                err,
                (out.pose.yaw_rad - truth.yaw_rad).to_degrees(),
                out.icp.status,
                out.stats.associated,
                out.stats.detections,
                out.stats.inliers,
                out.stats.keyframe_overlap
            );
        }
    }
    if let Some(oracle) = &mut oracle {
        oracle.report();
    }
    print_keyframe_errors(&slam, &truths, &online_at_keyframe, (sum2 / n).sqrt());
    if let Ok(path) = std::env::var("TRUTHS") {
        // Keyframe k's truth on line k: what the debug log's keyframe indices refer to.
        let text: String = truths
            .iter()
            .map(|t| format!("{} {} {}\n", t.x_m, t.y_m, t.yaw_rad))
            .collect();
        std::fs::write(path, text)?;
    }
    Ok(())
}

/// One frame as the oracle tracking sees it: true pose, odometry pose, scan (AGV frame) and each
/// point's `[range m, angle rad]` std.
type OracleFrame = (Pose2, Pose2, Vec<[f64; 2]>, Vec<[f64; 2]>);

/// `ORACLEMAP=1`: every frame matched by tracking's matcher (its parameters, prior and std
/// floors) against a map of the earlier frames' detections placed at their true poses (a frame
/// joins the map once it is `keyframe_distance_m` from the last one that did, as keyframes do),
/// from the odometry's prediction off the last true pose: how well one frame's match measures
/// its pose when the map is right. `ORACLEMAP=full`: against the map of the whole run, every
/// frame's own points left out of it while it is matched, so that no frame meets the end of
/// what has been mapped.
struct OracleTracking {
    params: Params,
    whole_run: bool,
    map: nrslam_association::scan_matcher::DistributionMap,
    frames: Vec<OracleFrame>,
    /// Whether each frame joined the map.
    mapped: Vec<bool>,
    /// Per matched frame: position error (m), signed heading error (deg), of the match and of
    /// the prediction.
    errors: Vec<[f64; 4]>,
}

impl OracleTracking {
    fn new(params: &Params, whole_run: bool) -> Self {
        Self {
            params: params.clone(),
            whole_run,
            map: params.distribution_map(),
            frames: Vec::new(),
            mapped: Vec::new(),
            errors: Vec::new(),
        }
    }

    fn frame(&mut self, frame: OracleFrame) {
        let last_mapped = self
            .frames
            .iter()
            .zip(&self.mapped)
            .rev()
            .find_map(|(f, &m)| m.then_some(f.0));
        let joins =
            last_mapped.is_none_or(|at| at.distance_m(&frame.0) >= self.params.keyframe_distance_m);
        if !self.whole_run {
            self.match_frame(self.frames.len(), &frame);
            if joins {
                self.map.extend(&Self::world(&frame));
            }
        }
        self.frames.push(frame);
        self.mapped.push(joins);
    }

    /// The frame's points placed at its true pose.
    fn world((truth, _, scan, _): &OracleFrame) -> Vec<[f64; 2]> {
        scan.iter().map(|p| truth.transform_point(*p)).collect()
    }

    /// Matches frame `index` (the previous frame is `self.frames[index - 1]`).
    fn match_frame(&mut self, index: usize, (truth, odometry, scan, std): &OracleFrame) {
        let Some((last_truth, last_odometry, _, _)) = index.checked_sub(1).map(|i| &self.frames[i])
        else {
            return;
        };
        let points: Vec<nrslam_association::scan_matcher::RadarPoint> = scan
            .iter()
            .zip(std)
            .map(|(p, s)| {
                let [range_std_m, angle_std_rad] = self.params.point_std(Some(*s));
                nrslam_association::scan_matcher::RadarPoint {
                    position_m: *p,
                    range_std_m,
                    angle_std_rad,
                }
            })
            .collect();
        let increment = last_odometry.between(odometry);
        let predicted = last_truth.compose(&increment);
        let settings = self
            .params
            .tracking_settings(increment.x_m.hypot(increment.y_m));
        let matched =
            nrslam_association::scan_matcher::match_scan(&self.map, &points, predicted, &settings);
        let yaw_deg = |p: &Pose2| wrap_angle_rad(p.yaw_rad - truth.yaw_rad).to_degrees();
        self.errors.push([
            matched.pose.distance_m(truth),
            yaw_deg(&matched.pose),
            predicted.distance_m(truth),
            yaw_deg(&predicted),
        ]);
    }

    fn report(&mut self) {
        if self.whole_run {
            for (frame, _) in self.frames.iter().zip(&self.mapped).filter(|(_, &m)| m) {
                self.map.extend(&Self::world(frame));
            }
            for index in 0..self.frames.len() {
                let frame = self.frames[index].clone();
                let own = Self::world(&frame);
                if self.mapped[index] {
                    self.map.retract(&own);
                }
                self.match_frame(index, &frame);
                if self.mapped[index] {
                    self.map.extend(&own);
                }
            }
        }
        if self.errors.is_empty() {
            return;
        }
        let n = self.errors.len() as f64;
        let rms = |k: usize| (self.errors.iter().map(|e| e[k] * e[k]).sum::<f64>() / n).sqrt();
        let mean = |k: usize| self.errors.iter().map(|e| e[k]).sum::<f64>() / n;
        println!(
            "oracle map: match {:.3} m {:.3} deg RMS (mean heading error {:+.3} deg), \
             prediction {:.3} m {:.3} deg RMS (mean {:+.3} deg)",
            rms(0),
            rms(1),
            mean(1),
            rms(2),
            rms(3),
            mean(3)
        );
    }
}

/// With `FIDELITY=spectral`, the estimator of `launch/paper-5g.toml` (peaks within 10 dB of the
/// frame's strongest; `REFINE=interpolation` refines them, else the bin centres, as the paper).
fn spectral_estimator(
    radar: &nrslam_radar::Params,
) -> anyhow::Result<Option<nrslam_estimator::Estimator>> {
    if radar.fidelity != nrslam_radar::Fidelity::Spectral {
        return Ok(None);
    }
    let refinement = match std::env::var("REFINE").as_deref() {
        Ok("interpolation") => nrslam_estimator::Refinement::Interpolation,
        _ => nrslam_estimator::Refinement::None,
    };
    let config = nrslam_estimator::EstimatorConfig {
        dynamic_range_db: 10.0,
        refinement,
        ..nrslam_estimator::EstimatorConfig::default()
    };
    Ok(Some(
        nrslam_estimator::Estimator::new(&radar.ofdm, config)
            .map_err(|e| anyhow::anyhow!("estimator: {e}"))?,
    ))
}

/// The detections of one spectral frame, each with the std the estimator node publishes.
fn estimated_detections(
    estimator: &mut nrslam_estimator::Estimator,
    radar: &nrslam_radar::Params,
    map: &nrslam_ofdm::RangeAngleSpectrum,
) -> anyhow::Result<Vec<nrslam_msgs::Detection>> {
    let found = estimator
        .process_spectrum(map)
        .map_err(|e| anyhow::anyhow!("estimator: {e}"))?;
    Ok(found
        .iter()
        .map(|d| nrslam_estimator::published_detection(&radar.ofdm, estimator.config(), d))
        .collect())
}

/// `QUANT=1`: each detection moved to the centre of its 5G resolution cell (range bin × sine
/// bin), one per cell, with the cell's std: the grid quantisation without the spectral map.
fn quantised(
    detections: &[nrslam_msgs::Detection],
    radar: &nrslam_radar::Params,
) -> Vec<nrslam_msgs::Detection> {
    let range_bin_m = radar.ofdm.range_bin_m();
    let sine_bin = radar.ofdm.sine_bin();
    let mut cells = std::collections::BTreeSet::new();
    detections
        .iter()
        .filter_map(|d| {
            let r = (d.range_m / range_bin_m).round() as i64;
            let s = (d.angle_rad.sin() / sine_bin).round() as i64;
            cells.insert((r, s)).then(|| {
                let angle_rad = (s as f64 * sine_bin).clamp(-1.0, 1.0).asin();
                let range_m = r as f64 * range_bin_m;
                nrslam_estimator::cell_detection(&radar.ofdm, range_m, angle_rad, d.power_db)
            })
        })
        .collect()
}

/// The radar's and the association's parameters and the seed, from the positional arguments and
/// the environment (module docs).
fn configure(args: &[String]) -> anyhow::Result<(nrslam_radar::Params, u64, Params)> {
    let get = |i: usize, d: &str| args.get(i).cloned().unwrap_or_else(|| d.to_owned());
    let mut radar = nrslam_radar::Params {
        range_std_m: get(1, "0").parse()?,
        angle_std_deg: get(2, "1").parse()?,
        ..nrslam_radar::Params::default()
    };
    if let Ok(scene) = std::env::var("SCENE") {
        radar.scene = scene.into();
    }
    if std::env::var("FIDELITY").as_deref() == Ok("spectral") {
        radar.fidelity = nrslam_radar::Fidelity::Spectral;
    }
    let seed: u64 = get(3, "1").parse()?;
    let mut params = Params {
        robust_scale_m: 0.5,
        ..Params::default()
    };
    params.loop_closure.enabled = get(4, "true").parse()?;
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    let set = |field: &mut f64, value: Option<f64>| {
        if let Some(v) = value {
            *field = v;
        }
    };
    let set_count = |field: &mut u32, value: Option<f64>| {
        if let Some(v) = value {
            *field = v as u32;
        }
    };
    set(&mut params.cell_m, env("CELL"));
    set_count(&mut params.cell_neighbours, env("NEIGH"));
    set(&mut params.max_correspondence_m, env("CORR"));
    set(&mut params.robust_sigma, env("ROBUST"));
    set(&mut params.prior_std_m, env("PRIOR_M"));
    set(&mut params.prior_std_deg, env("PRIOR_DEG"));
    set(&mut params.map_std_m, env("MAPSTD"));
    set_count(&mut params.max_iterations, env("MAXIT"));
    // Positional overrides apply only where given: the shipped defaults otherwise.
    let lc = &mut params.loop_closure;
    let opt = |i: usize| args.get(i).and_then(|v| v.parse::<f64>().ok());
    set(&mut lc.local_map_m, opt(5));
    set(&mut lc.overlap_distance_m, opt(7));
    set(&mut lc.min_inlier_ratio, opt(8));
    set(&mut lc.search_radius_per_m, opt(9));
    set(&mut lc.max_search_radius_m, opt(10));
    set(&mut lc.loop_std_deg, opt(11));
    set_count(&mut lc.query_keyframes, opt(12));
    set_count(&mut lc.submap_keyframes, opt(13));
    set(&mut lc.max_ambiguity, opt(14));
    // `LOOP='key = value …'` (TOML, newline- or semicolon-separated) overrides any loop closure
    // parameter by name.
    if let Ok(overrides) = std::env::var("LOOP") {
        let mut table = toml::Value::try_from(&params.loop_closure)?;
        let given: toml::Table = toml::from_str(&overrides.replace(';', "\n"))?;
        if let Some(t) = table.as_table_mut() {
            t.extend(given);
        }
        params.loop_closure = table.try_into()?;
    }
    Ok((radar, seed, params))
}

/// The first keyframe of the query the back end matched at keyframe `current`, and the
/// half-width of a candidate's submap, in keyframes (`submap_keyframes`).
fn loop_extent(slam: &Association, current: usize) -> (usize, usize) {
    let lc = &slam.params().loop_closure;
    (lc.query_from(current), lc.submap_keyframes as usize)
}

/// What `DISTORT` and `TRUECLOUD` ask for about the loop closure `m` (module docs).
fn trace_loop(
    slam: &Association,
    truths: &[Pose2],
    before: &[Pose2],
    at_last_closure_m: Option<f64>,
    m: &LoopMatch,
) -> anyhow::Result<()> {
    let j = m.candidate;
    let records = slam.keyframe_records();
    let cur = records.len() - 1;
    let (query_from, w) = loop_extent(slam, cur);
    if std::env::var("DISTORT").is_ok() {
        // How far the query's and the submap's keyframes are from their true placement relative
        // to the keyframe they are expressed in.
        let spread = |from: usize, to: usize, frame: usize| {
            (from..=to.min(records.len() - 1))
                .map(|k| {
                    let est = records[frame].pose.between(&records[k].pose);
                    let tru = truths[frame].between(&truths[k]);
                    format!(
                        "{:.2}/{:.1}",
                        est.distance_m(&tru),
                        est.rotation_to_rad(&tru).to_degrees()
                    )
                })
                .collect::<Vec<_>>()
                .join(" ")
        };
        println!("  query  {}", spread(query_from, cur, m.query));
        println!("  submap {}", spread(j.saturating_sub(w), j + w, j));
    }
    if std::env::var("TRUECLOUD").is_ok() {
        rematch_clouds(slam, truths, before, at_last_closure_m, m)?;
    }
    Ok(())
}

/// Re-matches the loop's query and submap built at the true poses and at the estimated ones,
/// from the true relative pose; `DUMP=DIR` writes the true-pose clouds.
fn rematch_clouds(
    slam: &Association,
    truths: &[Pose2],
    before: &[Pose2],
    at_last_closure_m: Option<f64>,
    m: &LoopMatch,
) -> anyhow::Result<()> {
    let j = m.candidate;
    let true_rel = truths[j].between(&truths[m.query]);
    let records = slam.keyframe_records();
    let cur = records.len() - 1;
    let cloud = |from: usize, to: usize, frame: usize, truth: bool| {
        let pose_of = |i: usize| if truth { truths[i] } else { before[i] };
        let mut pts = Vec::new();
        for (k, record) in records.iter().enumerate().take(to.min(cur) + 1).skip(from) {
            let rel = pose_of(frame).between(&pose_of(k));
            pts.extend(record.scan_agv_m.iter().map(|p| rel.transform_point(*p)));
        }
        pts
    };
    let (query_from, w) = loop_extent(slam, cur);
    // The tolerances the back end matched this query with: widened for its detections' scatter.
    let (lc, _) = slam.widened_for_scatter(slam.params().loop_closure.clone(), query_from..=cur);
    let refine = Params {
        max_correspondence_m: lc.refine_correspondence_m,
        ..slam.params().clone()
    };
    // The back end's own prediction and radius.
    let predicted = before[j].between(&before[m.query]);
    let radius_m = lc.search_radius_for_m(
        records[cur].travelled_m - records[j].travelled_m,
        at_last_closure_m.map(|at| records[cur].travelled_m - at),
    );
    for (truth, from_prediction) in [(true, false), (false, false), (true, true), (false, true)] {
        let q = cloud(query_from, cur, m.query, truth);
        let sm = cloud(j.saturating_sub(w), j + w, j, truth);
        let (start, radius) = if from_prediction {
            (predicted, radius_m)
        } else {
            (true_rel, 2.0)
        };
        let r = nrslam_association::match_loop(&q, &sm, start, radius, &lc, &refine);
        if truth && !from_prediction {
            if let Ok(dir) = std::env::var("DUMP") {
                let found = r.as_ref().ok().map(|f| f.relative);
                dump_clouds(
                    &format!("{dir}/cloud_{j}_{}.csv", m.query),
                    &sm,
                    &q,
                    true_rel,
                    found,
                )?;
            }
        }
        let from = if truth { "truth" } else { "estimate" };
        let started_at = if from_prediction {
            "the back end's prediction"
        } else {
            "true prediction"
        };
        match r {
            Ok(f) => println!(
                "  clouds from {from}: from {started_at} error {:.2} m {:.2}° score {:.2}",
                f.relative.distance_m(&true_rel),
                f.relative.rotation_to_rad(&true_rel).to_degrees(),
                f.score
            ),
            Err(e) => println!("  clouds from {from}: from {started_at} refused: {e:?}"),
        }
    }
    Ok(())
}

/// Writes the submap (`s`), the query at the true relative pose (`q`) and where it matched (`m`),
/// and the true relative position (`a`) to `path`.
fn dump_clouds(
    path: &str,
    submap: &[[f64; 2]],
    query: &[[f64; 2]],
    true_rel: Pose2,
    found: Option<Pose2>,
) -> anyhow::Result<()> {
    use std::io::Write as _;
    let mut f = std::fs::File::create(path)?;
    for p in submap {
        writeln!(f, "s,{},{}", p[0], p[1])?;
    }
    for p in query {
        let t = true_rel.transform_point(*p);
        writeln!(f, "q,{},{}", t[0], t[1])?;
    }
    if let Some(found) = found {
        for p in query {
            let t = found.transform_point(*p);
            writeln!(f, "m,{},{}", t[0], t[1])?;
        }
    }
    writeln!(f, "a,{},{}", true_rel.x_m, true_rel.y_m)?;
    Ok(())
}

/// Every tenth keyframe's online and final error, and the run's RMSEs.
fn print_keyframe_errors(
    slam: &Association,
    truths: &[Pose2],
    online_at_keyframe: &[f64],
    pose_rmse_m: f64,
) {
    let kf_err: Vec<f64> = slam
        .keyframe_records()
        .iter()
        .zip(truths)
        .map(|(r, t)| r.pose.distance_m(t))
        .collect();
    for (k, (final_m, online_m)) in kf_err.iter().zip(online_at_keyframe).enumerate() {
        if k % 10 == 0 {
            println!("keyframe {k:3}: error online {online_m:.2} m, final {final_m:.2} m");
        }
    }
    let kf_rmse = (kf_err.iter().map(|e| e * e).sum::<f64>() / kf_err.len() as f64).sqrt();
    println!(
        "final keyframe RMSE after the best rigid alignment to the truth {:.3} m",
        aligned_rmse_m(slam, truths)
    );
    let (nees, std_m, yaw_nees) = keyframe_nees(slam, truths);
    println!("keyframe position NEES {nees:.3} (2 if honest), mean std {std_m:.3} m, yaw NEES {yaw_nees:.3} (1 if honest)");
    println!(
        "pose RMSE {:.3} m, final keyframe RMSE {:.3} m, loops {}",
        pose_rmse_m,
        kf_rmse,
        slam.loop_closures()
    );
}

/// The keyframes' position NEES against the truth under their published covariance, and their
/// mean position standard deviation (m), over every keyframe but the first (which anchors).
fn keyframe_nees(slam: &Association, truths: &[Pose2]) -> (f64, f64, f64) {
    let (mut nees, mut std_m, mut n, mut yaw) = (0.0, 0.0, 0.0, 0.0);
    for (record, truth) in slam.keyframe_records().iter().zip(truths).skip(1) {
        let c = record.covariance;
        let (ex, ey) = (record.pose.x_m - truth.x_m, record.pose.y_m - truth.y_m);
        let det = c[(0, 0)] * c[(1, 1)] - c[(0, 1)] * c[(0, 1)];
        if det > 0.0 {
            nees += (c[(1, 1)] * ex * ex - 2.0 * c[(0, 1)] * ex * ey + c[(0, 0)] * ey * ey) / det;
            std_m += (0.5 * (c[(0, 0)] + c[(1, 1)])).sqrt();
            n += 1.0;
            let e_yaw = nrslam_association::wrap_angle_rad(record.pose.yaw_rad - truth.yaw_rad);
            yaw += e_yaw * e_yaw / c[(2, 2)];
        }
    }
    (nees / n, std_m / n, yaw / n)
}

/// The keyframe positions' RMSE against the truth once the best rigid motion (2-D Procrustes) has
/// moved them onto it: what remains when a global offset and rotation of the map are forgiven.
fn aligned_rmse_m(slam: &Association, truths: &[Pose2]) -> f64 {
    let pairs: Vec<([f64; 2], [f64; 2])> = slam
        .keyframe_records()
        .iter()
        .zip(truths)
        .map(|(r, t)| ([r.pose.x_m, r.pose.y_m], [t.x_m, t.y_m]))
        .collect();
    let n = pairs.len().max(1) as f64;
    let mean = |points: &mut dyn Iterator<Item = [f64; 2]>| {
        let s = points.fold([0.0, 0.0], |a, p| [a[0] + p[0], a[1] + p[1]]);
        [s[0] / n, s[1] / n]
    };
    let ma = mean(&mut pairs.iter().map(|p| p.0));
    let mb = mean(&mut pairs.iter().map(|p| p.1));
    let (mut sxx, mut sxy) = (0.0, 0.0);
    for (a, b) in &pairs {
        let (a, b) = ([a[0] - ma[0], a[1] - ma[1]], [b[0] - mb[0], b[1] - mb[1]]);
        sxx += a[0] * b[0] + a[1] * b[1];
        sxy += a[0] * b[1] - a[1] * b[0];
    }
    let angle = sxy.atan2(sxx);
    let (sin, cos) = angle.sin_cos();
    let sum2: f64 = pairs
        .iter()
        .map(|(a, b)| {
            let a = [a[0] - ma[0], a[1] - ma[1]];
            let r = [
                cos * a[0] - sin * a[1] + mb[0],
                sin * a[0] + cos * a[1] + mb[1],
            ];
            (r[0] - b[0]).powi(2) + (r[1] - b[1]).powi(2)
        })
        .sum();
    if std::env::var("ALIGNINFO").is_ok() {
        let t = [
            mb[0] - (cos * ma[0] - sin * ma[1]),
            mb[1] - (sin * ma[0] + cos * ma[1]),
        ];
        println!(
            "alignment: rotation {:.3} deg, translation ({:.3}, {:.3}) m (about the map origin)",
            angle.to_degrees(),
            t[0],
            t[1]
        );
        for (k, (r, tr)) in slam.keyframe_records().iter().zip(truths).enumerate() {
            if k < 12 || k % 25 == 0 {
                println!(
                    "  kf {k}: pos err {:.3} m, yaw err {:.3} deg",
                    r.pose.distance_m(tr),
                    nrslam_association::wrap_angle_rad(r.pose.yaw_rad - tr.yaw_rad).to_degrees()
                );
            }
        }
    }
    (sum2 / n).sqrt()
}
