#!/usr/bin/env bash
# draco-worlds with a --set override no component takes: the first world's team run fails, the
# console names the parameter, and the benchmark stops there with exit code 2 instead of
# failing every world in turn.
#   worlds_bad_override_test.sh DRACO_WORLDS
set -uo pipefail
worlds=$1
out=$(mktemp -d /tmp/draco-worlds-bad.XXXXXX)
trap 'rm -rf "$out"' EXIT
"$worlds" --seeds 101-102 --robots 3 --duration-s 20 --set slam.no_such_param=1 \
  --out "$out/w" > "$out/console.txt" 2>&1
rc=$?
cat "$out/console.txt"
[ "$rc" -eq 2 ] || { echo "exit code $rc, expected 2"; exit 1; }
grep -q "has no parameter 'no_such_param'" "$out/console.txt" || { echo "the error is not shown"; exit 1; }
[ ! -e "$out/w/seed-102" ] || { echo "went on to the second world"; exit 1; }
echo "bad override: stopped after the first world with the error shown"
