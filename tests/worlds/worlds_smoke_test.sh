#!/usr/bin/env bash
# The generalization benchmark's smoke version (CI): draco-worlds on three generated worlds
# (reporting seeds, short missions), then the first world again. Fails when a world did not
# run, when an ordered robot pair has no verdict, or when the second run of a world differs
# from the first (generation, simulation, the in-process team and the evaluation are all
# deterministic). Prints the placements; the goals on them are measured by the full
# benchmark (docs/safe-merges.md).
#   worlds_smoke_test.sh DRACO_WORLDS SEEDS DURATION_S
set -euo pipefail
worlds=$1
seeds=${2:-101-103}
duration=${3:-480}
out=$(mktemp -d /tmp/draco-worlds-smoke.XXXXXX)
trap 'rm -rf "$out"' EXIT
"$worlds" --seeds "$seeds" --robots 3 --duration-s "$duration" --out "$out/a"
first=${seeds%%[-,]*}
"$worlds" --seeds "$first" --robots 3 --duration-s "$duration" --out "$out/b"
csv="$out/a/worlds.csv"
pairs="$out/a/pairs.csv"
[ -f "$csv" ] || { echo "no $csv"; exit 1; }
bad=$(awk -F, 'NR > 1 && $2 != "ok"' "$csv")
[ -z "$bad" ] || { echo "worlds that did not run:"; echo "$bad"; exit 1; }
worlds_run=$(awk 'NR > 1' "$csv" | wc -l)
rows=$(awk -F, 'NR > 1 && ($5 == "right" || $5 == "wrong" || $5 == "none")' "$pairs" | wc -l)
[ "$rows" -eq $((worlds_run * 6)) ] || { echo "$rows verdicts for $worlds_run worlds of 3 robots"; exit 1; }
a=$(grep "^seed-$first," "$pairs")
b=$(awk -F, 'NR > 1' "$out/b/pairs.csv")
[ "$a" = "$b" ] || { echo "seed $first differs between two runs:"; echo "$a"; echo "$b"; exit 1; }
# The world's row too (team, oracle and dead-reckoning ATE, loops, bits), all but wall_s.
a=$(grep "^seed-$first," "$csv" | rev | cut -d, -f2- | rev)
b=$(awk -F, 'NR > 1' "$out/b/worlds.csv" | rev | cut -d, -f2- | rev)
[ "$a" = "$b" ] || { echo "seed $first's row differs between two runs:"; echo "$a"; echo "$b"; exit 1; }
echo "worlds smoke: $worlds_run worlds, $rows pairs: right $(grep -c ',right,' "$pairs" || true), wrong $(grep -c ',wrong,' "$pairs" || true), none $(grep -c ',none,' "$pairs" || true); seed $first identical twice"
