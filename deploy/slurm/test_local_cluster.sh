#!/usr/bin/env bash
# End-to-end test of the SLURM scripts on a single-node cluster on localhost.
#
# Installs Debian's slurm-wlm and munge if missing, starts munged, slurmctld and slurmd
# (one node, 2 CPUs, no cgroups, no accounting), submits a small study as a 4-task array
# plus the dependent summary job with deploy/slurm/submit.sh, waits for both, and checks
# that the summary, the cycles and the union of the shards' rows equal an unsharded run
# byte for byte. Stops the daemons on exit. Needs root (it writes /etc/slurm, /etc/munge).
#
#   cargo build --release && bash deploy/slurm/test_local_cluster.sh
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
bin="${CARGO_TARGET_DIR:-$root/target}/release/chassis-mc"
[ -x "$bin" ] || { echo "build first: cargo build --release" >&2; exit 2; }
[ "$(id -u)" = 0 ] || { echo "needs root (installs packages, writes /etc/slurm)" >&2; exit 2; }

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
    echo "== installing slurm-wlm and munge"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -qq
    apt-get install -y -qq slurm-wlm munge >/dev/null
fi

work=$(mktemp -d)
# Daemons are started with pid files under $work and stopped by those pids only: this
# script never signals a process it did not start (the machine may be shared, and a
# munged that was already running is left alone).
run_dir="$work/run"
mkdir -p "$run_dir"
started=()   # "pidfile name" of each daemon this script started
stop_pidfile() {
    local file=$1 name=$2 pid
    [ -s "$file" ] || return 0
    pid=$(cat "$file")
    # The pid must still be the daemon we started (not a reused pid).
    [ "$(cat "/proc/$pid/comm" 2>/dev/null)" = "$name" ] || return 0
    kill "$pid" 2>/dev/null || return 0
    for _ in $(seq 50); do
        kill -0 "$pid" 2>/dev/null || return 0
        sleep 0.2
    done
    kill -9 "$pid" 2>/dev/null || true
}
cleanup() {
    local i
    for ((i = ${#started[@]} - 1; i >= 0; i--)); do
        stop_pidfile ${started[$i]}
    done
    rm -rf "$work"
}
trap cleanup EXIT
trap "exit 143" INT TERM

echo "== munge"
mkdir -p /etc/munge /var/lib/munge /var/log/munge /run/munge
[ -s /etc/munge/munge.key ] || dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
chown -R munge:munge /etc/munge /var/lib/munge /var/log/munge /run/munge
chmod 0700 /etc/munge && chmod 0400 /etc/munge/munge.key
if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
    munge_pid=/run/munge/chassis-mc-test-munged.pid
    su -s /bin/sh munge -c "munged --pid-file=$munge_pid"
    started+=("$munge_pid munged")
fi
munge -n | unmunge >/dev/null

echo "== slurm (one node, 2 CPUs)"
mkdir -p /etc/slurm /var/spool/slurmctld /var/spool/slurmd /var/log/slurm
memory=$(awk '/MemTotal/ {print int($2 / 1024 / 2)}' /proc/meminfo)
cat > /etc/slurm/slurm.conf <<EOF
ClusterName=chassis-mc-test
SlurmctldHost=localhost
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=/var/spool/slurmctld
SlurmdSpoolDir=/var/spool/slurmd
SlurmctldPidFile=$run_dir/slurmctld.pid
SlurmdPidFile=$run_dir/slurmd.pid
SlurmctldLogFile=/var/log/slurm/slurmctld.log
SlurmdLogFile=/var/log/slurm/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
NodeName=localnode NodeAddr=127.0.0.1 NodeHostname=localhost CPUs=2 RealMemory=$memory State=UNKNOWN
PartitionName=local Nodes=localnode Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -c
started+=("$run_dir/slurmctld.pid slurmctld")
slurmd -N localnode
started+=("$run_dir/slurmd.pid slurmd")
for _ in $(seq 60); do
    sinfo -h -o %t 2>/dev/null | grep -qE '^idle' && break
    sleep 1
done
sinfo

echo "== submit: thesis study, R = 200, 4 shards"
study="$root/studies/thesis.toml"
out="$work/sharded"
export CHASSIS_MC="$bin"
read -r array summary < <(bash "$root/deploy/slurm/submit.sh" "$study" "$out" 4 --realisations 200)
echo "array job $array, summary job $summary"
for _ in $(seq 600); do
    [ -z "$(squeue -h -j "$array,$summary" 2>/dev/null)" ] && break
    sleep 1
done
[ -z "$(squeue -h -j "$array,$summary" 2>/dev/null)" ] || { squeue; echo "jobs did not finish" >&2; exit 1; }
tail -n 4 "$out"/chassis-mc-*.out 2>/dev/null || true
[ -f "$out/summary.parquet" ] || { echo "summary job produced nothing" >&2; tail -20 /var/log/slurm/*.log; exit 1; }

echo "== compare with an unsharded run"
"$bin" run "$study" --out "$work/whole" --realisations 200 --quiet
for f in summary.parquet cycles.parquet; do
    cmp "$work/whole/$f" "$out/$f"
done
for k in 0 1 2 3; do
    [ -f "$out/shard=$k/realisations.parquet" ] || { echo "shard $k missing" >&2; exit 1; }
done
# The shards' rows, concatenated in shard order, are the unsharded rows (shards are
# contiguous realisation ranges of every condition): summarize proves completeness and
# no duplicates; the identical summary proves identical values.
echo "slurm: 4-shard array + dependent summarize == unsharded run (summary.parquet and cycles.parquet byte-identical)"
