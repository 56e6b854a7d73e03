#!/bin/bash
# CPU of a 4-AGV, 2-station hall run in-process against four single-AGV runs (paper-5g.toml), one
# after the other on the same machine, SEEDS seeds (default 5): user + system seconds of each
# process, and the ratio of the sums (docs/cooperative.md, "Cost"). A process's CPU time varies
# by ±15 % between identical runs on a shared machine; REPEATS (default 3) runs each process
# that many times, interleaved, and keeps the least.
#   scripts/cooperative_cost.sh OUT [SEEDS]
set -euo pipefail
out=${1:?usage: scripts/cooperative_cost.sh OUT [SEEDS]}
seeds=${2:-5}
repeats=${REPEATS:-3}
bin=${NRSLAM:-target/release/nrslam}
mkdir -p "$out"
cpu() { # ARGS... -> user+sys seconds
  /usr/bin/time -f "%U %S" -o "$out/time.txt" "$bin" "$@" > /dev/null 2>&1
  awk '{ print $1 + $2 }' "$out/time.txt"
}
least() { awk -v a="$1" -v b="$2" 'BEGIN { print (a == "" || b < a) ? b : a }'; }
printf 'seed,cooperative_cpu_s,four_single_cpu_s,ratio\n' > "$out/cost.csv"
for s in $(seq 1 "$seeds"); do
  coop=""
  declare -A single=()
  for _ in $(seq 1 "$repeats"); do
    coop=$(least "$coop" "$(cpu launch launch/cooperative.toml agvs:=4 stations:=2 --seed "$s" --out "$out/coop")")
    for k in 1 2 3 4; do
      single[$k]=$(least "${single[$k]:-}" "$(cpu launch launch/paper-5g.toml --seed $((4 * s + k)) --out "$out/single")")
    done
  done
  singles=$(awk -v a="${single[1]}" -v b="${single[2]}" -v c="${single[3]}" -v d="${single[4]}" 'BEGIN { print a + b + c + d }')
  unset single
  awk -v s="$s" -v c="$coop" -v q="$singles" 'BEGIN { printf "%d,%.2f,%.2f,%.2f\n", s, c, q, c / q }' >> "$out/cost.csv"
done
awk -F, 'NR > 1 { c += $2; q += $3; n++ } END { printf "cooperative 4 AGVs + 2 stations: %.2f s CPU per run; four single-AGV runs: %.2f s; ratio %.2f (%d seeds, least of '"$repeats"' runs each)\n", c / n, q / n, c / q, n }' "$out/cost.csv"
