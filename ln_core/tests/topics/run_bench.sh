#!/usr/bin/env bash
# Topic benchmarks of ln_core, as LN 2.9's reference measurement
# (shared/reference/ln29/README.md §4): 64 B pub/sub round trip with
# blocking reads (both processes on one CPU, and on two CPUs) and the
# one-way 64 B rate with 1 and 256 buffers.
#
# usage: run_bench.sh BUILD_DIR [RUNS] [ROUND_TRIPS]
# Starts its own ln_manager on a free loopback port and stops it (and every
# process it started) at the end. Prints one JSON line per measurement.
set -euo pipefail
build=${1:?usage: run_bench.sh BUILD_DIR [RUNS] [ROUND_TRIPS]}
runs=${2:-3}
round_trips=${3:-20000}
here=$(cd "$(dirname "$0")" && pwd)
work=$(mktemp -d /tmp/ln_topic_bench.XXXXXX)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

export LN_MESSAGE_DEFINITION_DIRS=$here/msgdefs
"$build/ln_manager" --listen 127.0.0.1:0 --log-level warning > "$work/manager.out" 2>&1 &
pids+=($!)
for _ in $(seq 100); do
  address=$(sed -n 's/^ln_manager: listening on //p' "$work/manager.out")
  [ -n "$address" ] && break
  sleep 0.05
done
[ -n "$address" ] || { echo "the manager did not start" >&2; cat "$work/manager.out" >&2; exit 1; }
export LN_MANAGER=$address

# Waits (at most 60 s) until the machine is nearly idle (other work on a
# shared 2-CPU machine distorts every figure); prints whether it got there.
quiet() {
  for _ in $(seq 60); do
    read -r _ u1 n1 s1 i1 w1 q1 r1 _ < /proc/stat
    sleep 0.5
    read -r _ u2 n2 s2 i2 w2 q2 r2 _ < /proc/stat
    local busy=$(( (u2+n2+s2+q2+r2) - (u1+n1+s1+q1+r1) )) idle=$(( (i2+w2) - (i1+w1) ))
    if [ $(( busy * 100 )) -le $(( (busy + idle) * 15 )) ]; then echo true; return; fi
    sleep 0.5
  done
  echo false
}

pingpong() {  # placement (same | split) quiet
  local pong_cpu=1 ping_cpu=1
  [ "$1" = split ] && ping_cpu=0
  timeout 120 taskset -c $pong_cpu "$build/ln_bench_pingpong" pong &
  local pong=$!
  pids+=($pong)
  local result
  result=$(timeout 120 taskset -c $ping_cpu "$build/ln_bench_pingpong" ping "$round_trips")
  wait $pong || true
  echo "${result%\}}, \"placement\": \"$1\", \"quiet\": $2}"
}

rate() {  # placement buffers quiet
  local sub_cpu=1 pub_cpu=1
  [ "$1" = split ] && pub_cpu=0
  timeout 60 taskset -c $sub_cpu "$build/ln_bench_rate" sub "$2" > "$work/sub.out" &
  local sub=$!
  pids+=($sub)
  local pub_result
  pub_result=$(timeout 60 taskset -c $pub_cpu "$build/ln_bench_rate" pub 3 "$2")
  wait $sub || true
  echo "${pub_result%\}}, \"placement\": \"$1\", \"quiet\": $3}"
  local sub_result
  sub_result=$(cat "$work/sub.out")
  echo "${sub_result%\}}, \"placement\": \"$1\", \"quiet\": $3}"
}

for run in $(seq "$runs"); do
  for placement in same split; do pingpong $placement "$(quiet)"; done
  for placement in split same; do
    for buffers in 1 256; do rate $placement $buffers "$(quiet)"; done
  done
done
