#!/usr/bin/env bash
# draco-worlds --ping-quantization-step records the generated missions with lossy pings: the
# world runs, and every robot's first ping record carries the step (u16 at byte 38 of the ping
# payload: file header 16 bytes + record header 12, docs/recording-format.md).
#   worlds_quantized_test.sh DRACO_WORLDS
set -euo pipefail
worlds=$1
out=$(mktemp -d /tmp/draco-worlds-quant.XXXXXX)
trap 'rm -rf "$out"' EXIT
"$worlds" --seeds 101 --robots 3 --duration-s 20 --ping-quantization-step 24 --keep-missions \
  --out "$out/w"
status=$(awk -F, 'NR == 2 { print $2 }' "$out/w/worlds.csv")
[ "$status" = "ok" ] || { echo "the world did not run: $status"; exit 1; }
n=0
for f in "$out"/w/seed-101/mission/*/sonar.drs; do
  step=$(od -An -t u2 -j $((16 + 12 + 38)) -N 2 "$f" | tr -d ' ')
  [ "$step" = "24" ] || { echo "$f: step $step, expected 24"; exit 1; }
  n=$((n + 1))
done
[ "$n" -eq 3 ] || { echo "$n sonar files, expected 3"; exit 1; }
echo "quantized: 3 robots recorded with step 24, the world ran"
