#!/usr/bin/env python3
r"""Where each wrong loop closure of a study comes from: the detections, or the back end's clouds.

Replays every run of a `scripts/slam_study.sh` output that accepted a loop edge more than 0.5 m
off the truth (`loop_edges_wrong` in its `summary.json`; Δθ 5° rows skipped: docs/slam.md says
why no matcher measures those) with `examples/slam_trace.rs` and `TRUECLOUD=1`, which reproduces
the run and matches each closure's query against its submap again: with both clouds built at the
true keyframe poses or at the back end's estimates, from the true relative pose or from the back
end's own prediction and search radius. For every closure whose accepted edge is more than 0.5 m
off it prints the four re-matches, then counts the closures by the true-pose clouds matched from
the back end's prediction (the back end's search on perfect clouds):

- still more than 0.5 m off: what the detections of a partial revisit allow from where the
  search starts (a slide along one side);
- within 0.5 m: the back end's clouds made the difference (tracking's distortion of the query or
  the submap, or a keyframe's heading carried over the edge's lever).

The replay prints every closure as it was accepted, including those a later closure superseded
or the recheck removed, and counts closures, where the study counts edges: the two totals differ.

    cargo build --release --example slam_trace
    scripts/slam_study.sh out/study 40 20 2 2
    scripts/wrong_loop_origins.py out/study

Run from the repository's root (the hall's scene file is found from there).
"""
import argparse
import collections
import concurrent.futures
import glob
import json
import os
import re
import subprocess

# The ideal radar's noise for each condition of scripts/slam_study.sh, and the 5G chain's launch
# settings (launch/paper-5g.toml) where slam_trace needs them.
NOISE = {"a1": ("0", "1"), "r01a1": ("0.1", "1"), "5g": ("0", "0"), "5gi": ("0", "0")}
LOOP_5G = (
    "inlier_distance_m = 1.0; min_inlier_ratio = 0.40; pair_deg = 3.0; "
    "confirm_min_information_per_m2 = 0.5"
)
# A re-match prints its error against the truth, or "refused" and the matcher's reason.
REMATCH = re.compile(
    r"clouds from (truth|estimate): from (true prediction|the back end's prediction) "
    r"(?:error (\S+) m|refused)"
)
CLOSURE = re.compile(r"kf +(\d+) LOOP with kf +(\d+): relative error (\S+) m (\S+)°")
WAYS = [
    ("truth", "true prediction"),
    ("estimate", "true prediction"),
    ("truth", "the back end's prediction"),
    ("estimate", "the back end's prediction"),
]


def replay(binary, out, name):
    """The closures of one study run: (old, new, error m, error deg, {way: re-match error m})."""
    condition, _, scene, seed = name.split("_")
    env = {k: v for k, v in os.environ.items() if k not in ("LOOP", "DUMP", "ALL", "DISTORT")}
    env["TRUECLOUD"] = "1"
    if scene != "hall":
        env["SCENE"] = os.path.join(out, "scenes", f"{scene}.toml")
    if condition in ("5g", "5gi"):
        env["FIDELITY"] = "spectral"
        env["LOOP"] = LOOP_5G
        if condition == "5gi":
            env["REFINE"] = "interpolation"
    args = [binary, *NOISE[condition], seed, "true"]
    run = subprocess.run(args, env=env, capture_output=True, text=True)
    if run.returncode != 0:
        print(f"{name}: slam_trace failed: {run.stderr.strip().splitlines()[-1:]}")
        return []
    text = run.stdout
    closures, rematches = [], {}
    for line in text.splitlines():
        if m := REMATCH.search(line):
            rematches[(m.group(1), m.group(2))] = float(m.group(3)) if m.group(3) else None
        elif m := CLOSURE.search(line):
            closures.append(
                (int(m.group(2)), int(m.group(1)), float(m.group(3)), float(m.group(4)), rematches)
            )
            rematches = {}
    return closures


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("out", help="the output folder of scripts/slam_study.sh")
    parser.add_argument("--binary", default="target/release/examples/slam_trace")
    parser.add_argument("--jobs", type=int, default=2)
    args = parser.parse_args()
    names = []
    for path in sorted(glob.glob(os.path.join(args.out, "runs", "*_slam_*.json"))):
        name = os.path.basename(path)[:-5]
        condition = name.split("_")[0]
        with open(path) as f:
            wrong = json.load(f).get("loop_edges_wrong", 0)
        if condition in NOISE and wrong:
            names.append(name)
    counts = collections.Counter()
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        replays = pool.map(lambda n: replay(args.binary, args.out, n), names)
        for name, closures in zip(names, replays):
            for old, new, error_m, error_deg, rematches in closures:
                if error_m <= 0.5:
                    continue
                cells = ", ".join(
                    "refused" if rematches.get(w) is None else f"{rematches[w]:.2f}" for w in WAYS
                )
                print(f"{name}: {old} -> {new} accepted {error_m:.2f} m {error_deg:.1f}°; re-matched {cells}")
                search = rematches.get(WAYS[2])
                kind = (
                    "refused"
                    if search is None
                    else "detections (true-pose clouds also > 0.5 m off)"
                    if search > 0.5
                    else "back end's clouds (true-pose clouds within 0.5 m)"
                )
                counts[(name.split("_")[0], kind)] += 1
                counts[("all", kind)] += 1
    print("re-matched: true-pose clouds from the truth, estimated clouds from the truth, "
          "true-pose clouds from the prediction, estimated clouds from the prediction (m)")
    for (condition, kind), n in sorted(counts.items()):
        print(f"{condition:6} {kind}: {n}")


if __name__ == "__main__":
    main()
