#!/usr/bin/env bash
# ROS 2 monitoring end to end: a team of three draco-robot daemons over DDS (draco-fleet
# --mode dds) with fleet.Ros2Monitor on another domain, read by a plain Cyclone DDS
# subscriber with ROS 2's default QoS (ros2_listener). Every robot's path, pose and map arrive
# under ROS 2's names, in the robot's map frame, and the last path ends where the robot's
# trajectory file ends. The team link's domain and the monitor's stay apart.
set -u
sim=$1
fleet=$2
listener=$3
src=$4
fail() { echo "FAIL: $*"; exit 1; }
work=$(mktemp -d)
trap 'touch "$work/stop"; wait; rm -rf "$work"' EXIT
link_domain=$(( ($$ % 100) + 10 ))
ros2_domain=$(( link_domain + 110 ))

"$sim" "$src/config/missions/marina.yaml" --out "$work/m" --duration-s 40 --no-pictures \
  >"$work/sim.log" 2>&1 || { cat "$work/sim.log"; fail "simulation"; }

(cd "$work" && "$listener" "$ros2_domain" "$src/config/dds/loopback.xml" 120 alpha bravo charlie \
  >"$work/listener.out" 2>"$work/listener.err") &
for _ in $(seq 100); do grep -q listening "$work/listener.out" 2>/dev/null && break; sleep 0.1; done

"$fleet" "$work/m" --mode dds --out "$work/run" --domain "$link_domain" \
  --set link.lockstep_timeout_s=5 monitor.enabled=true "monitor.domain_id=$ros2_domain" \
  "monitor.dds_config=$src/config/dds/loopback.xml" monitor.path_period_s=2 \
  monitor.map_period_s=5 >"$work/fleet.log" 2>&1
rc=$?
cat "$work/fleet.log"
[ $rc -eq 0 ] || fail "draco-fleet exited $rc"
sleep 1
touch "$work/stop"
wait
cat "$work/listener.out" "$work/listener.err"
python3 - "$work/listener.out" "$work/run/dds" <<'PY' || fail "what the ROS 2 subscriber got"
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if l.startswith("{")]
by = {r["topic"]: r for r in rows}
for robot in ["alpha", "bravo", "charlie"]:
    path, pose, cloud = (by["rt/draco/%s/%s" % (robot, k)] for k in ("path", "pose", "map"))
    # Paths and poses go out every 2 s, the map every 5 s of a ~35 s mission: a slow run (TSan)
    # can lose a robot's first map to discovery, so one map sample is enough.
    for r in (path, pose):
        assert r["samples"] >= 2, r
    assert cloud["samples"] >= 1, cloud
    for r in (path, pose, cloud):
        assert r["frame_id"] == robot + "/map", r
    assert cloud["size"] > 100, cloud
    # The last path ends at (or one keyframe before) the trajectory file's last keyframe.
    tum = [l.split() for l in open("%s/%s.trajectory.tum" % (sys.argv[2], robot))
           if l.strip() and not l.startswith("#")]
    assert path["size"] >= len(tum) - 3 and path["size"] <= len(tum), (path, len(tum))
    x, y = float(tum[path["size"] - 1][1]), float(tum[path["size"] - 1][2])
    err = ((x - path["last_x"]) ** 2 + (y - path["last_y"]) ** 2) ** 0.5
    assert err < 0.5, (robot, err, path)
    print("%s: %d paths (last %d poses, %.3f m from the file), %d poses, %d clouds (last %d points)"
          % (robot, path["samples"], path["size"], err, pose["samples"], cloud["samples"],
             cloud["size"]))
PY
echo "PASS"
