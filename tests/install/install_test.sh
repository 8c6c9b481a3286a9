#!/usr/bin/env bash
# cmake --install into a temporary prefix, then run from there with the source tree out of
# the way ($DRACO_DATA_DIR, $CYCLONEDDS_URI and user overrides unset, working folder outside
# the source tree):
# 1. only bin/<apps>, share/draco-slam/ and the systemd unit lib/systemd/system/draco-robot@.service
#    are installed: nothing that collides with Debian's draco package (include/draco,
#    libdraco*, lib/cmake/draco, draco_encoder ...); the unit starts <prefix>/bin/draco-robot
#    and passes `systemd-analyze verify` (where systemd-analyze is installed);
# 2. draco-sim simulates a shipped mission (cut to 20 s, 3 robots);
# 3. draco-local-slam replays it with graphs/local-slam.yaml found in <prefix>/share/draco-slam
#    (run_info.json names it, with the version --version prints); trajectories parse;
# 3c. draco-team-eval runs a shipped experiment by name (experiments/oracle-matching.yaml in
#    the share folder) and records it, resolved, in its run folder;
# 4. draco run runs the default graph from the share folder;
# 5. draco-fleet --mode dds starts the draco-robot next to it in <prefix>/bin, both on the
#    loopback profile from the share folder;
# 6. the installed systemd unit as systemd runs it, one instance per robot: its ExecStart line
#    with %i and %S expanded, a clean environment holding only the unit's Environment= and an
#    environment file made from the installed robot.env.example; every instance exits 0, writes
#    into its state directory, and its own trajectory equals step 5's (local SLAM does not
#    depend on the link) with the team link heard and as many inter-robot loops (within 10 %).
set -u
build=$1
cmake=$2
fail() { echo "FAIL: $*"; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
prefix=$work/prefix
share=$prefix/share/draco-slam

"$cmake" --install "$build" --prefix "$prefix" >"$work/install.log" 2>&1 ||
  { cat "$work/install.log"; fail "cmake --install"; }

# 1. What is installed.
(cd "$prefix" && find . -type f -o -type l | sed 's|^\./||' | sort) >"$work/files"
unit=lib/systemd/system/draco-robot@.service
unexpected=$(grep -Ev "^(bin/draco(-[a-z-]+)?|share/draco-slam/.+|$unit)\$" "$work/files")
[ -z "$unexpected" ] || fail "unexpected files installed: $unexpected"
grep -v "^$unit\$" "$work/files" |
  grep -E '(^include/|^lib|libdraco|draco_(en|de|trans)coder|cmake/)' &&
  fail "installed a file that collides with Debian's draco package"
[ -f "$prefix/$unit" ] || fail "$unit not installed"
grep -q "^ExecStart=$prefix/bin/draco-robot --robot %i " "$prefix/$unit" ||
  fail "$unit does not start $prefix/bin/draco-robot: $(grep ExecStart "$prefix/$unit")"
grep -q '^StateDirectory=draco-slam/%i$' "$prefix/$unit" || fail "$unit: no StateDirectory"
grep -q '^EnvironmentFile=/etc/draco-slam/%i.env$' "$prefix/$unit" || fail "$unit: no env file"
[ -f "$share/systemd/robot.env.example" ] || fail "share/draco-slam/systemd/robot.env.example"
if command -v systemd-analyze >/dev/null; then
  mkdir -p "$work/units"
  cp "$prefix/$unit" "$work/units/draco-robot@alpha.service"
  verify=$(systemd-analyze verify "$work/units/draco-robot@alpha.service" 2>&1)
  rc=$?
  { [ $rc -eq 0 ] && ! echo "$verify" | grep -q draco-robot; } ||
    fail "systemd-analyze verify (exit $rc): $verify"
else
  echo "systemd-analyze not installed: the unit is not verified"
fi
for app in draco draco-robot draco-fleet draco-sim draco-eval draco-local-slam draco-worlds \
  draco-team-eval draco-frontend-eval draco-fleet-sizes; do
  [ -x "$prefix/bin/$app" ] || fail "bin/$app not installed"
done
for f in graphs/robot.yaml graphs/local-slam.yaml graphs/local-slam-core.yaml \
  graphs/default.yaml missions/airplane.yaml worlds/airplane.yaml generator/harbour.yaml \
  dds/loopback.xml dds/lan.xml dds/unicast.xml dds/acoustic.xml \
  experiments/oracle-matching.yaml; do
  [ -f "$share/$f" ] || fail "share/draco-slam/$f not installed"
done

# From here on: the installed tree only.
unset DRACO_DATA_DIR CYCLONEDDS_URI XDG_CONFIG_HOME
export HOME=$work/home
mkdir -p "$HOME"
cd "$work" || fail "cd $work"
bin=$prefix/bin

# 2. A short mission from a shipped mission file.
"$bin/draco-sim" "$share/missions/airplane.yaml" --out m --duration-s 20 --robots 3 \
  --no-pictures >sim.log 2>&1 || { cat sim.log; fail "draco-sim"; }
[ -f m/mission.yaml ] || fail "no mission.yaml"

# 3. Local SLAM with the installed graph.
"$bin/draco-local-slam" m --out ls >ls.log 2>&1 || { cat ls.log; fail "draco-local-slam"; }
version=$("$bin/draco-local-slam" --version) || fail "draco-local-slam --version"
python3 - ls "$share" "$version" "$bin/draco-local-slam" <<'PY' || fail "draco-local-slam outputs"
import json, os, sys
out, share, version_line, exe = sys.argv[1:]
info = json.load(open(os.path.join(out, "run_info.json")))
assert info["files"]["graph"] == os.path.join(share, "graphs/local-slam.yaml"), info["files"]
assert "draco-local-slam " + info["version"] == version_line, (info["version"], version_line)
assert info["executable"] == exe, info["executable"]
for robot in ("alpha", "bravo", "charlie"):
    rows = [l.split() for l in open(os.path.join(out, robot + ".trajectory.tum"))
            if l.strip() and not l.startswith("#")]
    assert len(rows) >= 2, (robot, len(rows))
    for r in rows:
        assert len(r) == 8, r
        [float(x) for x in r]
    json.load(open(os.path.join(out, robot + ".runtime_stats.json")))
PY

# 3b. draco-robot takes its settings from DRACO_* variables too (the systemd environment file).
out=$(DRACO_MISSION=m DRACO_ROBOT=zulu DRACO_LOG_LEVEL=warn "$bin/draco-robot" 2>&1) &&
  fail "draco-robot accepted robot zulu"
echo "$out" | grep -q "has no robot 'zulu'" || fail "DRACO_MISSION/DRACO_ROBOT not read: $out"

# 3c. A shipped experiment by name.
"$bin/draco-team-eval" m --out t --experiment oracle-matching >t.log 2>&1 ||
  { cat t.log; fail "draco-team-eval --experiment oracle-matching"; }
grep -q '^  oracle: true$' t/experiment.yaml || fail "t/experiment.yaml: oracle is not on"
[ -s t/slam/alpha.graph.yaml ] || fail "t/slam/alpha.graph.yaml missing"
python3 - t "$share" <<'PY' || fail "draco-team-eval run_info.json"
import json, os, sys
out, share = sys.argv[1:]
files = json.load(open(os.path.join(out, "run_info.json")))["files"]
assert files["experiment"] == os.path.join(share, "experiments/oracle-matching.yaml"), files
assert files["graph"] == os.path.join(share, "graphs/local-slam.yaml"), files
PY

# 4. The default graph from the share folder.
"$bin/draco" run --rate 0 --until 2 --out d >d.log 2>&1 || { cat d.log; fail "draco run"; }
python3 - d "$share" <<'PY' || fail "draco run outputs"
import json, os, sys
out, share = sys.argv[1:]
info = json.load(open(os.path.join(out, "run_info.json")))
assert info["files"]["graph"] == os.path.join(share, "graphs/default.yaml"), info["files"]
json.load(open(os.path.join(out, "runtime_stats.json")))
assert len(open(os.path.join(out, "sum.csv")).readlines()) > 1
PY

# 5. A three-daemon team over DDS: draco-fleet starts the draco-robot next to it.
domain=$(( ($$ % 200) + 10 ))
"$bin/draco-fleet" m --mode dds --out f --domain "$domain" --set link.lockstep_timeout_s=5 \
  >f.log 2>&1 || { cat f.log; for l in f/dds/*.log; do cat "$l"; done; fail "draco-fleet"; }
python3 - f/dds "$bin/draco-robot" "$share" <<'PY' || fail "draco-fleet outputs"
import json, os, sys
out, robot_exe, share = sys.argv[1:]
for robot in ("alpha", "bravo", "charlie"):
    info = json.load(open(os.path.join(out, robot + ".run_info.json")))
    assert info["executable"] == robot_exe, info["executable"]
    assert info["files"]["graph"] == os.path.join(share, "graphs/robot.yaml"), info["files"]
    assert info["files"]["dds_config"] == os.path.join(share, "dds/loopback.xml"), info["files"]
    stats = json.load(open(os.path.join(out, robot + ".link_stats.json")))
    assert all(t["frames_received"] > 0 for t in stats["teammates"]), stats["teammates"]
    assert os.path.getsize(os.path.join(out, robot + ".trajectory.tum")) > 0
PY

# 6. The systemd unit's command, per instance, as systemd would start it.
exec_start=$(sed -n 's/^ExecStart=//p' "$prefix/$unit")
state=$work/state
domain2=$(( domain + 1 ))
pids=()
for robot in alpha bravo charlie; do
  sed -e "s|^DRACO_MISSION=.*|DRACO_MISSION=$work/m|" -e "s|^DRACO_DOMAIN=.*|DRACO_DOMAIN=$domain2|" \
    -e 's|^DRACO_DDS_CONFIG=.*|DRACO_DDS_CONFIG=loopback|' \
    -e 's|^#DRACO_ARGS=.*|DRACO_ARGS=--set link.lockstep_timeout_s=5 --quiet|' \
    "$share/systemd/robot.env.example" >"$work/$robot.env"
  envs=(DRACO_LOG_LEVEL=info HOME="$HOME" PATH=/usr/bin:/bin)
  while IFS= read -r line; do
    case $line in '' | '#'*) continue ;; esac
    envs+=("$line")
  done <"$work/$robot.env"
  args=$(grep '^DRACO_ARGS=' "$work/$robot.env" | cut -d= -f2-)
  cmd=${exec_start//%i/$robot}
  cmd=${cmd//%S/$state}
  cmd=${cmd//\$DRACO_ARGS/$args}
  mkdir -p "$state/draco-slam/$robot"  # StateDirectory=
  # shellcheck disable=SC2086  # split as systemd splits ExecStart
  (cd / && env -i "${envs[@]}" $cmd >"$work/unit-$robot.log" 2>&1) &
  pids+=($!)
done
for i in 0 1 2; do
  wait "${pids[$i]}" || { cat "$work"/unit-*.log; fail "instance ${i} of $unit exited non-zero"; }
done
python3 - "$state/draco-slam" f/dds <<'PY' || { cat "$work"/unit-*.log; fail "the unit's outputs"; }
import csv, json, os, sys
state, fleet = sys.argv[1:]
def loops(path):  # accepted inter-robot loops
    return sum(1 for r in csv.DictReader(open(path)) if r["accepted"] == "1")
for robot in ("alpha", "bravo", "charlie"):
    out = os.path.join(state, robot)
    same = open(os.path.join(out, robot + ".trajectory.tum")).read()
    assert same == open(os.path.join(fleet, robot + ".trajectory.tum")).read(), robot
    stats = json.load(open(os.path.join(out, robot + ".link_stats.json")))
    assert all(t["frames_received"] > 0 for t in stats["teammates"]), stats["teammates"]
    info = json.load(open(os.path.join(out, robot + ".run_info.json")))
    assert info["files"]["dds_config"].endswith("share/draco-slam/dds/loopback.xml"), info
    a = loops(os.path.join(out, robot + ".inter_loops.csv"))
    b = loops(os.path.join(fleet, robot + ".inter_loops.csv"))
    assert abs(a - b) <= max(1, 0.1 * b), (robot, a, b)
    print(robot, "as a service: trajectory as draco-fleet's,", a, "accepted inter-robot loops, as", b)
PY
echo ok
