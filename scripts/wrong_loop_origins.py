#!/usr/bin/env python3
r"""Where each wrong loop closure of a study comes from: the detections, or the back end's clouds.

Replays every run of a `scripts/slam_study.sh` output that accepted a loop edge more than 0.5 m
off the truth (`loop_edges_wrong` in its `summary.json`; Δθ 5° rows skipped: docs/slam.md says
why no matcher measures those) with `examples/slam_trace.rs` and `TRUECLOUD=1`, which replays
the run (exactly on the hall; 9 of the 25 random-scene runs replayed from the study at 949030e
ended up to 0.06 m apart in keyframe RMSE, so a few of their closures differ) and matches each
closure's query against its submap again: with both clouds built at the
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
import tomllib


def loop_overrides(launch):
    """The loop closure settings a launch file gives its association node, as slam_trace's LOOP
    overrides (slam_trace reads no launch file); `enabled`, a launch argument, is left out."""
    with open(launch, "rb") as f:
        nodes = tomllib.load(f)["node"]
    (association,) = [n for n in nodes if n.get("kind") == "association"]
    table = association.get("params", {}).get("loop_closure", {})
    return "; ".join(f"{k} = {json.dumps(v)}" for k, v in table.items() if k != "enabled")


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


def replay(binary, out, name, summary):
    """The closures of one study run, replayed from its summary.json's launch arguments: (old,
    new, error m, error deg, {way: re-match error m, None if refused})."""
    arguments = summary["arguments"]
    env = {k: v for k, v in os.environ.items() if k not in ("LOOP", "DUMP", "ALL", "DISTORT")}
    env["TRUECLOUD"] = "1"
    if name.split("_")[2] != "hall":
        env["SCENE"] = os.path.join(out, "scenes", f"{name.split('_')[2]}.toml")
    if arguments.get("fidelity", "ideal") != "ideal":
        env["FIDELITY"] = arguments["fidelity"]
        env["LOOP"] = loop_overrides("launch/paper-5g.toml")
        env["REFINE"] = arguments.get("refinement", "none")
        noise = ("0", "0")
    else:
        noise = (str(arguments["range_std_m"]), str(arguments["angle_std_deg"]))
    args = [binary, *noise, str(summary["seed"]), "true"]
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
    runs = []
    for path in sorted(glob.glob(os.path.join(args.out, "runs", "*_slam_*.json"))):
        with open(path) as f:
            summary = json.load(f)
        # Δθ 5°: no matcher measures those loops to 0.5 m (docs/slam.md).
        scattered = float(summary["arguments"].get("angle_std_deg", 0)) >= 5
        fidelity = summary["arguments"].get("fidelity", "ideal")
        if summary.get("loop_edges_wrong", 0) and not (fidelity == "ideal" and scattered):
            runs.append((os.path.basename(path)[:-5], summary))
    names = [name for name, _ in runs]
    counts = collections.Counter()
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        replays = pool.map(lambda run: replay(args.binary, args.out, *run), runs)
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
