#!/usr/bin/env python3
"""How much of each AGV's fused pose error is the map frame's, and how much its own shape's.

    scripts/agent_pose_errors.py [--summary] RUN...

Reads each run's agents.csv (RUN: a run's output folder holding it, as `nrslam launch --out`
writes for a cooperative run, or the file itself, as scripts/cooperative_study.sh keeps it in
OUT/runs/NAME.agents.csv) and prints, per AGV
over the frames it has a fused pose: the RMSE of its own SLAM (its frame put on the truth's at its
start, as summary.json's `own_pose_rmse_fused_frames_m`), of its fused pose (map frame,
`fused_pose_rmse_m`), and of its fused pose after the one rigid motion (rotation and translation)
that best fits it to the truth. When the last is small, the fused error is a misplaced frame: the
agent's path has the right shape but sits rotated or shifted in the map, as the map it was matched
against does. --summary prints instead one Markdown row per AGV over the runs: mean ± 95 % CI of
each RMSE, the mean absolute rotation, and the runs worse with fusion than alone (the table of
docs/cooperative.md, "Where agv4's error comes from"). Plain Python, no third-party module.
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


def agent_rows(run):
    """(agent, frames, own, fused, fitted RMSE in m, rotation in degrees, shift in m) per AGV."""
    rows = defaultdict(list)
    path = run if run.endswith(".csv") else f"{run}/agents.csv"
    with open(path, newline="") as f:
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
        yield agent, len(rs), rmse(own, truth), rmse(fused, truth), rmse(fitted, truth), math.degrees(theta), shift


def mean_ci(values):
    mean = sum(values) / len(values)
    if len(values) < 2:
        return f"{mean:.3f}"
    sd = math.sqrt(sum((v - mean) ** 2 for v in values) / (len(values) - 1))
    return f"{mean:.3f} ± {1.96 * sd / math.sqrt(len(values)):.3f}"


def main(args):
    summary = args[:1] == ["--summary"]
    runs = args[1:] if summary else args
    if not runs:
        sys.exit(__doc__)
    if not summary:
        print("run,agent,frames,own_rmse_m,fused_rmse_m,fused_rigidly_fitted_rmse_m,frame_rotation_deg,frame_shift_m")
        for run in runs:
            for agent, n, own, fused, fitted, rotation, shift in agent_rows(run):
                print(f"{run},{agent},{n},{own:.3f},{fused:.3f},{fitted:.3f},{rotation:.2f},{shift:.3f}")
        return
    by_agent = defaultdict(list)
    for run in runs:
        for row in agent_rows(run):
            by_agent[row[0]].append(row)
    print("| AGV | runs merged | own SLAM (m) | fused (m) | fused, rigidly fitted (m) | rotation of that fit | worse with fusion |")
    print("|---|---|---|---|---|---|---|")
    for agent, rows in sorted(by_agent.items()):
        own, fused, fitted = ([r[i] for r in rows] for i in (2, 3, 4))
        rotation = sum(abs(r[5]) for r in rows) / len(rows)
        worse = sum(1 for r in rows if r[3] > r[2])
        print(f"| {agent} | {len(rows)} | {mean_ci(own)} | {mean_ci(fused)} | {mean_ci(fitted)} | {rotation:.2f}° | {worse} of {len(rows)} |")


if __name__ == "__main__":
    main(sys.argv[1:])
