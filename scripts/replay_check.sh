#!/usr/bin/env bash
# Record then replay a set of launches and compare summary.json byte for byte (docs/bags.md,
# "Deterministic replay"). Usage: scripts/replay_check.sh OUT [NRSLAM]
#   OUT     a new folder for the runs, bags and replays
#   NRSLAM  the binary (default target/release/nrslam; build it with cargo build --release)
# Prints one line per case: IDENTICAL or DIFFER, the run's final ET-GOPSA, loop closures and
# keyframes. Exits 1 if any case differs or fails.
set -uo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: scripts/replay_check.sh OUT [NRSLAM]}
nrslam=${2:-target/release/nrslam}
if [ -e "$out" ]; then echo "$out exists: give a new folder" >&2; exit 2; fi
mkdir -p "$out"
"$nrslam" scene --random --seed 21 --out "$out/random.toml" > /dev/null || exit 1
status=0
check() {
    local name=$1; shift
    local dir=$out/$name
    if ! "$nrslam" launch "$@" --out "$dir/run" --record "$dir/bag" > "$dir.log" 2>&1; then
        echo "$name: RECORD FAILED ($dir.log)"; status=1; return
    fi
    if ! "$nrslam" launch launch/replay.toml bag:="$dir/bag" --out "$dir/replay" > "$dir.replay.log" 2>&1; then
        echo "$name: REPLAY FAILED ($dir.replay.log)"; status=1; return
    fi
    local verdict=IDENTICAL
    cmp -s "$dir/run/summary.json" "$dir/replay/summary.json" || { verdict=DIFFER; status=1; }
    local figures
    figures=$(python3 -c "import json,sys; s=json.load(open(sys.argv[1])); print(s.get('etgospa'), s['loop_closures'], s['keyframes'])" "$dir/run/summary.json")
    echo "$name: $verdict (ET-GOPSA, loop closures, keyframes: $figures)"
}
check paper-ideal launch/paper-ideal.toml
check paper-5g launch/paper-5g.toml
check paper-5g-waveform launch/paper-5g.toml fidelity:=waveform frames:=40
check true-poses launch/true-poses.toml
check standard-input launch/standard-input.toml bag:=tests/fixtures/ros2/bags/v9_plain
check random-scene launch/paper-ideal.toml scene:="$out/random.toml" --seed 5
check paper-5g-processes launch/paper-5g.toml frames:=60 --mode processes
check true-poses-5g launch/true-poses.toml fidelity:=spectral frames:=80 --seed 4
check 5g-interp-overrides launch/paper-5g.toml refinement:=interpolation association.robust_scale_m:=0.7 association.loop_closure.min_inlier_ratio:=0.3 --seed 9
check ideal-noshapes-noviz launch/paper-ideal.toml shapes:=false viz:=false angle_std_deg:=5 --seed 2
check ideal-shape-representatives launch/paper-ideal.toml representatives:=shape range_std_m:=0.1 frames:=150
check true-poses-waveform launch/true-poses.toml fidelity:=waveform frames:=20
check ideal-zstd-split launch/paper-ideal.toml --compression zstd --max-bag-size 200000 --seed 13
check 5g-paced launch/paper-5g.toml frames:=30 --rate 20
exit $status
