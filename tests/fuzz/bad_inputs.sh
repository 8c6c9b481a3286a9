#!/usr/bin/env bash
# "Bad input, counted" (docs/hardening.md): makes each damaged input from real ones and runs
# the app a user would run on it, printing the exit status and the error it gives. Each row of
# the table in docs/hardening.md is one case here.
#
#   tests/fuzz/bad_inputs.sh [BUILD_DIR [CASE...]]     (default build; every case)
#
# Needs the apps of BUILD_DIR (draco, draco-sim, draco-local-slam) and /usr/bin/python3 with
# python3-rosbag (the test bags). Works in a scratch folder, removed at the end. A case passes
# when the app exits non-zero (or, for counted input, zero) with the expected text, within 60 s.
set -uo pipefail
cd "$(dirname "$0")/../.." || exit 2
root=$(pwd)
build=${1:-build}
shift || true
[ -d "$build" ] || { echo "bad_inputs.sh: no build folder '$build'" >&2; exit 2; }
build=$(cd "$build" && pwd)
draco=$build/apps/draco/draco
sim=$build/apps/sim/draco-sim
slam=$build/apps/local_slam/draco-local-slam
work=$(mktemp -d /tmp/draco-bad-inputs-XXXXXX)
trap 'rm -rf "$work"' EXIT

failures=0
# run CASE EXPECT_STATUS(nonzero|zero) EXPECTED_TEXT COMMAND...
run() {
  local name=$1 expect=$2 text=$3
  shift 3
  local out status
  out=$(cd "$work" && timeout 60 "$@" 2>&1)
  status=$?
  local line
  line=$(grep -m1 -F -- "$text" <<<"$out" || true)
  local ok=yes
  [ "$status" -eq 124 ] && ok=no
  if [ "$expect" = nonzero ]; then [ "$status" -ne 0 ] || ok=no; else [ "$status" -eq 0 ] || ok=no; fi
  [ -n "$line" ] || ok=no
  [ "$ok" = yes ] || failures=$((failures + 1))
  printf '%-4s %-3s exit %-3s %s\n' "$name" "$ok" "$status" "${line:-$(tail -1 <<<"$out")}"
}

want() { [ $# -eq 0 ] || [[ " ${selected[*]} " == *" $1 "* ]]; }
selected=("$@")
want_any() { [ ${#selected[@]} -eq 0 ] && return 0; for c in "$@"; do want "$c" && return 0; done; return 1; }
sel() { [ ${#selected[@]} -eq 0 ] || want "$1"; }

# ---- a real mission: 5 s of the marina mission, robot alpha ----------------------------------
if want_any R1 R2 R3 R4 R5 R6 R7 R8 R9; then
  "$sim" "$root/config/missions/marina.yaml" --duration-s 5 --robots 1 --no-pictures \
    --out "$work/mission" --log-level error >/dev/null 2>&1 ||
    { echo "bad_inputs.sh: draco-sim failed" >&2; exit 1; }
fi
fresh() {  # a copy of the mission to damage
  rm -rf "$work/m"
  cp -r "$work/mission" "$work/m"
}
slam_run=("$slam" "$work/m" --robot alpha --out "$work/run" --log-level error)

if sel R1; then fresh; head -c 20000 "$work/mission/alpha/sonar.drs" >"$work/m/alpha/sonar.drs"
  run R1 nonzero "truncated record" "${slam_run[@]}"; fi
if sel R2; then fresh; printf '\x55' | dd of="$work/m/alpha/sonar.drs" bs=1 seek=5000 conv=notrunc status=none
  run R2 nonzero "bad CRC" "${slam_run[@]}"; fi
if sel R3; then fresh  # record 0's payload length (bytes 24-27) claims 200 MiB
  printf '\x00\x00\x80\x0c' | dd of="$work/m/alpha/sonar.drs" bs=1 seek=24 conv=notrunc status=none
  run R3 nonzero "payload and CRC need 209715204 bytes" "${slam_run[@]}"; fi
if sel R4; then fresh; sed -i '3s/^\([^,]*\),[^,]*/\1,nan/' "$work/m/alpha/dvl.csv"
  run R4 nonzero "expected a finite number" "${slam_run[@]}"; fi
if sel R5; then fresh; head -c -7 "$work/mission/alpha/ahrs.csv" >"$work/m/alpha/ahrs.csv"
  run R5 nonzero "the last line has no end-of-line" "${slam_run[@]}"; fi
if sel R6; then fresh; sed -i '/range_bins:/d' "$work/m/mission.yaml"
  run R6 nonzero "missing key 'sonar.range_bins'" "${slam_run[@]}"; fi
if sel R7; then fresh; sed -i 's/beams: 512/beams: -5/' "$work/m/mission.yaml"
  run R7 nonzero "sonar.beams must be in 1..65536" "${slam_run[@]}"; fi
if sel R8; then fresh; sed -i 's/rate_hz: 5$/rate_hz: .nan/' "$work/m/mission.yaml"
  run R8 nonzero "expected a finite number" "${slam_run[@]}"; fi
if sel R9; then fresh; : >"$work/m/alpha/sonar.drs"
  run R9 nonzero "truncated file header: 0 of 16 bytes" "${slam_run[@]}"; fi

# ---- graphs ---------------------------------------------------------------------------------
graph() { printf '%b' "$1" >"$work/g.yaml"; }
if sel G1; then run G1 nonzero "expected double, got '.nan'" \
  "$draco" validate "$root/config/graphs/default.yaml" --set scale.factor=.nan; fi
if sel G2; then run G2 nonzero "period_s" \
  "$draco" validate "$root/config/graphs/default.yaml" --set ticker.period_s=-1; fi
if sel G3; then graph 'schema: 1\nthreads: 100000\ncomponents:\n  - {id: t, type: example.Ticker}\n'
  run G3 nonzero "'threads' must be an integer in [1, 256]" "$draco" validate "$work/g.yaml"; fi
if sel G4; then graph 'components:\n  - {id: t}\n'
  run G4 nonzero "missing 'schema: 1'" "$draco" validate "$work/g.yaml"; fi
if sel G5; then mkfifo "$work/pipe.yaml"
  graph "schema: 1\ninclude: [$work/pipe.yaml]\ncomponents:\n  - {id: t, type: example.Ticker}\n"
  run G5 nonzero "is not a regular file" "$draco" validate "$work/g.yaml"; fi
if sel G6; then graph 'schema: 1\n[a]: 1\ncomponents:\n  - {id: t, type: example.Ticker}\n'
  run G6 nonzero "expected a name as key, got a list" "$draco" validate "$work/g.yaml"; fi
if sel G7; then run G7 nonzero "not a regular file" "$draco" validate "$root/config"; fi

# ---- simulator missions and worlds -----------------------------------------------------------
mission() {  # the marina mission with one edit, next to a copy of its world
  mkdir -p "$work/sim/missions" "$work/sim/worlds"
  cp "$root/config/worlds/marina.yaml" "$work/sim/worlds/"
  sed "$1" "$root/config/missions/marina.yaml" >"$work/sim/missions/m.yaml"
}
sim_run=("$sim" "$work/sim/missions/m.yaml" --duration-s 1 --robots 1 --no-pictures --no-sonar
  --out "$work/simout" --log-level error)
if sel S1; then mission '0,/depth_m: [0-9.]*/s//depth_m: .nan/'
  run S1 nonzero "expected a finite number for depth_m" "${sim_run[@]}"; fi
if sel S2; then mission 's/^sonar:/sonar:\n  num_beams: 100000/'
  run S2 nonzero "exceed what a recording holds" "${sim_run[@]}"; fi
if sel S3; then mission '0,/speed_mps: [0-9.]*/s//speed_mps: -1/'
  run S3 nonzero "speed_mps must be positive" "${sim_run[@]}"; fi
# shellcheck disable=SC2016  # a sed address, not a shell expansion
if sel S4; then mission '/^robots:/,$d'
  run S4 nonzero "missing key 'robots'" "${sim_run[@]}"; fi
if sel S5; then
  printf 'objects:\n  - {type: pier, polyline_m: [[0, 0], [1e300, 0]], width_m: 4}\n' >"$work/w.yaml"
  run S5 nonzero "pier would expand to" "$sim" --world "$work/w.yaml" --picture "$work/w.png"; fi
if sel S6; then
  printf 'objects:\n  - {type: pier, polyline_m: [[0, 0], [9, 0]], width_m: 4, piles_per_bent: 100000000}\n' >"$work/w.yaml"
  run S6 nonzero "pier would expand to" "$sim" --world "$work/w.yaml" --picture "$work/w.png"; fi

# ---- ROS 1 bags -------------------------------------------------------------------------------
if want_any B1 B2 B3 B4; then
  /usr/bin/python3 "$root/tests/rosbag/write_test_bags.py" "$work/bags" >/dev/null 2>&1 ||
    { echo "bad_inputs.sh: write_test_bags.py failed" >&2; exit 1; }
fi
bag_run=("$draco" run "$root/config/graphs/local-slam-bag.yaml" --out "$work/bagrun"
  --log-level error --set)
if sel B1; then run B1 nonzero "not a readable ROS 1 bag" "${bag_run[@]}" "reader.bag=$work/bags/not_a_bag.bag"; fi
if sel B2; then run B2 nonzero "the bag is truncated" "${bag_run[@]}" "reader.bag=$work/bags/truncated_file.bag"; fi
if sel B3; then run B3 nonzero "-byte chunk" "${bag_run[@]}" \
  "reader.bag=$root/tests/data/fuzz/rosbag-index-offset-outside-chunk.bag"; fi
if sel B4; then head -c 9000 "$work/bags/lz4.bag" >"$work/cut.bag"
  run B4 nonzero "the bag is truncated" "${bag_run[@]}" "reader.bag=$work/cut.bag"; fi

echo
if [ "$failures" -ne 0 ]; then
  echo "bad_inputs.sh: $failures case(s) did not give the expected error" >&2
  exit 1
fi
echo "bad_inputs.sh: every case gave its error"
