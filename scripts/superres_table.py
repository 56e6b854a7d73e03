"""The SLAM table of docs/superresolution.md: each estimator's final ET-GOPSA and pose RMSE on the
hall and on the random scenes, beside the ideal radars, with paired differences against the ideal
(ΔR 0.1 m, Δθ 1°) radar on the same seeds and scenes (mean ± 95 % CI, t quantile).

    python3 scripts/superres_table.py OUT/runs

OUT is a scripts/slam_study.sh folder run with CONDITIONS="5g 5gi 5gm 5ge 5gn a1 r01a1".
"""

import collections
import glob
import json
import math
import os
import sys

ORDER = ["a1", "r01a1", "5g", "5gi", "5gm", "5ge", "5gn"]
LABELS = {
    "a1": "ideal ΔR 0, Δθ 1°",
    "r01a1": "ideal ΔR 0.1 m, Δθ 1°",
    "5g": "5G DFT (the paper)",
    "5gi": "5G interpolation",
    "5gm": "5G MUSIC",
    "5ge": "5G ESPRIT",
    "5gn": "5G NOMP",
}
REFERENCE = "r01a1"

# Two-sided 95 % t quantiles by degrees of freedom (normal beyond 120).
T95 = {1: 12.71, 2: 4.30, 3: 3.18, 4: 2.78, 5: 2.57, 6: 2.45, 7: 2.36, 8: 2.31, 9: 2.26,
       10: 2.23, 15: 2.13, 19: 2.09, 20: 2.09, 30: 2.04, 39: 2.02, 40: 2.02, 60: 2.00,
       120: 1.98}


def t95(dof):
    keys = sorted(k for k in T95 if k <= dof)
    return T95[keys[-1]] if keys else float("nan")


def mean_ci(values):
    n = len(values)
    if n == 0:
        return float("nan"), float("nan")
    m = sum(values) / n
    if n < 2:
        return m, float("nan")
    sd = math.sqrt(sum((v - m) ** 2 for v in values) / (n - 1))
    return m, t95(n - 1) * sd / math.sqrt(n)


def main(root):
    runs = collections.defaultdict(dict)
    for path in glob.glob(os.path.join(root, "*_slam_*.json")):
        condition, _, scene, seed = os.path.basename(path)[:-5].split("_")
        group = "hall" if scene == "hall" else "random"
        with open(path) as f:
            runs[(condition, group)][(scene, seed)] = json.load(f)
    print("| estimator | scenes | runs | ET-GOPSA | pose RMSE (m) | ET-GOPSA − ideal (0.1 m, 1°), paired | pose RMSE − ideal (0.1 m, 1°), paired (m) |")
    print("|---|---|---|---|---|---|---|")
    for group in ["hall", "random"]:
        reference = runs.get((REFERENCE, group), {})
        for condition in ORDER:
            own = runs.get((condition, group), {})
            if not own:
                continue
            et = mean_ci([r["etgospa"] for r in own.values()])
            pose = mean_ci([r["pose_rmse_m"] for r in own.values()])
            keys = sorted(set(own) & set(reference))
            d_et = mean_ci([own[k]["etgospa"] - reference[k]["etgospa"] for k in keys])
            d_pose = mean_ci([own[k]["pose_rmse_m"] - reference[k]["pose_rmse_m"] for k in keys])
            paired = "—" if condition == REFERENCE else f"{d_et[0]:+.2f} ± {d_et[1]:.2f}"
            paired_pose = "—" if condition == REFERENCE else f"{d_pose[0]:+.3f} ± {d_pose[1]:.3f}"
            print(
                f"| {LABELS[condition]} | {group} | {len(own)} | {et[0]:.2f} ± {et[1]:.2f} | "
                f"{pose[0]:.3f} ± {pose[1]:.3f} | {paired} | {paired_pose} |"
            )


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "out/superres/runs")
