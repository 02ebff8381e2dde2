#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# relief-slurm on a real Slurm: starts a private single-node cluster
# (munged, slurmctld, slurmd as root on loopback, its own slurm.conf and
# munge key under WORK), submits an 8-job manifest as a 4-task array,
# checks every output and the logs, deletes two outputs, resubmits, checks
# that exactly those two were recomputed, and stops the daemons it started
# (by pid).
#   check_slurm.sh RELIEF_SLURM WORK NORMAL_MAP
set -euo pipefail
relief_slurm=$(realpath "$1")
work=$2
normal=$(realpath "$3")

skip() { echo "relief-test-skipped: $*"; exit 0; }
[ "$(id -u)" -eq 0 ] || skip "starting slurmctld, slurmd and munged needs root"
for p in munged mungekey slurmctld slurmd sbatch squeue sinfo oiiotool; do
  command -v "$p" >/dev/null || { echo "FAIL: $p is not installed (scripts/setup installs slurm-wlm and munge)"; exit 1; }
done

rm -rf "$work"
# the manifest's folder and the logs' hold a blank and a %, as users' paths may
data="$work/maps 100%"
logs="$work/task logs %a"
mkdir -p "$work"/{state,spool} "$data/out" "$logs"
cd "$work"
pids=()
stop() {
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null || true; done
  for p in "${pids[@]}"; do
    for _ in $(seq 50); do kill -0 "$p" 2>/dev/null || break; sleep 0.1; done
    kill -9 "$p" 2>/dev/null || true
  done
}
trap stop EXIT
fail() {
  echo "FAIL: $*"
  for f in slurmctld.log slurmd.log munged.log; do [ -f "$f" ] && { echo "--- $f"; tail -20 "$f"; }; done
  exit 1
}

free_port() { /usr/bin/python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

# munge: our own key and socket, so a system munged (if any) is not touched.
mungekey --create --keyfile="$work/munge.key" --force
chmod 600 "$work/munge.key"
munged --foreground --force --key-file="$work/munge.key" --socket="$work/munge.socket" \
  --pid-file="$work/munged.pid" --log-file="$work/munged.log" --seed-file="$work/munge.seed" >/dev/null 2>&1 &
pids+=($!)

host=$(hostname -s)
cpus=$(nproc)
ctl_port=$(free_port)
d_port=$(free_port)
while [ "$d_port" = "$ctl_port" ]; do d_port=$(free_port); done
cat > slurm.conf <<EOF
ClusterName=relieftest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctl_port
SlurmdPort=$d_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$work/munge.socket
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
SchedulerType=sched/builtin
InactiveLimit=0
KillWait=5
NodeName=$host NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=relief Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$work/slurm.conf
for _ in $(seq 50); do [ -S "$work/munge.socket" ] && break; sleep 0.1; done
[ -S "$work/munge.socket" ] || fail "munged did not start"
slurmctld -D -i -f "$SLURM_CONF" >/dev/null 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" -N "$host" >/dev/null 2>&1 &
pids+=($!)
up=""
for _ in $(seq 300); do
  if sinfo -h -N -o '%T' 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then up=1; break; fi
  sleep 0.2
done
[ -n "$up" ] || fail "the node did not come up in 60 s: $(sinfo -h -N -o '%N %T' 2>&1)"
echo "slurm up after ${SECONDS}s"

# 8 jobs: 4 crops x (slopes, height); outputs in $data/out.
cd "$data"
for i in 0 1 2 3; do
  oiiotool "$normal" --cut "96x96+$((32 * i))+0" -d uint8 -o "n$i.png"
done
: > jobs.txt
for i in 0 1 2 3; do
  echo "n$i.png --slopes -o out/s$i.exr" >> jobs.txt
  echo "n$i.png --height -o out/h$i.exr" >> jobs.txt
done

wait_for() {  # job id: until it has left the queue
  for _ in $(seq 600); do
    [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0
    sleep 0.2
  done
  fail "job $1 still queued after 120 s: $(squeue -j "$1" 2>&1)"
}
statuses() {  # job index -> status, from the task logs
  /usr/bin/python3 -c '
import glob, json, sys
s = {}
for f in glob.glob(sys.argv[1] + "/task-*.jsonl"):
    for l in open(f):
        r = json.loads(l); s[r["job"]] = r["status"]
print(" ".join(f"{k}:{s[k]}" for k in sorted(s)))' "$1"
}

"$relief_slurm" submit jobs.txt --tasks 4 --dry-run > script.txt
grep -q -- '--array=0-3' script.txt || fail "dry run: no 0-3 array in $(cat script.txt)"
[ ! -e "$logs/relief-array.sbatch" ] || fail "a dry run wrote the script"

out=$("$relief_slurm" submit jobs.txt --tasks 4 --log-dir "$logs" -- --time=5)
id=$(echo "$out" | tail -1)
[[ "$id" =~ ^[0-9]+$ ]] || fail "submit printed '$out', not a job id"
wait_for "$id"
for i in 0 1 2 3; do
  [ -s "out/s$i.exr" ] && [ -s "out/h$i.exr" ] || fail "missing outputs after the first run: $(ls out)"
done
ls "$logs"/task-{0,1,2,3}.jsonl >/dev/null || fail "a task log is missing: $(ls "$logs")"
got=$(statuses "$logs")
[ "$got" = "0:ok 1:ok 2:ok 3:ok 4:ok 5:ok 6:ok 7:ok" ] || fail "first run: $got; $(cat "$logs"/task-*.out)"
"$relief_slurm" status jobs.txt --log-dir "$logs" | tail -1 | grep -q "8 job(s): 8 ok, 0 skipped, 0 failed, 0 missing" ||
  fail "status after the first run: $("$relief_slurm" status jobs.txt --log-dir "$logs")"
# each task took the jobs of its shard
grep -q '"job":5,' "$logs/task-1.jsonl" || fail "task 1 did not run job 5"

# two outputs lost (a node died, a disk was cleaned): only those recompute
before=$(stat -c %y out/h0.exr)
rm out/s1.exr out/h2.exr
id=$("$relief_slurm" submit jobs.txt --tasks 4 --log-dir "$logs" | tail -1)
wait_for "$id"
[ -s out/s1.exr ] && [ -s out/h2.exr ] || fail "the deleted outputs were not remade"
got=$(statuses "$logs")
[ "$got" = "0:skipped 1:skipped 2:ok 3:skipped 4:skipped 5:ok 6:skipped 7:skipped" ] || fail "resubmission: $got"
[ "$(stat -c %y out/h0.exr)" = "$before" ] || fail "an up-to-date output was rewritten"
"$relief_slurm" status jobs.txt --log-dir "$logs" | tail -1 | grep -q "6 skipped, 0 failed, 0 missing" || fail "status after the resubmission"
echo "PASS: 8 jobs as a 4-task array, 2 lost outputs recomputed alone (${SECONDS}s)"
