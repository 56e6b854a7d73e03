#!/usr/bin/env python3
"""How much of each AGV's fused pose error is the map frame's, and how much its own shape's.

    scripts/agent_pose_errors.py RUN_DIR...

Reads each run's agents.csv (written by `nrslam launch` for a cooperative run) and prints, per AGV
over the frames it has a fused pose: the RMSE of its own SLAM (its frame put on the truth's at its
start, as summary.json's `own_pose_rmse_fused_frames_m`), of its fused pose (map frame,
`fused_pose_rmse_m`), and of its fused pose after the one rigid motion (rotation and translation)
that best fits it to the truth. When the last is small, the fused error is a misplaced frame: the
agent's path has the right shape but sits rotated or shifted in the map, as the map it was matched
against does. Plain Python, no third-party module.
"""
import csv
import math
import sys
from collections import defaultdict


def best_rigid_fit(source, target):
    """(rotation_rad, tx, ty) minimising the squared distances of R·source + t to target."""
    n = len(source)
    sx = sum(p[0] for p in source) / n
    sy = sum(p[1] for p in source) / n
    tx = sum(p[0] for p in target) / n
    ty = sum(p[1] for p in target) / n
    dot = cross = 0.0
    for (px, py), (qx, qy) in zip(source, target):
        ax, ay, bx, by = px - sx, py - sy, qx - tx, qy - ty
        dot += ax * bx + ay * by
        cross += ax * by - ay * bx
    theta = math.atan2(cross, dot)
    c, s = math.cos(theta), math.sin(theta)
    return theta, tx - (c * sx - s * sy), ty - (s * sx + c * sy)


def rmse(points, truth):
    return math.sqrt(sum((p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2 for p, q in zip(points, truth)) / len(points))


def main(run_dirs):
    print("run,agent,frames,own_rmse_m,fused_rmse_m,fused_rigidly_fitted_rmse_m,frame_rotation_deg,frame_shift_m")
    for run in run_dirs:
        rows = defaultdict(list)
        with open(f"{run}/agents.csv", newline="") as f:
            for r in csv.DictReader(f):
                if r["fused_x_m"] and r["true_x_m"] and r["own_x_m"]:
                    rows[r["agent"]].append(r)
        for agent, rs in sorted(rows.items()):
            truth = [(float(r["true_x_m"]), float(r["true_y_m"])) for r in rs]
            own = [(float(r["own_x_m"]), float(r["own_y_m"])) for r in rs]
            fused = [(float(r["fused_x_m"]), float(r["fused_y_m"])) for r in rs]
            theta, tx, ty = best_rigid_fit(fused, truth)
            c, s = math.cos(theta), math.sin(theta)
            fitted = [(c * x - s * y + tx, s * x + c * y + ty) for x, y in fused]
            shift = math.sqrt(sum((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 for a, b in zip(fitted, fused)) / len(fused))
            print(f"{run},{agent},{len(rs)},{rmse(own, truth):.3f},{rmse(fused, truth):.3f},"
                  f"{rmse(fitted, truth):.3f},{math.degrees(theta):.2f},{shift:.3f}")


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
