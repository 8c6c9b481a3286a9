#!/usr/bin/env bash
# draco validate: a valid graph exits 0; a misspelled parameter exits non-zero and the
# message names the file, the line and the expected names; list shows the components.
set -u
draco=$1
data=$2
fail() { echo "FAIL: $*"; exit 1; }

"$draco" validate "$data/with_include.yaml" >/dev/null || fail "valid graph rejected"
out=$("$draco" validate "$data/misspelled.yaml" 2>&1) && fail "misspelled parameter accepted"
echo "$out" | grep -q "misspelled.yaml:7:7: error: component 'ticker' (example.Ticker) has no parameter 'perid_s'" \
  || fail "unexpected message: $out"
echo "$out" | grep -q "did you mean 'period_s'" || fail "no suggestion: $out"
"$draco" list | grep -q "^example.Ticker  \[source\]" || fail "list lacks example.Ticker"
"$draco" dot "$data/with_include.yaml" | grep -q "digraph" || fail "dot output"

# SIGINT: a paced run (10 s of mission at 1 x real time) stops early, flushes its sink and
# writes its statistics.
out_dir=$(mktemp -d)
"$draco" run "$data/../../../config/graphs/default.yaml" --rate 1 --out "$out_dir" >/dev/null 2>&1 &
pid=$!
sleep 1.5
kill -INT $pid
wait $pid || fail "interrupted run exited non-zero"
[ -f "$out_dir/runtime_stats.json" ] || fail "no runtime_stats.json after SIGINT"
rows=$(($(wc -l < "$out_dir/sum.csv") - 1))
[ "$rows" -ge 3 ] && [ "$rows" -lt 50 ] || fail "sum.csv has $rows rows after SIGINT (expected a partial run)"
ls "$out_dir" | grep -q partial && fail "a partial file was left behind"
rm -rf "$out_dir"
echo ok
