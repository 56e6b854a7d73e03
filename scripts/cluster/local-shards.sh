#!/usr/bin/env bash
# Runs a Monte Carlo study as SHARDS processes on this machine, then merges their folders:
# the same split a Slurm job array or a Kubernetes Indexed Job makes (docs/cluster.md).
#
#   scripts/cluster/local-shards.sh LAUNCH [NAME:=VALUE...] --trials N [montecarlo flags...]
#
# Environment (all optional):
#   SHARDS   number of shard processes (default 4)
#   THREADS  worker threads per shard (default 1; results do not depend on it)
#   OUT      study folder (default out/local-shards): shard-K/ per shard, merged/ at the end
#   NRSLAM   the binary (default target/release/nrslam if built, else nrslam on PATH)
#
# Every argument is passed to `nrslam montecarlo` unchanged, so do not give --shard, --out or
# --threads. Shard logs go to OUT/shard-K.log; the script fails if any shard or the merge fails.
set -euo pipefail

SHARDS=${SHARDS:-4}
THREADS=${THREADS:-1}
OUT=${OUT:-out/local-shards}
if [[ -z ${NRSLAM:-} ]]; then
    if [[ -x target/release/nrslam ]]; then NRSLAM=target/release/nrslam; else NRSLAM=nrslam; fi
fi
if [[ $# -eq 0 ]]; then
    sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
fi
for arg in "$@"; do
    case $arg in
    --shard* | --out* | --threads*) echo "local-shards.sh: $arg is set by the script" >&2; exit 2 ;;
    esac
done
if ! [[ $SHARDS =~ ^[1-9][0-9]*$ ]]; then
    echo "local-shards.sh: SHARDS must be a positive whole number, got '$SHARDS'" >&2
    exit 2
fi

# Milliseconds since the epoch, and a duration in ms printed as seconds.
now_ms() { echo $(($(date +%s%N) / 1000000)); }
secs() { printf '%d.%03d' $(($1 / 1000)) $(($1 % 1000)); }

mkdir -p "$OUT"
start=$(now_ms)
pids=()
for ((k = 1; k <= SHARDS; k++)); do
    # Each shard is timed on its own; its log holds nrslam's output and the time line.
    (
        s=$(now_ms)
        "$NRSLAM" montecarlo "$@" --shard "$k/$SHARDS" --threads "$THREADS" --out "$OUT/shard-$k"
        echo "shard $k/$SHARDS: $(secs $(($(now_ms) - s))) s"
    ) >"$OUT/shard-$k.log" 2>&1 &
    pids+=("$!")
done
failed=0
for ((k = 1; k <= SHARDS; k++)); do
    if ! wait "${pids[k - 1]}"; then
        echo "shard $k/$SHARDS failed; see $OUT/shard-$k.log:" >&2
        tail -n 5 "$OUT/shard-$k.log" >&2
        failed=1
    fi
done
((failed == 0)) || exit 1
shards_done=$(now_ms)
for ((k = 1; k <= SHARDS; k++)); do tail -n 1 "$OUT/shard-$k.log"; done

dirs=()
for ((k = 1; k <= SHARDS; k++)); do dirs+=("$OUT/shard-$k"); done
"$NRSLAM" merge "${dirs[@]}" --out "$OUT/merged"
end=$(now_ms)
echo "all shards: $(secs $((shards_done - start))) s wall; merge: $(secs $((end - shards_done))) s;" \
    "total $(secs $((end - start))) s"
