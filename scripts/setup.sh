#!/usr/bin/env bash
# One setup script behind both README commands.
#   scripts/setup.sh demo   install missing packages, build, simulate the default marina
#                           mission, replay it through local SLAM, evaluate, write the report
#                           (extra arguments go to draco-local-slam, e.g. --set k=v;
#                           MISSION=dir and RUN_DIR=dir choose the folders)
#   scripts/setup.sh test   install missing packages, build with -Werror, format check, all tests
#   scripts/setup.sh build  install missing packages and build only
# Environment: BUILD_DIR (default build), JOBS (default nproc), DRACO_SANITIZE=ON for ASan/UBSan.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$(pwd)
mode=${1:-demo}
shift || true
BUILD_DIR=${BUILD_DIR:-build}
JOBS=${JOBS:-$(nproc)}

log() { printf '[setup] %s\n' "$*"; }

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
    install_packages
    format_check
    configure_and_build ON
    log "running tests"
    ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS" --timeout 600 "$@"
    ;;
  *)
    echo "usage: scripts/setup.sh demo|test|build" >&2
    exit 2
    ;;
esac
