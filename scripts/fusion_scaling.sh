#!/bin/bash
# The fusion node's CPU and the searches it makes against the number of AGVs (1, 2, 4, 8): the
# criterion bench `nodes/fusion/benches/fusion.rs` (one lap of a synthetic box scene, every AGV but
# the first with an unknown start), its time per keyframe and its search counts, as a table and
# OUT/fusion_scaling.png (docs/cooperative.md, "Cost"). Needs matplotlib.
#   scripts/fusion_scaling.sh OUT
set -euo pipefail
out=${1:?usage: scripts/fusion_scaling.sh OUT}
mkdir -p "$out"
cargo bench -p nrslam-fusion --bench fusion 2> "$out/bench.log" > "$out/bench.txt"
python3 - "$out" <<'PY'
import json, os, re, sys
out = sys.argv[1]
stats = {}
for line in open(os.path.join(out, "bench.log")):
    m = re.match(r"agents (\d+): keyframes (\d+) FusionStats \{ (.*) \}", line.strip())
    if m:
        fields = dict(kv.split(": ") for kv in m.group(3).split(", "))
        stats[int(m.group(1))] = (int(m.group(2)), {k: int(v) for k, v in fields.items()})
rows = []
for agents, (keyframes, s) in sorted(stats.items()):
    est = json.load(open(f"target/criterion/fusion_lap/{agents}/new/estimates.json"))
    lap_s = est["mean"]["point_estimate"] * 1e-9
    rows.append((agents, keyframes, lap_s, lap_s / keyframes * 1e3, s))
print("| AGVs | keyframes | CPU per lap (s) | per keyframe (ms) | whole-map searches | re-check searches | local searches | query points scored | merges | merges moved |")
print("|---|---|---|---|---|---|---|---|---|---|")
for a, k, lap, per, s in rows:
    print(f"| {a} | {k} | {lap:.3f} | {per:.2f} | {s['global_searches']} | {s['verify_searches']} | {s['local_searches']} | {s['query_points_scored']} | {s['merges']} | {s['remerges']} |")
import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
fig, ax = plt.subplots(figsize=(6, 4))
xs = [r[0] for r in rows]
ax.plot(xs, [r[3] for r in rows], "-o", label="CPU per keyframe (ms)")
ax2 = ax.twinx()
ax2.plot(xs, [r[4]["query_points_scored"] / r[1] for r in rows], "--s", color="tab:orange", label="query points scored per keyframe")
ax.set_xlabel("AGVs")
ax.set_ylabel("ms per keyframe")
ax2.set_ylabel("query points scored per keyframe")
ax.set_xticks(xs)
ax.grid(alpha=0.3)
fig.legend(loc="upper left", fontsize=8)
ax.set_title("Fusion cost against the number of AGVs (one lap each)")
fig.tight_layout()
fig.savefig(os.path.join(out, "fusion_scaling.png"), dpi=120)
PY
