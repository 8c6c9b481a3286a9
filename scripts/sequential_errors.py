#!/usr/bin/python3
"""Sequential factors against the ground truth: the evidence behind the scan-match translation
floor (slam.min_scan_match_sigma_xy_m, docs/local-slam.md "Scan-match translation floor").

    scripts/sequential_errors.py RUN [RUN ...]

RUN is a local-SLAM output folder (draco-local-slam's --out, or a team run's `inproc`): per
robot `<robot>.pose_graph.g2o`, `.trajectory.tum`, `.dead_reckoning.tum` and
`.ground_truth.tum`. Every EDGE_SE2 between consecutive keyframes that differs from the
dead-reckoning increment of the same keyframes is a scan match (the dead-reckoning factor kept
beside it is that increment). Prints per robot the RMS error against the ground truth's
relative pose of the dead-reckoning increments at the scan-matched edges and of the scan
matches: translation (m) and yaw (deg), and the scan matches' mean yaw error. Standard library
only.
"""
import bisect
import glob
import math
import os
import sys


def read_tum(path):
    out = {}
    with open(path) as f:
        for line in f:
            if line.startswith('#') or not line.strip():
                continue
            t, x, y, _, _, _, qz, qw = map(float, line.split())
            out[t] = (x, y, 2.0 * math.atan2(qz, qw))
    return out


def between(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return (c * dx + s * dy, -s * dx + c * dy, math.remainder(b[2] - a[2], 2.0 * math.pi))


def nearest(times, poses, t):
    i = min(max(bisect.bisect_left(times, t), 1), len(times) - 1)
    return poses[times[i]] if abs(times[i] - t) < abs(times[i - 1] - t) else poses[times[i - 1]]


def rms(errors, axis):
    return math.sqrt(sum(e[axis] ** 2 for e in errors) / len(errors)) if errors else float('nan')


def robot_errors(folder, robot):
    keyframe_times = sorted(read_tum(f'{folder}/{robot}.trajectory.tum'))
    dr = read_tum(f'{folder}/{robot}.dead_reckoning.tum')
    dr_poses = [dr[t] for t in sorted(dr)]
    gt = read_tum(f'{folder}/{robot}.ground_truth.tum')
    gt_times = sorted(gt)
    truth = [nearest(gt_times, gt, t) for t in keyframe_times]
    scan, dr_at_scan = [], []
    with open(f'{folder}/{robot}.pose_graph.g2o') as f:
        for line in f:
            fields = line.split()
            if fields[0] != 'EDGE_SE2' or int(fields[2]) != int(fields[1]) + 1:
                continue
            i = int(fields[1])
            if i + 1 >= len(truth) or i + 1 >= len(dr_poses):
                continue
            measured = tuple(map(float, fields[3:6]))
            increment = between(dr_poses[i], dr_poses[i + 1])
            if max(abs(m - d) for m, d in zip(measured, increment)) <= 1e-6:
                continue  # the dead-reckoning factor itself
            true = between(truth[i], truth[i + 1])
            err = lambda p: (p[0] - true[0], p[1] - true[1], math.remainder(p[2] - true[2], 2 * math.pi))
            scan.append(err(measured))
            dr_at_scan.append(err(increment))
    return scan, dr_at_scan


def main(folders):
    for folder in folders:
        for g2o in sorted(glob.glob(os.path.join(folder, '*.pose_graph.g2o'))):
            robot = os.path.basename(g2o).split('.')[0]
            scan, dr = robot_errors(folder, robot)
            mean_yaw = sum(e[2] for e in scan) / len(scan) if scan else float('nan')
            print(f'{folder} {robot}: {len(scan)} scan matches; dead reckoning xy '
                  f'{math.hypot(rms(dr, 0), rms(dr, 1)):.3f} m, yaw {math.degrees(rms(dr, 2)):.2f} deg; '
                  f'scan match xy {math.hypot(rms(scan, 0), rms(scan, 1)):.3f} m, yaw '
                  f'{math.degrees(rms(scan, 2)):.2f} deg (mean {math.degrees(mean_yaw):+.2f})')


if __name__ == '__main__':
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    main(sys.argv[1:])
