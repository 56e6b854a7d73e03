#!/bin/bash
# The loop-closure acceptance study of docs/slam-log.md: every condition of the paper (four ideal,
# 5G spectral) with loop_closure false and true, seeds 1..N (default 20), one summary.json per run
# in OUT/<condition>_<false|true>_<seed>.json; then the table.
#   scripts/loop_closure_study.sh OUT [N]        (release binary: cargo build --release first)
# NRSLAM, LAUNCH_IDEAL and LAUNCH_5G override the binary and the launch files (to study a variant).
set -euo pipefail
out=${1:?usage: scripts/loop_closure_study.sh OUT [SEEDS]}
seeds=${2:-20}
bin=${NRSLAM:-target/release/nrslam}
ideal=${LAUNCH_IDEAL:-launch/paper-ideal.toml}   # launch files to study (a variant's copies)
fiveg=${LAUNCH_5G:-launch/paper-5g.toml}
mkdir -p "$out"
run() { # condition lc seed launch args...
  local name=$1 lc=$2 seed=$3; shift 3
  "$bin" launch "$@" loop_closure:="$lc" --seed "$seed" --out "$out/run" >/dev/null
  cp "$out/run/summary.json" "$out/${name}_${lc}_${seed}.json"
}
for seed in $(seq 1 "$seeds"); do
  for lc in false true; do
    run r0a1 "$lc" "$seed" "$ideal" range_std_m:=0 angle_std_deg:=1
    run r01a1 "$lc" "$seed" "$ideal" range_std_m:=0.1 angle_std_deg:=1
    run r0a5 "$lc" "$seed" "$ideal" range_std_m:=0 angle_std_deg:=5
    run r01a5 "$lc" "$seed" "$ideal" range_std_m:=0.1 angle_std_deg:=5
    run 5g "$lc" "$seed" "$fiveg"
  done
done
rm -rf "$out/run"
python3 "$(dirname "$0")/loop_closure_table.py" "$out"
