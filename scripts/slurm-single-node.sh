#!/usr/bin/env bash
# Single-node SLURM "cluster" on this machine: Debian's slurmctld + slurmd +
# slurm-client + munge, no systemd, no cgroups. Run as root.
#
#   slurm-single-node.sh [start]   install (if needed), configure, start, wait until the node is idle
#   slurm-single-node.sh stop      stop the daemons this script starts (by their pid files)
#   slurm-single-node.sh status    print daemon and node state
#
# Idempotent: running `start` twice leaves one set of daemons running; a
# changed configuration (e.g. a different CPU count) restarts them.
set -euo pipefail

CONF=/etc/slurm/slurm.conf          # Debian's compiled-in default path
STATE=/var/lib/slurm                # created by the Debian packages
LOGDIR=/var/log/slurm
RUNDIR=/run/slurm
CTLD_PID=$RUNDIR/slurmctld.pid
SLURMD_PID=$RUNDIR/slurmd.pid
MUNGE_PID=/run/munge/munged.pid     # munged's default pid file
WAIT_SECS=${SLURM_WAIT_SECS:-60}
NODE=localhost                      # slurmd is started with -N localhost: works whatever the hostname

log() { printf '[slurm-single-node] %s\n' "$*" >&2; }
die() { log "ERROR: $*"; exit 1; }

# pid_alive PID: a live process (not a zombie: PID 1 here reaps slowly, and
# kill -0 succeeds on a zombie) running one of our daemons (guards pid reuse).
pid_alive() {
    local stat
    stat=$(cat "/proc/$1/stat" 2>/dev/null) || return 1
    [[ $stat =~ ^[0-9]+\ \((munged|slurmctld|slurmd)\)\ [^Z] ]]
}
# alive PIDFILE: the pid file names a live daemon.
alive() {
    local pid
    pid=$(cat "$1" 2>/dev/null) || return 1
    [[ -n $pid ]] && pid_alive "$pid"
}

stop_pidfile() {  # stop_pidfile FILE NAME
    local f=$1 name=$2 pid i
    pid=$(cat "$f" 2>/dev/null || true)
    if [[ -n $pid ]] && pid_alive "$pid"; then
        log "stopping $name (pid $pid)"
        kill "$pid" 2>/dev/null || true
        for i in $(seq 1 100); do pid_alive "$pid" || break; sleep 0.1; done
        if pid_alive "$pid"; then log "$name did not stop, SIGKILL"; kill -9 "$pid" 2>/dev/null || true; fi
    fi
    rm -f "$f"
}

install_packages() {
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null \
       && command -v sbatch >/dev/null && command -v munged >/dev/null; then
        return
    fi
    [[ $(id -u) -eq 0 ]] || die "must run as root to install packages"
    log "installing slurmctld slurmd slurm-client munge"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    # --no-install-recommends: 8 packages instead of 42 (no mailutils/postfix etc.)
    apt-get install -y -qq --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
}

write_config() {
    local cpus mem tmp
    cpus=$(nproc)
    # slurmd -C reports what slurmd will detect; stay a little below it so the
    # node is never drained for "Low RealMemory".
    mem=$(slurmd -C 2>/dev/null | sed -n 's/.*RealMemory=\([0-9]*\).*/\1/p')
    [[ -n $mem ]] || mem=$(free -m | awk '/^Mem:/{print $2}')
    mem=$(( mem * 9 / 10 ))
    tmp=$(mktemp)
    cat >"$tmp" <<CONF
# Written by slurm-single-node.sh: a single-node test cluster.
ClusterName=local
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
MpiDefault=none
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
# CPUs only are consumable: a job without --mem does not take the whole node.
SelectTypeParameters=CR_Core
SchedulerType=sched/backfill
# React at once to submits/completions (defaults wait ~3 s between tasks).
SchedulerParameters=batch_sched_delay=0,sched_min_interval=0,bf_interval=1
ReturnToService=2
StateSaveLocation=$STATE/slurmctld
SlurmdSpoolDir=$STATE/slurmd
SlurmctldPidFile=$CTLD_PID
SlurmdPidFile=$SLURMD_PID
SlurmctldLogFile=$LOGDIR/slurmctld.log
SlurmdLogFile=$LOGDIR/slurmd.log
SlurmctldPort=6817
SlurmdPort=6818
# Short timeouts: this is a test cluster on one machine.
SlurmctldTimeout=30
SlurmdTimeout=30
InactiveLimit=0
MinJobAge=300
KillWait=5
Waittime=0
NodeName=$NODE NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=$NODE Default=YES MaxTime=INFINITE State=UP
CONF
    mkdir -p /etc/slurm
    if [[ -f $CONF ]] && cmp -s "$tmp" "$CONF"; then
        rm -f "$tmp"; return 1            # unchanged
    fi
    install -m 0644 "$tmp" "$CONF"; rm -f "$tmp"
    log "wrote $CONF (CPUs=$cpus RealMemory=$mem)"
    return 0                              # changed
}

start_munge() {
    if alive "$MUNGE_PID" && munge -n </dev/null | unmunge >/dev/null 2>&1; then return; fi
    stop_pidfile "$MUNGE_PID" munged
    if [[ ! -s /etc/munge/munge.key ]]; then   # the Debian package creates one; make sure
        log "creating /etc/munge/munge.key"
        mkdir -p /etc/munge
        dd if=/dev/urandom of=/etc/munge/munge.key bs=1 count=1024 status=none
    fi
    # munged insists that the key, its dirs and the socket dir belong to the user it runs as.
    mkdir -p /run/munge /var/lib/munge /var/log/munge
    chown munge:munge /etc/munge /etc/munge/munge.key /run/munge /var/lib/munge /var/log/munge
    chmod 0700 /etc/munge; chmod 0400 /etc/munge/munge.key; chmod 0755 /run/munge
    log "starting munged"
    runuser -u munge -- /usr/sbin/munged
    local i
    for i in $(seq 1 50); do munge -n </dev/null | unmunge >/dev/null 2>&1 && return; sleep 0.1; done
    die "munged does not answer (see /var/log/munge/munged.log)"
}

start_slurm() {
    mkdir -p "$RUNDIR" "$LOGDIR" "$STATE/slurmctld" "$STATE/slurmd"
    if ! alive "$SLURMD_PID" && alive "$CTLD_PID"; then
        # slurmd died under a running controller: its jobs are lost anyway, and the
        # node would sit in COMPLETING for ~30 s; restart both from a clean state.
        stop_pidfile "$CTLD_PID" slurmctld
    fi
    if ! alive "$CTLD_PID"; then
        rm -f "$CTLD_PID"
        log "starting slurmctld"
        # -c: forget saved jobs/nodes state of an earlier run (clean start)
        slurmctld -c
    fi
    local i
    for i in $(seq 1 100); do scontrol ping 2>/dev/null | grep -q 'is UP' && break; sleep 0.1; done
    scontrol ping 2>/dev/null | grep -q 'is UP' || die "slurmctld does not answer (see $LOGDIR/slurmctld.log)"
    if ! alive "$SLURMD_PID"; then
        rm -f "$SLURMD_PID"
        log "starting slurmd"
        slurmd -N "$NODE"
    fi
}

wait_idle() {
    local state i
    for i in $(seq 1 $((WAIT_SECS * 4))); do
        state=$(sinfo -h -n "$NODE" -o %T 2>/dev/null | head -n1 || true)
        case $state in
            idle|mixed|allocated)
                # end-to-end check: a one-task job step runs on the node
                if timeout 30 srun -N1 -n1 -t 1 true 2>/dev/null; then
                    log "node $NODE is $state, srun works"; return 0
                fi ;;
            *drain*|down*)        scontrol update NodeName="$NODE" State=RESUME 2>/dev/null || true ;;
        esac
        sleep 0.25
    done
    sinfo -N -l >&2 || true
    scontrol show node "$NODE" >&2 || true
    die "node $NODE not idle after ${WAIT_SECS}s (state '$state'; see $LOGDIR/*.log)"
}

do_stop() {
    stop_pidfile "$SLURMD_PID" slurmd
    stop_pidfile "$CTLD_PID" slurmctld
    stop_pidfile "$MUNGE_PID" munged
}

do_start() {
    [[ $(id -u) -eq 0 ]] || die "run as root"
    install_packages
    if write_config; then
        # the configuration changed: restart slurm daemons that run with the old one
        stop_pidfile "$SLURMD_PID" slurmd
        stop_pidfile "$CTLD_PID" slurmctld
    fi
    start_munge
    start_slurm
    wait_idle
}

do_status() {
    for p in "$MUNGE_PID:munged" "$CTLD_PID:slurmctld" "$SLURMD_PID:slurmd"; do
        if alive "${p%%:*}"; then echo "${p#*:}: running (pid $(cat "${p%%:*}"))"; else echo "${p#*:}: stopped"; fi
    done
    command -v sinfo >/dev/null && sinfo 2>/dev/null || true
}

case ${1:-start} in
    start)  do_start ;;
    stop)   do_stop ;;
    status) do_status ;;
    *) echo "usage: $0 [start|stop|status]" >&2; exit 2 ;;
esac
