#!/usr/bin/env python3
"""Checks and the summary table of tests/net/team_netns.sh (a team across network namespaces).

  team_netns_check.py files DIR REF_DIR ROBOT...     every output file parses; REF_DIR's files
                                                     of each robot are all there too
  team_netns_check.py heard DIR ROBOT...            every teammate known, frames received > 0,
                                                     nothing rejected (as tests/fleet_app)
  team_netns_check.py compare REF_EVAL CASE_EVAL    accepted loops, team ATE and robots placed
                                                     against the in-process run (draco-eval
                                                     tables), tolerance as draco-fleet --mode both
  team_netns_check.py heard-after DIR CUT BOUND_S ROBOT...
                                                     frames of CUT sent after mission time
                                                     BOUND_S reached each teammate, and theirs
                                                     reached CUT (the cut robot heard again)
  team_netns_check.py table WORK CASE...            the summary table of the cases run
  team_netns_check.py placements DIR MISSION ROBOT...
                                                     where each robot placed each teammate,
                                                     judged against ground truth as
                                                     draco-fleet's placements_verdict.csv
                                                     (report::EvaluatePlacements): one CSV row
                                                     per ordered pair on stdout
  team_netns_check.py held DIR ROBOT...             which version of each teammate's object
                                                     map each robot holds at the end, against
                                                     the newest any robot holds
  team_netns_check.py mission-table WORK CASE...    the mission cases against the in-process
                                                     run: loops, team ATE, placements, first
                                                     right placement per pair, every wrong one

Exit 0 when the check holds, 1 (with the reasons on stdout) when it does not.
"""
import csv
import json
import math
import os
import struct
import sys


def fail(problems):
    for p in problems:
        print("  " + p)
    return 1 if problems else 0


def numbers(tokens):
    vals = [float(t) for t in tokens]
    if not all(math.isfinite(v) for v in vals):
        raise ValueError("not finite")
    return vals


PCD_TYPES = {("F", 4): "f", ("F", 8): "d", ("I", 1): "b", ("I", 2): "h", ("I", 4): "i",
             ("I", 8): "q", ("U", 1): "B", ("U", 2): "H", ("U", 4): "I", ("U", 8): "Q"}
PLY_TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h",
             "ushort": "H", "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I",
             "float": "f", "float32": "f", "double": "d", "float64": "d"}


def check_pcd(data):
    """None when a PCD file (as PCL writes it: ascii, binary or binary_compressed) is whole.

    The header is ASCII up to the DATA line; binary data is POINTS x the point size, every
    float finite; binary_compressed starts with its compressed and uncompressed sizes."""
    header, pos = {}, 0
    while "DATA" not in header:
        end = data.find(b"\n", pos)
        if end < 0:
            return "no DATA line"
        tokens = data[pos:end].decode("ascii").split()
        pos = end + 1
        if tokens and not tokens[0].startswith("#"):
            header[tokens[0]] = tokens[1:]
    for key in ("FIELDS", "SIZE", "TYPE", "POINTS"):
        if key not in header:
            return "no %s line" % key
    fields = header["FIELDS"]
    counts = [int(c) for c in header.get("COUNT", ["1"] * len(fields))]
    types = list(zip(header["TYPE"], [int(z) for z in header["SIZE"]]))
    if not len(fields) == len(types) == len(counts) or any(t not in PCD_TYPES for t in types):
        return "FIELDS, SIZE, TYPE, COUNT disagree"
    points, kind, body = int(header["POINTS"][0]), header["DATA"][0], data[pos:]
    fmt = "<" + "".join(PCD_TYPES[t] * c for t, c in zip(types, counts))
    if kind == "ascii":
        lines = [l for l in body.decode("ascii").splitlines() if l.strip()]
        if len(lines) != points:
            return "%d points, header says %d" % (len(lines), points)
        for l in lines:
            numbers(l.split())
    elif kind == "binary":
        if len(body) != points * struct.calcsize(fmt):
            return "%d bytes of points, header says %d x %d" % (len(body), points,
                                                              struct.calcsize(fmt))
        for values in struct.iter_unpack(fmt, body):
            if not all(math.isfinite(v) for v in values):
                return "a value that is not finite"
    elif kind == "binary_compressed":
        if points == 0:
            return None
        if len(body) < 8:
            return "no compressed block"
        packed, unpacked = struct.unpack("<II", body[:8])
        if unpacked != points * struct.calcsize(fmt) or len(body) < 8 + packed:
            return "compressed block of %d bytes (%d unpacked), %d points" % (packed, unpacked,
                                                                             points)
    else:
        return "DATA %s" % kind
    return None


def check_ply(data):
    """None when a PLY file (ascii or binary_little_endian, scalar properties) is whole."""
    end = data.find(b"end_header\n")
    if not data.startswith(b"ply\n") or end < 0:
        return "no ply magic or end_header"
    elements, kind = [], None
    for line in data[:end].decode("ascii").splitlines():
        tokens = line.split()
        if tokens[:1] == ["format"]:
            kind = tokens[1]
        elif tokens[:1] == ["element"]:
            elements.append((tokens[1], int(tokens[2]), []))
        elif tokens[:1] == ["property"]:
            if tokens[1] == "list" or tokens[1] not in PLY_TYPES:
                return "property %s not checked" % " ".join(tokens[1:])
            elements[-1][2].append(PLY_TYPES[tokens[1]])
    vertices = [e for e in elements if e[0] == "vertex"]
    if not vertices:
        return "no vertex element"
    body = data[end + len(b"end_header\n"):]
    if kind == "ascii":
        lines = [l for l in body.decode("ascii").splitlines() if l.strip()]
        if len(lines) < vertices[0][1]:
            return "%d lines, header says %d vertices" % (len(lines), vertices[0][1])
        for l in lines:
            numbers(l.split())
    elif kind == "binary_little_endian":
        size = sum(n * struct.calcsize("<" + "".join(p)) for _, n, p in elements)
        if len(body) != size:
            return "%d bytes of elements, header says %d" % (len(body), size)
        fmt = "<" + "".join(vertices[0][2])
        start = sum(n * struct.calcsize("<" + "".join(p))
                    for _, n, p in elements[:elements.index(vertices[0])])
        for values in struct.iter_unpack(fmt, body[start:start + vertices[0][1] *
                                                   struct.calcsize(fmt)]):
            if not all(math.isfinite(v) for v in values):
                return "a vertex value that is not finite"
    else:
        return "format %s" % kind
    return None


def check_file(path):
    """None when the file parses, else why not."""
    name = os.path.basename(path)
    try:
        if name.endswith(".pcd") or name.endswith(".ply"):
            with open(path, "rb") as f:
                data = f.read()
            return check_pcd(data) if name.endswith(".pcd") else check_ply(data)
        with open(path, encoding="utf-8") as f:
            text = f.read()
        if name.endswith(".json"):
            json.loads(text)
        elif name.endswith(".tum"):
            for i, line in enumerate(text.splitlines(), 1):
                if not line.strip() or line.startswith("#"):
                    continue
                try:
                    if len(numbers(line.split())) != 8:
                        return "line %d: %d fields, expected 8" % (i, len(line.split()))
                except ValueError:
                    return "line %d: not 8 numbers: %r" % (i, line)
        elif name.endswith(".csv"):
            rows = list(csv.reader(text.splitlines()))
            if not rows:
                return "empty (no header)"
            for i, row in enumerate(rows[1:], 2):
                if len(row) != len(rows[0]):
                    return "line %d: %d fields, header has %d" % (i, len(row), len(rows[0]))
        elif name.endswith(".g2o"):
            for i, line in enumerate(text.splitlines(), 1):
                tokens = line.split()
                if not tokens or tokens[0].startswith("#"):  # a comment (g2o skips them)
                    continue
                try:
                    numbers(tokens[1:])
                except ValueError:
                    return "line %d: %s with a value that is not a number" % (i, tokens[0])
    except (ValueError, UnicodeDecodeError, OSError, struct.error, IndexError) as e:
        return str(e)
    return None


def cmd_files(d, ref, robots):
    problems = []
    names = sorted(os.listdir(d))
    for n in names:
        if ".partial" in n:
            problems.append("%s: a partial file was left" % n)
    for r in robots:
        mine = [n for n in names if n.startswith(r + ".") and n != r + ".log"]
        for n in mine:
            why = check_file(os.path.join(d, n))
            if why:
                problems.append("%s: %s" % (n, why))
        # Every file the in-process run wrote for this robot (draco-fleet's own summary files
        # aside) is here too.
        want = [n for n in os.listdir(ref) if n.startswith(r + ".")]
        for n in sorted(set(want) - set(mine)):
            problems.append("%s: missing (the in-process run wrote it)" % n)
        if len(mine) < 10:
            problems.append("%s: only %d files" % (r, len(mine)))
    return fail(problems)


def stats(d, r):
    with open(os.path.join(d, r + ".link_stats.json"), encoding="utf-8") as f:
        return json.load(f)


def cmd_heard(d, robots):
    problems = []
    for r in robots:
        s = stats(d, r)
        for t in s["teammates"]:
            if not t["known"] or t["frames_received"] <= 0:
                problems.append("%s heard nothing from robot %d: %s" % (r, t["robot_id"], t))
            if t["frames_rejected"] != 0:
                problems.append("%s rejected frames of robot %d: %s" % (r, t["robot_id"], t))
        if s["counters"]["rejected"] != 0:
            problems.append("%s rejected %d frames" % (r, s["counters"]["rejected"]))
    return fail(problems)


def eval_table(path):
    """Rows of draco-eval's "team run" table: name -> (accepted, team ATE m, placed)."""
    rows = {}
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    start = [i for i, l in enumerate(lines) if l.startswith("robot") and "accept" in l]
    if not start:
        raise SystemExit("%s: no team table (draco-eval failed?)" % path)
    for l in lines[start[0] + 1:]:
        t = l.split()
        if len(t) != 10:
            break
        rows[t[0]] = (int(t[7]), float(t[4]), int(t[5]))
    return rows


def compare(ref_path, case_path):
    """Per robot: (name, ref, case, same), the rule of draco-fleet --mode both (10 %)."""
    ref, case = eval_table(ref_path), eval_table(case_path)
    out = []
    for name, (a_acc, a_ate, a_placed) in ref.items():
        if name not in case:
            out.append((name, ref[name], None, False))
            continue
        b_acc, b_ate, b_placed = case[name]
        loops_ok = abs(a_acc - b_acc) <= 0.1 * max(a_acc, 1)
        ate_ok = (a_ate < 0 and b_ate < 0) or abs(a_ate - b_ate) <= 0.1 * max(a_ate, 1e-3)
        out.append((name, ref[name], case[name], loops_ok and ate_ok and a_placed == b_placed))
    return out


def cmd_compare(ref_path, case_path):
    problems = []
    for name, a, b, same in compare(ref_path, case_path):
        line = "%-8s in-process accepted %d, team ATE %.3f m, placed %d" % ((name,) + a)
        line += "; here " + ("missing" if b is None else
                             "accepted %d, team ATE %.3f m, placed %d" % b)
        print("  %s: %s" % (line, "same" if same else "DIFFERENT"))
        if not same:
            problems.append(name + ": differs from the in-process run (tolerance 10 %)")
    return fail(problems)


def sent_until(d, r, bound_s):
    """Frames robot r handed to its link up to mission time bound_s (its link_traffic.csv)."""
    with open(os.path.join(d, r + ".link_traffic.csv"), encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return sum(1 for row in rows if float(row["start_s"]) <= bound_s), len(rows)


def cmd_heard_after(d, cut, bound_s, robots):
    """A frame whose transmission started after bound_s (mission time) was sent after the link
    came back; receiving more frames from a robot than it had sent by then proves one of them
    crossed after the cut."""
    problems = []
    ids = {r: i for i, r in enumerate(robots)}
    for r in robots:
        if r == cut:
            continue
        for sender, receiver in ((cut, r), (r, cut)):
            before, total = sent_until(d, sender, bound_s)
            got = [t["frames_received"] for t in stats(d, receiver)["teammates"]
                   if t["robot_id"] == ids[sender]][0]
            ok = got > before
            print("  %s -> %s: %d frames sent by mission time %.1f s (of %d), %d received: %s"
                  % (sender, receiver, before, bound_s, total, got,
                     "heard after the cut" if ok else "NOT heard after the cut"))
            if not ok:
                problems.append("%s did not hear %s after the cut" % (receiver, sender))
    return fail(problems)


def read_meta(path):
    meta = {}
    if os.path.exists(path):
        with open(path, encoding="utf-8") as f:
            for line in f:
                if "=" in line:
                    k, v = line.rstrip("\n").split("=", 1)
                    meta[k] = v
    return meta


def cmd_table(work, cases):
    ref_eval = os.path.join(work, "ref", "eval.txt")
    head = ("%-22s %-8s %4s %6s %5s %5s %-9s %9s %9s %4s %4s %6s %8s %-9s" %
            ("case", "robot", "exit", "wall s", "sent", "recv", "recv from", "DDS tx/rx",
             "wire kB", "lsto", "acc", "placed", "team m", "vs inproc"))
    print(head)
    print("-" * len(head))
    notes = []
    for case in cases:
        d = os.path.join(work, case)
        meta = read_meta(os.path.join(d, "meta.txt"))
        robots = meta.get("robots", "").split()
        cmp = {}
        if os.path.exists(os.path.join(d, "eval.txt")):
            try:
                cmp = {c[0]: c for c in compare(ref_eval, os.path.join(d, "eval.txt"))}
            except SystemExit:
                cmp = {}
        for r in robots:
            try:
                s = stats(d, r)
                sent = sum(k["frames_sent"] for k in s["kinds"].values())
                per = [t["frames_received"] for t in s["teammates"]]
                c = s["counters"]
                dds = "%d/%d" % (c["transport_frames_sent"], c["transport_frames_received"])
                lsto = str(c["lockstep_timeouts"])
            except (OSError, ValueError, KeyError):
                sent, per, dds, lsto = "-", [], "-", "-"
            acc = team = placed = "-"
            verdict = "-"
            if r in cmp:
                _, a, b, same = cmp[r]
                if b is not None:
                    acc, team, placed = str(b[0]), "%.3f" % b[1], str(b[2])
                verdict = "same" if same else "DIFFERENT"
            wire = meta.get("wire." + r, "-")
            print("%-22s %-8s %4s %6s %5s %5s %-9s %9s %9s %4s %4s %6s %8s %-9s" %
                  (meta.get("title", case)[:22], r, meta.get("exit." + r, "-"),
                   meta.get("wall." + r, "-"), sent, sum(per) if per else "-",
                   "/".join(str(p) for p in per) or "-", dds, wire, lsto, acc, placed, team,
                   verdict))
        if meta.get("note"):
            notes.append("%s: %s" % (meta.get("title", case), meta["note"]))
    ref = os.path.join(work, "ref", "eval.txt")
    if os.path.exists(ref):
        rows = eval_table(ref)
        print("%-22s %s" % ("in-process reference", ", ".join(
            "%s accepted %d, team %.3f m, placed %d" % (n, a, t, p)
            for n, (a, t, p) in rows.items())))
    for n in notes:
        print(n)
    print("sent: frames the robot's link sent (link_stats kinds); recv: frames it received "
          "from its teammates (recv from: per teammate, in id order without itself); DDS tx/rx: "
          "frames the transport handed to / took from Cyclone; wire kB: bytes out/in on the "
          "robot's bridge port; lsto: lock-step timeouts; acc: accepted inter-robot loops; "
          "team m: team ATE (draco-eval)")
    return 0


# --- placements judged against ground truth (components/report/src/placements.cpp) ---------


def read_tum(path):
    """[(t, x, y, yaw)] of a TUM file (as eval::ReadTum); [] when it does not exist."""
    out = []
    if not os.path.exists(path):
        return out
    with open(path, encoding="utf-8") as f:
        for line in f:
            t = line.split()
            if not t or t[0].startswith("#"):
                continue
            v = [float(x) for x in t]
            qx, qy, qz, qw = v[4:8]
            out.append((v[0], v[1], v[2],
                        math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))))
    return out


def wrap(a):
    return math.atan2(math.sin(a), math.cos(a))


def compose(a, b):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (a[0] + c * b[0] - s * b[1], a[1] + s * b[0] + c * b[1], wrap(a[2] + b[2]))


def inverse(a):
    c, s = math.cos(a[2]), math.sin(a[2])
    return (-(c * a[0] + s * a[1]), -(-s * a[0] + c * a[1]), -a[2])


def associate(est, truth, max_gap_s=0.5):
    """Pairs (estimate, truth interpolated at its time), as eval::Associate."""
    pairs, j = [], 0
    if not truth:
        return pairs
    for e in est:
        while j + 1 < len(truth) and truth[j + 1][0] < e[0]:
            j += 1
        if e[0] < truth[0][0] or e[0] > truth[-1][0]:
            continue
        t0 = truth[j]
        t1 = truth[j + 1] if j + 1 < len(truth) else truth[j]
        span = t1[0] - t0[0]
        if not (e[0] == t0[0] or e[0] == t1[0]) and span > max_gap_s:
            continue
        u = min(max((e[0] - t0[0]) / span, 0.0), 1.0) if span > 0 else 0.0
        pairs.append((e, (e[0], t0[1] + u * (t1[1] - t0[1]), t0[2] + u * (t1[2] - t0[2]))))
    return pairs


def align(pairs):
    """T_world_map: the SE(2) alignment of the estimate to the truth (eval::AlignUmeyama)."""
    n = len(pairs)
    mex = sum(e[1] for e, _ in pairs) / n
    mey = sum(e[2] for e, _ in pairs) / n
    mtx = sum(t[1] for _, t in pairs) / n
    mty = sum(t[2] for _, t in pairs) / n
    dot = cross = 0.0
    for e, t in pairs:
        ex, ey, tx, ty = e[1] - mex, e[2] - mey, t[1] - mtx, t[2] - mty
        dot += ex * tx + ey * ty
        cross += ex * ty - ey * tx
    th = 0.0 if dot == 0 and cross == 0 else math.atan2(cross, dot)
    c, s = math.cos(th), math.sin(th)
    return (mtx - (c * mex - s * mey), mty - (s * mex + c * mey), th)


def judge_placements(d, mission, robots, right_m=2.0, right_deg=5.0):
    """Per ordered pair: verdict (right / wrong / none at the end), final error, first placed,
    first right, first wrong, mission time placed wrong and the largest wrong error."""
    kfs, T_wm, end_s = {}, {}, 0.0
    for r in robots:
        kfs[r] = read_tum(os.path.join(d, r + ".trajectory.tum"))
        truth = read_tum(os.path.join(mission, r, "groundtruth.tum"))
        pairs = associate(kfs[r], truth) if len(kfs[r]) >= 2 else []
        if len(pairs) >= 2:
            T_wm[r] = align(pairs)
            end_s = max(end_s, kfs[r][-1][0])
    out = []
    for own in robots:
        rows = {}
        path = os.path.join(d, own + ".placements.csv")
        if os.path.exists(path):
            with open(path, encoding="utf-8") as f:
                for row in csv.DictReader(f):
                    rows.setdefault(row["teammate"], []).append(
                        (float(row["time_s"]), float(row["placed"]) != 0,
                         (float(row["x_m"]), float(row["y_m"]), float(row["yaw_rad"]))))
        for mate in robots:
            if mate == own:
                continue
            p = {"own": own, "teammate": mate, "verdict": "none", "final_err_m": -1.0,
                 "final_err_deg": -1.0, "first_placed_s": -1.0, "first_right_s": -1.0,
                 "first_wrong_s": -1.0, "wrong_duration_s": 0.0, "max_wrong_err_m": 0.0,
                 "changes": len(rows.get(mate, []))}
            if own in T_wm and mate in T_wm and mate in rows:
                T_true = compose(inverse(T_wm[own]), T_wm[mate])
                rs = rows[mate]
                for i, (t, placed, T) in enumerate(rs):
                    until = rs[i + 1][0] if i + 1 < len(rs) else end_s
                    if not placed:
                        p["verdict"] = "none"
                        continue
                    sq = [(a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 for a, b in
                          ((compose(T, (k[1], k[2], 0.0)), compose(T_true, (k[1], k[2], 0.0)))
                           for k in kfs[mate])]
                    err_m = math.sqrt(sum(sq) / len(sq)) if sq else math.hypot(
                        T[0] - T_true[0], T[1] - T_true[1])
                    err_deg = abs(wrap(T[2] - T_true[2])) * 180.0 / math.pi
                    right = err_m <= right_m and err_deg <= right_deg
                    if p["first_placed_s"] < 0:
                        p["first_placed_s"] = t
                    if right and p["first_right_s"] < 0:
                        p["first_right_s"] = t
                    if not right:
                        if p["first_wrong_s"] < 0:
                            p["first_wrong_s"] = t
                        p["wrong_duration_s"] += max(0.0, until - t)
                        p["max_wrong_err_m"] = max(p["max_wrong_err_m"], err_m)
                    p["verdict"] = "right" if right else "wrong"
                    p["final_err_m"], p["final_err_deg"] = err_m, err_deg
            out.append(p)
    return out


PLACEMENT_FIELDS = ("own", "teammate", "verdict", "final_err_m", "final_err_deg",
                    "first_placed_s", "first_right_s", "first_wrong_s", "wrong_duration_s",
                    "max_wrong_err_m", "changes")


def cmd_placements(d, mission, robots):
    w = csv.writer(sys.stdout, lineterminator="\n")
    w.writerow(PLACEMENT_FIELDS)
    for p in judge_placements(d, mission, robots):
        w.writerow([("%.3f" % p[k]) if isinstance(p[k], float) else p[k]
                    for k in PLACEMENT_FIELDS])
    return 0


def read_placements(path):
    with open(path, encoding="utf-8") as f:
        return {(r["own"], r["teammate"]): r for r in csv.DictReader(f)}


def true_accepted(path):
    """(accepted, true positives) of the team's inter-robot loops (draco-eval's line)."""
    import re
    with open(path, encoding="utf-8") as f:
        m = re.search(r"(\d+) accepted, (\d+) TP", f.read())
    return (int(m.group(1)), int(m.group(2))) if m else (-1, -1)


def cmd_held(d, robots):
    held = {}
    for r in robots:
        for t in stats(d, r)["teammates"]:
            held[(r, robots[t["robot_id"]])] = t["held_map_version"]
    newest = {m: max(v for (_, mm), v in held.items() if mm == m) for m in robots}
    print("; ".join("%s holds %s" % (r, ", ".join(
        "%s v%d%s" % (m, held[(r, m)], "" if held[(r, m)] == newest[m] else
                      " (newest held v%d)" % newest[m]) for m in robots if m != r))
        for r in robots))
    return 0


def cmd_mission_table(work, cases):
    ref_eval = os.path.join(work, "ref", "eval.txt")
    ref_pl = read_placements(os.path.join(work, "ref", "placements.csv"))
    ref_rows = eval_table(ref_eval)
    head = ("%-22s %-8s %4s %9s %13s %5s %-27s %-9s" %
            ("case", "robot", "exit", "acc", "team m", "r/w/n", "first right s (teammates)",
             "vs in-process"))
    print(head)
    print("-" * len(head))
    wrong = []

    def first_rights(pl, own):
        return "/".join(
            "%.0f" % float(p["first_right_s"]) if float(p["first_right_s"]) >= 0 else "-"
            for (o, _), p in sorted(pl.items()) if o == own)

    def rwn(pl, own):
        v = [p["verdict"] for (o, _), p in pl.items() if o == own]
        return "%d/%d/%d" % (v.count("right"), v.count("wrong"), v.count("none"))

    ref_acc, ref_tp = true_accepted(ref_eval)
    for r, (acc, ate, _) in ref_rows.items():
        print("%-22s %-8s %4s %9s %13s %5s %-27s %-9s" % (
            "in-process", r, "-", str(acc), "%.3f" % ate, rwn(ref_pl, r),
            first_rights(ref_pl, r), "-"))
    totals = ["in-process: team %d accepted, %d true" % (ref_acc, ref_tp)]
    for case in cases:
        d = os.path.join(work, case)
        meta = read_meta(os.path.join(d, "meta.txt"))
        title = meta.get("title", case)[:22]
        try:
            pl = read_placements(os.path.join(d, "placements.csv"))
        except OSError:
            pl = {}
        cmp = {}
        try:
            cmp = {c[0]: c for c in compare(ref_eval, os.path.join(d, "eval.txt"))}
            acc_all, tp_all = true_accepted(os.path.join(d, "eval.txt"))
            totals.append("%s: team %d accepted, %d true" % (title, acc_all, tp_all))
        except (SystemExit, OSError):
            pass
        for r in meta.get("robots", "").split():
            acc = team = "-"
            verdict = "-"
            if r in cmp and cmp[r][2] is not None:
                _, a, b, same = cmp[r]
                acc = "%d (%+d)" % (b[0], b[0] - a[0])
                team = "%.3f (%+.0f%%)" % (b[1], 100.0 * (b[1] - a[1]) / max(a[1], 1e-3))
                # Placements: the same verdict for every pair as in-process.
                same_pl = all(pl.get(k, {}).get("verdict") == v["verdict"]
                              for k, v in ref_pl.items() if k[0] == r)
                verdict = ("within 10%" if same else "NOT within 10%") + (
                    "" if same_pl else ", placements differ")
            print("%-22s %-8s %4s %9s %13s %5s %-27s %-9s" % (
                title, r, meta.get("exit." + r, "-"), acc, team, rwn(pl, r) if pl else "-",
                first_rights(pl, r) if pl else "-", verdict))
        walls = [float(meta["wall." + r]) for r in meta.get("robots", "").split()
                 if "wall." + r in meta]
        if walls and "mission_s" in meta:
            totals.append("%s: %s s of mission in %.0f s of wall time (%.2fx; paced at %sx)" % (
                title, meta["mission_s"], max(walls), float(meta["mission_s"]) / max(walls),
                meta.get("pace", "-")))
        if meta.get("held"):
            totals.append("%s: object maps held at the end: %s" % (title, meta["held"]))
        for (o, m), p in sorted(pl.items()):
            if float(p["first_wrong_s"]) >= 0:
                wrong.append("%s: %s placed %s wrong from mission %.0f s for %.0f s (worst %.2f "
                             "m; at the end %s, %.2f m / %.2f deg)" % (
                                 title, o, m, float(p["first_wrong_s"]),
                                 float(p["wrong_duration_s"]), float(p["max_wrong_err_m"]),
                                 p["verdict"], float(p["final_err_m"]),
                                 float(p["final_err_deg"])))
    for t in totals:
        print(t)
    print("WRONG placements: %d" % len(wrong))
    for w in wrong:
        print("  " + w)
    print("acc: accepted inter-robot loops (change against in-process); team m: team ATE "
          "(change); r/w/n: teammates placed right / wrong / not at the end (within 2 m and "
          "5 deg of the truth); first right s: mission time of the first right placement of "
          "each teammate in name order")
    return 0


def main(argv):
    if len(argv) < 2:
        print(__doc__)
        return 2
    cmd, args = argv[1], argv[2:]
    if cmd == "files":
        return cmd_files(args[0], args[1], args[2:])
    if cmd == "heard":
        return cmd_heard(args[0], args[1:])
    if cmd == "compare":
        return cmd_compare(args[0], args[1])
    if cmd == "heard-after":
        return cmd_heard_after(args[0], args[1], float(args[2]), args[3:])
    if cmd == "table":
        return cmd_table(args[0], args[1:])
    if cmd == "placements":
        return cmd_placements(args[0], args[1], args[2:])
    if cmd == "held":
        return cmd_held(args[0], args[1:])
    if cmd == "mission-table":
        return cmd_mission_table(args[0], args[1:])
    print(__doc__)
    return 2


if __name__ == "__main__":
    sys.exit(main(sys.argv))
