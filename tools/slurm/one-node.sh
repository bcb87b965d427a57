#!/usr/bin/env bash
# A one-node Slurm on this machine, as you, for trying tools/slurm/ (docs/cluster.md, "Try it
# on one machine"); tests/slurm.rs starts and stops its cluster with this script.
#
#   tools/slurm/one-node.sh start DIR   munged, slurmctld and slurmd with DIR/slurm.conf (made
#                                       from tools/slurm/one-node.conf); waits for an idle node
#   tools/slurm/one-node.sh stop DIR    cancels your jobs, stops the three daemons
#
# DIR holds the configuration, a munge key, the daemons' state, sockets, pid files and logs
# (DIR/*.log); it is created if missing. Then `export SLURM_CONF=DIR/slurm.conf` points sbatch,
# sinfo and submit.sh at it. Ports: SLURMCTLD_PORT (default 6817) and SLURMD_PORT (6818).
# Needs Debian's (or Ubuntu's) slurm-wlm and munge packages: the daemons in /usr/sbin.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
export PATH="$PATH:/usr/sbin"
die() { echo "one-node.sh: $*" >&2; exit 2; }
[ $# -eq 2 ] || die "usage: one-node.sh start|stop DIR"
action=$1
mkdir -p "$2"
dir=$(cd "$2" && pwd)
conf=$dir/slurm.conf

pid_of() { [ -s "$1" ] && cat "$1" || true; }

# Stop the process whose pid is in file $1 and wait (10 s) for it to exit.
stop_pid() {
    local pid
    pid=$(pid_of "$1")
    [ -n "$pid" ] || return 0
    kill "$pid" 2>/dev/null || { rm -f "$1"; return 0; }
    for _ in $(seq 50); do
        kill -0 "$pid" 2>/dev/null || { rm -f "$1"; return 0; }
        sleep 0.2
    done
    kill -9 "$pid" 2>/dev/null || true
    rm -f "$1"
}

stop() {
    if [ -s "$dir/slurmctld.pid" ]; then
        SLURM_CONF=$conf scancel --full --user "$(id -un)" 2>/dev/null || true
        sleep 0.5
    fi
    stop_pid "$dir/slurmd.pid"
    stop_pid "$dir/slurmctld.pid"
    stop_pid "$dir/munge/munged.pid"
    echo "one-node.sh: stopped the Slurm in $dir"
}

logs() {
    for f in munge/munged.log slurmctld.log slurmd.log; do
        [ -f "$dir/$f" ] && { echo "--- $dir/$f"; tail -n 15 "$dir/$f"; }
    done >&2
}

start() {
    for p in munged mungekey slurmctld slurmd sinfo sbatch; do
        command -v "$p" >/dev/null || die "$p is not installed (apt-get install slurm-wlm munge)"
    done
    [ -z "$(pid_of "$dir/slurmctld.pid")" ] || die "$dir: a Slurm runs there (stop it first)"
    mkdir -p "$dir/state" "$dir/spool" "$dir/munge" "$dir/key"
    chmod 700 "$dir/key"
    chmod 755 "$dir/munge"
    local host cpus
    host=$(hostname -s)
    cpus=$(nproc)
    sed -e "s|@HOST@|$host|g" -e "s|@DIR@|$dir|g" -e "s|@USER@|$(id -un)|g" \
        -e "s|@CPUS@|$cpus|g" -e "s|@CTLD_PORT@|${SLURMCTLD_PORT:-6817}|g" \
        -e "s|@SLURMD_PORT@|${SLURMD_PORT:-6818}|g" "$here/one-node.conf" >"$conf"
    [ -s "$dir/key/munge.key" ] || mungekey -c -k "$dir/key/munge.key"
    munged --socket="$dir/munge/munge.sock" --key-file="$dir/key/munge.key" \
        --log-file="$dir/munge/munged.log" --pid-file="$dir/munge/munged.pid" \
        --seed-file="$dir/munge/munged.seed" || { logs; die "munged did not start"; }
    slurmctld -i -f "$conf" || { logs; stop; die "slurmctld did not start"; }
    slurmd -f "$conf" || { logs; stop; die "slurmd did not start"; }
    for _ in $(seq 300); do
        if [ "$(SLURM_CONF=$conf sinfo -h -o %T 2>/dev/null)" = idle ]; then
            echo "one-node.sh: one node ($host, $cpus CPUs) idle; now: export SLURM_CONF=$conf"
            return 0
        fi
        sleep 0.2
    done
    logs
    stop
    die "no idle node after 60 s (the logs above)"
}

case $action in
    start) start ;;
    stop) stop ;;
    *) die "usage: one-node.sh start|stop DIR" ;;
esac
