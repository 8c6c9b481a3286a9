#!/usr/bin/env bash
# The fleet over DDS, end to end, on a short simulated mission (3 robots, 40 s):
# 1. draco-fleet --mode both: three draco-robot daemons over Cyclone DDS on loopback and the
#    in-process replay agree (accepted loops and team ATE within 10 %; exit 3 otherwise), every
#    robot heard every teammate, nothing was rejected.
# 2. Kill bravo's daemon mid-mission (SIGKILL) and restart it: alpha and charlie keep running,
#    notice the restart and exchange with the new bravo again.
# 3. SIGTERM stops a daemon cleanly, outputs flushed.
# 4. A daemon with a robot name the mission lacks exits non-zero with a clear message.
# 5. A second run into the same --out replaces the earlier run's folder (a stale teammate
#    trajectory is not judged as this run's); a folder holding other files is refused, untouched.
set -u
sim=$1
fleet=$2
robot=$3
src=$4
fail() { echo "FAIL: $*"; exit 1; }
# Wall-time waits are scaled for slow (sanitizer) builds: CTest sets DRACO_TEST_TIME_FACTOR.
factor=${DRACO_TEST_TIME_FACTOR:-1}
scaled() { awk -v s="$1" -v f="$factor" 'BEGIN { print s * f }'; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
domain=$(( ($$ % 200) + 10 ))

"$sim" "$src/config/missions/marina.yaml" --out "$work/m" --duration-s 40 --no-pictures \
  >"$work/sim.log" 2>&1 || { cat "$work/sim.log"; fail "simulation"; }

"$fleet" "$work/m" --out "$work/both" --domain "$domain" --set link.lockstep_timeout_s=5 \
  >"$work/both.log" 2>&1
rc=$?
cat "$work/both.log"
[ $rc -eq 0 ] || fail "draco-fleet --mode both exited $rc"
grep -q "DDS against in-process" "$work/both.log" || fail "no comparison printed"
grep -q "DIFFERENT" "$work/both.log" && fail "DDS and in-process differ"
for r in alpha bravo charlie; do
  for m in inproc dds; do
    f="$work/both/$m/$r.link_stats.json"
    [ -f "$f" ] || fail "missing $f"
    python3 - "$f" <<'PY' || fail "link stats of $f"
import json, sys
s = json.load(open(sys.argv[1]))
for t in s["teammates"]:
    assert t["known"] and t["frames_received"] > 0, t
    assert t["frames_rejected"] == 0, t
assert s["counters"]["rejected"] == 0, s["counters"]
PY
  done
  [ -f "$work/both/dds/$r.trajectory.tum" ] || fail "no trajectory of $r over DDS"
done

# Kill bravo about a third of the way in (paced at 8x: 40 s of mission in ~5 s) and restart it.
# Slow builds scale the pace with the kill time (8 / factor), so the kill still falls inside
# the run: a sanitizer build that keeps up with 8x would otherwise finish before it.
"$fleet" "$work/m" --mode dds --out "$work/kill" --domain "$domain" --kill bravo \
  --kill-after-s "$(scaled 1.5)" --restart-after-s 0.5 --rate "$(awk -v f="$factor" 'BEGIN { print 8 / f }')" --set link.lockstep_timeout_s=2 \
  >"$work/kill.log" 2>&1 || { cat "$work/kill.log"; fail "kill/restart run failed"; }
cat "$work/kill.log"
grep -q "restarted bravo" "$work/kill.log" || fail "bravo was not restarted"
for r in alpha charlie; do
  python3 - "$work/kill/dds/$r.link_stats.json" <<'PY' || fail "$r did not exchange with the restarted bravo"
import json, sys
s = json.load(open(sys.argv[1]))
b = [t for t in s["teammates"] if t["robot_id"] == 1][0]
assert b["restarts"] >= 1, b
assert b["frames_since_restart"] > 0, b
PY
done
python3 - "$work/kill/dds/bravo.link_stats.json" <<'PY' || fail "the restarted bravo heard nobody"
import json, sys
s = json.load(open(sys.argv[1]))
for t in s["teammates"]:
    assert t["frames_received"] > 0, t
PY

# 3. SIGTERM: a lone daemon (its teammates never come, so it waits for them) stops within
#    seconds, exits 0 and leaves its outputs whole.
"$robot" --mission "$work/m" --robot charlie --out "$work/term" --domain "$domain" --quiet \
  >"$work/term.log" 2>&1 &
pid=$!
# Under load the start-up (loading the shared libraries) can outlast a fixed sleep, and a
# SIGTERM before main() installs its handler kills the process: wait until the daemon catches
# SIGTERM (bit 15 of SigCgt in /proc/PID/status), then let it run a while.
for _ in $(seq 1 $((300 * factor))); do
  cgt=$(awk '/^SigCgt:/ { print $2 }' "/proc/$pid/status" 2>/dev/null)
  [ -n "$cgt" ] && (((16#$cgt >> 14) & 1)) && break
  sleep 0.1
done
sleep "$(scaled 1.5)"
kill -TERM $pid
for _ in $(seq 1 $((50 * factor))); do kill -0 $pid 2>/dev/null || break; sleep 0.1; done
kill -0 $pid 2>/dev/null && { kill -KILL $pid; fail "daemon still running 5 s after SIGTERM"; }
wait $pid || { cat "$work/term.log"; fail "SIGTERM: non-zero exit"; }
for f in charlie.link_stats.json charlie.trajectory.tum charlie.runtime_stats.json; do
  [ -f "$work/term/$f" ] || fail "SIGTERM: $f not written"
done
ls "$work/term" | grep -q partial && fail "SIGTERM: a partial file was left"

out=$("$robot" --mission "$work/m" --robot zulu --out "$work/z" 2>&1) && fail "unknown robot accepted"
echo "$out" | grep -q "has no robot 'zulu'" || fail "unclear message: $out"

# 6. The in-process team on one thread and on several gives the same files (but for wall
#    times, the incarnations drawn from the clock and the bus name in the resolved graph).
"$fleet" "$work/m" --mode inproc --threads 1 --out "$work/t1" >"$work/t1.log" 2>&1 ||
  { cat "$work/t1.log"; fail "in-process run on one thread"; }
"$fleet" "$work/m" --mode inproc --threads 3 --out "$work/t3" >"$work/t3.log" 2>&1 ||
  { cat "$work/t3.log"; fail "in-process run on three threads"; }
python3 - "$work/t1/inproc" "$work/t3/inproc" <<'PY' || fail "one thread and three differ"
import json, os, re, sys
a, b = sys.argv[1], sys.argv[2]
names = sorted(os.listdir(a))
assert names == sorted(os.listdir(b)), (names, sorted(os.listdir(b)))
assert any(n.endswith(".inter_loops.csv") for n in names), names
def text(path):
    t = open(path, "rb").read().decode("utf-8", "replace")
    n = os.path.basename(path)
    if n.endswith(".agent_steps.csv"):  # the last column is wall_ms
        t = "\n".join(l.rsplit(",", 1)[0] for l in t.splitlines())
    if n.endswith(".link_stats.json"):
        t = re.sub(r'"incarnation": \d+|"inproc:team-\d+"', "", t)
    if n == "team.graph.yaml":
        t = re.sub(r'bus: "team-\d+"', "", t)
    return t
for n in names:
    if n == "runtime_stats.json":
        continue
    assert text(os.path.join(a, n)) == text(os.path.join(b, n)), n
print("identical:", len(names) - 1, "files")
PY

# 5. Run folders.
echo "0 999 999 0 0 0 0 1" >"$work/both/inproc/alpha.team.stale.tum"
"$fleet" "$work/m" --mode inproc --out "$work/both" >"$work/again.log" 2>&1 ||
  { cat "$work/again.log"; fail "second in-process run into the same folder"; }
grep -q "replacing the earlier run in $work/both/inproc" "$work/again.log" ||
  fail "the earlier run was not replaced: $(cat "$work/again.log")"
[ -e "$work/both/inproc/alpha.team.stale.tum" ] && fail "a stale file survived the second run"
[ -f "$work/both/inproc/alpha.trajectory.tum" ] || fail "the second run wrote no trajectory"
mkdir -p "$work/foreign/inproc"
echo "field notes" >"$work/foreign/inproc/notes.txt"
out=$("$fleet" "$work/m" --mode inproc --out "$work/foreign" 2>&1) &&
  fail "a folder of other files was run into"
echo "$out" | grep -q "holds no earlier draco-fleet run" || fail "unclear message: $out"
[ -f "$work/foreign/inproc/notes.txt" ] || fail "a foreign file was deleted"
echo ok
