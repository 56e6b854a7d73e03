#!/usr/bin/env bash
# Multi-session merging study (issue 43, acceptance 4; docs/bags.md, "Merging two sessions"):
# for each seed pair, two single-AGV sessions of the hall are recorded and replayed together
# through launch/multi-session.toml, and the fused map is scored against each session alone.
#
# Usage: scripts/multi_session.sh OUT [SEEDS]
#   OUT    a new folder for the bags, runs and the table (OUT/table.md)
#   SEEDS  seed pairs (default 10): pair s records session 1 with --seed s and session 2 with
#          --seed s+100, for s = 1 .. SEEDS
# Environment:
#   NRSLAM    the binary (default target/release/nrslam; cargo build --release --bin nrslam)
#   FIDELITY  the front end (default spectral: paper-5g.toml's 5G sensing)
#   FRAMES    frames per session (default 0: the whole lap, 294 frames)
#   SENSING   more arguments of paper-5g.toml and true-poses.toml for every recording, e.g.
#             SENSING="refinement:=interpolation" (default none)
#
# Session 1: launch/paper-5g.toml on config/hall.toml (the hall's loop from (27, 6)), its
# odometry in the map frame. Session 2: the same launch on config/hall-cooperative.toml with
# radar.sensor:=agv2 (the same loop, half a lap ahead: from (27, 38)) and radar.odom_origin:=start
# (its frame unknown). "Alone" for session 2 is the same session with odom_origin:=map (the same
# odometry noise and measurements, the start given), i.e. its map in the true frame.
# Each row: the final map's ET-GOPSA (summary.json's shapes.etgospa_box_corners: the last
# segments scored by the report, as the evaluator scores them) of
#   s1, s2            each session's own run;
#   s1 fus, s2 fus    each session replayed alone through multi-session.toml (sessions:=1: the
#                     fusion node's graph, the mapper at its republish thresholds);
#   fused             both sessions replayed with their recorded stamps (side by side), and the
#                     number of session 2's frames with a fused pose (0: never merged);
#   later             the same with session 2 shifted to start 10 s after session 1 ends
#                     (second_offset_s), as a session recorded on a later day;
#   known             both sessions fused side by side with both starts given (session 2's
#                     recording in the map frame, fusion.known_starts:=2, matching on): what the
#                     unknown start of session 2 costs, the map frame being session 1's alone;
#   o1, o2, o fused   the oracle: both sessions recorded again at their true poses
#                     (launch/true-poses.toml: the same detections, no SLAM error), each alone and
#                     both fused with both starts known and no matching (what fusion could reach);
# then means with 95 % confidence intervals and the paired differences fused - best single.
set -uo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: scripts/multi_session.sh OUT [SEEDS]}
seeds=${2:-10}
nrslam=${NRSLAM:-target/release/nrslam}
fidelity=${FIDELITY:-spectral}
frames=${FRAMES:-0}
read -r -a sensing <<< "${SENSING:-}"
if [ -e "$out" ]; then echo "$out exists: give a new folder" >&2; exit 2; fi
if ! [[ $seeds =~ ^[1-9][0-9]*$ ]]; then echo "SEEDS must be a positive integer, got $seeds" >&2; exit 2; fi
[ -x "$nrslam" ] || { echo "$nrslam: no such binary (cargo build --release --bin nrslam, or NRSLAM=...)" >&2; exit 2; }
mkdir -p "$out"
topics=(/ground_truth/targets /clock /ground_truth/pose /slam/keyframe /slam/keyframe_poses /slam/pose)
common=(launch/paper-5g.toml fidelity:="$fidelity" frames:="$frames" viz:=false "${sensing[@]}")
second=(scene:=config/hall-cooperative.toml radar.sensor:=agv2)
run() {
    local log=$1; shift
    if ! "$nrslam" "$@" > "$log" 2>&1; then
        echo "FAILED: nrslam $* (see $log)" >&2
        exit 1
    fi
}
for s in $(seq 1 "$seeds"); do
    d=$out/pair-$s
    mkdir -p "$d"
    run "$d/s1.log" launch "${common[@]}" --seed "$s" --record "$d/bag1" --record-topics "${topics[@]}" --out "$d/s1"
    run "$d/s2.log" launch "${common[@]}" "${second[@]}" radar.odom_origin:=start --seed $((s + 100)) \
        --record "$d/bag2" --record-topics "${topics[@]}" --out "$d/s2-own-frame"
    run "$d/s2map.log" launch "${common[@]}" "${second[@]}" radar.odom_origin:=map --seed $((s + 100)) \
        --record "$d/bag2map" --record-topics "${topics[@]}" --out "$d/s2"
    run "$d/s1fus.log" launch launch/multi-session.toml sessions:=1 first:="$d/bag1" --out "$d/s1-fusion"
    run "$d/s2fus.log" launch launch/multi-session.toml sessions:=1 first:="$d/bag2map" --out "$d/s2-fusion"
    run "$d/fused.log" launch launch/multi-session.toml first:="$d/bag1" second:="$d/bag2" --out "$d/fused"
    run "$d/known.log" launch launch/multi-session.toml first:="$d/bag1" second:="$d/bag2map" \
        fusion.known_starts:=2 --out "$d/known"
    run "$d/o1.log" launch launch/true-poses.toml fidelity:="$fidelity" frames:="$frames" viz:=false \
        "${sensing[@]}" --seed "$s" --record "$d/obag1" --record-topics "${topics[@]}" --out "$d/o1"
    run "$d/o2.log" launch launch/true-poses.toml fidelity:="$fidelity" frames:="$frames" viz:=false \
        "${sensing[@]}" "${second[@]}" radar.odom_origin:=map --seed $((s + 100)) \
        --record "$d/obag2" --record-topics "${topics[@]}" --out "$d/o2"
    run "$d/ofused.log" launch launch/multi-session.toml first:="$d/obag1" second:="$d/obag2" \
        fusion.known_starts:=2 fusion.matching:=false --out "$d/ofused"
    offset=$(python3 - "$nrslam" "$d/bag1" "$d/bag2" <<'EOF'
import json, subprocess, sys
info = lambda bag: json.loads(subprocess.run([sys.argv[1], "bag", "info", bag, "--json"],
                                             check=True, capture_output=True).stdout)
print((info(sys.argv[2])["end_ns"] - info(sys.argv[3])["start_ns"]) / 1e9 + 10.0)
EOF
) || { echo "FAILED: bag info of $d/bag1 or $d/bag2" >&2; exit 1; }
    run "$d/later.log" launch launch/multi-session.toml first:="$d/bag1" second:="$d/bag2" \
        second_offset_s:="$offset" --out "$d/later"
    echo "pair $s done" >&2
done
python3 - "$out" "$seeds" "$fidelity" "$frames" "${SENSING:-}" <<'EOF' | tee "$out/table.md"
import json, math, statistics, sys
out, seeds, fidelity, frames, sensing = sys.argv[1], int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5]
# Two-sided 95 % Student t quantiles by degrees of freedom (1.96 beyond 30).
T = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
     2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
     2.052, 2.048, 2.045, 2.042]
def ci(xs):
    m = statistics.fmean(xs)
    if len(xs) < 2:
        return f"{m:.2f}"
    t = T[len(xs) - 2] if len(xs) - 1 <= len(T) else 1.96
    return f"{m:.2f} ± {t * statistics.stdev(xs) / math.sqrt(len(xs)):.2f}"
def load(pair, run):
    return json.load(open(f"{out}/pair-{pair}/{run}/summary.json"))
def final_map(s):
    return s["shapes"]["etgospa_box_corners"]
rows = []
for p in range(1, seeds + 1):
    r = {k: load(p, k)
         for k in ["s1", "s2", "s1-fusion", "s2-fusion", "fused", "later", "known", "o1", "o2",
                   "ofused"]}
    rows.append({k: final_map(v) for k, v in r.items()} | {
        "fused_frames": r["fused"]["agents"]["agv2"]["fused_frames"],
        "later_frames": r["later"]["agents"]["agv2"]["fused_frames"],
        "frames2": r["fused"]["agents"]["agv2"]["frames"],
    })
print(f"Final-map ET-GOPSA, paper-5g fidelity:={fidelity} frames:={frames}{' ' + sensing if sensing else ''}, {seeds} seed pairs "
      "(session 1 --seed s from (27, 6), session 2 --seed s+100 from (27, 38), frame unknown)\n")
print("| pair | s1 | s2 | s1 fus | s2 fus | fused | merged | later | merged | known |")
print("|---|---|---|---|---|---|---|---|---|---|")
for p, r in enumerate(rows, 1):
    print(f"| {p}, {p + 100} | {r['s1']:.2f} | {r['s2']:.2f} | {r['s1-fusion']:.2f} | "
          f"{r['s2-fusion']:.2f} | {r['fused']:.2f} | {r['fused_frames']}/{r['frames2']} | "
          f"{r['later']:.2f} | {r['later_frames']}/{r['frames2']} | {r['known']:.2f} |")
col = lambda k: [r[k] for r in rows]
best = [min(r["s1"], r["s2"]) for r in rows]
best_fus = [min(r["s1-fusion"], r["s2-fusion"]) for r in rows]
print()
print("| mean ± 95 % CI | value |")
print("|---|---|")
for k, name in [("s1", "session 1 alone"), ("s2", "session 2 alone"),
                ("s1-fusion", "session 1 alone through fusion"),
                ("s2-fusion", "session 2 alone through fusion"),
                ("fused", "fused, side by side"), ("later", "fused, session 2 later"),
                ("known", "fused, both starts known"),
                ("o1", "oracle: session 1 alone"), ("o2", "oracle: session 2 alone"),
                ("ofused", "oracle: both fused")]:
    print(f"| {name} | {ci(col(k))} |")
print(f"| best single | {ci(best)} |")
obest = [min(r["o1"], r["o2"]) for r in rows]
od = [r["ofused"] - b for r, b in zip(rows, obest)]
print(f"| oracle: fused − best single (paired) | {ci(od)} |")
print(f"| oracle: pairs fused ≤ best single | {sum(1 for x in od if x <= 0)}/{seeds} |")
for k, name in [("fused", "side by side"), ("later", "session 2 later"),
                ("known", "both starts known")]:
    d = [f - b for f, b in zip(col(k), best)]
    dfus = [f - b for f, b in zip(col(k), best_fus)]
    d1 = [f - a for f, a in zip(col(k), col("s1"))]
    frames_key = {"fused": "fused_frames", "later": "later_frames"}.get(k)
    merged = sum(1 for r in rows if r[frames_key] > 0) if frames_key else seeds
    wins = sum(1 for x in d if x <= 0)
    print(f"| {name}: fused − best single (paired) | {ci(d)} |")
    print(f"| {name}: fused − best single through fusion (paired) | {ci(dfus)} |")
    print(f"| {name}: fused − session 1 (paired) | {ci(d1)} |")
    print(f"| {name}: pairs merged, pairs fused ≤ best single | {merged}/{seeds}, {wins}/{seeds} |")
EOF
