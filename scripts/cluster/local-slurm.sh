#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, to try the Slurm scripts of this folder
# (docs/cluster.md) without a site cluster. Run as root on Debian or Ubuntu:
#
#   scripts/cluster/local-slurm.sh start    # install if absent, configure, start, wait until idle
#   scripts/cluster/local-slurm.sh status   # daemons, sinfo, squeue
#   scripts/cluster/local-slurm.sh stop     # stop slurmd and slurmctld (and munged if we started it)
#
# `start` is idempotent: it installs slurmctld, slurmd, slurm-client and munge with apt-get only if
# slurmctld is absent, creates a munge key only if /etc/munge/munge.key is absent, rewrites the
# configuration (one node with the CPUs and memory `slurmd -C` finds, a partition `debug`), starts
# only the daemons not running (restarting them if the configuration changed), then waits until
# `sinfo` shows the node idle, printing the daemons' logs and failing if it does not within WAIT
# seconds. The daemons run directly (no systemd, so it works in a container): munged as user
# munge, slurmctld and slurmd as root, with proctrack/linuxproc and task/none (no cgroups).
#
# Settings (environment):
#   SLURM_DIR  configuration, logs and pid files (default /var/lib/nrslam-slurm); state under
#              /var/spool/nrslam-slurm. /etc/slurm/slurm.conf is made a link to
#              $SLURM_DIR/slurm.conf so that sinfo, sbatch, ... find it; a slurm.conf that is not
#              such a link (a real site's) is never touched: the script stops with an error.
#   WAIT       seconds to wait for the node to be idle (default 60)
#   MAX_TIME   the partition's MaxTime (default 02:00:00)
set -euo pipefail

SLURM_DIR=${SLURM_DIR:-/var/lib/nrslam-slurm}
SPOOL=/var/spool/nrslam-slurm
WAIT=${WAIT:-60}
MAX_TIME=${MAX_TIME:-02:00:00}
CONF=$SLURM_DIR/slurm.conf
SITE_CONF=/etc/slurm/slurm.conf

die() {
    echo "local-slurm: $*" >&2
    exit 1
}

# Is the process of this pid file alive and the daemon named after the file (slurmd.pid: slurmd)?
# A pid file left by a machine that restarted may name a pid some other process has now.
alive() {
    local name
    name=$(basename "$1" .pid)
    [[ -s $1 ]] && [[ $(cat "/proc/$(cat "$1")/comm" 2>/dev/null) == "$name" ]]
}

show_logs() {
    local log
    for log in "$SLURM_DIR/slurmctld.log" "$SLURM_DIR/slurmd.log" /var/log/munge/munged.log; do
        [[ -f $log ]] || continue
        echo "---- last lines of $log" >&2
        tail -n 30 "$log" >&2
    done
}

install_packages() {
    command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
        && command -v sinfo >/dev/null && command -v munged >/dev/null && return 0
    command -v apt-get >/dev/null || die "Slurm is not installed and there is no apt-get to install it"
    echo "local-slurm: installing slurmctld slurmd slurm-client munge"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
}

start_munge() {
    if [[ ! -s /etc/munge/munge.key ]]; then
        echo "local-slurm: creating a munge key"
        install -d -o munge -g munge -m 700 /etc/munge
        dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
        chown munge:munge /etc/munge/munge.key
        chmod 400 /etc/munge/munge.key
    fi
    if munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
        return 0 # a munged answers already (ours or the system's)
    fi
    install -d -o munge -g munge -m 755 /run/munge
    install -d -o munge -g munge -m 700 /var/lib/munge /var/log/munge
    runuser -u munge -- munged \
        || { show_logs; die "munged did not start"; }
    touch "$SLURM_DIR/munged.ours"
    local i
    for ((i = 0; i < 50; i++)); do
        munge -n 2>/dev/null | unmunge >/dev/null 2>&1 && return 0
        sleep 0.1
    done
    show_logs
    die "munged started but does not answer (munge -n | unmunge)"
}

write_config() {
    local host node conf_new
    host=$(hostname -s)
    # "NodeName=vm CPUs=2 Boards=1 SocketsPerBoard=1 CoresPerSocket=2 ThreadsPerCore=1 RealMemory=24105"
    node=$(slurmd -C | head -n 1)
    [[ $node == NodeName=* ]] || die "slurmd -C printed no node line: $node"
    node=${node#NodeName=* }
    conf_new=$(
        cat <<EOF
# Written by scripts/cluster/local-slurm.sh: a one-node cluster for trying the Slurm scripts.
ClusterName=nrslam-local
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$SPOOL/ctld
SlurmdSpoolDir=$SPOOL/d
SlurmctldPidFile=$SLURM_DIR/slurmctld.pid
SlurmdPidFile=$SLURM_DIR/slurmd.pid
SlurmctldLogFile=$SLURM_DIR/slurmctld.log
SlurmdLogFile=$SLURM_DIR/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
MailProg=/bin/true
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
DefMemPerCPU=1024
ReturnToService=2
# Finished jobs stay visible to scontrol show job for an hour (no accounting database: no sacct).
MinJobAge=3600
SlurmdTimeout=60
NodeName=$host NodeAddr=127.0.0.1 $node State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=$MAX_TIME State=UP
EOF
    )
    install -d -m 755 "$SLURM_DIR" /etc/slurm
    install -d -m 700 "$SPOOL/ctld" "$SPOOL/d"
    if [[ -e $SITE_CONF || -L $SITE_CONF ]] && [[ $(readlink -f "$SITE_CONF") != "$(readlink -f "$CONF")" ]]; then
        die "$SITE_CONF exists and is not a link to $CONF: this script leaves a real site's configuration alone"
    fi
    CHANGED=0
    if [[ ! -f $CONF ]] || [[ $(cat "$CONF") != "$conf_new" ]]; then
        printf '%s\n' "$conf_new" >"$CONF"
        CHANGED=1
    fi
    ln -sfn "$CONF" "$SITE_CONF"
}

stop_daemon() { # name pidfile
    alive "$2" || return 0
    local pid i
    pid=$(cat "$2")
    kill "$pid"
    for ((i = 0; i < 100; i++)); do
        kill -0 "$pid" 2>/dev/null || return 0
        sleep 0.1
    done
    echo "local-slurm: $1 (pid $pid) did not stop in 10 s; killing it" >&2
    kill -9 "$pid" 2>/dev/null || true
}

node_state() {
    sinfo -h -N -o '%T' 2>/dev/null | head -n 1
}

start() {
    [[ $(id -u) == 0 ]] || die "run as root (it installs packages and starts daemons)"
    install_packages
    install -d -m 755 "$SLURM_DIR"
    write_config
    start_munge
    if ((CHANGED)); then
        # A new configuration: daemons still running from an older one are restarted.
        stop_daemon slurmd "$SLURM_DIR/slurmd.pid"
        stop_daemon slurmctld "$SLURM_DIR/slurmctld.pid"
    fi
    if ! alive "$SLURM_DIR/slurmctld.pid"; then
        slurmctld || { show_logs; die "slurmctld did not start"; }
    fi
    if ! alive "$SLURM_DIR/slurmd.pid"; then
        slurmd || { show_logs; die "slurmd did not start"; }
    fi
    local deadline state
    deadline=$((SECONDS + WAIT))
    while :; do
        state=$(node_state || true)
        case $state in
            idle | mixed | allocated | completing) break ;;
            down* | drain* | fail*)
                # e.g. left down by an earlier unclean stop: the node is back, resume it.
                scontrol update nodename="$(hostname -s)" state=resume 2>/dev/null || true
                ;;
        esac
        if ((SECONDS >= deadline)); then
            show_logs
            sinfo -N -l >&2 || true
            die "the node is not idle after ${WAIT} s (state: ${state:-no answer from slurmctld})"
        fi
        sleep 1
    done
    echo "local-slurm: up ($(sinfo -V)), node $(hostname -s) $state; config $CONF, logs $SLURM_DIR"
    sinfo
}

stop() {
    stop_daemon slurmd "$SLURM_DIR/slurmd.pid"
    stop_daemon slurmctld "$SLURM_DIR/slurmctld.pid"
    if [[ -f $SLURM_DIR/munged.ours ]]; then
        stop_daemon munged /run/munge/munged.pid
        rm -f "$SLURM_DIR/munged.ours"
    fi
    echo "local-slurm: stopped"
}

status() {
    local name pidfile
    for name in slurmctld slurmd; do
        pidfile=$SLURM_DIR/$name.pid
        if alive "$pidfile"; then echo "$name: running (pid $(cat "$pidfile"))"; else echo "$name: not running"; fi
    done
    if munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then echo "munged: answers"; else echo "munged: no answer"; fi
    if alive "$SLURM_DIR/slurmctld.pid"; then
        sinfo
        squeue
    else
        return 3
    fi
}

case ${1:-} in
    start) start ;;
    stop) stop ;;
    status) status ;;
    *)
        echo "usage: $0 start|stop|status" >&2
        exit 2
        ;;
esac
