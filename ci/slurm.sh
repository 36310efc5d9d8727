#!/usr/bin/env bash
# CI (issue 31): the Slurm walk-through of docs/guide/merge-and-clusters.md ("On a Slurm
# cluster"), run as printed on a one-node Slurm started here, as root, from Debian's packages.
#
# The blocks of that page whose fence is marked `slurm` are extracted (`file=NAME` blocks are
# written to NAME; the others are run with bash), so the guide cannot drift from what is tested:
#   1. the experiment's and the render table's job arrays and their dependent merges; the merged
#      folders must be, byte for byte, one unsharded run's (timings* and *-cost.svg aside);
#   2. one experiment task cancelled (scancel) while it runs, then the page's `resubmit` block:
#      the task resumes from its unit log, and the merge is again the one run's bytes.
# The daemons (munged, slurmctld, slurmd) are stopped at the end whatever happens. A machine
# where Slurm cannot start fails with the reason; nothing is skipped.
#
# Usage: ci/slurm.sh [path/to/workbench]  (default: target/release/workbench, built by
# `cargo test --release`).
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
bin=$(realpath "${1:-target/release/workbench}")
guide="$repo/docs/guide/merge-and-clusters.md"
started=$SECONDS

fail() {
  echo "ci/slurm.sh: error: $*" >&2
  exit 1
}
[ "$(id -u)" = 0 ] || fail "must run as root (it installs slurm-wlm and munge and starts their daemons)"
[ -x "$bin" ] || fail "$bin is not an executable workbench; build it first (cargo test --release)"

if ! command -v slurmctld > /dev/null || ! command -v munged > /dev/null; then
  export DEBIAN_FRONTEND=noninteractive
  { apt-get update -qq && apt-get install -y -qq slurm-wlm munge > /dev/null; } ||
    fail "could not install slurm-wlm and munge with apt-get"
fi

tmp=$(mktemp -d /tmp/workbench-slurm.XXXXXX)
pids=()
stop() {
  local code=$?
  # Only what this script started: its jobs (on its own cluster) and its daemons, by pid.
  if [ -n "${SLURM_CONF:-}" ] && [ -f "${SLURM_CONF:-}" ]; then
    scancel --user root 2> /dev/null || true
  fi
  for pid in "${pids[@]}"; do
    kill "$pid" 2> /dev/null || true
  done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do
      kill -0 "$pid" 2> /dev/null || break
      sleep 0.1
    done
    kill -9 "$pid" 2> /dev/null || true
  done
  if [ "$code" != 0 ]; then
    for log in "$tmp"/log/*.log; do
      [ -f "$log" ] && { echo "--- $log (last lines)" >&2; tail -n 20 "$log" >&2; }
    done
  fi
  rm -rf "$tmp"
  exit "$code"
}
trap stop EXIT INT TERM

mkdir -p "$tmp"/{munge,state,spool,log,bin,work,one}
chmod 700 "$tmp/munge"

# munge: a fresh key, the daemon on a socket of its own.
mungekey --create --keyfile "$tmp/munge/munge.key" 2> "$tmp/log/mungekey.log" ||
  dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 600 "$tmp/munge/munge.key"
socket="$tmp/munge/munge.socket"
munged --foreground --force --key-file="$tmp/munge/munge.key" --socket="$socket" \
  --pid-file="$tmp/munge/munged.pid" --seed-file="$tmp/munge/seed" \
  --log-file="$tmp/log/munged.log" > /dev/null 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$socket" ] && break; sleep 0.1; done
[ -S "$socket" ] || fail "munged did not start (see $tmp/log/munged.log above)"

# slurm.conf: this host as the one node (its name, CPUs and memory as slurmd sees them), the
# plugins that need neither systemd nor cgroups, every state file under $tmp.
node=$(slurmd -C | head -n 1 | sed 's/ UpTime=.*//')
[[ $node == NodeName=* ]] || fail "slurmd -C did not describe this host: $node"
host=$(echo "$node" | sed 's/^NodeName=\([^ ]*\).*/\1/')
export SLURM_CONF="$tmp/slurm.conf"
cat > "$SLURM_CONF" << EOF
ClusterName=workbench-ci
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
SlurmctldPort=16817
SlurmdPort=16818
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=30
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=ci Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -D -f "$SLURM_CONF" > "$tmp/log/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D -f "$SLURM_CONF" > "$tmp/log/slurmd.out" 2>&1 &
pids+=($!)
state=""
for _ in $(seq 120); do
  state=$(sinfo -h -o %t 2> /dev/null || true)
  [ "$state" = idle ] && break
  sleep 0.5
done
[ "$state" = idle ] || fail "the node did not become idle within 60 s (sinfo says ${state:-nothing}; slurmctld and slurmd logs above)"
echo "ci/slurm.sh: one-node Slurm up on $host after $((SECONDS - started)) s"

# The workbench the jobs run: the build under test, first on PATH (sbatch passes the
# environment on to the jobs).
ln -s "$bin" "$tmp/bin/workbench"
export PATH="$tmp/bin:$PATH"

# The page's `slurm` blocks: `file=NAME` ones into NAME, the others into block-<k>[-label].sh.
extract() {
  awk -v dir="$1" '
    /^```[a-z]+ slurm/ {
      inside = 1; out = ""
      for (i = 3; i <= NF; i++) if ($i ~ /^file=/) out = dir "/" substr($i, 6)
      if (out == "") { k++; out = dir "/block-" k (NF >= 3 ? "-" $3 : "") ".sh" }
      system("mkdir -p \"$(dirname \"" out "\")\"")
      printf "" > out
      next
    }
    /^```/ { if (inside) close(out); inside = 0; next }
    inside { print >> out }
  ' "$guide"
}
extract "$tmp/work"
extract "$tmp/one"
for f in exp.sbatch table.sbatch block-1.sh block-2-resubmit.sh try/exp.json try/table.json; do
  [ -s "$tmp/work/$f" ] || fail "$guide has no \`slurm\` block for $f"
done

# Waits until this cluster has no job left (the merges run after their arrays).
wait_jobs() {
  for _ in $(seq 600); do
    [ -z "$(squeue -h -o %i)" ] && return 0
    sleep 0.5
  done
  squeue >&2
  fail "jobs still queued or running after 300 s"
}

# Every file of a finished folder but the machine-dependent ones must be the one run's.
same() {
  local a=$1 b=$2 names
  [ -f "$b/manifest.json" ] || {
    tail -n 5 "$tmp"/work/slurm-*.out >&2 || true
    fail "$b was not written (the job outputs above)"
  }
  names() { (cd "$1" && ls | grep -Ev '^timings|-cost\.svg$|-cost\.caption\.txt$'); }
  [ "$(names "$a")" = "$(names "$b")" ] || fail "$b does not hold the files of $a: $(diff <(names "$a") <(names "$b") | tr '\n' ' ')"
  for f in $(names "$a"); do
    cmp -s "$a/$f" "$b/$f" || fail "$b/$f differs from one unsharded run's ($a/$f)"
  done
  echo "ci/slurm.sh: $b = one unsharded run, byte for byte ($(names "$a" | wc -l) files)"
}

# 1. The walk-through as printed, and one unsharded run of each file.
(cd "$tmp/work" && bash block-1.sh > /dev/null)
(cd "$tmp/one" && workbench run try/exp.json -q > /dev/null && workbench render try/table.json -q > /dev/null) 2> "$tmp/log/one.log" ||
  fail "the unsharded runs failed: $(cat "$tmp/log/one.log")"
wait_jobs
same "$tmp/one/results/exp" "$tmp/work/results/exp"
same "$tmp/one/results/table" "$tmp/work/results/table"

# 2. Task 2 of the experiment cancelled while it runs, then resubmitted as the page shows.
cd "$tmp/work"
rm -rf shards/exp-2 results/exp
job=$(sbatch --parsable --array=2 exp.sbatch)
log=shards/exp-2/trials.partial.csv
for _ in $(seq 600); do
  [ -f "$log" ] && [ "$(wc -l < "$log")" -gt 10 ] && break
  sleep 0.05
done
scancel "$job"
for _ in $(seq 100); do
  [ -z "$(squeue -h -j "$job" -o %i 2> /dev/null)" ] && break
  sleep 0.1
done
[ -f shards/exp-2/manifest.json ] && fail "task 2 finished before it could be cancelled; make try/exp.json slower"
[ -f "$log" ] || fail "task 2 was cancelled before it wrote its unit log"
echo "ci/slurm.sh: task 2 cancelled with $(($(wc -l < "$log") - 2)) rows in its unit log"
bash block-2-resubmit.sh > /dev/null
wait_jobs
grep -q "resumed: [1-9]" slurm-*_2.out ||
  fail "the resubmitted task did not resume from its unit log: $(cat slurm-*_2.out)"
same "$tmp/one/results/exp" "$tmp/work/results/exp"
echo "ci/slurm.sh: passed in $((SECONDS - started)) s"
