#!/usr/bin/env python3
"""Where the evidence stops for the eligible pairs a draco-worlds run did not place right.

    scripts/pair_stops.py runs/rep            # a draco-worlds --out folder

For every eligible ordered pair (pairs.csv) not placed right at the end, the own robot's files
of that world's run (<world>/run/inproc/<own>.matches.csv, registrations.csv, inter_loops.csv)
are read against the ground truth, and the pair is put in the first stage that stops it:

  matcher: no answer           no object-graph match at all (the statuses say why)
  matcher: only wrong answers  matches, none within 3 m (RMS over the teammate's keyframes)
                               and 10 deg of the true map-to-map transform
  registration: no candidate   right matches, but no candidate loop
  filter: none accepted        candidates, none accepted by the consistency filter
  optimiser: rules (R)         accepted loops, the optimiser's rules did not place it; R the
                               last reason of <own>.holds.csv (lever, mutual, ...) when present
  placed wrong                 placed, and wrong at the end

The true transform is the one the judge uses (docs/safe-merges.md): each robot's local-SLAM
trajectory aligned to its ground truth, T_own_teammate = inv(T_world_own) T_world_teammate.
Prints one line per pair and the count per stage.
"""
import argparse
import bisect
import collections
import csv
import math
import os
import sys

NAMES = ["alpha", "bravo", "charlie", "delta", "echo", "foxtrot", "golf", "hotel"]


def read_tum(path):
    out = []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            v = [float(x) for x in line.split()]
            out.append((v[0], v[1], v[2], 2.0 * math.atan2(v[6], v[7])))
    return out


def align(est, truth):
    """SE(2) that best maps est's positions onto truth's at the same times (Umeyama, no scale)."""
    times = [g[0] for g in truth]
    a, b = [], []
    for e in est:
        i = bisect.bisect_left(times, e[0] - 1e-6)
        if i < len(truth) and abs(truth[i][0] - e[0]) <= 0.05:
            a.append(e[1:3])
            b.append(truth[i][1:3])
    if not a:
        raise ValueError("no common times")
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


def inverse(t):
    c, s = math.cos(t[2]), math.sin(t[2])
    return (-(c * t[0] + s * t[1]), -(-s * t[0] + c * t[1]), -t[2])


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], a[2] + b[2])


def wrap(angle):
    return math.atan2(math.sin(angle), math.cos(angle))


def rms_m(t, t_true, keyframes):
    total = 0.0
    for k in keyframes:
        p, q = compose(t, (k[1], k[2], 0.0)), compose(t_true, (k[1], k[2], 0.0))
        total += (p[0] - q[0]) ** 2 + (p[1] - q[1]) ** 2
    return math.sqrt(total / max(1, len(keyframes)))


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run", help="a draco-worlds --out folder (pairs.csv and one folder per world)")
    ap.add_argument("--right-m", type=float, default=3.0, help="a match within this is right")
    ap.add_argument("--right-deg", type=float, default=10.0)
    a = ap.parse_args()
    pairs_csv = os.path.join(a.run, "pairs.csv")
    if not os.path.exists(pairs_csv):
        sys.exit(f"pair_stops: {pairs_csv} not found (give a draco-worlds --out folder)")
    aligned = {}

    def world_T(d, robot):
        if (d, robot) not in aligned:
            aligned[(d, robot)] = align(read_tum(f"{d}/{robot}.trajectory.tum"),
                                        read_tum(f"{d}/{robot}.ground_truth.tum"))
        return aligned[(d, robot)]

    counts = collections.Counter()
    for p in rows(pairs_csv):
        if p["eligible"] != "1" or p["verdict"] == "right":
            continue
        d = os.path.join(a.run, p["world"], "run", "inproc")
        own, mate = p["own"], p["teammate"]
        try:
            mate_id = NAMES.index(mate)
            t_true = compose(inverse(world_T(d, own)), world_T(d, mate))
            mate_kfs = read_tum(f"{d}/{mate}.trajectory.tum")
            matches = [r for r in rows(f"{d}/{own}.matches.csv")
                       if int(r["teammate_robot"]) == mate_id]
            regs = [r for r in rows(f"{d}/{own}.registrations.csv")
                    if int(r["teammate_robot"]) == mate_id and r.get("configured", "1") == "1"]
            loops = [r for r in rows(f"{d}/{own}.inter_loops.csv")
                     if int(r["teammate_robot"]) == mate_id]
        except (OSError, ValueError, KeyError) as e:
            print(f"{p['world']:9s} {own}->{mate}: unreadable ({e})")
            counts["unreadable"] += 1
            continue
        statuses = collections.Counter(f"{r['status']} ({r['path']})" for r in matches)
        answered = [r for r in matches if r["status"] == "matched"]
        right = 0
        for r in answered:
            t = (float(r["x_m"]), float(r["y_m"]), float(r["yaw_rad"]))
            right += (rms_m(t, t_true, mate_kfs) < a.right_m and
                      abs(math.degrees(wrap(t[2] - t_true[2]))) < a.right_deg)
        accepted = sum(r["accepted"] == "1" for r in loops)
        if p["verdict"] == "wrong":
            stage = "placed wrong"
        elif not answered:
            stage = "matcher: no answer"
        elif right == 0:
            stage = "matcher: only wrong answers"
        elif not loops:
            stage = "registration: no candidate"
        elif accepted == 0:
            stage = "filter: none accepted"
        else:
            stage = "optimiser: rules"
            holds = f"{d}/{own}.holds.csv"
            if os.path.exists(holds):
                last = [r["held"] for r in rows(holds) if r["teammate"] == mate]
                stage += f" ({last[-1] if last and last[-1] else 'not held'})"
        counts[stage] += 1
        reg_statuses = dict(collections.Counter(r["status"] for r in regs))
        print(f"{p['world']:9s} {own}->{mate}: {stage:28s} matches {dict(statuses)} right "
              f"{right}/{len(answered)} registrations {reg_statuses} candidates {len(loops)} "
              f"accepted {accepted}")
    print()
    for stage, n in counts.most_common():
        print(f"{n:4d}  {stage}")


if __name__ == "__main__":
    main()
