"""The table of scripts/slam_study.sh: SLAM against the true-pose oracle, per condition and set
of scenes (the hall; the random scenes), from the runs' summary.json files.

    python3 scripts/slam_study_table.py OUT/runs

Columns: runs paired; mean final ET-GOPSA of SLAM and of the oracle on the same seeds; their
ratio (SLAM / oracle, the back end's cost; ± the standard error of the mean paired ratio); mean
final keyframe RMSE (the trajectory after every loop closure); runs that diverged (final keyframe
RMSE > 2 m); mean online pose RMSE over the second half of the frames (on two laps, the second
lap: what the user gets once loops have closed); loop closures per run; accepted loop edges more than 0.5 m off the truth (all runs);
of those scored, edges off beyond their own stated uncertainty (squared Mahalanobis distance under
the information the back end published, above the 99 % point of chi-square with 3 degrees of
freedom; n/a for runs from before it was published); loop edges, wrong or not, whose two
keyframes the final graph holds more than 0.5 m off their true relative position (n/a for runs
from before it was counted, or whose back end published no keyframe poses).
"""

import collections
import glob
import json
import math
import os
import sys

LABELS = {
    "a1": "ΔR 0, Δθ 1°",
    "r01a1": "ΔR 0.1 m, Δθ 1°",
    "a5": "ΔR 0, Δθ 5°",
    "r01a5": "ΔR 0.1 m, Δθ 5°",
    "5g": "5G (paper chain, no refinement)",
    "5gi": "5G with interpolation",
    "5gm": "5G with MUSIC",
    "5ge": "5G with ESPRIT",
    "5gn": "5G with NOMP",
}


def mean_se(values):
    n = len(values)
    if n == 0:
        return float("nan"), float("nan")
    m = sum(values) / n
    if n < 2:
        return m, float("nan")
    sd = math.sqrt(sum((v - m) ** 2 for v in values) / (n - 1))
    return m, sd / math.sqrt(n)


def main(root):
    runs = collections.defaultdict(dict)
    for path in glob.glob(os.path.join(root, "*.json")):
        condition, kind, scene, seed = os.path.basename(path)[:-5].split("_")
        group = "hall" if scene == "hall" else "random"
        with open(path) as f:
            runs[(condition, kind, group)][(scene, seed)] = json.load(f)
    print(
        "| condition | scenes | runs | ET-GOPSA SLAM | ET-GOPSA oracle | ratio | "
        "final keyframe RMSE (m) | diverged (> 2 m) | second-half pose RMSE (m) | loops/run | "
        "loop edges > 0.5 m off | beyond their own 99 % | loops > 0.5 m off in the final graph |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for condition, label in LABELS.items():
        for group in ("hall", "random"):
            slam = runs.get((condition, "slam", group), {})
            oracle = runs.get((condition, "oracle", group), {})
            keys = sorted(set(slam) & set(oracle))
            if not keys:
                continue
            et_slam = [slam[k]["etgospa"] for k in keys]
            et_oracle = [oracle[k]["etgospa"] for k in keys]
            ratio = sum(et_slam) / sum(et_oracle)
            paired = [a / b for a, b in zip(et_slam, et_oracle) if b > 0]
            _, ratio_se = mean_se(paired)
            # One run has no spread to show.
            ratio_text = f"{ratio:.2f} ± {ratio_se:.2f}" if len(paired) > 1 else f"{ratio:.2f}"
            kf = [slam[k].get("keyframe_rmse_m", float("nan")) for k in keys]
            diverged = sum(1 for v in kf if v > 2.0)
            last_lap = [
                slam[k]["second_half_pose_rmse_m"]
                for k in keys
                if isinstance(slam[k].get("second_half_pose_rmse_m"), (int, float))
            ]
            loops = [slam[k].get("loop_closures", 0) for k in keys]
            scored = [slam[k]["loop_edges_scored"] for k in keys if "loop_edges_scored" in slam[k]]
            bad = (
                f"{sum(slam[k].get('loop_edges_wrong', 0) for k in keys)} of {sum(scored)}"
                if scored
                else "n/a"
            )
            informed = [slam[k]["loop_edges_inconsistent"] for k in keys if "loop_edges_inconsistent" in slam[k]]
            bad += f" | {sum(informed)}" if informed else " | n/a"
            in_graph = [slam[k]["loop_edges_off_in_graph"] for k in keys if isinstance(slam[k].get("loop_edges_off_in_graph"), int)]
            bad += f" | {sum(in_graph)}" if in_graph else " | n/a"
            print(
                f"| {label} | {group} | {len(keys)} | {mean_se(et_slam)[0]:.1f} | "
                f"{mean_se(et_oracle)[0]:.1f} | {ratio_text} | "
                f"{mean_se(kf)[0]:.3f} | {diverged} | "
                f"{mean_se(last_lap)[0]:.3f} | {mean_se(loops)[0]:.2f} | {bad} |"
                if last_lap
                else f"| {label} | {group} | {len(keys)} | {mean_se(et_slam)[0]:.1f} | "
                f"{mean_se(et_oracle)[0]:.1f} | {ratio_text} | "
                f"{mean_se(kf)[0]:.3f} | {diverged} | n/a | {mean_se(loops)[0]:.2f} | {bad} |"
            )


if __name__ == "__main__":
    main(sys.argv[1])
