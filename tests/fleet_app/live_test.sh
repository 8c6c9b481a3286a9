#!/usr/bin/env bash
# The live team end to end: draco-fleet --simulate (every robot's sensors simulated while the
# in-process team runs, sim.LiveRobot) against the in-process team on a recording draco-sim
# wrote of the same mission (marina, 3 robots, 40 s, robots as parts on 2 threads):
# 1. every output file of the team is byte-identical (trajectories, team estimates, maps, loop
#    closures, link statistics), and so is the printed evaluation (ATE, loops, placements);
# 2. no ping reaches the disk: the live run's mission folder holds navigation and ground truth,
#    its sonar files no ping;
# 3. --simulate with --mode dds is refused.
set -u
sim=$1
fleet=$2
src=$3
fail() { echo "FAIL: $*"; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mission="$src/config/missions/marina.yaml"

"$sim" "$mission" --out "$work/m" --duration-s 40 --no-pictures >"$work/sim.log" 2>&1 ||
  { cat "$work/sim.log"; fail "simulation"; }
"$fleet" "$work/m" --mode inproc --threads 2 --out "$work/rec" >"$work/rec.log" 2>&1 ||
  { cat "$work/rec.log"; fail "the team on the recording"; }
"$fleet" --simulate "$mission" --duration-s 40 --threads 2 --out "$work/live" \
  >"$work/live.log" 2>&1 || { cat "$work/live.log"; fail "the live team"; }
cat "$work/live.log"

# 1. The same outputs, but for wall times (runtime_stats.json, the wall_ms column of
#    <robot>.agent_steps.csv), the link's incarnations drawn from the clock, the bus name and
#    the reader's parameters in the resolved graph.
python3 - "$work/rec/inproc" "$work/live/inproc" <<'PY' || fail "recorded and live outputs differ"
import os, re, sys
a, b = sys.argv[1], sys.argv[2]
names = sorted(os.listdir(a))
assert names == sorted(os.listdir(b)), (names, sorted(os.listdir(b)))
for must in ("alpha.trajectory.tum", "alpha.team.alpha.tum", "charlie.map.ply", "bravo.ground_truth.tum"):
    assert must in names, (must, names)
def text(path):
    t = open(path, "rb").read().decode("utf-8", "replace")
    n = os.path.basename(path)
    if n.endswith(".agent_steps.csv"):
        t = "\n".join(l.rsplit(",", 1)[0] for l in t.splitlines())
    if n.endswith(".link_stats.json"):
        t = re.sub(r'"incarnation": \d+|"inproc:team-\d+"', "", t)
    return t
compared = 0
for n in names:
    if n in ("runtime_stats.json", "team.graph.yaml"):
        continue
    assert text(os.path.join(a, n)) == text(os.path.join(b, n)), n
    compared += 1
print("identical:", compared, "files")
PY
# The evaluation as printed, from the first table on (the titles name the folders).
sed -n '/^in-process (/,$p' "$work/rec.log" | sed "s|$work/rec|OUT|g" >"$work/rec.eval"
sed -n '/^in-process (/,$p' "$work/live.log" | sed "s|$work/live|OUT|g" >"$work/live.eval"
[ -s "$work/rec.eval" ] || fail "no evaluation printed"
diff "$work/rec.eval" "$work/live.eval" || fail "the evaluations differ"
grep -q "simulated while the team ran" "$work/live/fleet_report.md" || fail "report header"

# 2. Navigation and ground truth on disk, no ping.
for r in alpha bravo charlie; do
  cmp -s "$work/m/$r/groundtruth.tum" "$work/live/mission/$r/groundtruth.tum" ||
    fail "$r: ground truth differs from the recording's"
  cmp -s "$work/m/$r/ahrs.csv" "$work/live/mission/$r/ahrs.csv" || fail "$r: ahrs.csv differs"
  size=$(stat -c %s "$work/live/mission/$r/sonar.drs")
  [ "$size" -lt 100 ] || fail "$r: sonar.drs holds $size bytes"
done
big=$(find "$work/live" -type f -size +20M)
[ -z "$big" ] || fail "large files in the live run: $big"

# 3. In-process only.
"$fleet" --simulate "$mission" --mode dds --out "$work/dds" >"$work/dds.log" 2>&1 &&
  fail "--simulate --mode dds was accepted"
grep -q "in-process only" "$work/dds.log" || { cat "$work/dds.log"; fail "no reason given"; }
echo "PASS: outputs and evaluation identical, no pings on disk"
