#!/usr/bin/env python3
"""Two cooperative studies of the hall side by side, paired seed by seed.

    scripts/cooperative_compare.py OUT_NEW OUT_BASE [NEW_NAME BASE_NAME]

OUT_NEW and OUT_BASE are folders of scripts/cooperative_study.sh (the same seeds, STUDIES "hall"
and "known" at least), run with different sensing, for instance OUT_NEW with
SENSING="refinement:=interpolation" and OUT_BASE without. Prints Markdown: per configuration the
new study's fused ET-GOPSA, its oracle and their ratio, the base study's ratio, the paired
difference of the fused maps (new − base), and the AGVs' fused pose RMSE in both; then, per
study, what stations change paired by seed (M stations − none, fused and oracle). Means ± 95 %
CI (scripts/cooperative_table.py's). docs/cooperative.md, "With interpolated peaks". Plain
Python, no third-party module.
"""
import importlib.util
import json
import os
import sys

_spec = importlib.util.spec_from_file_location(
    "cooperative_table", os.path.join(os.path.dirname(os.path.abspath(__file__)), "cooperative_table.py")
)
_table = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_table)


def ci(values):
    return _table.fmt(_table.ci(values)).replace("-", "−")


def load(out, name):
    path = os.path.join(out, "runs", f"{name}.json")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        return json.load(f)


def seeds(out, name):
    found = []
    for s in range(1, 1000):
        if load(out, f"{name}_slam_{s}") is None:
            break
        found.append(s)
    return found


def agv_pose_rmse(summary):
    return [
        a["fused_pose_rmse_m"]
        for name, a in summary["agents"].items()
        if name.startswith("agv") and a.get("fused_pose_rmse_m") is not None
    ]


def main(args):
    if len(args) not in (2, 4):
        sys.exit(__doc__)
    new, base = args[0], args[1]
    new_name, base_name = (args[2], args[3]) if len(args) == 4 else ("new", "base")
    print(
        f"| AGVs | stations | runs | ET-GOPSA fused | fused oracle | ratio to oracle | ratio, {base_name} "
        f"| fused: {new_name} − {base_name}, paired | AGV pose RMSE fused (m) | {base_name} (m) |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for study, label in (("hall", ""), ("known", ", every start known")):
        for agvs in range(1, 9):
            for stations in range(0, 9):
                name = f"{study}_a{agvs}_m{stations}"
                oracle = f"hall_a{agvs}_m{stations}_oracle"
                common = [s for s in seeds(new, name) if s in seeds(base, name)]
                if not common:
                    continue
                rows = []
                for s in common:
                    pair = [load(new, f"{name}_slam_{s}"), load(new, f"{oracle}_{s}"),
                            load(base, f"{name}_slam_{s}"), load(base, f"{oracle}_{s}")]
                    if None not in pair:
                        rows.append(pair)
                if not rows:
                    continue
                fused = [r[0]["etgospa"] for r in rows]
                oracles = [r[1]["etgospa"] for r in rows]
                print(
                    f"| {agvs}{label} | {stations} | {len(rows)} | {ci(fused)} | {ci(oracles)} "
                    f"| {ci([f / o for f, o in zip(fused, oracles)])} "
                    f"| {ci([r[2]['etgospa'] / r[3]['etgospa'] for r in rows])} "
                    f"| {ci([r[0]['etgospa'] - r[2]['etgospa'] for r in rows])} "
                    f"| {ci([x for r in rows for x in agv_pose_rmse(r[0])])} "
                    f"| {ci([x for r in rows for x in agv_pose_rmse(r[2])])} |"
                )
    print()
    print("What stations change, paired by seed (M stations − none, the hall study):")
    print()
    for out, title in ((new, new_name), (base, base_name)):
        for agvs in range(1, 9):
            for stations in range(1, 9):
                common = [s for s in seeds(out, f"hall_a{agvs}_m{stations}") if s in seeds(out, f"hall_a{agvs}_m0")]
                if not common:
                    continue
                cells = []
                for kind in ("slam", "oracle"):
                    with_ = [load(out, f"hall_a{agvs}_m{stations}_{kind}_{s}") for s in common]
                    without = [load(out, f"hall_a{agvs}_m0_{kind}_{s}") for s in common]
                    cells.append(ci([a["etgospa"] - b["etgospa"] for a, b in zip(with_, without) if a and b]))
                print(f"- {title}, {agvs} AGV(s), {stations} stations: fused {cells[0]}, oracle {cells[1]}")


if __name__ == "__main__":
    main(sys.argv[1:])
