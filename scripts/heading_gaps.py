#!/usr/bin/python3
"""How far inter-robot loops turn from the maps' absolute headings: the evidence behind the
heading bound (max_heading_gap_rad, docs/safe-merges.md safeguard 1).

    scripts/heading_gaps.py RUN:MISSION [RUN:MISSION ...]

RUN is a team run's output folder (draco-fleet's `inproc`, or draco-worlds' `WORLD/run/inproc`),
MISSION the recorded mission it replayed (its `mission.yaml`, and per robot `ahrs.csv`). For
every candidate loop in `<robot>.inter_loops.csv`: the map-to-map rotation it implies (own
keyframe yaw + loop yaw - teammate keyframe yaw, the keyframes' final local-SLAM poses from
`<robot>.trajectory.tum`), and its gap to the difference of the two maps' absolute headings,
each heading taken two ways: the first AHRS reading, and the circular mean over the keyframes
up to the later of the loop's two keyframe times of the AHRS yaw minus the local-SLAM yaw (what
team.ObjectMapper sends with map_heading_from_keyframes). A loop is true when it lies within
1.5 m and 15 deg of the ground truth's relative pose of its keyframes. Prints the gaps of true
and false loops and how many of each a bound of 10-25 deg keeps or drops. Standard library and
PyYAML only.
"""
import bisect
import math
import sys

import yaml


def wrap(a):
    return math.remainder(a, 2.0 * math.pi)


def yaw_of(qx, qy, qz, qw):
    return math.atan2(2.0 * (qw * qz + qx * qy), 1.0 - 2.0 * (qy * qy + qz * qz))


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def inverse(a):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-c * a[0] - s * a[1], s * a[0] - c * a[1], -a[2])


def read_tum(path):
    rows = []
    with open(path) as f:
        for line in f:
            if line.strip() and not line.startswith("#"):
                v = [float(x) for x in line.split()]
                rows.append((v[0], v[1], v[2], yaw_of(*v[4:8])))
    return rows


def at_time(times, rows, t):
    return rows[min(bisect.bisect_left(times, t), len(rows) - 1)]


def robot_data(run, mission, name):
    keyframes = read_tum(f"{run}/{name}.trajectory.tum")
    truth = read_tum(f"{run}/{name}.ground_truth.tum")
    with open(f"{mission}/{name}/ahrs.csv") as f:
        next(f)
        ahrs = [(float(r[0]), float(r[3])) for r in (line.split(",") for line in f)]
    ahrs_t = [a[0] for a in ahrs]
    mean, s, c = [], 0.0, 0.0
    for t, _, _, yaw in keyframes:
        h = at_time(ahrs_t, ahrs, t)[1] - yaw
        s, c = s + math.sin(h), c + math.cos(h)
        mean.append((t, math.atan2(s, c)))
    return {"kf": keyframes, "truth": truth, "truth_t": [r[0] for r in truth],
            "first": ahrs[0][1], "mean": mean, "mean_t": [m[0] for m in mean]}


def mean_heading(d, t):
    i = max(0, bisect.bisect_right(d["mean_t"], t) - 1)
    return d["mean"][i][1]


def gaps(run, mission):
    with open(f"{mission}/mission.yaml") as f:
        names = [r["name"] for r in yaml.safe_load(f)["robots"]]
    data = {n: robot_data(run, mission, n) for n in names}
    out = []
    for own in names:
        with open(f"{run}/{own}.inter_loops.csv") as f:
            next(f)
            for line in f:
                p = line.strip().split(",")
                mate = names[int(p[3])]
                i, j = int(p[2]), int(p[4])
                a, b = data[own], data[mate]
                if i >= len(a["kf"]) or j >= len(b["kf"]):
                    continue
                ka, kb = a["kf"][i], b["kf"][j]
                loop = (float(p[5]), float(p[6]), float(p[7]))
                rotation = wrap(ka[3] + loop[2] - kb[3])
                ta = at_time(a["truth_t"], a["truth"], ka[0])
                tb = at_time(b["truth_t"], b["truth"], kb[0])
                rel = compose(inverse(ta[1:]), tb[1:])
                true = (math.hypot(rel[0] - loop[0], rel[1] - loop[1]) <= 1.5 and
                        abs(wrap(rel[2] - loop[2])) <= math.radians(15.0))
                later = max(ka[0], kb[0])
                first = abs(wrap(rotation - (b["first"] - a["first"])))
                mean = abs(wrap(rotation - (mean_heading(b, later) - mean_heading(a, later))))
                out.append((true, math.degrees(first), math.degrees(mean)))
    return out


def quantile(v, q):
    v = sorted(v)
    return v[min(len(v) - 1, int(q * len(v)))] if v else float("nan")


def main():
    if len(sys.argv) < 2 or any(":" not in a for a in sys.argv[1:]):
        sys.exit(__doc__)
    loops = []
    for arg in sys.argv[1:]:
        run, mission = arg.split(":", 1)
        loops += gaps(run, mission)
    for column, heading in ((1, "first AHRS reading"), (2, "keyframe mean")):
        print(f"heading: {heading}")
        for true in (True, False):
            v = [x[column] for x in loops if x[0] == true]
            print(f"  {'true' if true else 'false'} loops {len(v)}: gap median "
                  f"{quantile(v, 0.5):.1f}, p95 {quantile(v, 0.95):.1f}, max "
                  f"{quantile(v, 1.0):.1f} deg")
        for bound in (10, 12, 15, 18, 20, 25):
            dropped = sum(1 for x in loops if x[0] and x[column] > bound)
            kept = sum(1 for x in loops if not x[0] and x[column] <= bound)
            print(f"  bound {bound} deg: true loops dropped {dropped}, false loops kept {kept}")
        far = sorted(round(x[column], 1) for x in loops if not x[0] and x[column] > 10)
        print(f"  false loops beyond 10 deg: {len(far)}, the nearest {far[:3]}")


if __name__ == "__main__":
    main()
