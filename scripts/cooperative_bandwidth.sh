#!/bin/bash
# Bytes per second each AGV sends the fusion node (its /agvN/slam/keyframe, keyframe_poses and
# pose), and what the fused map loses when it sends less: every AGV's keyframes spaced
# KEYFRAME_DISTANCES apart (association.keyframe_distance_m; default 1 2 4 m), SEEDS seeds each
# (default 5) of `launch/cooperative.toml agvs:=2` on the hall, recorded and measured in the bag
# (the CDR bytes of each message; docs/cooperative.md, "Bandwidth"). Needs the release binary and
# `pip install mcap`.
#   scripts/cooperative_bandwidth.sh OUT [SEEDS]
set -euo pipefail
out=${1:?usage: scripts/cooperative_bandwidth.sh OUT [SEEDS]}
seeds=${2:-5}
bin=${NRSLAM:-target/release/nrslam}
distances=${KEYFRAME_DISTANCES:-1 2 4}
mkdir -p "$out"
for d in $distances; do
  for s in $(seq 1 "$seeds"); do
    run="$out/d${d}_s$s"
    [ -f "$run/summary.json" ] && continue
    rm -rf "$run" "$run.bag"
    "$bin" launch launch/cooperative.toml agvs:=2 --seed "$s" \
      agv1/association.keyframe_distance_m:="$d" agv2/association.keyframe_distance_m:="$d" \
      --record "$run.bag" --out "$run" > "$run.log" 2>&1
  done
done
python3 - "$out" $distances <<'PY'
import glob, json, math, sys, collections
from mcap.reader import make_reader
out, distances = sys.argv[1], sys.argv[2:]
sent = ("/slam/keyframe", "/slam/keyframe_poses", "/slam/pose")
print("| keyframe spacing (m) | runs | bytes/s per AGV: keyframes | keyframe poses | poses | total | ET-GOPSA fused | AGV pose RMSE fused (m) |")
print("|---|---|---|---|---|---|---|---|")
for d in distances:
    rows = []
    for run in sorted(glob.glob(f"{out}/d{d}_s*/summary.json")):
        s = json.load(open(run))
        bag = glob.glob(run.replace("/summary.json", ".bag") + "/*.mcap")[0]
        total = collections.Counter()
        first = last = None
        with open(bag, "rb") as f:
            for _, channel, message in make_reader(f).iter_messages():
                t = message.log_time
                first = t if first is None else min(first, t)
                last = t if last is None else max(last, t)
                for agv in ("agv1", "agv2"):
                    for topic in sent:
                        if channel.topic == f"/{agv}{topic}":
                            total[topic] += len(message.data)
        seconds = (last - first) * 1e-9
        per_agv = {t: total[t] / 2 / seconds for t in sent}
        fused = [v["fused_pose_rmse_m"] for k, v in s["agents"].items() if k.startswith("agv") and v["fused_pose_rmse_m"] is not None]
        rows.append((per_agv, s["etgospa"], sum(fused) / len(fused) if fused else float("nan")))
    n = len(rows)
    mean = lambda xs: sum(xs) / len(xs)
    def ci(xs):
        m = mean(xs)
        sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1)) if len(xs) > 1 else 0
        t = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262][min(len(xs) - 2, 8)] if len(xs) > 1 else 0
        return f"{m:.2f} ± {t * sd / math.sqrt(len(xs)):.2f}"
    b = {t: mean([r[0][t] for r in rows]) for t in sent}
    print(f"| {d} | {n} | {b[sent[0]]:.0f} | {b[sent[1]]:.0f} | {b[sent[2]]:.0f} | {sum(b.values()):.0f} | {ci([r[1] for r in rows])} | {ci([r[2] for r in rows])} |")
PY
