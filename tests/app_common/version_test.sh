#!/usr/bin/env bash
# Every app given prints "<name> <project version>[ (<git describe>)]" for --version and exits 0;
# `draco run` writes run_info.json into its run folder with the same version, the exact command
# line and the graph it ran.
set -u
project_version=$1
src=$2
shift 2
fail() { echo "FAIL: $*"; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

version=""
for exe in "$@"; do
  name=$(basename "$exe")
  line=$("$exe" --version) || fail "$name --version exited non-zero"
  echo "$line"
  echo "$line" | grep -Eq "^$name $project_version( \([^()]+\))?$" || fail "$name --version: '$line'"
  v=${line#"$name "}
  [ -z "$version" ] && version=$v
  [ "$v" = "$version" ] || fail "$name reports '$v', another app '$version'"
done

draco=$1
graph="$src/config/graphs/default.yaml"
"$draco" run "$graph" --rate 0 --until 1 --out "$work/run" --set "scale.factor=2" \
  >"$work/run.log" 2>&1 || { cat "$work/run.log"; fail "draco run"; }
python3 - "$work/run/run_info.json" "$version" "$draco" "$graph" "$work/run" <<'PY' || fail "run_info.json"
import json, os, sys
path, version, draco, graph, out = sys.argv[1:]
info = json.load(open(path))
assert info["app"] == "draco", info
assert info["version"] == version, (info["version"], version)
assert info["argv"] == [draco, "run", graph, "--rate", "0", "--until", "1", "--out", out,
                        "--set", "scale.factor=2"], info["argv"]
assert info["files"]["graph"] == os.path.normpath(graph), info["files"]
PY
echo ok
