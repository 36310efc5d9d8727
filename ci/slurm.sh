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
#
# Any failure ends with exit 1 and, as the last line on stderr, `ci/slurm.sh: error: <reason>`
# naming what failed (package install, munged, slurmctld, slurmd, the node not idle in time, a
# command of this script, a job's result); the daemons' logs come before it.
# For ci/slurm-test.sh (the start-up failures, without root or Slurm installed):
#   CI_SLURM_BIN=DIR          take munged, mungekey, slurmctld, slurmd, sinfo, sbatch, squeue
#                             and scancel from DIR (no root needed);
#   CI_SLURM_INSTALL=COMMAND  how to install missing programs [default: apt-get update and
#                             install slurm-wlm and munge];
#   CI_SLURM_IDLE_TIMEOUT=S   how long the node may take to become idle [default: 60].
set -Eeuo pipefail
cd "$(dirname "$0")/.."
repo=$(pwd)
bin=$(realpath "${1:-target/release/workbench}")
guide="$repo/docs/guide/merge-and-clusters.md"
started=$SECONDS
idle_timeout=${CI_SLURM_IDLE_TIMEOUT:-60}
fake_bin=${CI_SLURM_BIN:-}

reason=""
fail() {
  reason="$*"
  exit 1
}
# A command of this script that fails (with set -e) fails with its line and text.
trap 'fail "line $LINENO: \`$BASH_COMMAND\` failed (exit $?)"' ERR

tmp=""
pids=()
names=()
stop() {
  local code=$?
  trap - ERR
  set +e
  # Only what this script started: its jobs (on its own cluster) and its daemons, by pid.
  if [ -n "${SLURM_CONF:-}" ] && [ -f "${SLURM_CONF:-}" ] && command -v scancel > /dev/null; then
    scancel --user "$(id -un)" 2> /dev/null
  fi
  for pid in "${pids[@]}"; do
    kill "$pid" 2> /dev/null
  done
  for pid in "${pids[@]}"; do
    for _ in $(seq 50); do
      kill -0 "$pid" 2> /dev/null || break
      sleep 0.1
    done
    kill -9 "$pid" 2> /dev/null
    wait "$pid" 2> /dev/null
  done
  if [ "$code" != 0 ] && [ -n "$tmp" ]; then
    for log in "$tmp"/log/*; do
      [ -s "$log" ] && { echo "--- $log (last lines)" >&2; tail -n 20 "$log" >&2; }
    done
  fi
  [ -n "$tmp" ] && rm -rf "$tmp"
  if [ "$code" != 0 ]; then
    echo "ci/slurm.sh: error: ${reason:-exited with status $code}" >&2
  fi
  exit "$code"
}
trap stop EXIT
trap 'reason="interrupted"; exit 1' INT TERM

programs=(munged slurmctld slurmd sinfo sbatch squeue scancel)
have() {
  if [ -n "$fake_bin" ]; then [ -x "$fake_bin/$1" ]; else command -v "$1" > /dev/null; fi
}
missing() {
  local p out=()
  for p in "${programs[@]}"; do have "$p" || out+=("$p"); done
  echo "${out[*]}"
}
if [ -n "$fake_bin" ]; then
  export PATH="$fake_bin:$PATH"
else
  [ "$(id -u)" = 0 ] || fail "must run as root (it installs slurm-wlm and munge and starts their daemons)"
fi
[ -x "$bin" ] || fail "$bin is not an executable workbench; build it first (cargo test --release)"

if [ -n "$(missing)" ]; then
  export DEBIAN_FRONTEND=noninteractive
  install=${CI_SLURM_INSTALL:-"apt-get update -qq && apt-get install -y -qq slurm-wlm munge > /dev/null"}
  bash -c "$install" < /dev/null > /dev/null 2>&1 ||
    fail "package install failed: \`$install\` exited with status $? ($(missing) missing)"
  [ -z "$(missing)" ] || fail "package install: $(missing) still missing after \`$install\`"
fi

tmp=$(mktemp -d /tmp/workbench-slurm.XXXXXX)
mkdir -p "$tmp"/{munge,state,spool,log,bin,work,one}
chmod 700 "$tmp/munge"

# Starts a daemon in the background, its output in $tmp/log/<name>.out.
start() {
  local name=$1
  shift
  "$@" > "$tmp/log/$name.out" 2>&1 &
  pids+=($!)
  names+=("$name")
}
# Fails naming the first daemon that is no longer running, with its exit status and last line.
check_alive() {
  local i status last
  for i in "${!pids[@]}"; do
    if ! kill -0 "${pids[$i]}" 2> /dev/null; then
      status=0
      wait "${pids[$i]}" || status=$?
      last=$(tail -n 1 "$tmp/log/${names[$i]}.out" 2> /dev/null || true)
      fail "${names[$i]} did not start: it exited with status $status (${last:-no output}) $1"
    fi
  done
}

# munge: a fresh key, the daemon on a socket of its own.
mungekey --create --keyfile "$tmp/munge/munge.key" 2> "$tmp/log/mungekey.log" ||
  dd if=/dev/urandom of="$tmp/munge/munge.key" bs=1024 count=1 status=none
chmod 600 "$tmp/munge/munge.key"
socket="$tmp/munge/munge.socket"
start munged munged --foreground --force --key-file="$tmp/munge/munge.key" --socket="$socket" \
  --pid-file="$tmp/munge/munged.pid" --seed-file="$tmp/munge/seed" \
  --log-file="$tmp/log/munged.log"
for _ in $(seq 50); do
  [ -S "$socket" ] && break
  check_alive "before creating its socket"
  sleep 0.1
done
[ -S "$socket" ] || fail "munged did not start: no socket $socket after 5 s"

# slurm.conf: this host as the one node (its name, CPUs and memory as slurmd sees them), the
# plugins that need neither systemd nor cgroups, every state file under $tmp.
# (Its whole output first: `| head -n 1` could close the pipe before slurmd writes its second
# line, and under pipefail the SIGPIPE would read as slurmd failing.)
described=$(slurmd -C 2> "$tmp/log/slurmd-C.log") ||
  fail "slurmd: \`slurmd -C\` failed: $(tail -n 1 "$tmp/log/slurmd-C.log")"
node=$(printf '%s\n' "$described" | sed -n '1{s/ UpTime=.*//;p}')
[[ $node == NodeName=* ]] || fail "slurmd: \`slurmd -C\` did not describe this host: ${node:-no output}"
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
start slurmctld slurmctld -D -f "$SLURM_CONF"
start slurmd slurmd -D -f "$SLURM_CONF"
state=""
deadline=$((SECONDS + idle_timeout))
while :; do
  check_alive "before the node was up"
  state=$(sinfo -h -o %t 2> /dev/null || true)
  [ "$state" = idle ] && break
  [ "$SECONDS" -ge "$deadline" ] && break
  sleep 0.5
done
[ "$state" = idle ] ||
  fail "node not idle within $idle_timeout s (sinfo says ${state:-nothing}; slurmctld and slurmd logs above)"
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
