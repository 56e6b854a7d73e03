#!/usr/bin/env python3
"""scikit-learn's DBSCAN beside `nrslam segment`, on the points of nrslam's DBSCAN benchmark.

  pip install scikit-learn          # optional; never needed by CI
  python3 scripts/dbscan_peer.py [--n 100000] [--nrslam target/release/nrslam]

Writes the points of nodes/segmenter/benches/dbscan.rs (the same xorshift64* stream: 200 blobs of
3 m x 3 m on a 10 m pitch, one point in ten uniform over 200 m x 100 m) to a CSV, times
scikit-learn's `DBSCAN(eps=0.3, min_samples=4, n_jobs=-1).fit` on them (best of 5), runs
`nrslam segment` on the CSV (whole process, best of 5), and checks that the labels are equal up to
renumbering (noise -1 on both sides). Exit status 1 if they are not.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

MASK = (1 << 64) - 1


def peer_points(n):
    state = 0x9E3779B97F4A7C15

    def uniform():
        nonlocal state
        state ^= state >> 12
        state ^= (state << 25) & MASK
        state ^= state >> 27
        return (((state * 0x2545F4914F6CDD1D) & MASK) >> 11) * (1.0 / (1 << 53))

    points = []
    for i in range(n):
        if i % 10 == 0:
            points.append((uniform() * 200.0, uniform() * 100.0))
        else:
            c = i % 200
            cx, cy = (c % 20) * 10.0 + 5.0, (c // 20) * 10.0 + 5.0
            x = cx + (uniform() - 0.5) * 3.0
            y = cy + (uniform() - 0.5) * 3.0
            points.append((x, y))
    return points


def same_partition(a, b):
    """Labels equal up to renumbering of the clusters, noise (-1) fixed."""
    forward, backward = {}, {}
    for x, y in zip(a, b):
        if (x == -1) != (y == -1):
            return False
        if x == -1:
            continue
        if forward.setdefault(x, y) != y or backward.setdefault(y, x) != x:
            return False
    return True


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--n", type=int, default=100_000, help="points (default 100000)")
    parser.add_argument("--nrslam", default="target/release/nrslam", help="the nrslam binary")
    parser.add_argument("--repeat", type=int, default=5, help="timings to take the best of")
    args = parser.parse_args()
    import numpy as np
    from sklearn.cluster import DBSCAN

    points = peer_points(args.n)
    xy = np.array(points)
    best_fit = float("inf")
    for _ in range(args.repeat):
        started = time.perf_counter()
        theirs = DBSCAN(eps=0.3, min_samples=4, n_jobs=-1).fit(xy).labels_
        best_fit = min(best_fit, time.perf_counter() - started)
    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "points.csv")
        out = os.path.join(tmp, "labels.csv")
        with open(path, "w") as f:
            f.write("x,y\n")
            for x, y in points:
                f.write(f"{x!r},{y!r}\n")
        best_process = float("inf")
        for _ in range(args.repeat):
            started = time.perf_counter()
            subprocess.run([args.nrslam, "segment", "--input", path, "--eps", "0.3",
                            "--min-samples", "4", "--output", out], check=True,
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            best_process = min(best_process, time.perf_counter() - started)
        with open(out) as f:
            next(f)
            ours = [int(line.rsplit(",", 1)[1]) for line in f]
    equal = same_partition(list(theirs), ours)
    clusters = len(set(theirs) - {-1})
    print(f"{args.n} points, {clusters} clusters, {int((theirs == -1).sum())} noise")
    print(f"scikit-learn DBSCAN.fit (n_jobs=-1, {os.cpu_count()} cores): {best_fit * 1e3:.1f} ms")
    print(f"nrslam segment, whole process with CSV in and out: {best_process * 1e3:.1f} ms")
    print(f"labels equal up to renumbering: {equal}")
    sys.exit(0 if equal else 1)


if __name__ == "__main__":
    main()
