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
echo ok
