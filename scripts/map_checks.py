#!/usr/bin/env python3
"""Every map check of a draco-worlds run judged against the ground truth (safeguard 5 of
docs/safe-merges.md: the teammate's objects on the own sonar returns).

    scripts/map_checks.py runs/rep [runs/other ...]     # draco-worlds --out folders

Each row of <world>/run/inproc/<own>.map_checks.csv is one check of a transform the accepted
loops imply. The transform is judged as draco-worlds judges a placement (RMS distance of the
teammate's keyframes under it and under the true map-to-map transform, and the yaw error):
right (< 2 m and 5 deg), near (< 5 m) or far. Prints per class the checks that contradicted
the placement and the distribution of missing teammate objects (expected minus those on own
sonar points), then the pairs whose right transforms were contradicted. Standard library only;
the geometry is scripts/pair_stops.py's.
"""
import argparse
import collections
import math
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import pair_stops as ps  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("runs", nargs="+", help="draco-worlds --out folders")
    a = ap.parse_args()
    checks = collections.Counter()
    misses = collections.Counter()
    refused_right = collections.defaultdict(list)
    for run in a.runs:
        if not os.path.isdir(run):
            sys.exit(f"map_checks: {run} is not a folder")
        for world in sorted(os.listdir(run)):
            d = os.path.join(run, world, "run", "inproc")
            if not os.path.isdir(d):
                continue
            robots = sorted(f.split(".")[0] for f in os.listdir(d) if f.endswith(".trajectory.tum"))
            try:
                T = {r: ps.align(ps.read_tum(f"{d}/{r}.trajectory.tum"),
                                 ps.read_tum(f"{d}/{r}.ground_truth.tum")) for r in robots}
                kfs = {r: ps.read_tum(f"{d}/{r}.trajectory.tum") for r in robots}
            except (OSError, ValueError) as e:
                print(f"{run}/{world}: unreadable ({e})")
                continue
            for own in robots:
                path = f"{d}/{own}.map_checks.csv"
                if not os.path.exists(path):
                    continue
                for r in ps.rows(path):
                    mate = r["teammate"]
                    if mate not in T:
                        continue
                    t_true = ps.compose(ps.inverse(T[own]), T[mate])
                    t = (float(r["x_m"]), float(r["y_m"]), float(r["yaw_rad"]))
                    err_m = ps.rms_m(t, t_true, kfs[mate])
                    err_deg = abs(math.degrees(ps.wrap(t[2] - t_true[2])))
                    cls = "right" if err_m < 2 and err_deg < 5 else "near" if err_m < 5 else "far"
                    expected = int(r["mate_objects_expected"])
                    missing = expected - int(r["mate_objects_on_own_points"])
                    contradicted = r["contradicted"] == "1"
                    checks[(cls, contradicted)] += 1
                    misses[(cls, min(missing, 4))] += 1
                    if cls == "right" and contradicted:
                        refused_right[(run, world, own, mate)].append(
                            (missing, expected, round(err_m, 2), round(err_deg, 1)))
    print("class  checks  contradicted  missing 0 / 1 / 2 / 3 / >=4")
    for cls in ("right", "near", "far"):
        n = checks[(cls, False)] + checks[(cls, True)]
        dist = " / ".join(str(misses[(cls, k)]) for k in range(5))
        print(f"{cls:6s} {n:7d} {checks[(cls, True)]:13d}  {dist}")
    print(f"pairs with a right transform contradicted: {len(refused_right)}")
    for (run, world, own, mate), rows in sorted(refused_right.items()):
        m, e, em, ed = rows[-1]
        print(f"  {run}/{world} {own}->{mate}: {len(rows)} checks; last {m} of {e} missing, "
              f"{em} m / {ed} deg off")


if __name__ == "__main__":
    main()
