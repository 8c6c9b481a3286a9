#!/usr/bin/env python3
"""Would the object maps place a teammate better than its loops? For the placed pairs of a run.

    scripts/object_fit.py runs/worlds [--world seed-31] [--blend 16]   # a draco-worlds --out folder

For every ordered pair placed at the end (pairs.csv, verdict right or wrong), from the run's
files: the error of the final placement (<own>.placements.csv, last row), of the rigid fit of
the accepted loops alone (<own>.inter_loops.csv on the local-SLAM keyframes), and of the
object-map refinement from the final placement, as team.TwoStepOptimizer's refine_* does it
(objects::RefineUnderTransform: each small teammate object, length <= 8 m, paired with the
nearest small own object within 1.5 m, the rigid fit of the pairs, five times; at least 5
pairs), on the final object maps (<robot>.objects.csv). Errors as the judge's: RMS distance
of the teammate's keyframes against the true map-to-map transform, and the yaw. With
--blend N the refinement moves only n / (n + N) of the way (refine_blend_pairs). Last lines:
right / wrong (2 m, 5 deg), errors summed, and how many pairs the refinement makes worse or
better by more than 0.1 m.
"""
import argparse
import collections
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pair_stops import NAMES, align, compose, inverse, read_tum, rms_m, rows, wrap  # noqa: E402


def fit_points(a, b):
    """SE(2) mapping points a onto b (least squares)."""
    n = len(a)
    ma = (sum(p[0] for p in a) / n, sum(p[1] for p in a) / n)
    mb = (sum(p[0] for p in b) / n, sum(p[1] for p in b) / n)
    sd = sc = 0.0
    for p, q in zip(a, b):
        ax, ay, bx, by = p[0] - ma[0], p[1] - ma[1], q[0] - mb[0], q[1] - mb[1]
        sd += ax * bx + ay * by
        sc += ax * by - ay * bx
    th = math.atan2(sc, sd)
    c, s = math.cos(th), math.sin(th)
    return (mb[0] - (c * ma[0] - s * ma[1]), mb[1] - (s * ma[0] + c * ma[1]), th)


def small_centres(path, max_length_m):
    return [(float(r["center_x_m"]), float(r["center_y_m"])) for r in rows(path)
            if float(r["length_m"]) <= max_length_m]


def refine(T, own, mate, gate_m, min_pairs, iterations=5):
    """objects::RefineUnderTransform: (T, pairs) or (None, pairs)."""
    n = 0
    for _ in range(iterations):
        a, b = [], []
        for m in mate:
            p = compose(T, (m[0], m[1], 0.0))
            best = min(own, key=lambda o: math.hypot(o[0] - p[0], o[1] - p[1]), default=None)
            if best is not None and math.hypot(best[0] - p[0], best[1] - p[1]) <= gate_m:
                a.append(m)
                b.append(best)
        n = len(a)
        if n < max(2, min_pairs):
            return None, n
        T = fit_points(a, b)
    return T, n


def blend(T0, T1, a, keyframes):
    """T0 moved the fraction a of the way to T1 about the teammate keyframes' centroid."""
    cx = sum(k[1] for k in keyframes) / len(keyframes)
    cy = sum(k[2] for k in keyframes) / len(keyframes)
    p0, p1 = compose(T0, (cx, cy, 0.0)), compose(T1, (cx, cy, 0.0))
    yaw = T0[2] + a * wrap(T1[2] - T0[2])
    px, py = p0[0] + a * (p1[0] - p0[0]), p0[1] + a * (p1[1] - p0[1])
    c, s = math.cos(yaw), math.sin(yaw)
    return (px - (c * cx - s * cy), py - (s * cx + c * cy), yaw)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run", help="a draco-worlds --out folder (pairs.csv and one folder per world)")
    ap.add_argument("--world", help="only this world (e.g. seed-31)")
    ap.add_argument("--gate-m", type=float, default=1.5)
    ap.add_argument("--max-length-m", type=float, default=8.0)
    ap.add_argument("--min-pairs", type=int, default=5)
    ap.add_argument("--blend", type=float, default=0.0, help="refine_blend_pairs (0: all the way)")
    a = ap.parse_args()
    pairs_csv = os.path.join(a.run, "pairs.csv")
    if not os.path.exists(pairs_csv):
        sys.exit(f"object_fit: {pairs_csv} not found (give a draco-worlds --out folder)")
    total = collections.Counter()
    sums = collections.defaultdict(float)
    for p in rows(pairs_csv):
        if p["verdict"] == "none" or (a.world and p["world"] != a.world):
            continue
        d = os.path.join(a.run, p["world"], "run", "inproc")
        own, mate = p["own"], p["teammate"]
        kf_own, kf_mate = read_tum(f"{d}/{own}.trajectory.tum"), read_tum(f"{d}/{mate}.trajectory.tum")
        T_true = compose(inverse(align(kf_own, read_tum(f"{d}/{own}.ground_truth.tum"))),
                         align(kf_mate, read_tum(f"{d}/{mate}.ground_truth.tum")))
        last = [r for r in rows(f"{d}/{own}.placements.csv") if r["teammate"] == mate][-1]
        T_final = (float(last["x_m"]), float(last["y_m"]), float(last["yaw_rad"]))
        src, dst = [], []
        for r in rows(f"{d}/{own}.inter_loops.csv"):
            if r["accepted"] != "1" or int(r["teammate_robot"]) != NAMES.index(mate):
                continue
            po, pm = kf_own[int(r["own_keyframe"])], kf_mate[int(r["teammate_keyframe"])]
            q = compose((po[1], po[2], po[3]), (float(r["x_m"]), float(r["y_m"]), float(r["yaw_rad"])))
            src.append((pm[1], pm[2]))
            dst.append((q[0], q[1]))
        T_loops = fit_points(src, dst) if len(src) >= 2 else None
        T_obj, n = refine(T_final, small_centres(f"{d}/{own}.objects.csv", a.max_length_m),
                          small_centres(f"{d}/{mate}.objects.csv", a.max_length_m), a.gate_m,
                          a.min_pairs)
        if T_obj is not None and a.blend > 0.0:
            T_obj = blend(T_final, T_obj, n / (n + a.blend), kf_mate)
        line = [p["world"], own, "->", mate]
        errors = {}
        for name, T in (("final", T_final), ("loops", T_loops), ("objects", T_obj or T_final)):
            if T is None:
                line.append(f"{name} -")
                continue
            e_m, e_deg = rms_m(T, T_true, kf_mate), abs(math.degrees(wrap(T[2] - T_true[2])))
            errors[name] = e_m
            line.append(f"{name} {e_m:.2f} m / {e_deg:.1f} deg")
            total[f"{name} {'right' if e_m <= 2.0 and e_deg <= 5.0 else 'wrong'}"] += 1
            sums[name] += e_m
        line.append(f"({n} object pairs{'' if T_obj is not None else ', not refined'})")
        print("  ".join(line))
        if errors["objects"] > errors["final"] + 0.1:
            total["worse"] += 1
        elif errors["objects"] < errors["final"] - 0.1:
            total["better"] += 1
    for name in ("final", "loops", "objects"):
        print(f"{name}: {total[name + ' right']} right / {total[name + ' wrong']} wrong, "
              f"errors summed {sums[name]:.1f} m")
    print(f"the refinement: {total['worse']} pairs worse, {total['better']} better (by > 0.1 m)")


if __name__ == "__main__":
    main()
