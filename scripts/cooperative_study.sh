#!/bin/bash
# What cooperation buys, and what fusion costs against its oracle (docs/cooperative.md): every
# run of launch/cooperative.toml (the agents' own SLAM, fused) beside the same seed of
# launch/cooperative-true-poses.toml (every AGV at its true pose: the fused oracle, same
# detections), at paper-5g.toml's sensing. Then the tables and plots (scripts/cooperative_table.py).
#
#   scripts/cooperative_study.sh OUT [SEEDS] [SCENES]
#
# Studies (STUDIES, default "hall known random separate repeated"):
#   hall      the paper's hall with 4 AGVs and 4 stations on the walls (config/hall-cooperative.toml):
#             agvs 1-4 × stations 0, 2, 4, SEEDS seeds each (default 20);
#   known     the hall again with every AGV's start known (known_starts = agvs): agvs 2-4 ×
#             stations 0, 2, SEEDS seeds each; and the random scenes below with both starts
#             known. What the unknown starts cost: with one known start the map frame is that
#             AGV's, its heading drift and all;
#   random    SCENES random scenes (default 10; `nrslam scene --random --seed K --agvs 2
#             --stations 2`: two AGVs on one loop half a lap apart) with 2 AGVs, stations 0 and 2,
#             2 seeds each;
#   separate  config/two-rooms.toml: two AGVs that never see the same targets, both starts known;
#   repeated  config/repeated-structure.toml: two identical groups of targets, agv2's start unknown.
# SENSING: arguments given to every run, SLAM and oracle alike (default none: paper-5g.toml's
# sensing), e.g. SENSING="refinement:=interpolation" for the estimator's interpolated peaks.
# JOBS runs in parallel (default nproc). Runs already in OUT are not run again (resumable).
# Needs the release binary (cargo build --release) or NRSLAM pointing at one.
set -euo pipefail
out=${1:?usage: scripts/cooperative_study.sh OUT [SEEDS] [SCENES]}
seeds=${2:-20}
scenes=${3:-10}
bin=${NRSLAM:-target/release/nrslam}
jobs=${JOBS:-$(nproc)}
studies=${STUDIES:-hall known random separate repeated}
sensing=${SENSING:-}
mkdir -p "$out/runs" "$out/scenes"
# The tables say what sensing the runs had.
printf '%s\n' "$sensing" > "$out/sensing.txt"
plan="$out/plan.txt"
: > "$plan"
line() { printf '%s\n' "$(echo "$*" | sed 's/[[:space:]]*$//')" >> "$plan"; }
both() { # NAME SEED ARGS...: the SLAM run and its oracle
  local name=$1 seed=$2; shift 2
  line "${name}_slam_$seed $seed launch/cooperative.toml $* $sensing"
  # The oracle knows every start (known_starts is its own, not an argument).
  line "${name}_oracle_$seed $seed launch/cooperative-true-poses.toml $(echo "$*" | sed 's/known_starts:=[0-9]*//') $sensing"
}
random_scenes() { # PREFIX ARGS: SCENES random scenes, 2 AGVs, stations 0 and 2, 2 seeds each
  local prefix=$1 args=$2 k m s
  for k in $(seq 1 "$scenes"); do
    "$bin" scene --random --seed "$k" --agvs 2 --stations 2 --out "$out/scenes/s$k.toml" >/dev/null
    for m in 0 2; do for s in 1 2; do
      both "${prefix}_s${k}_m${m}" "$s" "agvs:=2 stations:=$m $args scene:=$out/scenes/s$k.toml"
    done; done
  done
}
for study in $studies; do
  case $study in
    hall)
      for a in 1 2 3 4; do for m in 0 2 4; do for s in $(seq 1 "$seeds"); do
        both "hall_a${a}_m${m}" "$s" "agvs:=$a stations:=$m"
      done; done; done ;;
    known)
      for a in 2 3 4; do for m in 0 2; do for s in $(seq 1 "$seeds"); do
        both "known_a${a}_m${m}" "$s" "agvs:=$a stations:=$m known_starts:=$a"
      done; done; done
      random_scenes knownrandom "known_starts:=2" ;;
    random)
      random_scenes random "" ;;
    separate)
      for s in $(seq 1 "$seeds"); do
        both separate "$s" "agvs:=2 known_starts:=2 scene:=config/two-rooms.toml"
      done ;;
    repeated)
      for s in $(seq 1 "$seeds"); do
        both repeated "$s" "agvs:=2 scene:=config/repeated-structure.toml"
      done ;;
    *) echo "unknown study $study" >&2; exit 2 ;;
  esac
done

run_one() { # NAME SEED LAUNCH ARGS...
  local name=$1 seed=$2 launch=$3; shift 3
  [ -f "$out/runs/$name.json" ] && return 0
  local dir="$out/work/$name"
  if "$bin" launch "$launch" "$@" --seed "$seed" --out "$dir" > "$out/work/$name.log" 2>&1; then
    cp "$dir/summary.json" "$out/runs/$name.json"
    # Each agent's poses frame by frame, for scripts/agent_pose_errors.py.
    [ -f "$dir/agents.csv" ] && cp "$dir/agents.csv" "$out/runs/$name.agents.csv"
    rm -rf "$dir"
  else
    echo "FAILED $name (log: $out/work/$name.log)" >&2
  fi
}
export -f run_one
export out bin
mkdir -p "$out/work"
total=$(wc -l < "$plan")
echo "$total runs, $jobs at a time" >&2
xargs -P "$jobs" -L 1 bash -c 'run_one "$@"' _ < "$plan"
python3 scripts/cooperative_table.py "$out"
