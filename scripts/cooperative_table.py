#!/usr/bin/env python3
"""Tables and plots of scripts/cooperative_study.sh OUT: OUT/tables.md, OUT/cooperation.png.

Every figure is a mean with its 95 % confidence interval (Student t) over the runs; paired
differences are taken run by run on the same seed (and scene).
"""
import collections
import glob
import json
import math
import os
import sys

# Two-sided 95 % Student t quantiles by degrees of freedom (1-30), then the normal's.
T95 = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179,
       2.160, 2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064,
       2.060, 2.056, 2.052, 2.048, 2.045, 2.042]


def ci(values):
    """(mean, half-width of the 95 % CI, n); half-width None for fewer than 2 values."""
    values = [v for v in values if v is not None]
    n = len(values)
    if n == 0:
        return (None, None, 0)
    mean = sum(values) / n
    if n < 2:
        return (mean, None, n)
    sd = math.sqrt(sum((v - mean) ** 2 for v in values) / (n - 1))
    t = T95[n - 2] if n - 1 <= len(T95) else 1.96
    return (mean, t * sd / math.sqrt(n), n)


def fmt(c, digits=2):
    mean, half, n = c
    if mean is None:
        return "n/a"
    if half is None:
        return f"{mean:.{digits}f}"
    return f"{mean:.{digits}f} ± {half:.{digits}f}"


def load(out):
    runs = {}
    for path in glob.glob(os.path.join(out, "runs", "*.json")):
        name = os.path.basename(path)[:-5]
        with open(path) as f:
            runs[name] = json.load(f)
    return runs


def agvs_of(summary):
    return {k: v for k, v in summary.get("agents", {}).items() if k.startswith("agv")}


def pose_gains(runs):
    """Of a condition's SLAM runs, each merged AGV's pose RMSE with fusion − without, by AGV."""
    per = collections.defaultdict(list)
    for (kind, _seed), summary in runs.items():
        if kind != "slam":
            continue
        for name, v in agvs_of(summary).items():
            if v["fused_pose_rmse_m"] is not None and v["own_pose_rmse_fused_frames_m"] is not None:
                per[name].append(v["fused_pose_rmse_m"] - v["own_pose_rmse_fused_frames_m"])
    return per


def mean_or_none(values):
    values = [v for v in values if v is not None]
    return sum(values) / len(values) if values else None


def random_table(lines, by, pairs, prefix, title):
    """The random scenes' table: runs named PREFIX + sK_mM, by station count."""
    randoms = [c for c in by if c.startswith(prefix)]
    if randoms:
        lines.append(f"## {title}\n")
        lines.append("| stations | runs | ET-GOPSA fused | fused oracle | ratio to oracle | runs within 1.2 × oracle | AGVs merged | wrong edges / accepted |")
        lines.append("|---|---|---|---|---|---|---|---|")
        for m in (0, 2):
            ps = []
            for c in randoms:
                if c.endswith(f"_m{m}"):
                    ps += [(sl, orc) for _, sl, orc in pairs(c) if sl and orc]
            if not ps:
                continue
            ratio = [sl["etgospa"] / orc["etgospa"] for sl, orc in ps]
            merged = ci([sum(1 for v in agvs_of(sl).values() if v["fused_frames"]) / max(len(agvs_of(sl)), 1) for sl, _ in ps])
            acc = sum((sl.get("inter_agent_edges") or {}).get("accepted", 0) for sl, _ in ps)
            wr = sum((sl.get("inter_agent_edges") or {}).get("wrong", 0) for sl, _ in ps)
            lines.append(f"| {m} | {len(ps)} | {fmt(ci([sl['etgospa'] for sl, _ in ps]))} | {fmt(ci([o['etgospa'] for _, o in ps]))} | {fmt(ci(ratio))} | {sum(1 for r in ratio if r <= 1.2)} of {len(ratio)} | {fmt(merged)} | {wr} / {acc} |")
        lines.append("")


def sensing_of(out):
    """The runs' sensing: paper-5g.toml's, with the study's SENSING arguments if it had any."""
    try:
        with open(os.path.join(out, "sensing.txt")) as f:
            extra = f.read().strip()
    except FileNotFoundError:
        extra = ""
    return f"paper-5g sensing, {extra}" if extra else "paper-5g sensing"


def main():
    out = sys.argv[1]
    runs = load(out)
    lines = []
    # name: study_cond_kind_seed
    by = collections.defaultdict(dict)  # (cond) -> {(kind, seed): summary}
    for name, s in runs.items():
        cond, kind, seed = name.rsplit("_", 2)
        by[cond][(kind, int(seed))] = s

    def pairs(cond):
        d = by.get(cond, {})
        seeds = sorted({seed for (_, seed) in d})
        return [(seed, d.get(("slam", seed)), d.get(("oracle", seed))) for seed in seeds]

    hall = [c for c in by if c.startswith("hall_")]
    if hall:
        lines.append(f"## The hall: what cooperation buys ({sensing_of(out)})\n")
        lines.append("| AGVs | stations | runs | ET-GOPSA fused | ET-GOPSA fused oracle | ratio to oracle | AGV pose RMSE own (m) | AGV pose RMSE fused (m) | AGVs merged | inter-agent edges | wrong |")
        lines.append("|---|---|---|---|---|---|---|---|---|---|---|")
        plot = collections.defaultdict(dict)
        for a in (1, 2, 3, 4):
            for m in (0, 2, 4):
                cond = f"hall_a{a}_m{m}"
                if cond not in by:
                    continue
                ps = [(seed, sl, orc) for seed, sl, orc in pairs(cond) if sl and orc]
                et = ci([sl["etgospa"] for _, sl, _ in ps])
                eto = ci([orc["etgospa"] for _, _, orc in ps])
                ratio = ci([sl["etgospa"] / orc["etgospa"] for _, sl, orc in ps])
                own = ci([mean_or_none([v["own_pose_rmse_fused_frames_m"] for v in agvs_of(sl).values()]) for _, sl, _ in ps])
                fused = ci([mean_or_none([v["fused_pose_rmse_m"] for v in agvs_of(sl).values()]) for _, sl, _ in ps])
                merged = ci([sum(1 for v in agvs_of(sl).values() if v["fused_frames"]) / max(len(agvs_of(sl)), 1) for _, sl, _ in ps])
                edges = ci([(sl.get("inter_agent_edges") or {}).get("accepted", 0) for _, sl, _ in ps])
                wrong = ci([(sl.get("inter_agent_edges") or {}).get("wrong", 0) for _, sl, _ in ps])
                lines.append(f"| {a} | {m} | {len(ps)} | {fmt(et)} | {fmt(eto)} | {fmt(ratio)} | {fmt(own, 3)} | {fmt(fused, 3)} | {fmt(merged)} | {fmt(edges, 1)} | {fmt(wrong, 1)} |")
                plot[m][a] = (et, eto)
        lines.append("")
        # Paired comparisons.
        def paired(cond_a, cond_b, kind="slam"):
            da, db = by.get(cond_a, {}), by.get(cond_b, {})
            diffs = [da[(kind, s)]["etgospa"] - db[(kind, s)]["etgospa"]
                     for (k, s) in da if k == kind and (kind, s) in db]
            return ci(diffs)
        lines.append("Paired differences of the final ET-GOPSA, same seeds (negative: the first is better):\n")
        for m in (0, 2, 4):
            for a in (2, 3, 4):
                if f"hall_a{a}_m{m}" in by and f"hall_a1_m{m}" in by:
                    lines.append(f"- {a} AGVs − 1 AGV, {m} stations: {fmt(paired(f'hall_a{a}_m{m}', f'hall_a1_m{m}'))}")
        for a in (1, 2, 3, 4):
            if f"hall_a{a}_m0" in by and "hall_a1_m0" in by and a > 1:
                lines.append(f"- fused oracle of {a} AGVs − single-AGV oracle: {fmt(paired(f'hall_a{a}_m0', 'hall_a1_m0', 'oracle'))}")
        lines.append("")
        # Each AGV's pose RMSE with fusion minus without, over every merged AGV of every run.
        gains = {(a, m): pose_gains(by[f"hall_a{a}_m{m}"])
                 for a in (2, 3, 4) for m in (0, 2, 4) if f"hall_a{a}_m{m}" in by}
        lines.append("Each merged AGV's pose RMSE with fusion − without (its own SLAM over the same frames), m:\n")
        for (a, m), per in gains.items():
            diffs = [d for agv in per.values() for d in agv]
            worse = sum(1 for d in diffs if d > 0)
            lines.append(f"- {a} AGVs, {m} stations: {fmt(ci(diffs), 3)} ({worse} of {len(diffs)} AGV runs worse with fusion)")
        lines.append("")
        # The same by AGV: which of them fusion helps and which it does not.
        lines.append("The same by AGV (mean ± 95 % CI over the runs it merged in; runs worse with fusion):\n")
        lines.append("| AGVs | stations | agv1 | agv2 | agv3 | agv4 |")
        lines.append("|---|---|---|---|---|---|")
        for (a, m), per in gains.items():
            cells = []
            for name in ("agv1", "agv2", "agv3", "agv4"):
                d = per.get(name, [])
                cells.append(f"{fmt(ci(d), 3)} ({sum(1 for x in d if x > 0)} of {len(d)})" if d else "")
            lines.append(f"| {a} | {m} | " + " | ".join(cells) + " |")
        lines.append("")
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
            fig, ax = plt.subplots(figsize=(7, 4.5))
            for m, series in sorted(plot.items()):
                xs = sorted(series)
                for which, style, label in ((0, "-o", "fused"), (1, "--s", "fused oracle")):
                    ys = [series[a][which][0] for a in xs]
                    es = [series[a][which][1] or 0 for a in xs]
                    ax.errorbar(xs, ys, yerr=es, fmt=style, capsize=3, label=f"{label}, {m} stations")
            ax.set_xlabel("AGVs")
            ax.set_ylabel("final ET-GOPSA (m), mean and 95 % CI")
            ax.set_xticks([1, 2, 3, 4])
            ax.set_title("The hall at the paper's 5G sensing: what each sensing point is worth")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7, ncol=2)
            fig.tight_layout()
            fig.savefig(os.path.join(out, "cooperation.png"), dpi=120)
        except ImportError:
            lines.append("(matplotlib not installed: no cooperation.png)\n")

    known = [c for c in by if c.startswith("known_")]
    if known:
        lines.append("## The hall with every AGV's start known (the easy case)\n")
        lines.append("Paired with the same seed of the hall study above, where only agv1's start is known.\n")
        lines.append("| AGVs | stations | runs | ET-GOPSA fused | ET-GOPSA fused oracle | ratio to oracle | every start known − agv1's only | AGV pose RMSE own (m) | AGV pose RMSE fused (m) | fused − own by AGV: agv1, agv2, agv3, agv4 (runs worse) |")
        lines.append("|---|---|---|---|---|---|---|---|---|---|")
        for a in (2, 3, 4):
            for m in (0, 2, 4):
                cond = f"known_a{a}_m{m}"
                if cond not in by:
                    continue
                ps = [(seed, sl, orc) for seed, sl, orc in pairs(cond) if sl and orc]
                unknown = by.get(f"hall_a{a}_m{m}", {})
                diff = ci([sl["etgospa"] - unknown[("slam", seed)]["etgospa"]
                           for seed, sl, _ in ps if ("slam", seed) in unknown])
                own = ci([mean_or_none([v["own_pose_rmse_fused_frames_m"] for v in agvs_of(sl).values()]) for _, sl, _ in ps])
                fused = ci([mean_or_none([v["fused_pose_rmse_m"] for v in agvs_of(sl).values()]) for _, sl, _ in ps])
                per = pose_gains(by[cond])
                by_agv = ", ".join(
                    f"{fmt(ci(per[n]), 3)} ({sum(1 for x in per[n] if x > 0)} of {len(per[n])})"
                    for n in sorted(per))
                lines.append(f"| {a} | {m} | {len(ps)} | {fmt(ci([sl['etgospa'] for _, sl, _ in ps]))} | "
                             f"{fmt(ci([o['etgospa'] for _, _, o in ps]))} | "
                             f"{fmt(ci([sl['etgospa'] / o['etgospa'] for _, sl, o in ps]))} | {fmt(diff)} | "
                             f"{fmt(own, 3)} | {fmt(fused, 3)} | {by_agv} |")
        lines.append("")

    for prefix, title in (("random_", "Random scenes with 2 AGVs (fused against the fused oracle)"),
                          ("knownrandom_", "Random scenes with 2 AGVs, both starts known")):
        random_table(lines, by, pairs, prefix, title)

    for study, title in (("separate", "Two AGVs that never see the same targets (config/two-rooms.toml, both starts known)"),
                         ("repeated", "Repeated structure (config/repeated-structure.toml, agv2's start unknown)")):
        if study not in by:
            continue
        ps = [(sl, orc) for _, sl, orc in pairs(study) if sl and orc]
        acc = sum((sl.get("inter_agent_edges") or {}).get("accepted", 0) for sl, _ in ps)
        wr = sum((sl.get("inter_agent_edges") or {}).get("wrong", 0) for sl, _ in ps)
        merged = sum(1 for sl, _ in ps if (agvs_of(sl).get("agv2") or {}).get("fused_frames"))
        lines.append(f"## {title}\n")
        lines.append(f"- runs: {len(ps)}; inter-agent edges accepted: {acc}, of which wrong (> 0.5 m or 2°): {wr}")
        lines.append(f"- agv2 merged in {merged} of {len(ps)} runs")
        lines.append(f"- ET-GOPSA fused {fmt(ci([sl['etgospa'] for sl, _ in ps]))}, fused oracle {fmt(ci([o['etgospa'] for _, o in ps]))}")
        pairs_wrong = collections.Counter()
        for sl, _ in ps:
            for pair, e in ((sl.get("inter_agent_edges") or {}).get("by_pair") or {}).items():
                pairs_wrong[pair] += e["wrong"]
        if any(pairs_wrong.values()):
            lines.append(f"- wrong edges by pair: {dict(pairs_wrong)}")
        lines.append("")

    text = "\n".join(lines) + "\n"
    with open(os.path.join(out, "tables.md"), "w") as f:
        f.write(text)
    print(text)


if __name__ == "__main__":
    main()
