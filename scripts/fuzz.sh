#!/usr/bin/env bash
# Builds draco's libFuzzer targets (tests/fuzz, docs/hardening.md) with clang and runs each for
# a while on its seed corpus; fails when any target finds a crash, a leak, a timeout, an
# out-of-memory or a broken memory bound.
#
#   scripts/fuzz.sh [--seconds N] [--build-dir DIR] [--jobs N] [TARGET...]
#
#   --seconds N      per target (default 30; env FUZZ_SECONDS)
#   --build-dir DIR  clang build folder, configured with -DDRACO_FUZZ=ON when it has no cache
#                    yet (default build-fuzz; env FUZZ_BUILD_DIR)
#   --jobs N         build jobs (default nproc; env JOBS)
#   TARGET...        fuzz_fleet_codec fuzz_udp_datagram fuzz_graph_loader fuzz_recording
#                    fuzz_rosbag fuzz_pointcloud (default all)
# Environment: FUZZ_TIMEOUT (seconds per input before it counts as a hang, default 5),
# FUZZ_RSS_MB (default 2048), FUZZ_ARGS (more libFuzzer flags, e.g. "-runs=1000000").
#
# The repository's seeds (tests/fuzz/corpus/<target>) are only read; what the fuzzer adds goes
# to DIR/fuzz-corpus/<target> (kept between runs), findings to DIR/fuzz-artifacts/<target>,
# and each run's log to DIR/fuzz-logs/<target>.log. Needs clang and libclang-rt-14-dev
# (scripts/debian-packages.txt). Reproduce a finding with: DIR/tests/fuzz/<target> <file>.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)

seconds=${FUZZ_SECONDS:-30}
build_dir=${FUZZ_BUILD_DIR:-build-fuzz}
jobs=${JOBS:-$(nproc)}
timeout=${FUZZ_TIMEOUT:-5}
rss_mb=${FUZZ_RSS_MB:-2048}
all_targets=(fuzz_fleet_codec fuzz_udp_datagram fuzz_graph_loader fuzz_recording fuzz_rosbag fuzz_pointcloud)
targets=()
while [ $# -gt 0 ]; do
  case "$1" in
    --seconds) seconds=$2; shift 2 ;;
    --build-dir) build_dir=$2; shift 2 ;;
    --jobs) jobs=$2; shift 2 ;;
    -h|--help) sed -n '2,23p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "fuzz.sh: unknown option $1 (see --help)" >&2; exit 2 ;;
    *) targets+=("$1"); shift ;;
  esac
done
[ ${#targets[@]} -eq 0 ] && targets=("${all_targets[@]}")

log() { printf '[fuzz] %s\n' "$*"; }

cc=$(command -v clang || command -v clang-14 || true)
cxx=$(command -v clang++ || command -v clang++-14 || true)
if [ -z "$cc" ] || [ -z "$cxx" ]; then
  echo "fuzz.sh: clang not found; install the packages of scripts/debian-packages.txt" >&2
  exit 1
fi
probe=$(mktemp -d)
trap 'rm -rf "$probe"' EXIT
echo 'extern "C" int LLVMFuzzerTestOneInput(const unsigned char*, unsigned long) { return 0; }' \
  >"$probe/probe.cpp"
if ! "$cxx" -fsanitize=fuzzer,address,undefined "$probe/probe.cpp" -o "$probe/probe" \
  >"$probe/log" 2>&1; then
  cat "$probe/log" >&2
  echo "fuzz.sh: $cxx cannot link libFuzzer; install libclang-rt-14-dev" \
    "(scripts/debian-packages.txt)" >&2
  exit 1
fi

if [ ! -f "$build_dir/CMakeCache.txt" ]; then
  generator=()
  command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
  log "configuring $build_dir with $cxx"
  CC=$cc CXX=$cxx cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DDRACO_FUZZ=ON -DDRACO_BUILD_TESTS=OFF >/dev/null
elif ! grep -q '^CMAKE_CXX_COMPILER:.*clang' "$build_dir/CMakeCache.txt"; then
  echo "fuzz.sh: $build_dir is not a clang build; give another --build-dir" >&2
  exit 1
else
  cmake -S . -B "$build_dir" -DDRACO_FUZZ=ON >/dev/null
fi
log "building ${targets[*]} in $build_dir with $jobs jobs"
cmake --build "$build_dir" -j "$jobs" --target "${targets[@]}"

symbolizer=$(command -v llvm-symbolizer || command -v llvm-symbolizer-14 || true)
[ -n "$symbolizer" ] && export ASAN_SYMBOLIZER_PATH=$symbolizer
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1}

rows=()
failed=0
for t in "${targets[@]}"; do
  bin="$build_dir/tests/fuzz/$t"
  seeds="$root/tests/fuzz/corpus/$t"
  corpus="$build_dir/fuzz-corpus/$t"
  artifacts="$build_dir/fuzz-artifacts/$t/"
  logfile="$build_dir/fuzz-logs/$t.log"
  mkdir -p "$corpus" "$artifacts" "$(dirname "$logfile")"
  dict=()
  [ -f "$root/tests/fuzz/$t.dict" ] && dict=(-dict="$root/tests/fuzz/$t.dict")
  log "$t: ${seconds} s"
  set +e
  # shellcheck disable=SC2086
  "$bin" -max_total_time="$seconds" -timeout="$timeout" -rss_limit_mb="$rss_mb" \
    -print_final_stats=1 -artifact_prefix="$artifacts" "${dict[@]}" ${FUZZ_ARGS:-} \
    "$corpus" "$seeds" >"$logfile" 2>&1
  rc=$?
  set -e
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$logfile" | tail -1)
  rate=$(sed -n 's/^stat::average_exec_per_sec: *//p' "$logfile" | tail -1)
  status_line=$(grep -E '^#[0-9]+' "$logfile" | tail -1 || true)
  corp=$(sed -n 's/.* corp: \([^ ]*\).*/\1/p' <<<"$status_line")
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$status_line")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$status_line")
  if [ "$rc" -eq 0 ]; then
    result=ok
  else
    failed=1
    finding=$(grep -o "Test unit written to .*" "$logfile" | tail -1 | sed 's/Test unit written to //')
    kind=$(grep -m1 -oE "ERROR: [A-Za-z]+: [a-z -]+|memory bound broken|runtime error|deadly signal" \
      "$logfile" || echo "exit $rc")
    result="FAILED: $kind${finding:+ -> $finding}"
  fi
  rows+=("$t|${runs:-?}|${rate:-?}|${corp:-?}|${cov:-?}|${ft:-?}|$result")
done

printf '\n%-20s %10s %8s %16s %7s %8s  %s\n' target runs exec/s "corpus (n/size)" cov features result
for row in "${rows[@]}"; do
  IFS='|' read -r t runs rate corp cov ft result <<<"$row"
  printf '%-20s %10s %8s %16s %7s %8s  %s\n' "$t" "$runs" "$rate" "$corp" "$cov" "$ft" "$result"
done
if [ "$failed" -ne 0 ]; then
  echo
  echo "fuzz.sh: a target failed; its log is in $build_dir/fuzz-logs/, the input in $build_dir/fuzz-artifacts/" >&2
  exit 1
fi
