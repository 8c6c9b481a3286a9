#!/usr/bin/env bash
# draco-team-eval run from experiment files, end to end on a short simulated marina mission
# (two robots, 300 s: both place each other by matching and close true inter-robot loops):
# - a run folder holds experiment.yaml (every key), the local-SLAM graph each robot ran
#   (slam/<robot>.graph.yaml), run_info.json (version with the commit, command line, files);
# - its experiment.yaml runs the same experiment again: identical tables;
# - an experiment's keys act: filter.min_clique_size above the candidate count rejects every
#   loop, inject.fraction adds wrong candidates (and no true ones), --exp-set overrides a file;
# - every file in config/experiments/ loads;
# - an unknown key, a wrong type and a value out of range stop it with exit status 1 and an
#   error naming the file, line and key, before anything runs.
#   team_eval_test.sh DRACO_SIM DRACO_TEAM_EVAL SOURCE_DIR
set -u
sim=$1
te=$2
src=$3
fail() { echo "FAIL: $*"; exit 1; }
work=$(mktemp -d /tmp/draco-team-eval-test.XXXXXX)
trap 'rm -rf "$work"' EXIT
cd "$work" || fail "cd $work"

"$sim" "$src/config/missions/marina.yaml" --out m --duration-s 300 --robots 2 --no-pictures \
  >sim.log 2>&1 || { cat sim.log; fail "simulation"; }

# column NAME of robot ROBOT's row in DIR/team_loops.csv
col() {
  awk -F, -v name="$3" -v robot="$2" 'NR == 1 { for (i = 1; i <= NF; ++i) c[$i] = i; next }
    $1 == robot { print $c[name] }' "$1/team_loops.csv"
}
# run NAME ARGS...: draco-team-eval into NAME, reusing the local SLAM of the first run
run() {
  local name=$1
  shift
  mkdir -p "$name"
  ln -sfn ../a/slam "$name/slam"
  "$te" m --out "$name" --reuse "$@" >"$name.log" 2>&1 || { cat "$name.log"; fail "$name"; }
}

# 1. Every default; the run folder records what ran.
"$te" m --out a >a.log 2>&1 || { cat a.log; fail "draco-team-eval m --out a"; }
for f in experiment.yaml run_info.json table3.csv team_loops.csv slam/alpha.graph.yaml \
  slam/bravo.graph.yaml; do
  [ -s "a/$f" ] || fail "a/$f missing"
done
keys=$(grep -c '^  [a-z_]*: ' a/experiment.yaml)
[ "$keys" -eq 22 ] || fail "a/experiment.yaml has $keys keys, not 22"
grep -q '^  min_clique_size: 5$' a/experiment.yaml || fail "a/experiment.yaml: min_clique_size"
grep -q 'id: reader' a/slam/alpha.graph.yaml || fail "a/slam/alpha.graph.yaml: no reader"
grep -q 'robot: "alpha"' a/slam/alpha.graph.yaml || fail "a/slam/alpha.graph.yaml: not alpha's"
python3 - a/run_info.json "$te" <<'PY' || fail "a/run_info.json"
import json, sys
info = json.load(open(sys.argv[1]))
assert info["app"] == "draco-team-eval", info
assert info["argv"] == [sys.argv[2], "m", "--out", "a"], info["argv"]
assert "git_describe" in info and "command_line" in info, info
assert info["files"]["graph"].endswith("graphs/local-slam.yaml"), info["files"]
PY
for r in alpha bravo; do
  [ "$(col a $r candidates)" -gt 0 ] || fail "a: $r has no candidate loops"
  [ "$(col a $r gcm_accepted)" -gt 0 ] || fail "a: $r accepted no loop"
done

# 2. The recorded experiment runs it again.
run b --experiment a/experiment.yaml
cmp -s a/table3.csv b/table3.csv || fail "b/table3.csv differs from a/table3.csv"
cmp -s a/team_loops.csv b/team_loops.csv || fail "b/team_loops.csv differs"
cmp -s a/experiment.yaml b/experiment.yaml || fail "b/experiment.yaml differs"
python3 - b/run_info.json <<'PY' || fail "b/run_info.json: no experiment file"
import json, sys
assert json.load(open(sys.argv[1]))["files"]["experiment"].endswith("/a/experiment.yaml")
PY

# 3. Keys act: a minimum clique above every robot's candidates rejects every loop.
printf 'filter:\n  min_clique_size: 1000\n' >clique.yaml
run c --experiment clique.yaml
grep -q '^  min_clique_size: 1000$' c/experiment.yaml || fail "c/experiment.yaml"
for r in alpha bravo; do
  [ "$(col c $r candidates)" = "$(col a $r candidates)" ] || fail "c: $r candidates changed"
  [ "$(col c $r pcm_accepted)" = 0 ] || fail "c: $r PCM accepted $(col c $r pcm_accepted)"
  [ "$(col c $r gcm_accepted)" = 0 ] || fail "c: $r GCM accepted $(col c $r gcm_accepted)"
done
# ... and injected wrong loops add candidates, none of them true; --exp-set after the file.
printf 'inject:\n  fraction: 0.3\n  kind: correlated\n' >inject.yaml
run d --experiment inject.yaml --exp-set inject.fraction=0.5 --exp-set inject.kind=random
grep -q 'injected: random outliers, 50 %' d.log || fail "d: no injection line"
for r in alpha bravo; do
  n=$(col a $r candidates)
  [ "$(col d $r candidates)" -ge $((2 * n - 1)) ] || fail "d: $r: $(col d $r candidates) candidates"
  [ "$(col d $r candidate_tp)" = "$(col a $r candidate_tp)" ] || fail "d: $r: true candidates"
done

# 4. Every shipped experiment loads.
for f in "$src"/config/experiments/*.yaml; do
  "$te" --experiment "$f" --print-experiment >print.log 2>&1 || { cat print.log; fail "$f"; }
done

# 5. Bad files: exit status 1, the file, line and key named, no run folder.
expect_error() {  # expect_error NAME TEXT PATTERN
  printf "$2" >"$1.yaml"
  "$te" m --out "bad-$1" --reuse --experiment "$1.yaml" >"$1.log" 2>&1
  local rc=$?
  [ $rc -eq 1 ] || { cat "$1.log"; fail "$1: exit status $rc, not 1"; }
  grep -q -- "$3" "$1.log" || { cat "$1.log"; fail "$1: no '$3' in the error"; }
  [ ! -e "bad-$1" ] || fail "$1: a run folder was made"
}
expect_error unknown 'filter:\n  min_cliqe_size: 3\n' \
  "unknown.yaml:2:3: error: unknown key 'min_cliqe_size' in filter"
expect_error type 'candidates:\n  window: three\n' \
  "type.yaml:2:11: error: candidates.window: expected an integer >= 0, got 'three'"
expect_error range 'inject:\n  fraction: 1.5\n' \
  "range.yaml:2:13: error: inject.fraction: expected a number in \[0, 1), got '1.5'"
echo "team-eval experiments: ok (alpha $(col a alpha candidates), bravo $(col a bravo candidates) candidates)"
