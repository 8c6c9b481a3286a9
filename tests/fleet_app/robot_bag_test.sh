#!/usr/bin/env bash
# draco-robot on a ROS 1 bag (config/graphs/robot-bag.yaml): the bag written by the rosbag
# tests' writer (python3-rosbag) replays through local SLAM and the team stages, every output
# is written; a truncated bag exits non-zero naming the file.
set -u
robot=$1
writer=$2
fail() { echo "FAIL: $*"; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 "$writer" "$work/bags" >/dev/null 2>&1 || fail "cannot write the test bags"
"$robot" --bag "$work/bags/full.bag" --team alpha,bravo --robot bravo --transport inproc \
  --out "$work/out" --quiet >"$work/log" 2>&1 || { cat "$work/log"; fail "bag replay failed"; }
for f in trajectory.tum dead_reckoning.tum ground_truth.tum pose_graph.g2o map.pcd \
         link_stats.json objects.csv inter_loops.csv runtime_stats.json; do
  [ -s "$work/out/bravo.$f" ] || fail "bravo.$f not written"
done
out=$("$robot" --bag "$work/bags/truncated_file.bag" --team alpha --robot alpha \
  --transport inproc --out "$work/bad" --quiet 2>&1) && fail "a truncated bag was accepted"
echo "$out" | grep -q "truncated_file.bag" || fail "the error does not name the bag: $out"
echo ok
