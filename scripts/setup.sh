#!/usr/bin/env bash
# One setup script behind both README commands.
#   scripts/setup.sh demo   install missing packages, build, simulate the default marina
#                           mission, replay it through local SLAM, evaluate, write the report
#                           (extra arguments go to draco-local-slam, e.g. --set k=v;
#                           MISSION=dir and RUN_DIR=dir choose the folders)
#   scripts/setup.sh test   install missing packages, format check, build with -Werror, all
#                           tests; then the hardening stages (docs/hardening.md, "What CI runs"):
#                           one clang build (-O1) of the fuzzers and of the suite under ASan +
#                           UBSan, every fuzzer 30 s on its corpus, the suite under ASan + UBSan
#                           (the long end-to-end runs left out), the tsan-labelled tests under
#                           TSan. Any test failure, sanitizer report or fuzz finding fails it.
#   scripts/setup.sh build  install missing packages and build only
#   scripts/setup.sh --help this text
# Environment: BUILD_DIR (default build), JOBS (default nproc), DRACO_SANITIZE=ON for ASan/UBSan
# in BUILD_DIR. For `test`: DRACO_CI_SANITIZERS=0 skips the hardening stages (developers; CI
# runs them), SAN_BUILD_DIR (default build-san), TSAN_BUILD_DIR (default build-tsan),
# FUZZ_SECONDS (default 30 per target).
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
mode=${1:-demo}
shift || true
BUILD_DIR=${BUILD_DIR:-build}
JOBS=${JOBS:-$(nproc)}

log() { printf '[setup] %s\n' "$*"; }

# Stage headers and a table of wall times at the end (also when a stage fails).
stage_rows=()
stage_name=""
stage_t0=0
stage() {
  stage_end ok
  stage_name=$1
  stage_t0=$(date +%s)
  printf '\n[setup] ==================== %s ====================\n' "$stage_name"
}
stage_end() {
  [ -n "$stage_name" ] || return 0
  stage_rows+=("$(printf '%-58s %6d s  %s' "$stage_name" $(($(date +%s) - stage_t0)) "$1")")
  stage_name=""
}
stage_summary() {
  local rc=$?
  stage_end "$([ $rc -eq 0 ] && echo ok || echo FAILED)"
  [ ${#stage_rows[@]} -gt 0 ] || return 0
  printf '\n[setup] stage wall times (%s)\n' "$([ $rc -eq 0 ] && echo all passed || echo FAILED)"
  printf '  %s\n' "${stage_rows[@]}"
}

install_packages() {
  local missing=()
  while read -r pkg; do
    pkg=${pkg%%#*}; pkg=$(echo "$pkg" | xargs)
    [ -z "$pkg" ] && continue
    dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
  done < scripts/debian-packages.txt
  if [ ${#missing[@]} -eq 0 ]; then
    log "all Debian packages present"
    return
  fi
  log "installing ${#missing[@]} missing packages: ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"
}

configure_and_build() {
  local werror=$1
  local generator=()
  command -v ninja >/dev/null 2>&1 && generator=(-G Ninja)
  if [ ! -f "$BUILD_DIR/CMakeCache.txt" ]; then
    cmake -S . -B "$BUILD_DIR" "${generator[@]}" -DCMAKE_BUILD_TYPE=Release
  fi
  # demo keeps the build folder's -Werror setting (no rebuild after a test run); test sets it.
  local flags=(-DDRACO_SANITIZE="${DRACO_SANITIZE:-OFF}")
  [ -n "$werror" ] && flags+=(-DDRACO_WERROR="$werror")
  cmake -S . -B "$BUILD_DIR" "${flags[@]}" >/dev/null
  log "building in $BUILD_DIR with $JOBS jobs"
  cmake --build "$BUILD_DIR" -j "$JOBS"
}

format_check() {
  log "clang-format check"
  local bad
  bad=$(git ls-files '*.cpp' '*.hpp' '*.h' | xargs -r clang-format --dry-run -Werror 2>&1 | grep -c 'error:' || true)
  if [ "$bad" != "0" ]; then
    git ls-files '*.cpp' '*.hpp' '*.h' | xargs -r clang-format --dry-run -Werror
    log "format check failed: run 'git ls-files \"*.cpp\" \"*.hpp\" | xargs clang-format -i'"
    exit 1
  fi
}

case "$mode" in
  build)
    install_packages
    configure_and_build OFF
    ;;
  demo)
    # The main job: simulate the default three-robot marina mission (once; ~2.7 GB), run the
    # team as three draco-robot daemons over Cyclone DDS on loopback and, for comparison, in
    # one process; evaluate the DDS run against ground truth and write the report.
    install_packages
    configure_and_build ""
    mission=${MISSION:-runs/missions/marina}
    run_dir=${RUN_DIR:-runs/demo-marina}
    if [ ! -f "$mission/mission.yaml" ]; then
      log "simulating config/missions/marina.yaml into $mission"
      "$BUILD_DIR/apps/sim/draco-sim" config/missions/marina.yaml --out "$mission"
    else
      log "reusing the mission in $mission (delete it to simulate again)"
    fi
    "$BUILD_DIR/apps/fleet/draco-fleet" "$mission" --mode both --out "$run_dir" "$@"
    "$BUILD_DIR/apps/eval/draco-eval" "$run_dir/dds" --mission "$mission"
    ;;
  test)
    trap stage_summary EXIT
    t_start=$(date +%s)
    stage "packages and format check"
    install_packages
    format_check
    stage "Release build with -Werror ($BUILD_DIR)"
    configure_and_build ON
    stage "all tests (ctest -j $JOBS, $BUILD_DIR)"
    ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS" --timeout 600 "$@"
    if [ "${DRACO_CI_SANITIZERS:-1}" = 0 ]; then
      stage_end ok
      log "DRACO_CI_SANITIZERS=0: sanitizer and fuzz stages skipped (CI runs them)"
      exit 0
    fi
    san_dir=${SAN_BUILD_DIR:-build-san}
    tsan_dir=${TSAN_BUILD_DIR:-build-tsan}
    # One clang folder serves the fuzzers (linked with -fsanitize=fuzzer) and the suite (linked
    # with ASan + UBSan); -O1 with line tables builds in about half the time of -O2 -g.
    stage "ASan + UBSan + fuzzer build (clang -O1, $san_dir)"
    SANITIZE_BUILD_ONLY=1 SANITIZE_FUZZ=ON JOBS=$JOBS scripts/sanitize.sh asan "$san_dir"
    stage "fuzzers, ${FUZZ_SECONDS:-30} s each on their corpora ($san_dir)"
    FUZZ_TIMEOUT=${FUZZ_TIMEOUT:-20} scripts/fuzz.sh --seconds "${FUZZ_SECONDS:-30}" \
      --build-dir "$san_dir" --jobs "$JOBS"
    stage "test suite under ASan + UBSan ($san_dir)"
    SANITIZE_FUZZ=ON CTEST_JOBS=$JOBS scripts/sanitize.sh asan "$san_dir"
    stage "tsan-labelled tests under TSan ($tsan_dir)"
    JOBS=$JOBS CTEST_JOBS=$JOBS scripts/sanitize.sh tsan "$tsan_dir"
    stage_end ok
    log "test: everything passed in $(($(date +%s) - t_start)) s"
    ;;
  -h|--help)
    sed -n '2,18p' "$0" | sed 's/^# \{0,1\}//'
    ;;
  *)
    echo "usage: scripts/setup.sh demo|test|build|--help" >&2
    exit 2
    ;;
esac
