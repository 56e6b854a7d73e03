#!/usr/bin/env python3
"""nrslam's metric and segmentation against the usual Python tools, on the same inputs.

Writes the point sets as the CSV files `nrslam metric` and `nrslam segment` read, times the
nrslam release binary (whole process: wall time around the process, median of --repeat runs;
peak RSS of one more run from `/usr/bin/time -v`) and the peers (solver alone, in this process,
median of --repeat calls), and prints the figures:

- GOSPA (c = 5 m, p = 1, alpha = 2) of 1000 truth points (250 targets, the corners of 2 m
  squares placed uniformly over 300 m x 300 m) against 1000 estimates (800 noisy corners,
  sigma 0.5 m, and 200 uniform clutter points): `nrslam metric` (GOSPA and ET-GOPSA, CSV parsing
  included) against SciPy `cdist` + `linear_sum_assignment` on min(d, c) - c (GOSPA only);
  both totals are printed, they must agree;
- the same at 100 000 x 100 000 points (25 000 targets over 3000 m x 3000 m, same density):
  `nrslam metric` only (the dense matrix SciPy needs would be 1e10 cells, 80 GB);
- DBSCAN is compared by scripts/dbscan_peer.py, on the points of nrslam's DBSCAN benchmark.

Usage: python3 scripts/peers.py [--nrslam target/release/nrslam] [--repeat 11] [--dir DIR]

Needs numpy and scipy (pip install scipy); never needed by CI.
"""

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

C, P, ALPHA = 5.0, 1.0, 2.0


def scene(targets, extent, seed):
    """Truth (ids, points) and estimates for `targets` 2 m squares over extent x extent m."""
    rng = np.random.default_rng(seed)
    origins = rng.uniform(0.0, extent - 2.0, size=(targets, 2))
    corners = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]])
    truth = (origins[:, None, :] + corners[None, :, :]).reshape(-1, 2)
    ids = np.repeat(np.arange(targets), 4)
    n = truth.shape[0]
    detected = truth[rng.choice(n, size=n * 4 // 5, replace=False)]
    noisy = detected + rng.normal(0.0, 0.5, size=detected.shape)
    clutter = rng.uniform(0.0, extent, size=(n - noisy.shape[0], 2))
    estimates = np.vstack([noisy, clutter])
    estimates = estimates[rng.permutation(estimates.shape[0])]
    return ids, truth, estimates


def write_truth(path, ids, truth):
    with open(path, "w") as f:
        f.write("target,x,y\n")
        for i, (x, y) in zip(ids, truth):
            f.write(f"{int(i)},{float(x)!r},{float(y)!r}\n")


def write_points(path, points):
    with open(path, "w") as f:
        f.write("x,y\n")
        for x, y in points:
            f.write(f"{float(x)!r},{float(y)!r}\n")


def run_timed(cmd):
    """Wall time (s) of one run, measured around the process (start, run, exit), and its stdout."""
    start = time.perf_counter()
    result = subprocess.run(cmd, capture_output=True, text=True, check=True)
    return time.perf_counter() - start, result.stdout


def peak_rss_mb(cmd):
    """Peak RSS (MB) and elapsed time as `/usr/bin/time -v` reports them for one run."""
    result = subprocess.run(
        ["/usr/bin/time", "-v"] + cmd, capture_output=True, text=True, check=True
    )
    rss_kb = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", result.stderr).group(1))
    elapsed = re.search(r"Elapsed \(wall clock\) time.*: (\S+)", result.stderr).group(1)
    return rss_kb / 1024.0, elapsed


def nrslam_metric(binary, truth_csv, estimates_csv, repeat):
    cmd = [binary, "metric", "--truth", truth_csv, "--estimates", estimates_csv,
           "--c", str(C), "--p", "1", "--alpha", str(ALPHA), "--json"]
    runs = [run_timed(cmd) for _ in range(repeat)]
    report = json.loads(runs[0][1])
    rss, elapsed = peak_rss_mb(cmd)
    times = [r[0] for r in runs]
    return (statistics.median(times), min(times)), rss, elapsed, report["gospa"]["total"]


def scipy_gospa(truth, estimates):
    """GOSPA (p = 1, alpha = 2) by cdist + linear_sum_assignment on min(d, c)^p - c^p."""
    d = cdist(truth, estimates)
    cost = np.minimum(d, C) ** P - C**P
    rows, cols = linear_sum_assignment(cost)
    paired = d[rows, cols] < C
    k = int(paired.sum())
    localisation = float((d[rows, cols][paired] ** P).sum())
    unassigned = truth.shape[0] + estimates.shape[0] - 2 * k
    return (localisation + C**P / ALPHA * unassigned) ** (1.0 / P)


def best_of(repeat, fn):
    times, value = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        value = fn()
        times.append(time.perf_counter() - start)
    return (statistics.median(times), min(times)), value


def ms(times):
    """(median, min) seconds as text."""
    return f"median {times[0] * 1e3:7.1f} ms (min {times[1] * 1e3:7.1f} ms)"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--nrslam", default="target/release/nrslam")
    parser.add_argument("--repeat", type=int, default=11)
    parser.add_argument("--dir", default=None, help="where to write the CSV files (default: a temporary directory)")
    args = parser.parse_args()
    binary = os.path.abspath(args.nrslam)
    if not os.access(binary, os.X_OK):
        sys.exit(f"{binary}: not found; build it with `cargo build --release -p nrslam`")
    workdir = args.dir or tempfile.mkdtemp(prefix="nrslam-peers-")
    os.makedirs(workdir, exist_ok=True)
    print(f"files in {workdir}; median and minimum of {args.repeat} runs each; {os.cpu_count()} CPUs")

    # 1000 x 1000 over 300 m.
    ids, truth, estimates = scene(250, 300.0, seed=1)
    truth_csv, est_csv = os.path.join(workdir, "truth_1k.csv"), os.path.join(workdir, "estimates_1k.csv")
    write_truth(truth_csv, ids, truth)
    write_points(est_csv, estimates)
    wall, rss, elapsed, total = nrslam_metric(binary, truth_csv, est_csv, args.repeat)
    scipy_s, scipy_total = best_of(args.repeat, lambda: scipy_gospa(truth, estimates))
    print(f"GOSPA 1000 x 1000 over 300 m, c = 5 m:")
    print(f"  nrslam metric (whole process, GOSPA + ET-GOPSA): {ms(wall)}, "
          f"peak RSS {rss:.1f} MB (/usr/bin/time -v: {elapsed}), GOSPA {total!r}")
    print(f"  scipy cdist + linear_sum_assignment (solver alone): {ms(scipy_s)}, "
          f"GOSPA {scipy_total!r}")
    print(f"  scipy / nrslam: {scipy_s[0] / wall[0]:.2f}x (medians), {scipy_s[1] / wall[1]:.2f}x (minima); "
          f"totals differ by {abs(total - scipy_total) / scipy_total:.1e} relative")

    # 100 000 x 100 000 over 3000 m (same density).
    ids, truth, estimates = scene(25_000, 3000.0, seed=2)
    truth_csv, est_csv = os.path.join(workdir, "truth_100k.csv"), os.path.join(workdir, "estimates_100k.csv")
    write_truth(truth_csv, ids, truth)
    write_points(est_csv, estimates)
    wall, rss, elapsed, total = nrslam_metric(binary, truth_csv, est_csv, args.repeat)
    print(f"GOSPA 100000 x 100000 over 3000 m, c = 5 m:")
    print(f"  nrslam metric (whole process, GOSPA + ET-GOPSA): {ms(wall)}, "
          f"peak RSS {rss:.1f} MB (/usr/bin/time -v: {elapsed}), GOSPA {total!r}")
    print("  scipy: not run (a dense 1e5 x 1e5 cost matrix is 80 GB)")


if __name__ == "__main__":
    main()
