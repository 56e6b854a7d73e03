# shellcheck shell=bash
# Shell code the Slurm study scripts share (slurm-montecarlo.sh, slurm-sizing.sh): the resources
# asked of Slurm, the check that they fit the cluster before anything is submitted, and the log
# folder. Sourced by the submitting run of those scripts, never run on its own. docs/cluster.md.
#
# Settings (environment), with their defaults:
#   CPUS_PER_TASK  CPUs of one array task (1); the task runs that many threads
#   MEM_PER_CPU    memory per CPU, Slurm's syntax: 512M, 1G, or a number of MB (1G)
#   TIME_LIMIT     wall time of one array task, Slurm's syntax: MM, HH:MM:SS, D-HH:MM:SS (01:00:00)
#   FINAL_TIME     wall time of the job that runs after the array (00:10:00)
#   PARTITION      partition to submit to (default: the cluster's default partition)
# They are given on the sbatch command line, which overrides the #SBATCH lines of the scripts.

CPUS_PER_TASK=${CPUS_PER_TASK:-1}
MEM_PER_CPU=${MEM_PER_CPU:-1G}
TIME_LIMIT=${TIME_LIMIT:-01:00:00}
FINAL_TIME=${FINAL_TIME:-00:10:00}
PARTITION=${PARTITION:-}

slurm_die() {
    echo "$(basename "$0"): $*" >&2
    exit 2
}

# A Slurm memory size (512M, 1G, 2048, 1T; no suffix: MB) in MB, rounded up.
slurm_mb() {
    local v=${1^^}
    [[ $v =~ ^([0-9]+)([KMGT]?)B?$ ]] || return 1
    local n=$((10#${BASH_REMATCH[1]}))
    case ${BASH_REMATCH[2]} in
        K) echo $(((n + 1023) / 1024)) ;;
        M | "") echo "$n" ;;
        G) echo $((n * 1024)) ;;
        T) echo $((n * 1024 * 1024)) ;;
    esac
}

# A Slurm time (MM, MM:SS, HH:MM:SS, D-HH, D-HH:MM, D-HH:MM:SS) in seconds; infinite: -1.
slurm_seconds() {
    local t=$1 d=0 h=0 m=0 s=0
    local -a p
    case ${t,,} in infinite | unlimited) echo -1 && return 0 ;; esac
    [[ $t =~ ^([0-9]+-)?[0-9]+(:[0-9]+){0,2}$ ]] || return 1
    if [[ $t == *-* ]]; then
        d=${t%%-*}
        IFS=: read -r h m s <<<"${t#*-}"
    else
        IFS=: read -ra p <<<"$t"
        case ${#p[@]} in
            1) m=${p[0]} ;;
            2) m=${p[0]} s=${p[1]} ;;
            3) h=${p[0]} m=${p[1]} s=${p[2]} ;;
        esac
    fi
    echo $(((((10#$d * 24) + 10#${h:-0}) * 60 + 10#${m:-0}) * 60 + 10#${s:-0}))
}

# Checks that an array task (CPUS_PER_TASK × MEM_PER_CPU for TIME_LIMIT) and the final job fit a
# node of the partition and its time limit, and fails naming the setting and what the cluster
# offers if not. Without the check Slurm accepts such a job and leaves it pending forever (reason
# PartitionConfig, PartitionTimeLimit). Sets SBATCH_OPTS, the options every submission takes
# (memory, partition); the array's submission adds --cpus-per-task and --time=$TIME_LIMIT.
slurm_check_fit() {
    if ! command -v sbatch >/dev/null || ! command -v sinfo >/dev/null; then
        slurm_die "no sbatch or sinfo on PATH: submit from a Slurm login node"
    fi
    [[ $CPUS_PER_TASK =~ ^[1-9][0-9]*$ ]] || slurm_die "CPUS_PER_TASK=$CPUS_PER_TASK is not a positive integer"
    local mem_cpu task_mem time_s final_s
    mem_cpu=$(slurm_mb "$MEM_PER_CPU") || slurm_die "MEM_PER_CPU=$MEM_PER_CPU is not a memory size (e.g. 512M, 1G)"
    time_s=$(slurm_seconds "$TIME_LIMIT") || slurm_die "TIME_LIMIT=$TIME_LIMIT is not a Slurm time (e.g. 30, 01:00:00, 1-00:00:00)"
    final_s=$(slurm_seconds "$FINAL_TIME") || slurm_die "FINAL_TIME=$FINAL_TIME is not a Slurm time (e.g. 00:10:00)"
    task_mem=$((CPUS_PER_TASK * mem_cpu))

    local part
    if [[ -n $PARTITION ]]; then
        part=$PARTITION
        [[ -n $(sinfo -h -p "$part" -o '%P' 2>/dev/null) ]] \
            || slurm_die "PARTITION=$part: no such partition (sinfo lists: $(sinfo -h -o '%P' | tr '\n' ' '))"
    else
        part=$(sinfo -h -o '%P' | sed -n 's/\*$//p' | head -n 1)
        [[ -n $part ]] || slurm_die "the cluster has no default partition: set PARTITION"
    fi

    # Every node of the partition: CPUs and memory (MB).
    local nodes max_cpus=0 max_mem=0 fit=0 c m
    nodes=$(sinfo -h -N -p "$part" -o '%c %m' | tr -d '+')
    [[ -n $nodes ]] || slurm_die "partition $part has no nodes"
    while read -r c m; do
        ((c > max_cpus)) && max_cpus=$c
        ((c >= CPUS_PER_TASK && m > max_mem)) && max_mem=$m
        ((c >= CPUS_PER_TASK && m >= task_mem)) && fit=1
    done <<<"$nodes"
    ((CPUS_PER_TASK <= max_cpus)) \
        || slurm_die "CPUS_PER_TASK=$CPUS_PER_TASK: the largest node of partition $part has $max_cpus CPUs (set CPUS_PER_TASK=$max_cpus or fewer)"
    ((fit)) \
        || slurm_die "MEM_PER_CPU=$MEM_PER_CPU with CPUS_PER_TASK=$CPUS_PER_TASK asks $task_mem MB per task: the nodes of partition $part with $CPUS_PER_TASK CPUs or more have at most $max_mem MB (set MEM_PER_CPU=$((max_mem / CPUS_PER_TASK))M or less)"

    local max_time max_s
    max_time=$(sinfo -h -p "$part" -o '%l' | head -n 1)
    max_s=$(slurm_seconds "$max_time") || max_s=-1
    if ((max_s >= 0)); then
        ((time_s <= max_s)) || slurm_die "TIME_LIMIT=$TIME_LIMIT: partition $part allows at most $max_time"
        ((final_s <= max_s)) || slurm_die "FINAL_TIME=$FINAL_TIME: partition $part allows at most $max_time"
    fi

    SBATCH_OPTS=(--mem-per-cpu="$MEM_PER_CPU")
    [[ -n $PARTITION ]] && SBATCH_OPTS+=(--partition="$PARTITION")
    # Slurm's own check as well (account and QOS limits, node features...): --test-only submits
    # nothing.
    local answer
    if ! answer=$(sbatch --test-only --cpus-per-task="$CPUS_PER_TASK" "${SBATCH_OPTS[@]}" \
        --time="$TIME_LIMIT" --wrap true 2>&1); then
        slurm_die "sbatch --test-only refuses CPUS_PER_TASK=$CPUS_PER_TASK MEM_PER_CPU=$MEM_PER_CPU TIME_LIMIT=$TIME_LIMIT on partition $part: $answer"
    fi
}

# The log folder OUT/logs, created before anything is submitted: Slurm does not create the folder
# of --output, and a job whose log cannot be opened fails (JobLaunchFailure) with no log at all.
slurm_log_dir() {
    mkdir -p "$OUT/logs"
    echo "$OUT/logs"
}
