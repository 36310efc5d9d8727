#!/usr/bin/env bash
# CI (issue 31): a machine where Slurm cannot start must fail ci/slurm.sh with the reason, never
# skip, and leave no daemon running. Each case points ci/slurm.sh (through CI_SLURM_BIN) at fake
# munged/slurmctld/slurmd/sinfo programs that fail in one way, and checks the exit code (1), the
# last stderr line (`ci/slurm.sh: error: <reason>`) and that every fake daemon it started is
# gone. Needs neither root nor Slurm; takes a few seconds.
set -euo pipefail
cd "$(dirname "$0")/.."
tmp=$(mktemp -d /tmp/workbench-slurm-test.XXXXXX)
trap 'rm -rf "$tmp"' EXIT
failures=0

# fakes DIR [NAME=BEHAVIOUR…]: every program ci/slurm.sh calls, in DIR. Behaviours: `ok` (a
# daemon that runs until killed; munged creates its socket), `exit` (prints a fatal line and
# exits with status 3), `daemon-exit` (slurmd: `-C` works, the daemon exits), `missing` (no such program); `sinfo=STATE` prints STATE.
fakes() {
  local dir=$1 name behaviour
  shift
  mkdir -p "$dir" "$tmp/pids"
  declare -A how=([munged]=ok [slurmctld]=ok [slurmd]=ok [sinfo]=down [sbatch]=ok [squeue]=ok [scancel]=ok)
  for kv in "$@"; do how[${kv%%=*}]=${kv#*=}; done
  for name in "${!how[@]}"; do
    behaviour=${how[$name]}
    [ "$behaviour" = missing ] && continue
    {
      echo '#!/usr/bin/env bash'
      case $name:$behaviour in
        sinfo:*) echo "echo $behaviour" ;;
        *:exit) echo "echo \"$name: fatal: fake failure\" >&2; exit 3" ;;
        munged:ok)
          echo "echo \$\$ > '$tmp/pids/munged'"
          echo 'for a in "$@"; do case $a in --socket=*) sock=${a#--socket=} ;; esac; done'
          echo "exec python3 -c 'import socket, sys, time; s = socket.socket(socket.AF_UNIX); s.bind(sys.argv[1]); time.sleep(1000)' \"\$sock\""
          ;;
        slurmd:ok)
          echo 'if [ "${1:-}" = -C ]; then echo "NodeName=fakehost CPUs=2 RealMemory=1000"; echo "UpTime=0-00:00:01"; exit 0; fi'
          echo "echo \$\$ > '$tmp/pids/slurmd'"
          echo 'exec sleep 1000'
          ;;
        slurmd:daemon-exit)
          echo 'if [ "${1:-}" = -C ]; then echo "NodeName=fakehost CPUs=2 RealMemory=1000"; exit 0; fi'
          echo 'echo "slurmd: fatal: fake failure" >&2; exit 3'
          ;;
        slurmctld:ok) echo "echo \$\$ > '$tmp/pids/slurmctld'"; echo 'exec sleep 1000' ;;
        *) echo 'exit 0' ;;
      esac
    } > "$dir/$name"
    chmod +x "$dir/$name"
  done
}

# expect NAME WANTED [ENV=VALUE…] -- [FAKE=BEHAVIOUR…]
expect() {
  local name=$1 wanted=$2 code last pid
  shift 2
  local env=()
  while [ "$1" != -- ]; do env+=("$1"); shift; done
  shift
  rm -rf "$tmp/pids"
  fakes "$tmp/$name" "$@"
  code=0
  env CI_SLURM_BIN="$tmp/$name" CI_SLURM_INSTALL=false CI_SLURM_IDLE_TIMEOUT=2 "${env[@]}" \
    ci/slurm.sh /bin/true > "$tmp/$name.out" 2> "$tmp/$name.err" || code=$?
  last=$(tail -n 1 "$tmp/$name.err")
  if [ "$code" != 1 ] || [[ $last != "ci/slurm.sh: error: "*"$wanted"* ]]; then
    echo "ci/slurm-test.sh: $name: want exit 1 and a last line naming \"$wanted\"; got exit $code and: $last" >&2
    failures=$((failures + 1))
  fi
  for pid in "$tmp"/pids/*; do
    [ -f "$pid" ] || continue
    if kill -0 "$(cat "$pid")" 2> /dev/null; then
      echo "ci/slurm-test.sh: $name: the fake $(basename "$pid") (pid $(cat "$pid")) is still running" >&2
      kill "$(cat "$pid")" 2> /dev/null || true
      failures=$((failures + 1))
    fi
  done
  echo "ci/slurm-test.sh: $name: $last"
}

expect install-fails "package install failed: \`false\` exited with status 1 (slurmctld sinfo missing)" -- \
  slurmctld=missing sinfo=missing
expect install-incomplete "package install: munged still missing after \`true\`" CI_SLURM_INSTALL=true -- \
  munged=missing
expect munged-exits "munged did not start: it exited with status 3 (munged: fatal: fake failure) before creating its socket" -- \
  munged=exit
expect slurmd-C-fails "slurmd: \`slurmd -C\` failed: slurmd: fatal: fake failure" -- slurmd=exit
expect slurmctld-exits "slurmctld did not start: it exited with status 3 (slurmctld: fatal: fake failure) before the node was up" -- \
  slurmctld=exit
expect slurmd-exits "slurmd did not start: it exited with status 3 (slurmd: fatal: fake failure) before the node was up" -- \
  slurmd=daemon-exit
expect node-down "node not idle within 2 s (sinfo says down;" --
if [ "$failures" != 0 ]; then
  echo "ci/slurm-test.sh: $failures failure(s)" >&2
  exit 1
fi
echo "ci/slurm-test.sh: passed"
