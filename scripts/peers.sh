#!/usr/bin/env bash
# draco against the peers a user would pick instead, on identical inputs (docs/benchmarks.md,
# "Peers on identical inputs: the Python reference and Open3D"): writes draco's inputs of a
# recorded marina mission to files with draco's answers and times (tests/peers/peers_inputs),
# runs the DRACo-SLAM2 reference algorithms on Debian's Python stack and Open3D's ICP on the
# same files (tests/peers/reference_peers.py), and prints one table: item, draco time, peer
# time, ratio, agreement. Not part of CI or scripts/setup.sh.
#
#   scripts/peers.sh [--mission DIR] [--out DIR] [--repeats N] [--reuse] [--jobs N]
#
#   --mission DIR  recorded mission (default runs/missions/marina, simulated from
#                  config/missions/marina.yaml when absent: about 2.7 GB)
#   --out DIR      inputs, answers and the local SLAM's cache (default runs/peers)
#   --repeats N    best of N runs per item, both sides (default 5)
#   --reuse        take the local SLAM's keyframes cached in OUT/slam
#   --jobs N       build jobs (default 2)
# Installs python3-numpy, -scipy, -sklearn, -opencv, -networkx and -open3d with apt when
# missing (through sudo when not root). Every peer runs on one thread (OMP_NUM_THREADS=1,
# OPENBLAS_NUM_THREADS=1), as draco does here.
set -euo pipefail
cd "$(dirname "$0")/.."

mission=runs/missions/marina
out=runs/peers
repeats=5
reuse=()
jobs=2
while [[ $# -gt 0 ]]; do
  case "$1" in
    --mission) mission=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --repeats) repeats=$2; shift 2 ;;
    --reuse) reuse=(--reuse); shift ;;
    --jobs) jobs=$2; shift 2 ;;
    -h|--help) sed -n '2,20p' "$0"; exit 0 ;;
    *) echo "peers.sh: unknown argument $1" >&2; exit 2 ;;
  esac
done

packages=(python3-numpy python3-scipy python3-sklearn python3-opencv python3-networkx python3-open3d)
missing=()
for p in "${packages[@]}"; do
  dpkg -s "$p" >/dev/null 2>&1 || missing+=("$p")
done
if [[ ${#missing[@]} -gt 0 ]]; then
  sudo_cmd=()
  [[ $(id -u) -ne 0 ]] && sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update
  "${sudo_cmd[@]}" apt-get install -y "${missing[@]}"
fi

[[ -f build/CMakeCache.txt ]] || cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j"$jobs" --target peers_inputs draco-sim

if [[ ! -f "$mission/mission.yaml" ]]; then
  build/apps/sim/draco-sim config/missions/marina.yaml --out "$mission" --no-pictures
fi

# Keep the local SLAM's cache, replace the rest.
mkdir -p "$out"
find "$out" -mindepth 1 -maxdepth 1 ! -name slam -exec rm -rf {} +
echo "load before: $(uptime)"
build/tests/peers/peers_inputs "$mission" --out "$out" --repeats "$repeats" "${reuse[@]}"
OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 /usr/bin/python3 tests/peers/reference_peers.py "$out" \
  --repeats "$repeats"
echo "load after: $(uptime)"
