#!/bin/bash
# The back end against the pose oracle, on the paper's hall and on random scenes: every
# condition runs twice on the same seeds, once through SLAM (launch/paper-ideal.toml,
# launch/paper-5g.toml, loop closure on) and once mapped at the true poses
# (launch/true-poses.toml, same detections), so the ratio of their final ET-GOPSA is what the
# back end costs. Then the table (scripts/slam_study_table.py). docs/slam.md is written around it.
#
#   scripts/slam_study.sh OUT [HALL_SEEDS] [SCENES] [SCENE_SEEDS] [LAPS]
#
# Defaults: 40 hall seeds, 20 random scenes (`nrslam scene --random --seed K`) × 2 seeds, 2 laps.
# Conditions: CONDITIONS (default "a1 r01a1 a5 5g 5gi": ΔR 0/Δθ 1°, ΔR 0.1 m/Δθ 1°, ΔR 0/Δθ 5°,
# 5G spectral without refinement, 5G with interpolation; also 5gm, 5ge and 5gn: 5G with MUSIC,
# ESPRIT or NOMP, docs/superresolution.md). JOBS runs in parallel (default: nproc).
# FIRST_HALL_SEED and FIRST_SCENE (default 1) shift the hall seeds and the random scenes, for
# held-out checks on seeds and scenes no setting was chosen on (e.g. FIRST_HALL_SEED=41
# FIRST_SCENE=21: hall seeds 41–80, scenes 21–40). Run names keep the true seed and scene.
# SLAM_ARGS adds launch arguments to the SLAM runs only, e.g. a knob to study
# (SLAM_ARGS="association.loop_closure.oracle_max_error_m:=0.5": loops verified against the
# truth, docs/slam.md); the oracle runs do not change, so copying an earlier study's
# runs/*_oracle_*.json into OUT/runs first skips them (runs already in OUT are not run again).
# Needs the release binary (cargo build --release) or NRSLAM pointing at one.
set -euo pipefail
out=${1:?usage: scripts/slam_study.sh OUT [HALL_SEEDS] [SCENES] [SCENE_SEEDS] [LAPS]}
hall_seeds=${2:-40}
scenes=${3:-20}
scene_seeds=${4:-2}
laps=${5:-2}
bin=${NRSLAM:-target/release/nrslam}
jobs=${JOBS:-$(nproc)}
conditions=${CONDITIONS:-a1 r01a1 a5 5g 5gi}
first_hall_seed=${FIRST_HALL_SEED:-1}
first_scene=${FIRST_SCENE:-1}
slam_extra=${SLAM_ARGS:-}
hall_range=$(seq "$first_hall_seed" $((first_hall_seed + hall_seeds - 1)))
scene_range=$(seq "$first_scene" $((first_scene + scenes - 1)))
mkdir -p "$out/runs" "$out/scenes"
# Runs already in OUT are not run again, so OUT must hold one setting: SLAM_ARGS is recorded there
# and a different one refused.
if [ -f "$out/slam_args.txt" ] && [ "$(cat "$out/slam_args.txt")" != "$slam_extra" ]; then
  echo "$out holds runs made with SLAM_ARGS=\"$(cat "$out/slam_args.txt")\"; use another OUT" >&2
  exit 2
fi
printf '%s\n' "$slam_extra" > "$out/slam_args.txt"

args_of() { # condition -> "SLAM_LAUNCH ORACLE_ARGS ... | launch arguments"
  case $1 in
    a1) echo "launch/paper-ideal.toml|range_std_m:=0 angle_std_deg:=1|fidelity:=ideal range_std_m:=0 angle_std_deg:=1" ;;
    r01a1) echo "launch/paper-ideal.toml|range_std_m:=0.1 angle_std_deg:=1|fidelity:=ideal range_std_m:=0.1 angle_std_deg:=1" ;;
    a5) echo "launch/paper-ideal.toml|range_std_m:=0 angle_std_deg:=5|fidelity:=ideal range_std_m:=0 angle_std_deg:=5" ;;
    r01a5) echo "launch/paper-ideal.toml|range_std_m:=0.1 angle_std_deg:=5|fidelity:=ideal range_std_m:=0.1 angle_std_deg:=5" ;;
    5g) echo "launch/paper-5g.toml||fidelity:=spectral" ;;
    5gi) echo "launch/paper-5g.toml|refinement:=interpolation|fidelity:=spectral refinement:=interpolation" ;;
    5gm) echo "launch/paper-5g.toml|refinement:=music angle_window_cells:=16|fidelity:=spectral refinement:=music angle_window_cells:=16" ;;
    5ge) echo "launch/paper-5g.toml|refinement:=esprit angle_window_cells:=16|fidelity:=spectral refinement:=esprit angle_window_cells:=16" ;;
    5gn) echo "launch/paper-5g.toml|refinement:=nomp angle_window_cells:=16|fidelity:=spectral refinement:=nomp angle_window_cells:=16" ;;
    *) echo "unknown condition $1" >&2; exit 2 ;;
  esac
}

# One line per run: NAME SCENE_ARG SEED LAUNCH ARGS...
plan="$out/plan.txt"
: > "$plan"
# xargs -L continues a line that ends in a blank, so no line may.
line() { printf '%s\n' "$(echo "$1" | sed 's/[[:space:]]*$//')" >> "$plan"; }
for k in $scene_range; do
  "$bin" scene --random --seed "$k" --laps "$laps" --out "$out/scenes/s$k.toml" >/dev/null
done
for c in $conditions; do
  IFS='|' read -r slam_launch slam_args oracle_args <<< "$(args_of "$c")"
  for s in $hall_range; do
    line "${c}_slam_hall_$s - $s $slam_launch $slam_args $slam_extra"
    line "${c}_oracle_hall_$s - $s launch/true-poses.toml $oracle_args"
  done
  for k in $scene_range; do
    for s in $(seq 1 "$scene_seeds"); do
      line "${c}_slam_s${k}_$s scene:=$out/scenes/s$k.toml $s $slam_launch $slam_args $slam_extra"
      line "${c}_oracle_s${k}_$s scene:=$out/scenes/s$k.toml $s launch/true-poses.toml $oracle_args"
    done
  done
done

run_one() { # NAME SCENE_ARG SEED LAUNCH ARGS...
  local name=$1 scene=$2 seed=$3 launch=$4; shift 4
  [ -f "$out/runs/$name.json" ] && return 0   # resumable
  local extra=()
  [ "$scene" != "-" ] && extra+=("$scene")
  local dir
  dir=$(mktemp -d)
  if "$bin" launch "$launch" "$@" "${extra[@]}" --seed "$seed" --out "$dir" >/dev/null 2>"$dir/stderr"; then
    cp "$dir/summary.json" "$out/runs/$name.json"
    printf '\r%s of %s runs done' "$(find "$out/runs" -name '*.json' | wc -l)" "$total" >&2
  else
    printf '\nrun %s failed: %s\n' "$name" "$(tail -1 "$dir/stderr")" >&2
  fi
  rm -rf "$dir"
}
export -f run_one
total=$(wc -l < "$plan")
export bin out total
echo "$total runs, $jobs at a time" >&2
# shellcheck disable=SC2016
xargs -P "$jobs" -L 1 bash -c 'run_one "$@"' _ < "$plan"
echo >&2
python3 "$(dirname "$0")/slam_study_table.py" "$out/runs"
