#!/usr/bin/env bash
# Sanitizer builds and runs (docs/hardening.md, "Sanitizers").
#   scripts/sanitize.sh asan [build-dir]  ASan + UBSan (-fno-sanitize-recover=all): build
#                                         everything, run the whole suite but the worlds
#                                         smoke test (default build-asan; ASAN_FULL=1: all)
#   scripts/sanitize.sh tsan [build-dir]  ThreadSanitizer: build the threaded executor's, the
#                                         link's and the daemons' tests and run them (ctest -L
#                                         tsan; default build-tsan)
# Environment: JOBS (build jobs, default nproc), CTEST_JOBS (default 2), CTEST_ARGS (more ctest
# arguments, e.g. "-R Fleet"), ASAN_FULL=1 (also the worlds smoke test: ~30 min under ASan).
# worlds.smoke_runs_judges_and_repeats is left out of the ASan run by default: four 480 s
# three-robot missions, ~7 min each under ASan, through code (generator, simulator, in-process
# team, evaluation) that the rest of the suite runs under ASan too (fleet.*, install.*, sim,
# team and agent tests).
# Any sanitizer report fails the test that produced it; suppressions of third-party findings
# are in scripts/sanitizers/ with the reason for each.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
kind=${1:-}
case "$kind" in
  asan) default_dir=build-asan ;;
  tsan) default_dir=build-tsan ;;
  *)
    echo "usage: $0 asan|tsan [build-dir]" >&2
    exit 2
    ;;
esac
build_dir=${2:-$default_dir}
JOBS=${JOBS:-$(nproc)}
CTEST_JOBS=${CTEST_JOBS:-2}
read -r -a ctest_args <<<"${CTEST_ARGS:-}"
supp=$root/scripts/sanitizers

log() { printf '[sanitize] %s\n' "$*"; }
seconds() { date +%s; }

generator=()
command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
if [ "$kind" = asan ]; then
  sanitize=ON
  targets=(all)
else
  sanitize=thread
  # graph_test, middleware_test, fleet_link_test and what tests/fleet_app runs.
  targets=(graph_test middleware_test fleet_link_test draco-sim draco-fleet draco-robot
    ros2_listener)
fi

log "configuring $build_dir (RelWithDebInfo, DRACO_SANITIZE=$sanitize)"
cmake -S . -B "$build_dir" "${generator[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DDRACO_SANITIZE="$sanitize" -DDRACO_WERROR=ON >/dev/null
t0=$(seconds)
log "building ${targets[*]} with $JOBS jobs"
cmake --build "$build_dir" -j "$JOBS" --target "${targets[@]}"
t1=$(seconds)
log "build took $((t1 - t0)) s"

# halt_on_error / exitcode: the first report ends the process with a non-zero status.
export ASAN_OPTIONS="detect_leaks=1:halt_on_error=1:detect_stack_use_after_return=0:strict_string_checks=1:check_initialization_order=1:${ASAN_OPTIONS:-}"
export LSAN_OPTIONS="suppressions=$supp/lsan.supp:print_suppressions=0:${LSAN_OPTIONS:-}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1:suppressions=$supp/ubsan.supp:${UBSAN_OPTIONS:-}"
export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$supp/tsan.supp:${TSAN_OPTIONS:-}"

cd "$build_dir"
status=0
if [ "$kind" = asan ]; then
  [ "${ASAN_FULL:-0}" = 1 ] || ctest_args=(-E '^worlds\.' "${ctest_args[@]}")
  log "running the whole suite under ASan + UBSan (ctest -j $CTEST_JOBS ${ctest_args[*]})"
  ctest -j "$CTEST_JOBS" --output-on-failure "${ctest_args[@]}" || status=$?
else
  log "running the tsan-labelled tests under TSan (ctest -L tsan -j $CTEST_JOBS ${ctest_args[*]})"
  ctest -L tsan -j "$CTEST_JOBS" --output-on-failure "${ctest_args[@]}" || status=$?
fi
t2=$(seconds)
log "tests took $((t2 - t1)) s (build $((t1 - t0)) s)"
exit $status
