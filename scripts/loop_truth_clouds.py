#!/usr/bin/env python3
r"""Is a loop edge's error the back end's, or already in the detections? Hall runs, seed by seed.

For every loop closure of each run, `examples/slam_trace.rs` (with `TRUECLOUD=1`) matches the
closure's query against its submap again, four ways: with both clouds built at the true keyframe
poses or at the back end's estimates, and starting from the true relative pose (2 m radius) or
from the back end's own prediction and radius. This script runs it over many seeds and prints, for
each way and for the edge the back end accepted, how many matches lie more than 0.5 m from the
truth and the median translation (m) and heading (deg) errors.

Clouds built at the true poses hold no pose error at all: what a match of them still gets wrong
comes from the detections (their scatter, and what each visit sees), not from the back end. At
Δθ 5° that is most of it (docs/slam.md).

    cargo build --release --example slam_trace
    scripts/loop_truth_clouds.py --angle-std-deg 5 --seeds 1-40
    scripts/loop_truth_clouds.py --angle-std-deg 5 --seeds 1-40 --loop 'plateau_fraction = 0'

`--loop` overrides loop closure parameters by name (`KEY = VALUE; …`, TOML values); `--jobs`
runs that many seeds at once (default 2). Run from the repository's root (the hall's scene file
is found from there).
"""
import argparse
import concurrent.futures
import os
import re
import statistics
import subprocess
import sys

REMATCH = re.compile(
    r"clouds from (truth|estimate): from (true prediction|the back end's prediction) "
    r"error (\S+) m (\S+)°"
)
ACCEPTED = re.compile(r"LOOP with kf +\d+: relative error (\S+) m (\S+)°")
WAYS = [
    (("truth", "true prediction"), "true-pose clouds, from the true relative pose"),
    (("estimate", "true prediction"), "estimated clouds, from the true relative pose"),
    (("truth", "the back end's prediction"), "true-pose clouds, from the back end's prediction"),
    (("estimate", "the back end's prediction"), "estimated clouds, from the back end's prediction"),
    ("accepted", "the edge the back end accepted"),
]


def seeds_of(text):
    """'1-40' or '1,5,9' or a mix of both, as a list of seeds."""
    seeds = []
    for part in text.split(","):
        first, _, last = part.partition("-")
        seeds.extend(range(int(first), int(last or first) + 1))
    return seeds


def trace(binary, range_std_m, angle_std_deg, seed, loop):
    """Every closure of one run: a dict from way to (error m, error deg)."""
    # Only this script's settings: a LOOP, DUMP or ALL left in the shell would change the runs.
    env = {k: v for k, v in os.environ.items() if k not in ("LOOP", "DUMP", "ALL", "DISTORT")}
    env["TRUECLOUD"] = "1"
    if loop:
        env["LOOP"] = loop
    args = [binary, str(range_std_m), str(angle_std_deg), str(seed), "true"]
    run = subprocess.run(args, env=env, capture_output=True, text=True, check=False)
    if run.returncode != 0:
        sys.exit(f"seed {seed}: {' '.join(args)} failed:\n{run.stderr[-2000:]}")
    out = run.stdout
    closures, current = [], {}
    for line in out.splitlines():
        if m := REMATCH.search(line):
            current[(m[1], m[2])] = (float(m[3]), abs(float(m[4])))
        elif m := ACCEPTED.search(line):
            current["accepted"] = (float(m[1]), abs(float(m[2])))
            closures.append(current)
            current = {}
    return closures


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--range-std-m", type=float, default=0.0, help="ΔR, metres (0)")
    parser.add_argument("--angle-std-deg", type=float, default=5.0, help="Δθ, degrees (5)")
    parser.add_argument("--seeds", default="1-40", help="seeds, e.g. 1-40 or 1,3,7 (1-40)")
    parser.add_argument("--loop", default="", help="loop closure overrides, 'KEY = VALUE; …'")
    parser.add_argument("--jobs", type=int, default=2, help="runs at once (2)")
    parser.add_argument(
        "--bin", default="target/release/examples/slam_trace", help="the slam_trace binary"
    )
    args = parser.parse_args()
    if not os.path.exists(args.bin):
        sys.exit(f"{args.bin} not found: cargo build --release --example slam_trace")
    seeds = seeds_of(args.seeds)
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(args.jobs, 1)) as pool:
        runs = list(
            pool.map(
                lambda s: trace(args.bin, args.range_std_m, args.angle_std_deg, s, args.loop),
                seeds,
            )
        )
    closures = [c for run in runs for c in run]
    print(
        f"ΔR {args.range_std_m} m, Δθ {args.angle_std_deg}°, {len(seeds)} seeds, "
        f"{len(closures)} closures" + (f", loop overrides: {args.loop}" if args.loop else "")
    )
    print("| match | matched | > 0.5 m off | median error (m) | median heading error (deg) |")
    print("|---|---|---|---|---|")
    for key, label in WAYS:
        errors = [c[key] for c in closures if key in c]
        if not errors:
            print(f"| {label} | 0 | — | — | — |")
            continue
        off = sum(m > 0.5 for m, _ in errors)
        median_m = statistics.median(m for m, _ in errors)
        median_deg = statistics.median(d for _, d in errors)
        print(f"| {label} | {len(errors)} | {off} | {median_m:.2f} | {median_deg:.1f} |")


if __name__ == "__main__":
    main()
