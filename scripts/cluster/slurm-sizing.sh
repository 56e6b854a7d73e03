#!/usr/bin/env bash
# A sizing study (`nrslam sizing`) as a Slurm job array: array task K runs the configurations of
# shard K/N (index = K-1 mod N) into the study folder, and a job that depends on the whole array
# runs `nrslam sizing` once more without --shard: it finds every configuration decided, runs
# nothing more and writes the frontier (docs/cluster.md, "Sizing study on Slurm"). Run from the
# repository root on a login node:
#
#   REQUIREMENT=path/to/requirement.toml scripts/cluster/slurm-sizing.sh
#
# or submit the two by hand (the #SBATCH defaults below, logs in the current folder):
#
#   jid=$(REQUIREMENT=req.toml sbatch --parsable --array=1-8 scripts/cluster/slurm-sizing.sh)
#   sbatch --dependency=afterok:$jid --wrap "nrslam sizing req.toml --out out/cluster/sizing"
#
# Settings (environment variables at submission; sbatch passes the environment on by default):
#   REQUIREMENT  the requirement file (required)
#   SHARDS       number of shards N (default 8; in an array task, default: the array's size).
#                To rerun only shard 3 of 8: SHARDS=8 sbatch --array=3 scripts/cluster/slurm-sizing.sh
#   OUT          study folder on a file system every node sees (default out/cluster/sizing): every
#                shard writes its configurations' files there, the final job the frontier;
#                logs/ the jobs' logs (nrslam-sizing-<array job>_<K>.log, nrslam-sizing-final-<job>.log)
#   NRSLAM       how to run nrslam on a compute node (default: nrslam on PATH)
#   CPUS_PER_TASK (default 1; each task runs that many threads), MEM_PER_CPU (1G), TIME_LIMIT
#                (01:00:00) per array task, FINAL_TIME (00:10:00) for the final job, PARTITION:
#                as in slurm-montecarlo.sh, on the sbatch command line and checked against the
#                cluster before anything is submitted (scripts/cluster/slurm-common.sh).
#
#SBATCH --job-name=nrslam-sizing
#SBATCH --array=1-8
#SBATCH --cpus-per-task=1
#SBATCH --mem-per-cpu=1G
#SBATCH --time=01:00:00
#SBATCH --output=nrslam-sizing-%A_%a.log
set -euo pipefail

GIVEN_SHARDS=${SHARDS:-}
SHARDS=${SHARDS:-8}
REQUIREMENT=${REQUIREMENT:-}
OUT=${OUT:-out/cluster/sizing}
NRSLAM=${NRSLAM:-nrslam}

if [[ -z ${SLURM_ARRAY_TASK_ID:-} ]]; then
    # Not an array task: check the request fits, then submit the array and the final run, which
    # starts only once every task has succeeded (afterok).
    # shellcheck source=scripts/cluster/slurm-common.sh
    source "$(dirname "$0")/slurm-common.sh"
    [[ -n $REQUIREMENT ]] || slurm_die "give the requirement file: REQUIREMENT=path/to/requirement.toml $0"
    [[ -f $REQUIREMENT ]] || slurm_die "REQUIREMENT=$REQUIREMENT: no such file"
    [[ $SHARDS =~ ^[1-9][0-9]*$ ]] || slurm_die "SHARDS=$SHARDS is not a positive integer"
    slurm_check_fit
    logs=$(slurm_log_dir)
    export SHARDS REQUIREMENT
    array=$(sbatch --parsable --array="1-$SHARDS" --cpus-per-task="$CPUS_PER_TASK" \
        "${SBATCH_OPTS[@]}" --time="$TIME_LIMIT" \
        --output="$logs/nrslam-sizing-%A_%a.log" "$0")
    array=${array%%;*} # "jobid;cluster" on multi-cluster sites
    # NRSLAM is split into words on purpose (e.g. "apptainer exec nrslam.sif nrslam").
    final=$(sbatch --parsable --job-name=nrslam-sizing-final --dependency="afterok:$array" \
        --cpus-per-task=1 "${SBATCH_OPTS[@]}" --time="$FINAL_TIME" \
        --output="$logs/nrslam-sizing-final-%j.log" \
        --wrap "$NRSLAM sizing $(printf %q "$REQUIREMENT") --out $(printf %q "$OUT")")
    final=${final%%;*}
    echo "submitted array job $array ($SHARDS shards, $CPUS_PER_TASK CPUs each) and final job $final"
    echo "result: $OUT/frontier.csv once job $final has finished; logs in $logs"
    exit 0
fi

# An array task: shard K of N, N = SHARDS if given, else the size of an array submitted as 1-N.
K=$SLURM_ARRAY_TASK_ID
if [[ -n $GIVEN_SHARDS ]]; then
    N=$GIVEN_SHARDS
elif [[ ${SLURM_ARRAY_TASK_MIN:-} == 1 && ${SLURM_ARRAY_TASK_MAX:-} == "${SLURM_ARRAY_TASK_COUNT:-}" ]]; then
    N=$SLURM_ARRAY_TASK_COUNT
else
    echo "the array is not 1-N: give the shard count as SHARDS=N" >&2
    exit 2
fi
[[ -n $REQUIREMENT ]] || { echo "no REQUIREMENT in the environment" >&2 && exit 2; }
echo "sizing shard $K/$N of $REQUIREMENT on $(hostname), ${SLURM_CPUS_PER_TASK:-1} threads"
# shellcheck disable=SC2086 # NRSLAM is split into words on purpose
$NRSLAM sizing "$REQUIREMENT" --out "$OUT" --shard "$K/$N" --threads "${SLURM_CPUS_PER_TASK:-1}"
