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
//! `PRIOR_DEG` (the prior's floors) and `MAPSTD` (`map_std_m`); `ALL=1` prints every frame; `SCENE=FILE` replaces the hall; `DISTORT=1` prints
//! how far each loop's query and submap keyframes are from their true placement; `TRUECLOUD=1`
//! re-matches each loop's query and submap built at the true poses, from the true relative pose
//! (is a wrong loop the clouds' fault or the data's?), and `DUMP=DIR` writes those clouds as
//! `DIR/cloud_OLD_NEW.csv` (`s` submap, `q` query at the truth, `m` query where it matched).

use nrslam_association::{detection_to_agv_m, Association, Params, Pose2};

fn main() -> anyhow::Result<()> {
    tracing_subscriber::fmt()
        .with_env_filter(tracing_subscriber::EnvFilter::from_env("NRSLAM_LOG"))
        .with_writer(std::io::stderr)
        .init();
    let args: Vec<String> = std::env::args().collect();
    let get = |i: usize, d: &str| args.get(i).cloned().unwrap_or_else(|| d.to_owned());
    let mut radar = nrslam_radar::Params {
        range_std_m: get(1, "0").parse()?,
        angle_std_deg: get(2, "1").parse()?,
        ..nrslam_radar::Params::default()
    };
    if let Ok(scene) = std::env::var("SCENE") {
        radar.scene = scene.into();
    }
    let seed: u64 = get(3, "1").parse()?;
    let mut params = Params {
        robust_scale_m: 0.5,
        ..Params::default()
    };
    params.loop_closure.enabled = get(4, "true").parse()?;
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(v) = env("CELL") {
        params.cell_m = v;
    }
    if let Some(v) = env("NEIGH") {
        params.cell_neighbours = v as u32;
    }
    if let Some(v) = env("CORR") {
        params.max_correspondence_m = v;
    }
    if let Some(v) = env("ROBUST") {
        params.robust_sigma = v;
    }
    if let Some(v) = env("PRIOR_M") {
        params.prior_std_m = v;
    }
    if let Some(v) = env("PRIOR_DEG") {
        params.prior_std_deg = v;
    }
    if let Some(v) = env("MAPSTD") {
        params.map_std_m = v;
    }
    // Positional overrides apply only where given: the shipped defaults otherwise.
    let lc = &mut params.loop_closure;
    let opt = |i: usize| args.get(i).and_then(|v| v.parse::<f64>().ok());
    if let Some(v) = opt(5) {
        lc.local_map_m = v;
    }
    if let Some(v) = opt(7) {
        lc.overlap_distance_m = v;
    }
    if let Some(v) = opt(8) {
        lc.min_inlier_ratio = v;
    }
    if let Some(v) = opt(9) {
        lc.search_radius_per_m = v;
    }
    if let Some(v) = opt(10) {
        lc.max_search_radius_m = v;
    }
    if let Some(v) = opt(11) {
        lc.loop_std_deg = v;
    }
    if let Some(v) = opt(12) {
        lc.query_keyframes = v as u32;
    }
    if let Some(v) = opt(13) {
        lc.submap_keyframes = v as u32;
    }
    if let Some(v) = opt(14) {
        lc.max_ambiguity = v;
    }
    let ctx = nrslam_runtime::NodeContext::for_tests(seed);
    let mut sim = nrslam_radar::Simulator::from_params(
        &radar,
        std::path::Path::new("."),
        ctx.seed_for("radar"),
    )?;
    let boresight = sim.scene().sensor.boresight_rad;
    let mut slam = Association::new(params)?;
    let mut truths: Vec<Pose2> = Vec::new();
    // The online error when each keyframe was taken, beside its final error after every closure.
    let mut online_at_keyframe: Vec<f64> = Vec::new();
    let mut sum2 = 0.0;
    let mut n = 0.0;
    while let Some(frame) = sim.try_next_frame()? {
        let o = frame.odometry.pose;
        slam.on_odometry_at(frame.stamp_s, Pose2::new(o.x_m, o.y_m, o.yaw_rad))?;
        let scan: Vec<[f64; 2]> = frame
            .detections
            .iter()
            .map(|d| detection_to_agv_m(d.range_m, d.angle_rad, boresight))
            .collect();
        let std: Vec<[f64; 2]> = frame
            .detections
            .iter()
            .map(|d| [d.range_std_m, d.angle_std_rad])
            .collect();
        let out = slam.on_scan_with_std(&scan, Some(&std))?;
        let t = frame.true_pose;
        let truth = Pose2::new(t.x_m, t.y_m, t.yaw_rad);
        let err = out.pose.distance_m(&truth);
        sum2 += err * err;
        n += 1.0;
        if let Some(id) = out.keyframe_id {
            truths.push(truth);
            online_at_keyframe.push(err);
            if let Some(m) = out.loop_match {
                let j = m.candidate;
                let true_rel = truths[j].between(&truths[m.query]);
                if std::env::var("DISTORT").is_ok() {
                    // How far the query's and the submap's keyframes are from their true
                    // placement relative to the keyframe they are expressed in.
                    let records = slam.keyframe_records();
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
                    let cur = records.len() - 1;
                    println!("  query  {}", spread(cur.saturating_sub(9), cur, m.query));
                    println!("  submap {}", spread(j.saturating_sub(10), j + 10, j));
                }
                if std::env::var("TRUECLOUD").is_ok() {
                    let records = slam.keyframe_records();
                    let cur = records.len() - 1;
                    let cloud = |from: usize, to: usize, frame: usize, truth: bool| {
                        let mut pts = Vec::new();
                        for k in from..=to.min(cur) {
                            let pose_of =
                                |i: usize| if truth { truths[i] } else { records[i].pose };
                            let rel = pose_of(frame).between(&pose_of(k));
                            pts.extend(
                                records[k]
                                    .scan_agv_m
                                    .iter()
                                    .map(|p| rel.transform_point(*p)),
                            );
                        }
                        pts
                    };
                    let lc = slam.params().loop_closure.clone();
                    let refine = Params {
                        max_correspondence_m: lc.refine_correspondence_m,
                        ..slam.params().clone()
                    };
                    for truth in [true, false] {
                        let q = cloud(cur.saturating_sub(9), cur, m.query, truth);
                        let sm = cloud(j.saturating_sub(10), j + 10, j, truth);
                        let r =
                            nrslam_association::match_loop(&q, &sm, true_rel, 2.0, &lc, &refine);
                        if truth {
                            if let Ok(dir) = std::env::var("DUMP") {
                                use std::io::Write as _;
                                let mut f = std::fs::File::create(format!(
                                    "{dir}/cloud_{j}_{}.csv",
                                    m.query
                                ))?;
                                for p in &sm {
                                    writeln!(f, "s,{},{}", p[0], p[1])?;
                                }
                                for p in &q {
                                    let t = true_rel.transform_point(*p);
                                    writeln!(f, "q,{},{}", t[0], t[1])?;
                                }
                                if let Ok(found) = &r {
                                    for p in &q {
                                        let t = found.relative.transform_point(*p);
                                        writeln!(f, "m,{},{}", t[0], t[1])?;
                                    }
                                }
                                let a = true_rel;
                                writeln!(f, "a,{},{}", a.x_m, a.y_m)?;
                            }
                        }
                        match r {
                            Ok(f) => println!("  clouds from {}: from true prediction error {:.2} m {:.2}° score {:.2}", if truth {"truth"} else {"estimate"}, f.relative.distance_m(&true_rel), f.relative.rotation_to_rad(&true_rel).to_degrees(), f.score),
                            Err(e) => println!("  clouds from {}: {e:?}", if truth {"truth"} else {"estimate"}),
                        }
                    }
                }
                println!(
                    "frame {:3} kf {:3} LOOP with kf {:3}: relative error {:.2} m {:.2}°, inliers {:.2}, score {:.2}/{:.2}",
                    frame.index,
                    id,
                    j,
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
    let kf_err: Vec<f64> = slam
        .keyframe_records()
        .iter()
        .zip(&truths)
        .map(|(r, t)| r.pose.distance_m(t))
        .collect();
    for (k, (final_m, online_m)) in kf_err.iter().zip(&online_at_keyframe).enumerate() {
        if k % 10 == 0 {
            println!("keyframe {k:3}: error online {online_m:.2} m, final {final_m:.2} m");
        }
    }
    let kf_rmse = (kf_err.iter().map(|e| e * e).sum::<f64>() / kf_err.len() as f64).sqrt();
    println!(
        "pose RMSE {:.3} m, final keyframe RMSE {:.3} m, loops {}",
        (sum2 / n).sqrt(),
        kf_rmse,
        slam.loop_closures()
    );
    Ok(())
}
