#!/usr/bin/env python3
"""Checks of a sizing study (docs/sizing.md):

  scripts/sizing_check.py screen NO_SCREEN_DIR
      In a study run with --no-screen, every configuration the screen would drop (its `screen`
      column starts with "drop") must not be met by the simulation. Prints each dropped
      configuration with its simulated status; exits 1 if one is met.

  scripts/sizing_check.py sequential SEQUENTIAL_DIR FIXED_DIR
      The same configurations decided sequentially and with a fixed trial count per
      configuration ([trials] first = max): the decisions must be equal, and the trials spent
      are compared. Exits 1 if a decision differs.
"""

import csv
import sys


def rows(folder):
    with open(f"{folder}/frontier.csv", newline="") as f:
        return {r["config"]: r for r in csv.DictReader(f)}


def screen(folder):
    bad = 0
    dropped = [r for r in rows(folder).values() if r["screen"].startswith("drop")]
    kept = [r for r in rows(folder).values() if not r["screen"].startswith("drop")]
    for r in dropped:
        print(f"  dropped {r['config']:<40} simulated: {r['status']:<9} over {r['trials']} trials")
        bad += r["status"] == "met"
    print(f"{len(dropped)} dropped, {len(kept)} kept; dropped but met by the simulation: {bad}")
    return 1 if bad else 0


def sequential(seq_dir, fixed_dir):
    seq, fixed = rows(seq_dir), rows(fixed_dir)
    common = [c for c in seq if c in fixed and seq[c]["status"] != "screened"]
    differ = 0
    seq_trials = fixed_trials = 0
    for c in common:
        a, b = seq[c], fixed[c]
        seq_trials += int(a["trials"])
        fixed_trials += int(b["trials"])
        same = a["status"] == b["status"]
        differ += not same
        print(f"  {c:<40} sequential {a['status']:<9} ({a['trials']:>3} trials)   "
              f"fixed {b['status']:<9} ({b['trials']} trials){'' if same else '   DIFFERENT'}")
    ratio = fixed_trials / seq_trials if seq_trials else float("nan")
    print(f"{len(common)} configurations, {differ} decisions differ; trials: sequential "
          f"{seq_trials}, fixed {fixed_trials} ({ratio:.1f}x fewer)")
    return 1 if differ else 0


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "screen":
        sys.exit(screen(sys.argv[2]))
    if len(sys.argv) == 4 and sys.argv[1] == "sequential":
        sys.exit(sequential(sys.argv[2], sys.argv[3]))
    print(__doc__, file=sys.stderr)
    sys.exit(2)
