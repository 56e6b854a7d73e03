#!/usr/bin/env python3
r"""Errors against the truth of every loop match the back end accepted or left pending.

Pairs the association's debug log with the keyframe truths that `examples/slam_trace.rs` writes
(`TRUTHS=FILE`). For one run of the hall at Δθ 5°, seed 22:

    cargo build --release --example slam_trace
    TRUTHS=/tmp/t22.truth NRSLAM_LOG=nrslam_association=debug \
        target/release/examples/slam_trace 0 5 22 true 2> /tmp/t22.log > /dev/null
    scripts/loop_match_errors.py /tmp/t22

Each argument is a path without extension (STEM.log and STEM.truth are read; a trailing .log or
.truth is dropped). One line per match: pending or accepted; the old keyframe (the candidate) ->
the query's anchor keyframe (the middle of the query, which the loop edge measures); the
translation error (m) and heading error (deg) of its relative pose against the truth; the
translation error (m) of the back end's prediction; its inlier ratio and correlative score.
With several runs, a summary follows: how many matches lie within 0.5 m of the truth, in runs
that closed a loop and in runs that closed none.
"""
import math
import re
import statistics
import sys

MATCH = re.compile(
    r"loop (pending|accepted) candidate=(\d+) anchor=(\d+) .*?relative: Pose2 \{ x_m: (\S+), "
    r"y_m: (\S+), yaw_rad: (\S+) \}, inlier_ratio: (\S+), score: (\S+),.*predicted=Pose2 "
    r"\{ x_m: (\S+), y_m: (\S+), yaw_rad: (\S+) \}"
)
ANSI = re.compile(r"\x1b\[[0-9;]*m")


def between(a, b):
    """Pose b in the frame of pose a (x_m, y_m, yaw_rad)."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    c, s = math.cos(a[2]), math.sin(a[2])
    return (c * dx + s * dy, -s * dx + c * dy, b[2] - a[2])


def wrapped_deg(rad):
    return abs(math.degrees((rad + math.pi) % (2 * math.pi) - math.pi))


def read_lines(path):
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.readlines()
    except OSError as e:
        sys.exit(f"cannot read {path}: {e.strerror}")


def matches(stem):
    truths = []
    for number, line in enumerate(read_lines(stem + ".truth"), 1):
        try:
            x, y, yaw = map(float, line.split())
        except ValueError:
            sys.exit(f"{stem}.truth line {number}: expected 'x_m y_m yaw_rad'")
        truths.append((x, y, yaw))
    lines = read_lines(stem + ".log")
    if not any("nrslam_association" in line for line in lines):
        sys.exit(f"{stem}.log has no association debug lines: was NRSLAM_LOG=nrslam_association=debug set?")
    for line in lines:
        m = MATCH.search(ANSI.sub("", line))
        if not m:
            continue
        value = lambda i: float(m.group(i).rstrip(","))
        old, new = int(m.group(2)), int(m.group(3))
        if max(old, new) >= len(truths):
            sys.exit(f"{stem}: keyframe {max(old, new)} has no truth; wrong .truth file?")
        truth = between(truths[old], truths[new])
        measured = (value(4), value(5), value(6))
        predicted = (value(9), value(10), value(11))
        error = lambda p: math.hypot(p[0] - truth[0], p[1] - truth[1])
        yield {
            "kind": m.group(1),
            "old": old,
            "new": new,
            "error_m": error(measured),
            "error_deg": wrapped_deg(measured[2] - truth[2]),
            "predicted_error_m": error(predicted),
            "inlier_ratio": value(7),
            "score": value(8),
        }


def strip_extension(path):
    for ext in (".log", ".truth"):
        if path.endswith(ext):
            return path[: -len(ext)]
    return path


def main(stems):
    stems = [strip_extension(s) for s in stems]
    runs = {}
    for stem in stems:
        runs[stem] = list(matches(stem))
        for x in runs[stem]:
            print(
                f"{stem.split('/')[-1]:12s} {x['kind']:8s} {x['old']:3d} -> {x['new']:3d}  "
                f"error {x['error_m']:5.2f} m {x['error_deg']:4.1f} deg  prediction "
                f"{x['predicted_error_m']:5.2f} m  inliers {x['inlier_ratio']:.2f}  "
                f"score {x['score']:.2f}"
            )
    if len(stems) < 2:
        return
    closed = {s for s, xs in runs.items() if any(x["kind"] == "accepted" for x in xs)}

    def summary(label, errors):
        if errors:
            near = sum(e <= 0.5 for e in errors)
            print(f"{label}: {len(errors)}, {near} within 0.5 m, median {statistics.median(errors):.2f} m")
        else:
            print(f"{label}: none")

    print(f"runs: {len(runs)}, {len(closed)} closed a loop")
    summary("accepted", [x["error_m"] for xs in runs.values() for x in xs if x["kind"] == "accepted"])
    summary(
        "pending, runs that closed a loop",
        [x["error_m"] for s in closed for x in runs[s] if x["kind"] == "pending"],
    )
    summary(
        "pending, runs that closed none",
        [x["error_m"] for s, xs in runs.items() if s not in closed for x in xs],
    )


if __name__ == "__main__":
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
