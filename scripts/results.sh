#!/usr/bin/env bash
# The results page: every table of the paper this project reproduces (I-IV, Fig. 3), the
# per-robot ATE tables, link traffic and speed figures, from fresh runs, in docs/figures.md.
#
#   scripts/results.sh [--missions DIR] [--out DIR] [--page FILE] [--quick]
#
#   --missions DIR  recorded missions DIR/marina and DIR/airplane (default runs/missions);
#                   each is simulated from config/missions/<name>.yaml only when missing
#                   (about 2.7 GB and a minute each)
#   --out DIR       run folders, logs and benchmark JSON (default runs/results); emptied first
#   --page FILE     the page to write (default docs/figures.md)
#   --quick         skip the slow parts: the in-process team's report, local SLAM alone
#                   (draco-local-slam), the ground-truth seeded "possible loops" of
#                   draco-frontend-eval, sonar frames in the reports, the slowest benchmark
#                   cases and benchmark repetitions
#
# Per mission: draco-fleet --mode both (the running team, DDS and in-process), draco-eval on
# both modes (report.md: Table I-IV layouts, Fig. 3 of the running team), draco-local-slam and
# draco-eval on it (local SLAM alone), draco-frontend-eval (Fig. 3), draco-team-eval on its
# cached local SLAM (Table III: two-step / full PGO x PCM / GCM, the default experiment, which
# its run folder records as experiment.yaml), draco-fleet-sizes (Table IV on the cached
# keyframes); then the Google Benchmarks of docs/benchmarks.md; then
# scripts/figures.py composes the page from the run folders' files and, with the default
# --page, rewrites the headline block of README.md.
# A failing step is recorded (exit code on the page) and the others still run.
# Environment: BUILD_DIR (default build; configured and built with scripts/setup.sh build when
# it has no CMakeCache.txt, else only the needed targets are brought up to date), JOBS (build
# jobs, default nproc). Run it under `nice` on a shared machine.
set -uo pipefail
cd "$(dirname "$0")/.."

missions=runs/missions
out=runs/results
page=docs/figures.md
quick=0
while [ $# -gt 0 ]; do
  case "$1" in
    --missions) missions=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --page) page=$2; shift 2 ;;
    --quick) quick=1; shift ;;
    -h|--help) awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$0"; exit 0 ;;
    *) echo "results.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
BUILD_DIR=${BUILD_DIR:-build}
JOBS=${JOBS:-$(nproc)}
missions=${missions%/}
out=${out%/}

log() { printf '[results] %s\n' "$*" >&2; }

# ---- build
targets=(draco-sim draco-fleet draco-robot draco-local-slam draco-eval draco-frontend-eval
         draco-team-eval draco-fleet-sizes objects_bench cfar_bench icp_bench pose_graph_bench
         consistency_bench registration_bench team_bench)
if [ ! -f "$BUILD_DIR/CMakeCache.txt" ]; then
  log "no build in $BUILD_DIR: scripts/setup.sh build"
  BUILD_DIR=$BUILD_DIR JOBS=$JOBS scripts/setup.sh build || exit 1
else
  log "bringing $BUILD_DIR up to date (${#targets[@]} targets, $JOBS jobs)"
  cmake --build "$BUILD_DIR" -j "$JOBS" --target "${targets[@]}" || exit 1
fi
B=$BUILD_DIR

# ---- the run folder and its record (emptied only when it is one this script wrote)
if [ -e "$out" ] && [ ! -f "$out/steps.tsv" ] && [ -n "$(ls -A "$out" 2>/dev/null)" ]; then
  echo "results.sh: $out exists and is not a results folder; choose another --out" >&2
  exit 2
fi
rm -rf "$out"
mkdir -p "$out/logs" "$out/bench"
steps=$out/steps.tsv
printf 'step\tmission\twall_s\texit\tcommand\n' >"$steps"
quick_flag=""; [ "$quick" = 1 ] && quick_flag=" --quick"
invocation="scripts/results.sh --missions $missions --out $out"
[ "$page" != docs/figures.md ] && invocation+=" --page $page"
invocation+=$quick_flag

machine() {  # key=value lines: the stamp of the page
  echo "commit=$(git describe --always --dirty 2>/dev/null || echo unknown)"
  echo "nproc=$(nproc)"
  echo "cpu=$(grep -m1 '^model name' /proc/cpuinfo | cut -d: -f2- | sed 's/^ *//')"
  echo "ram_kb=$(awk '/^MemTotal/ {print $2}' /proc/meminfo)"
  echo "os=$(. /etc/os-release 2>/dev/null && echo "$PRETTY_NAME")"
  echo "compiler=$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$B/CMakeCache.txt" | head -1)"
  echo "build_type=$(sed -n 's/^CMAKE_BUILD_TYPE:[A-Z]*=//p' "$B/CMakeCache.txt" | head -1)"
  echo "nice=$(nice)"
  echo "quick=$quick"
  echo "invocation=$invocation"
}
machine >"$out/machine.txt"
echo "load_start=$(cut -d' ' -f1-3 /proc/loadavg)" >>"$out/machine.txt"

# run_step NAME MISSION CMD...: runs CMD, its stdout in OUT/logs/NAME.out and stderr in
# OUT/logs/NAME.err; records the command, wall time and exit code in OUT/steps.tsv. Never stops
# the script.
run_step() {
  local name=$1 mission=$2; shift 2
  log "$name: $*"
  local t0 t1 rc
  t0=$(date +%s.%N)
  "$@" >"$out/logs/$name.out" 2>"$out/logs/$name.err"
  rc=$?
  t1=$(date +%s.%N)
  local wall
  wall=$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }')
  printf '%s\t%s\t%s\t%s\t%s\n' "$name" "$mission" "$wall" "$rc" "$*" >>"$steps"
  [ "$rc" -ne 0 ] && log "$name: exit $rc after ${wall} s (log: $out/logs/$name.err)"
  log "$name: ${wall} s"
  return 0
}

t_start=$(date +%s)

# ---- missions
for m in marina airplane; do
  if [ ! -f "$missions/$m/mission.yaml" ]; then
    run_step "sim-$m" "$m" "$B/apps/sim/draco-sim" "config/missions/$m.yaml" --out "$missions/$m"
  else
    log "reusing the mission in $missions/$m"
  fi
done

# ---- the paper's tables, per mission
frames=()
[ "$quick" = 1 ] && frames=(--frames 0)
for m in marina airplane; do
  M=$missions/$m
  R=$out/$m
  mkdir -p "$R"
  # The running team: three daemons over DDS on loopback and the same team in one process. The
  # topic prefix keeps this team apart from any other team on the machine's DDS domain.
  run_step "fleet-$m" "$m" "$B/apps/fleet/draco-fleet" "$M" --mode both --out "$R/fleet" \
    --set "link.dds_topic_prefix=results$$_"
  # Its evaluation: report.md with the Table I-IV layouts, Fig. 3 of the running team, figures.
  run_step "eval-$m-dds" "$m" "$B/apps/eval/draco-eval" "$R/fleet/dds" --mission "$M" \
    "${frames[@]}"
  if [ "$quick" = 0 ]; then
    run_step "eval-$m-inproc" "$m" "$B/apps/eval/draco-eval" "$R/fleet/inproc" \
      --mission "$M" --frames 0
    # Local SLAM alone, every robot (docs/local-slam.md "Accuracy").
    run_step "local-slam-$m" "$m" "$B/apps/local_slam/draco-local-slam" "$M" --out "$R/local-slam"
    run_step "eval-$m-local-slam" "$m" "$B/apps/eval/draco-eval" "$R/local-slam"
  fi
  # Fig. 3 offline: every robot's local SLAM (cached in frontend/slam), matching, registration.
  fe=()
  [ "$quick" = 1 ] && fe=(--no-possible-loops)
  run_step "frontend-$m" "$m" "$B/apps/frontend_eval/draco-frontend-eval" "$M" \
    --out "$R/frontend" "${fe[@]}"
  # Table III offline on the same local SLAM (its own folder; slam/ is the frontend's cache).
  mkdir -p "$R/team"
  ln -sfn ../frontend/slam "$R/team/slam"
  run_step "team-$m" "$m" "$B/apps/team_eval/draco-team-eval" "$M" --out "$R/team" --reuse
  # Table IV offline: message sizes on the cached keyframes.
  kfs=()
  for f in "$R"/frontend/slam/*.keyframes.bin; do [ -f "$f" ] && kfs+=("$f"); done
  if [ ${#kfs[@]} -gt 0 ]; then
    run_step "sizes-$m" "$m" "$B/apps/fleet_sizes/draco-fleet-sizes" "${kfs[@]}"
  else
    printf 'sizes-%s\t%s\t0\t1\t(no keyframe cache: draco-frontend-eval failed)\n' "$m" "$m" \
      >>"$steps"
  fi
done

# ---- speed: the Google Benchmarks of docs/benchmarks.md
reps=(--benchmark_repetitions=3 --benchmark_report_aggregates_only=true)
[ "$quick" = 1 ] && reps=()
bench() {  # bench NAME BINARY [FILTER]
  local name=$1 bin=$2 filter=${3:-}
  local args=("${reps[@]}" --benchmark_min_time=0.05
              --benchmark_out="$out/bench/$name.json" --benchmark_out_format=json)
  [ -n "$filter" ] && args+=("--benchmark_filter=$filter")
  run_step "bench-$name" "-" "$B/$bin" "${args[@]}"
}
if [ "$quick" = 1 ]; then
  bench objects tests/objects/objects_bench '/(10|20|25|30|50|100)$'
  bench cfar tests/cfar/cfar_bench
  bench icp tests/icp/icp_bench
  bench pose_graph tests/pose_graph/pose_graph_bench \
    'Solve/(intel|manhattan).g2o/(baseline|default/)|KeyframeAt1000|Incremental1000/update'
  bench consistency tests/consistency/consistency_bench \
    '^BM_(DecisionBatch|DecisionIncremental|CliqueExact)/'
  bench registration tests/registration/registration_bench
  bench team tests/team/team_bench
else
  bench objects tests/objects/objects_bench
  bench cfar tests/cfar/cfar_bench
  bench icp tests/icp/icp_bench
  pg='Solve/(intel|manhattan|city10000).g2o/(baseline|default/|default_suitesparse|default_1thread)'
  bench pose_graph tests/pose_graph/pose_graph_bench "$pg|Incremental1000|KeyframeAt1000"
  bench consistency tests/consistency/consistency_bench
  bench registration tests/registration/registration_bench
  bench team tests/team/team_bench
fi

echo "load_end=$(cut -d' ' -f1-3 /proc/loadavg)" >>"$out/machine.txt"
echo "wall_s=$(( $(date +%s) - t_start ))" >>"$out/machine.txt"

# ---- the team map of the marina team run, small, beside the page (img/), for it and the README
img=$(dirname "$page")/img/team-map-marina-team.png
mkdir -p "$(dirname "$img")"
if [ -f "$out/marina/fleet/dds/team_map.png" ]; then
  if /usr/bin/python3 -c 'import PIL' 2>/dev/null; then
    /usr/bin/python3 - "$out/marina/fleet/dds/team_map.png" "$img" <<'EOF'
import sys
from PIL import Image
im = Image.open(sys.argv[1]).convert("RGB")
w = 720
if im.width > w:
    im = im.resize((w, round(im.height * w / im.width)), Image.LANCZOS)
im = im.quantize(colors=128, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE)
im.save(sys.argv[2], optimize=True)
EOF
  else
    cp "$out/marina/fleet/dds/team_map.png" "$img"
  fi
  echo "team_map=$img" >>"$out/machine.txt"
fi

# ---- the page
readme=()
[ "$page" = docs/figures.md ] && readme=(--readme README.md)
python3 scripts/figures.py "$out" --page "$page" --missions "$missions" "${readme[@]}" || exit 1
log "wrote $page ($(( $(date +%s) - t_start )) s)"
