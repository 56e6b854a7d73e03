#!/usr/bin/env bash
# A Monte Carlo study as a Slurm job array: array task K runs shard K/N of the trials, and a
# job that depends on the whole array merges the shard folders into the unsharded result
# (docs/cluster.md). Run from the repository root (the launch files and config/ must be there)
# on a login node:
#
#   scripts/cluster/slurm-montecarlo.sh            # checks the request fits, submits the array and the merge
#
# or submit the two by hand (the script's #SBATCH defaults, logs in the current folder):
#
#   jid=$(sbatch --parsable --array=1-8 scripts/cluster/slurm-montecarlo.sh)
#   sbatch --dependency=afterok:$jid --wrap "nrslam merge out/cluster/mc/shard-{1..8} --out out/cluster/mc/merged"
#
# Settings (environment variables at submission; sbatch passes the environment on by default):
#   SHARDS   number of shards N (default 8; in an array task, default: the array's size).
#            To rerun only shard 3 of 8: SHARDS=8 sbatch --array=3 scripts/cluster/slurm-montecarlo.sh
#   TRIALS   trials of the whole study (default 500, the paper's)
#   LAUNCH   launch file and its arguments (default: the paper's ideal run with loop closure)
#   SEED     base seed (default 1)
#   OUT      study folder on a file system every node sees (default out/cluster/mc):
#            shard-K/ per array task, merged/ at the end, logs/ the jobs' logs
#            (nrslam-mc-<array job>_<K>.log, nrslam-mc-merge-<job>.log)
#   NRSLAM   how to run nrslam on a compute node (default: nrslam on PATH), e.g.
#            "apptainer exec nrslam.sif nrslam" or "$PWD/target/release/nrslam"
#   CPUS_PER_TASK (default 1; each task runs that many threads), MEM_PER_CPU (1G), TIME_LIMIT
#            (01:00:00) per array task, FINAL_TIME (00:10:00) for the merge, PARTITION (the
#            default partition): given on the sbatch command line, so they override the #SBATCH
#            lines below. Before submitting, the script checks that a node of the partition has
#            CPUS_PER_TASK CPUs and CPUS_PER_TASK x MEM_PER_CPU of memory and that the partition's
#            time limit allows TIME_LIMIT, and fails naming the setting and what the cluster
#            offers (Slurm itself would accept the job and leave it pending forever, reason
#            PartitionConfig). scripts/cluster/slurm-common.sh holds that check.
#
# Trial i goes to shard (i mod N) + 1 and runs with a seed derived from (SEED, i) alone, so the
# merged folder is byte for byte the folder one unsharded `nrslam montecarlo` would write.
#
#SBATCH --job-name=nrslam-mc
#SBATCH --array=1-8
#SBATCH --cpus-per-task=1
#SBATCH --mem-per-cpu=1G
#SBATCH --time=01:00:00
#SBATCH --output=nrslam-mc-%A_%a.log
set -euo pipefail

GIVEN_SHARDS=${SHARDS:-}
SHARDS=${SHARDS:-8}
TRIALS=${TRIALS:-500}
LAUNCH=${LAUNCH:-launch/paper-ideal.toml loop_closure:=true viz:=false}
SEED=${SEED:-1}
OUT=${OUT:-out/cluster/mc}
NRSLAM=${NRSLAM:-nrslam}

if [[ -z ${SLURM_ARRAY_TASK_ID:-} ]]; then
    # Not an array task: check the request fits, then submit the array (N tasks, overriding the
    # --array line above) and the merge, which starts only once every task has succeeded (afterok).
    # (An array task runs a copy of this script in Slurm's spool: only the submitter sources.)
    # shellcheck source=scripts/cluster/slurm-common.sh
    source "$(dirname "$0")/slurm-common.sh"
    [[ $SHARDS =~ ^[1-9][0-9]*$ ]] || slurm_die "SHARDS=$SHARDS is not a positive integer"
    slurm_check_fit
    logs=$(slurm_log_dir)
    export SHARDS
    array=$(sbatch --parsable --array="1-$SHARDS" --cpus-per-task="$CPUS_PER_TASK" \
        "${SBATCH_OPTS[@]}" --time="$TIME_LIMIT" \
        --output="$logs/nrslam-mc-%A_%a.log" "$0")
    array=${array%%;*} # "jobid;cluster" on multi-cluster sites
    dirs=""
    for ((k = 1; k <= SHARDS; k++)); do dirs+=" $(printf %q "$OUT/shard-$k")"; done
    # NRSLAM is split into words on purpose (e.g. "apptainer exec nrslam.sif nrslam").
    merge=$(sbatch --parsable --job-name=nrslam-mc-merge --dependency="afterok:$array" \
        --cpus-per-task=1 "${SBATCH_OPTS[@]}" --time="$FINAL_TIME" \
        --output="$logs/nrslam-mc-merge-%j.log" \
        --wrap "$NRSLAM merge$dirs --out $(printf %q "$OUT/merged")")
    merge=${merge%%;*}
    echo "submitted array job $array ($SHARDS shards of $TRIALS trials, $CPUS_PER_TASK CPUs each) and merge job $merge"
    echo "result: $OUT/merged/montecarlo.csv once job $merge has finished; logs in $logs"
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
echo "shard $K/$N of $TRIALS trials on $(hostname), ${SLURM_CPUS_PER_TASK:-1} threads"
# LAUNCH is split into words on purpose: the file and its NAME:=VALUE arguments.
# shellcheck disable=SC2086
$NRSLAM montecarlo $LAUNCH --trials "$TRIALS" --seed "$SEED" --shard "$K/$N" \
    --threads "${SLURM_CPUS_PER_TASK:-1}" --out "$OUT/shard-$K"
