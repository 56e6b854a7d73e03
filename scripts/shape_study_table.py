"""The shape table of issue 16 (docs/results.md, "Extended targets as shapes"), from the runs of
scripts/slam_study.sh (each run's summary.json carries a "shapes" record):

    CONDITIONS="a1 r01a1 a5 r01a5 5g 5gi" scripts/slam_study.sh OUT 40 0
    python3 scripts/shape_study_table.py OUT/runs

Per condition and back end (SLAM, or the true-pose oracle on the same seeds):
- matched targets per run (fitted shapes assigned to true targets on centre distance);
- mean IoU of each matched shape with its true outline, mean centre, size and yaw errors (yaw over
  rectangles whose truth and fit are both rectangles), the fraction of matched targets whose kind
  (rectangle or circle) is right;
- the centre's NEES pooled over every matched target of every run (2 if the published covariance
  is honest: the centre is 2-D);
- final ET-GOPSA with each choice of representatives on the same maps (`box-corners`,
  `farthest-point`, `shape`) and the paired difference shape − box-corners (mean ± standard
  error over runs; negative: the shapes score better).
"""

import collections
import glob
import json
import os
import sys

# The conditions and the mean ± standard error are the SLAM study's (same runs, same labels).
from slam_study_table import LABELS, mean_se


def pooled(runs, key):
    """Mean of a per-target quantity over all matched targets of all runs."""
    total, count = 0.0, 0
    for s in runs:
        value, n = s.get(key), s.get("matched", 0)
        if value is not None and n:
            total += value * n
            count += n
    return total / count if count else float("nan")


def row(label, kind, shapes):
    n = len(shapes)
    matched = sum(s["matched"] for s in shapes) / n
    kinds = sum(s["kind_correct"] for s in shapes) / max(1, sum(s["matched"] for s in shapes))
    box = [s["etgospa_box_corners"] for s in shapes]
    fps = [s["etgospa_farthest_point"] for s in shapes]
    shp = [s["etgospa_shape"] for s in shapes]
    diff_m, diff_se = mean_se([a - b for a, b in zip(shp, box)])
    cells = [
        label,
        kind,
        str(n),
        f"{matched:.1f} of {shapes[0]['true_targets']}",
        f"{pooled(shapes, 'mean_iou'):.3f}",
        f"{pooled(shapes, 'mean_center_error_m'):.3f}",
        f"{pooled(shapes, 'mean_size_error_m'):.3f}",
        f"{pooled(shapes, 'mean_yaw_error_deg'):.2f}",
        f"{100 * kinds:.1f} %",
        f"{pooled(shapes, 'mean_center_nees'):.2f}",
        f"{mean_se(box)[0]:.1f}",
        f"{mean_se(fps)[0]:.1f}",
        f"{mean_se(shp)[0]:.1f}",
        f"{diff_m:+.2f} ± {diff_se:.2f}",
    ]
    print("| " + " | ".join(cells) + " |")


def main(root):
    runs = collections.defaultdict(list)
    for path in sorted(glob.glob(os.path.join(root, "*.json"))):
        condition, kind, scene, _seed = os.path.basename(path)[:-5].split("_")
        with open(path) as f:
            summary = json.load(f)
        if summary.get("shapes") is not None:
            runs[(condition, kind, "hall" if scene == "hall" else "random")].append(summary["shapes"])
    print(
        "| condition | back end | runs | matched/run | IoU | centre error (m) | size error (m) | "
        "yaw error (°) | kind right | centre NEES (2 if honest) | ET-GOPSA box-corners | "
        "farthest-point | shape | shape − box-corners |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for group in ("hall", "random"):
        for condition, label in LABELS.items():
            for kind in ("slam", "oracle"):
                shapes = runs.get((condition, kind, group))
                if shapes:
                    name = label if group == "hall" else f"{label} (random scenes)"
                    row(name, "SLAM" if kind == "slam" else "true poses", shapes)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "out/slam-study/runs")
