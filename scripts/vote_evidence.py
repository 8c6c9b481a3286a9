#!/usr/bin/env python3
"""Is the truth in the object maps? For the eligible pairs a draco-worlds run did not place right.

    scripts/vote_evidence.py runs/rep [--world seed-28]     # a draco-worlds --out folder

For every eligible ordered pair (pairs.csv) not placed right at the end, the final object maps
of both robots (<world>/run/inproc/<robot>.objects.csv) are compared as the matcher's
translation votes compare them (docs/front-end.md, steps 10-12): support = teammate objects
landing within 1.5 m of an own object of similar shape (landmarks with landmarks). Printed:
the support of the true transform (the judge's, as scripts/pair_stops.py computes it), then
the best-supported translations distinct from it (3 m) at rotations within 10 deg of the true
one, each with its offset from the truth and its misses: objects of either map laid where the
other robot's sonar looked (20 m, +-65 deg of a keyframe) with fewer than 3 of that robot's
returns (<robot>.map.pcd) inside the object's rectangle grown by 2 m (objects::SupportByPoints).
A rival with the truth's support and no more misses means the maps cannot tell the two apart.
"""
import argparse
import collections
import math
import os
import struct
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pair_stops import align, compose, inverse, read_tum, rows, wrap  # noqa: E402

LANDMARK_ID = 1 << 30


def read_objects(path):
    out = []
    for r in rows(path):
        out.append({"x": float(r["center_x_m"]), "y": float(r["center_y_m"]),
                    "l": float(r["length_m"]), "b": float(r["breadth_m"]),
                    "yaw": float(r["yaw_rad"]), "lm": int(r["id"]) >= LANDMARK_ID})
    return out


def read_pcd_xy(path):
    """x, y of a binary PCD with fields x y z (float32), as the team run writes it."""
    with open(path, "rb") as f:
        n = 0
        while True:
            line = f.readline().decode("ascii", "replace")
            if not line:
                raise ValueError(f"{path}: no DATA line")
            if line.startswith("POINTS"):
                n = int(line.split()[1])
            if line.startswith("DATA"):
                if "binary" not in line:
                    raise ValueError(f"{path}: only binary PCD is read")
                break
        data = f.read(12 * n)
    return [struct.unpack_from("<fff", data, 12 * i)[:2] for i in range(len(data) // 12)]


class Returns:
    """A robot's sonar points in 1 m cells, and where its keyframes looked."""

    def __init__(self, points, keyframes):
        self.cells = collections.Counter((math.floor(x), math.floor(y)) for x, y in points)
        self.keyframes = keyframes

    def observed(self, p, range_m=20.0, half_rad=1.1345):
        for k in self.keyframes:
            dx, dy = p[0] - k[1], p[1] - k[2]
            if math.hypot(dx, dy) <= range_m and abs(wrap(math.atan2(dy, dx) - k[3])) <= half_rad:
                return True
        return False

    def count_in(self, c, yaw, hl, hb):
        n, r = 0, math.hypot(hl, hb)
        cy, sy = math.cos(yaw), math.sin(yaw)
        for ix in range(math.floor(c[0] - r), math.floor(c[0] + r) + 1):
            for iy in range(math.floor(c[1] - r), math.floor(c[1] + r) + 1):
                dx, dy = ix + 0.5 - c[0], iy + 0.5 - c[1]
                if abs(cy * dx + sy * dy) <= hl and abs(-sy * dx + cy * dy) <= hb:
                    n += self.cells.get((ix, iy), 0)
        return n


def apply(t, o):
    c, s = math.cos(t[2]), math.sin(t[2])
    return (t[0] + c * o["x"] - s * o["y"], t[1] + s * o["x"] + c * o["y"])


def compatible(p, q):
    if p["lm"] != q["lm"]:
        return False
    if p["lm"]:
        return True
    d = abs(p["l"] - q["l"]) + abs(p["b"] - q["b"])
    return math.exp(-2.0 * d / (1.0 + 0.25 * max(p["l"], q["l"]))) >= 1e-2


def support(a, b, t):
    n = 0
    for ob in b:
        q = apply(t, ob)
        n += any(math.hypot(oa["x"] - q[0], oa["y"] - q[1]) < 1.5 and compatible(oa, ob) for oa in a)
    return n


def misses(objects, t, returns):
    """Objects placed by t where `returns` looked, with fewer than 3 of its points near."""
    m = 0
    for o in objects:
        if o["lm"]:
            continue
        q = apply(t, o)
        if returns.observed(q) and returns.count_in(q, o["yaw"] + t[2], o["l"] / 2 + 2.0,
                                                    o["b"] / 2 + 2.0) < 3:
            m += 1
    return m


def distinct(b, x, y):
    return sum(math.dist(apply(x, o), apply(y, o)) for o in b) / max(1, len(b)) > 3.0


def vote_peaks(a, b, yaw0):
    """The densest 2 x 2 blocks of 2 m cells at each rotation, as the matcher's votes."""
    out = []
    for step in range(-5, 6):
        yaw = yaw0 + step * 0.0349
        c, s = math.cos(yaw), math.sin(yaw)
        cells = collections.defaultdict(list)
        for oa in a:
            for ob in b:
                if compatible(oa, ob):
                    t = (oa["x"] - (c * ob["x"] - s * ob["y"]), oa["y"] - (s * ob["x"] + c * ob["y"]))
                    cells[(math.floor(t[0] / 2), math.floor(t[1] / 2))].append(t)
        blocks = []
        for i, j in cells:
            v = [t for di in (0, 1) for dj in (0, 1) for t in cells.get((i + di, j + dj), [])]
            if len(v) >= 2:
                blocks.append((len(v), sum(t[0] for t in v) / len(v), sum(t[1] for t in v) / len(v)))
        blocks.sort(key=lambda x: (-x[0], x[1], x[2]))
        out += [(x, y, yaw) for _, x, y in blocks[:8]]
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("run", help="a draco-worlds --out folder (pairs.csv and one folder per world)")
    ap.add_argument("--world", help="only this world (e.g. seed-28)")
    ap.add_argument("--rivals", type=int, default=3, help="distinct translations shown per pair")
    a = ap.parse_args()
    pairs_csv = os.path.join(a.run, "pairs.csv")
    if not os.path.exists(pairs_csv):
        sys.exit(f"vote_evidence: {pairs_csv} not found (give a draco-worlds --out folder)")
    for p in rows(pairs_csv):
        if p["eligible"] != "1" or p["verdict"] == "right" or (a.world and p["world"] != a.world):
            continue
        d = os.path.join(a.run, p["world"], "run", "inproc")
        own, mate = p["own"], p["teammate"]
        try:
            kf = {r: read_tum(f"{d}/{r}.trajectory.tum") for r in (own, mate)}
            tw = {r: align(kf[r], read_tum(f"{d}/{r}.ground_truth.tum")) for r in (own, mate)}
            objs = {r: read_objects(f"{d}/{r}.objects.csv") for r in (own, mate)}
            ret = {r: Returns(read_pcd_xy(f"{d}/{r}.map.pcd"), kf[r]) for r in (own, mate)}
        except (OSError, ValueError, KeyError) as e:
            print(f"{p['world']:9s} {own}->{mate}: unreadable ({e})")
            continue
        t_true = compose(inverse(tw[own]), tw[mate])
        A, B = objs[own], objs[mate]

        def describe(t):
            m_own = misses(B, t, ret[own])
            m_mate = misses(A, inverse(t), ret[mate])
            return f"support {support(A, B, t)}, misses {m_own} own + {m_mate} teammate"

        line = (f"{p['world']:9s} {own}->{mate}: objects {len(A)} / {len(B)}; "
                f"truth {describe(t_true)}")
        scored = sorted(((support(A, B, t), t) for t in vote_peaks(A, B, t_true[2])),
                        key=lambda x: -x[0])
        shown = [t_true]
        for _, t in scored:
            if len(shown) > a.rivals:
                break
            if all(distinct(B, t, u) for u in shown):
                shown.append(t)
                off = math.hypot(t[0] - t_true[0], t[1] - t_true[1])
                line += (f"; rival {off:.1f} m {math.degrees(wrap(t[2] - t_true[2])):+.0f} deg "
                         f"{describe(t)}")
        print(line)


if __name__ == "__main__":
    main()
