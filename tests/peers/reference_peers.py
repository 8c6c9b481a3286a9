#!/usr/bin/python3
"""The peers of draco on identical inputs (docs/benchmarks.md, "Peers on identical inputs").

Reads the folder written by peers_inputs (draco's inputs, answers and times), runs on the same
files the DRACo-SLAM2 reference algorithms rebuilt on Debian's Python stack and Open3D's ICP,
checks that each peer's answers agree with draco's within the stated tolerances, times each
peer (best of --repeats runs of the whole item, wall time) and prints a table.

    /usr/bin/python3 tests/peers/reference_peers.py DIR [--repeats N]

Reference algorithms (facts from the authors' public code, restated; no code of theirs):
  cfar    SOCA along range per beam: 20 training and 10 guard cells a side, a detection when
          value > tau * min(lead, lag) / 20 and value > the intensity threshold; cells whose
          windows run past either end are never detections (numpy, running sums).
  dbscan  sklearn DBSCAN (eps 1.5 m, min_samples 20) on the map, cv2.minAreaRect per cluster,
          centre the mean of its points, clusters with a long side under 3 m dropped.
  match   dense affinity matrix over all (n_a n_b)^2 assignment pairs (mu 8, the code's shape
          term), principal eigenvector by scipy's ARPACK (eigs), |v| reshaped, rectangular
          Hungarian (linear_sum_assignment) on the negated weights, cv2.estimateAffinePartial2D
          (RANSAC, 5 m), scale divided out, re-match on centre distance (< 5 m).
  icp     point-to-point ICP on a scipy cKDTree: nearest neighbour within 3 m, the closest
          80 % kept, closed-form 2D fit, at most 40 iterations, converged when the mean change
          over 4 iterations is under draco's thresholds; then the overlap (0.5 m).
  gcm     pairwise consistency of every candidate pair (cycle error, Mahalanobis with the
          first loop's covariance, chi-square 11.34; numpy), maximum clique by pivoting
          Bron-Kerbosch (networkx find_cliques), at least 5 members.
  open3d  o3d.pipelines.registration.registration_icp, point-to-point, 3 m correspondence
          distance, at most 40 iterations (its defaults otherwise), z = 0.
"""
import argparse
import csv
import math
import os
import sys
import time

import numpy as np


def best_ms(repeats, f):
    best = float("inf")
    out = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = f()
        best = min(best, (time.perf_counter() - t0) * 1e3)
    return best, out


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def read_points(path):
    with open(path) as f:
        f.readline()
        rest = f.read()
    if not rest.strip():
        return np.zeros((0, 2))
    return np.loadtxt(rest.splitlines(), delimiter=",", ndmin=2)


def wrap(a):
    return (a + np.pi) % (2.0 * np.pi) - np.pi


# --- SE(2) on arrays of (x, y, yaw), broadcasting --------------------------------------------
def compose(a, b):
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([a[..., 0] + c * b[..., 0] - s * b[..., 1],
                     a[..., 1] + s * b[..., 0] + c * b[..., 1],
                     wrap(a[..., 2] + b[..., 2])], axis=-1)


def inverse(a):
    c, s = np.cos(a[..., 2]), np.sin(a[..., 2])
    return np.stack([-c * a[..., 0] - s * a[..., 1], s * a[..., 0] - c * a[..., 1], -a[..., 2]],
                    axis=-1)


def pose_error(a, b):
    """Translation (m) and rotation (deg) of inv(a) * b."""
    e = compose(inverse(np.asarray(a, float)), np.asarray(b, float))
    return float(np.hypot(e[0], e[1])), float(abs(math.degrees(e[2])))


# --- (a) CFAR ---------------------------------------------------------------------------------
def soca_cfar(image, train, guard, tau, min_value):
    n, g = train // 2, guard // 2
    rows = image.shape[0]
    cs = np.vstack([np.zeros((1, image.shape[1])), np.cumsum(image, axis=0)])
    r = np.arange(n + g, rows - n - g)
    lead = cs[r - g] - cs[r - g - n]
    lag = cs[r + g + n + 1] - cs[r + g + 1]
    v = image[r]
    hit = (v > tau * np.minimum(lead, lag) / n) & (v > min_value)
    rr, bb = np.nonzero(hit)
    return rr + r[0], bb


def item_cfar(d, repeats):
    p = read_csv(os.path.join(d, "cfar", "params.csv"))[0]
    train, guard = int(p["train_cells"]), int(p["guard_cells"])
    tau, min_value = float(p["tau"]), float(p["min_intensity"])
    images, draco = [], []
    i = 0
    while os.path.exists(os.path.join(d, "cfar", f"ping{i}.u8")):
        with open(os.path.join(d, "cfar", f"ping{i}.u8"), "rb") as f:
            rows, cols = map(int, f.readline().split())
            images.append(np.frombuffer(f.read(), np.uint8).reshape(rows, cols))
        draco.append(read_points(os.path.join(d, "cfar", f"ping{i}.draco.csv")).astype(int))
        i += 1

    def run():
        return [soca_cfar(im.astype(np.float64), train, guard, tau, min_value) for im in images]

    ms, out = best_ms(repeats, run)
    differ, total = 0, 0
    for (rr, bb), dd in zip(out, draco):
        mine = set(zip(rr.tolist(), bb.tolist()))
        theirs = set(map(tuple, dd.tolist())) if dd.size else set()
        differ += len(mine ^ theirs)
        total += len(theirs)
    agree = differ == 0
    note = f"{total} detections in {len(images)} pings, {differ} differ"
    return [("cfar", "cfar", len(images), "numpy SOCA (reference)", ms, agree, note)]


# --- (b) DBSCAN + minimum-area rectangles -----------------------------------------------------
def item_dbscan(d, repeats):
    import cv2
    from sklearn.cluster import DBSCAN
    p = read_csv(os.path.join(d, "dbscan", "params.csv"))[0]
    eps, min_samples, d_min = float(p["eps_m"]), int(p["min_samples"]), float(p["min_length_m"])
    pts = read_points(os.path.join(d, "dbscan", "points.csv"))
    draco_labels = np.loadtxt(os.path.join(d, "dbscan", "draco_labels.csv"), skiprows=1,
                              dtype=int)
    draco_objects = read_csv(os.path.join(d, "dbscan", "draco_objects.csv"))

    def run():
        db = DBSCAN(eps=eps, min_samples=min_samples).fit(pts)
        labels = db.labels_
        objects = {}
        for c in range(labels.max() + 1):
            q = pts[labels == c]
            (_, _), (w, h), _ = cv2.minAreaRect(q.astype(np.float32))
            l, b = max(w, h), min(w, h)
            if l >= d_min:
                objects[c] = (q.mean(axis=0), l, b)
        return labels, db.core_sample_indices_, objects

    ms, (labels, core_idx, objects) = best_ms(repeats, run)
    core = np.zeros(len(pts), bool)
    core[core_idx] = True
    # Partition of the core points and the noise must be identical; border points (non-core
    # members) may go to another cluster they touch (scikit-learn: the first to reach them;
    # draco: the nearest core point's).
    same_noise = np.array_equal(labels == -1, draco_labels == -1)
    mapping, bad_core = {}, 0
    for i in np.nonzero(core)[0]:
        a, b = draco_labels[i], labels[i]
        if mapping.setdefault(a, b) != b:
            bad_core += 1
    one_to_one = len(set(mapping.values())) == len(mapping)
    border_moved = int(sum(1 for i in np.nonzero(~core & (labels >= 0))[0]
                           if mapping.get(draco_labels[i]) != labels[i]))
    # Rectangles: cv2.minAreaRect on draco's own clusters against draco's rectangles (the
    # rectangle step alone), and the objects whose members are identical in both partitions.
    worst_size, worst_centre, same_members, missing = 0.0, 0.0, 0, 0
    for o in draco_objects:
        lab = int(o["label"])
        q = pts[draco_labels == lab]
        (_, _), (w, h), _ = cv2.minAreaRect(q.astype(np.float32))
        worst_size = max(worst_size, abs(max(w, h) - float(o["length_m"])),
                         abs(min(w, h) - float(o["breadth_m"])))
        worst_centre = max(worst_centre, float(np.hypot(*(q.mean(axis=0) - [float(o["cx_m"]),
                                                                            float(o["cy_m"])]))))
        c = mapping.get(lab)
        if c not in objects:
            missing += 1
        elif np.array_equal(labels == c, draco_labels == lab):
            same_members += 1
    extra = len(objects) - (len(draco_objects) - missing)
    partition_ok = same_noise and bad_core == 0 and one_to_one
    agree = partition_ok and missing == 0 and extra == 0 and worst_size <= 0.01 and worst_centre <= 0.01
    note = (f"{len(pts)} points, {labels.max() + 1} clusters, {len(objects)} objects; core points "
            f"and noise {'identical' if partition_ok else 'DIFFER'}; {border_moved} border points "
            f"in another cluster they touch (the border rule), so {same_members} of "
            f"{len(draco_objects)} objects have identical members; cv2 rectangles of draco's "
            f"clusters within {worst_size * 1e3:.2f} mm, means {worst_centre * 1e3:.4f} mm")
    if missing or extra:
        note += f"; {missing} objects missing, {extra} extra"
    return [("dbscan", "dbscan + rectangles", 1, "sklearn DBSCAN + cv2.minAreaRect (reference)", ms, agree,
             note)]


# --- (c) object-graph matching ----------------------------------------------------------------
def rigid_fit(a, b):
    """Least-squares T with a ~ T * b (2D Kabsch)."""
    ma, mb = a.mean(axis=0), b.mean(axis=0)
    A, B = a - ma, b - mb
    sc = float(np.sum(B * A))
    ss = float(np.sum(B[:, 0] * A[:, 1] - B[:, 1] * A[:, 0]))
    yaw = math.atan2(ss, sc)
    R = np.array([[math.cos(yaw), -math.sin(yaw)], [math.sin(yaw), math.cos(yaw)]])
    t = ma - R @ mb
    return np.array([t[0], t[1], yaw])


def reference_match(A, B, p):
    import cv2
    from scipy.optimize import linear_sum_assignment
    from scipy.sparse.linalg import eigs
    mu = p["mu"]
    na, nb = len(A), len(B)
    if min(na, nb) < p["min_objects"] or min(na, nb) * (min(na, nb) - 1) // 2 < p["min_edges"]:
        return None
    ca, cb = A[:, 0:2], B[:, 0:2]
    Wa = np.linalg.norm(ca[:, None] - ca[None], axis=-1)
    Wb = np.linalg.norm(cb[:, None] - cb[None], axis=-1)
    S = np.exp(-2.0 * (np.abs(A[:, None, 2] - B[None, :, 2]) + np.abs(A[:, None, 3] - B[None, :, 3])))
    M = np.exp(-mu * np.abs(Wa[:, None, :, None] - Wb[None, :, None, :]))
    M *= S[:, :, None, None] * S[None, None, :, :]
    M[np.arange(na), :, np.arange(na), :] = 0.0  # i == j
    M[:, np.arange(nb), :, np.arange(nb)] = 0.0  # k == l
    M = M.reshape(na * nb, na * nb)
    _, v = eigs(M, k=1)
    X = np.abs(v[:, 0].real).reshape(na, nb)
    rows, cols = linear_sum_assignment(-X)
    if len(rows) < p["min_assignments"]:
        return None
    T, inl = cv2.estimateAffinePartial2D(cb[cols].astype(np.float64), ca[rows].astype(np.float64),
                                         method=cv2.RANSAC,
                                         ransacReprojThreshold=p["ransac_threshold_m"])
    if T is None or int(inl.sum()) < p["min_inliers"]:
        return None
    s = math.hypot(T[0, 0], T[1, 0])
    R = T[:, :2] / s
    t = T[:, 2]
    moved = cb @ R.T + t
    D = np.linalg.norm(ca[:, None] - moved[None], axis=-1)
    r2, c2 = linear_sum_assignment(D)
    keep = D[r2, c2] < p["rematch_distance_m"]
    r2, c2 = r2[keep], c2[keep]
    if len(r2) < p["min_inliers"]:
        return None
    return np.array([t[0], t[1], math.atan2(R[1, 0], R[0, 0])]), list(zip(r2, c2))


def item_match(d, repeats):
    p = {k: float(v) for k, v in read_csv(os.path.join(d, "match", "params.csv"))[0].items()}
    for k in ("min_objects", "min_edges", "min_assignments", "min_inliers"):
        p[k] = int(p[k])
    variants = [("match", "object matching, every entry kept"),
                ("match_sparse", "object matching, draco's sparsity (1e-2)")]
    draco_rows = {k: read_csv(os.path.join(d, "match", f"draco_{k}.csv")) for k, _ in variants}
    first = draco_rows["match"]
    maps = {}
    for row in first:
        for r in (row["a"], row["b"]):
            if r not in maps:
                objs = read_points(os.path.join(d, "match", f"{r}.objects.csv"))
                maps[r] = (objs[:, 0].astype(np.int64), objs[:, 1:5])

    def run():
        return [reference_match(maps[row["a"]][1], maps[row["b"]][1], p) for row in first]

    np.random.seed(1)
    ms, out = best_ms(repeats, run)
    result = []
    for key, label in variants:
        agree_all, notes = True, []
        for row, res in zip(draco_rows[key], out):
            matched = int(row["status"]) == 0
            name = f"{row['a']}<-{row['b']}"
            if not matched and res is None:
                notes.append(f"{name}: both no match")
                continue
            if matched != (res is not None):
                agree_all = False
                notes.append(f"{name}: draco {'match' if matched else 'no match'} (status "
                             f"{row['status']}), reference {'match' if res is not None else 'no match'}")
                continue
            T, pairs = res
            ida, idb = maps[row["a"]][0], maps[row["b"]][0]
            mine = {(int(ida[i]), int(idb[k])) for i, k in pairs}
            theirs = {tuple(map(int, x.split(":"))) for x in row["pairs"].split()}
            Td = np.array([float(row["x_m"]), float(row["y_m"]), float(row["yaw_rad"])])
            em, ed = pose_error(Td, T)
            A, B = maps[row["a"]][1], maps[row["b"]][1]
            Tf = rigid_fit(A[[i for i, _ in pairs], 0:2], B[[k for _, k in pairs], 0:2])
            fm, fd = pose_error(Td, Tf)
            ok = mine == theirs and fm <= 0.01 and fd <= 0.1
            agree_all &= ok
            notes.append(f"{name}: {len(theirs)} pairs {'same' if mine == theirs else 'DIFFER'}, "
                         f"cv2's transform {em:.3f} m / {ed:.2f} deg off, refit on the pairs "
                         f"{fm * 1e3:.2f} mm / {fd:.4f} deg")
        result.append((key, label, len(first), "dense eigs + Hungarian + cv2 RANSAC (reference)",
                       ms, agree_all, "; ".join(notes)))
    return result


# --- (d) ICP ----------------------------------------------------------------------------------
def reference_icp(src, tgt, seed, p):
    from scipy.spatial import cKDTree
    tree = cKDTree(tgt)
    T = np.array(seed, float)
    dt_hist, dr_hist = [], []
    w = int(p["convergence_window"])
    for _ in range(int(p["max_iterations"])):
        c, s = math.cos(T[2]), math.sin(T[2])
        moved = src @ np.array([[c, s], [-s, c]]) + T[:2]
        dist, j = tree.query(moved, distance_upper_bound=p["max_correspondence_distance_m"])
        ok = np.isfinite(dist)
        si, tj, dd = np.nonzero(ok)[0], j[ok], dist[ok]
        keep = math.ceil(p["trim_fraction"] * len(dd))
        if keep < len(dd):
            sel = np.argpartition(dd, keep)[:keep]
            si, tj = si[sel], tj[sel]
        if len(si) < p["min_correspondences"]:
            break
        a, b = moved[si], tgt[tj]
        d = rigid_fit(b, a)
        T = compose(d, T)
        dt_hist.append(math.hypot(d[0], d[1]))
        dr_hist.append(abs(d[2]))
        if len(dt_hist) >= w and (np.mean(dt_hist[-w:]) < p["convergence_translation_m"]
                                  and np.mean(dr_hist[-w:]) < p["convergence_rotation_rad"]):
            break
    c, s = math.cos(T[2]), math.sin(T[2])
    moved = src @ np.array([[c, s], [-s, c]]) + T[:2]
    dist, _ = tree.query(moved, distance_upper_bound=p["overlap_distance_m"])
    return T, float(np.isfinite(dist).mean())


def item_icp(d, repeats):
    p = {k: float(v) for k, v in read_csv(os.path.join(d, "icp", "params.csv"))[0].items()}
    rows = read_csv(os.path.join(d, "icp", "pairs.csv"))
    clouds = [(read_points(os.path.join(d, "icp", f"pair{r['pair']}.source.csv")),
               read_points(os.path.join(d, "icp", f"pair{r['pair']}.target.csv"))) for r in rows]
    seeds = [np.array([float(r["seed_x"]), float(r["seed_y"]), float(r["seed_yaw"])]) for r in rows]
    truth = [np.array([float(r["truth_x"]), float(r["truth_y"]), float(r["truth_yaw"])])
             for r in rows]
    draco = [np.array([float(r["draco_x"]), float(r["draco_y"]), float(r["draco_yaw"])])
             for r in rows]

    def judge(answers):
        within = sum(1 for a, b in zip(answers, draco)
                     if pose_error(b, a)[0] <= 0.01 and pose_error(b, a)[1] <= 0.1)
        err = [pose_error(t, a) for t, a in zip(truth, answers)]
        return within, np.median([e[0] for e in err]), np.median([e[1] for e in err])

    _, dm, dd = judge(draco)
    out_rows = []
    ms, out = best_ms(repeats, lambda: [reference_icp(s, t, seed, p)
                                        for (s, t), seed in zip(clouds, seeds)])
    within, em, ed = judge([o[0] for o in out])
    out_rows.append(("icp", "icp", len(rows), "cKDTree point-to-point ICP (reference)", ms,
                     within == len(rows),
                     f"{within}/{len(rows)} pairs within 1 cm / 0.1 deg of draco; error to truth "
                     f"median {em:.3f} m / {ed:.2f} deg (draco {dm:.3f} m / {dd:.2f} deg)"))
    # The reference computes no covariance: draco doing the same work (the same answers,
    # checked by peers_inputs), against the same reference run.
    out_rows.append(("icp_pose", "icp, pose and overlap only (the reference's work)", len(rows),
                     "cKDTree point-to-point ICP (reference)", ms, within == len(rows),
                     "draco without the covariance (IcpOptions::covariance false): the same "
                     "poses, validity and overlaps as the row above"))
    try:
        import open3d as o3d
    except ImportError:
        return out_rows
    reg = o3d.pipelines.registration
    pcs = []
    for s, t in clouds:
        ps, pt = o3d.geometry.PointCloud(), o3d.geometry.PointCloud()
        ps.points = o3d.utility.Vector3dVector(np.c_[s, np.zeros(len(s))])
        pt.points = o3d.utility.Vector3dVector(np.c_[t, np.zeros(len(t))])
        pcs.append((ps, pt))

    def seed4(q):
        c, s = math.cos(q[2]), math.sin(q[2])
        return np.array([[c, -s, 0, q[0]], [s, c, 0, q[1]], [0, 0, 1, 0], [0, 0, 0, 1]])

    crit = reg.ICPConvergenceCriteria(max_iteration=int(p["max_iterations"]))
    est = reg.TransformationEstimationPointToPoint()

    def run_o3d():
        return [reg.registration_icp(ps, pt, p["max_correspondence_distance_m"], seed4(q), est,
                                     crit).transformation for (ps, pt), q in zip(pcs, seeds)]

    ms, out = best_ms(repeats, run_o3d)
    answers = [np.array([M[0, 3], M[1, 3], math.atan2(M[1, 0], M[0, 0])]) for M in out]
    within, em, ed = judge(answers)
    out_rows.append(("icp", "icp", len(rows), "Open3D registration_icp point-to-point", ms,
                     within == len(rows),
                     f"{within}/{len(rows)} pairs within 1 cm / 0.1 deg of draco (no trimming: "
                     f"a different estimator); error to truth median {em:.3f} m / {ed:.2f} deg "
                     f"(draco {dm:.3f} m / {dd:.2f} deg)"))
    return out_rows


# --- (e) GCM ----------------------------------------------------------------------------------
def item_gcm(d, repeats):
    import networkx as nx
    p = read_csv(os.path.join(d, "gcm", "params.csv"))[0]
    chi2, min_size = float(p["chi2_threshold"]), int(p["min_clique_size"])
    poses = {}
    for r in read_csv(os.path.join(d, "gcm", "poses.csv")):
        poses.setdefault(int(r["robot"]), []).append(
            [float(r["x_m"]), float(r["y_m"]), float(r["yaw_rad"])])
    poses = {k: np.array(v) for k, v in poses.items()}
    maps = {int(r["teammate"]): np.array([float(r["x_m"]), float(r["y_m"]), float(r["yaw_rad"])])
            for r in read_csv(os.path.join(d, "gcm", "map_transforms.csv"))}
    rows = read_csv(os.path.join(d, "gcm", "loops.csv"))
    ids = np.array([int(r["id"]) for r in rows])
    own = np.array([poses[int(r["own_robot"])][int(r["own_keyframe"])] for r in rows])
    team = np.array([compose(maps[int(r["teammate_robot"])],
                             poses[int(r["teammate_robot"])][int(r["teammate_keyframe"])])
                     for r in rows])
    z = np.array([[float(r["x_m"]), float(r["y_m"]), float(r["yaw_rad"])] for r in rows])
    cov = np.array([[float(r[f"c{i}{j}"]) for i in range(3) for j in range(3)]
                    for r in rows]).reshape(-1, 3, 3)
    draco = {int(r["id"]) for r in read_csv(os.path.join(d, "gcm", "draco_accepted.csv"))}
    wrong = np.array([int(r["wrong"]) for r in rows], bool)

    def run():
        info = np.linalg.inv(cov)
        a = compose(inverse(z), inverse(own))      # inv(z_1) inv(P_1), per first loop
        b = compose(compose(own, z), inverse(team))  # P_2 z_2 inv(Q_2), per second loop
        e = compose(compose(a[:, None], b[None, :]), team[:, None])
        d2 = np.einsum("ijk,ikl,ijl->ij", e, info, e)
        n = len(rows)
        iu = np.triu_indices(n, 1)
        ok = d2[iu] < chi2
        G = nx.Graph()
        G.add_nodes_from(range(n))
        G.add_edges_from(zip(iu[0][ok], iu[1][ok]))
        best = max(nx.find_cliques(G), key=len)
        return set(ids[best].tolist()) if len(best) >= min_size else set(), G

    ms, (clique, G) = best_ms(repeats, run)
    is_clique = all(G.has_edge(int(np.nonzero(ids == a)[0][0]), int(np.nonzero(ids == b)[0][0]))
                    for a in draco for b in draco if a < b)
    agree = len(clique) == len(draco) and is_clique
    note = (f"{len(rows)} candidates ({int(wrong.sum())} wrong), {G.number_of_edges()} consistent "
            f"pairs; clique {len(clique)} (draco {len(draco)}, "
            f"{'the same set' if clique == draco else 'another set of equal size' if agree else 'DIFFER'}"
            f"{'' if is_clique else '; draco set not a clique here'}), "
            f"{int(wrong[[int(np.nonzero(ids == i)[0][0]) for i in clique]].sum()) if clique else 0}"
            f" wrong in it")
    return [("gcm", "gcm pair tests + max clique", len(rows), "numpy + networkx find_cliques (reference)",
             ms, agree, note)]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dir", help="folder written by peers_inputs")
    ap.add_argument("--repeats", type=int, default=5, help="best of N runs per item")
    ap.add_argument("--items", default="cfar,dbscan,match,icp,gcm")
    args = ap.parse_args()
    draco = {r["item"]: (int(r["instances"]), float(r["best_ms"]))
             for r in read_csv(os.path.join(args.dir, "draco_times.csv"))}
    items = {"cfar": item_cfar, "dbscan": item_dbscan, "match": item_match, "icp": item_icp,
             "gcm": item_gcm}
    rows = []
    for name in args.items.split(","):
        if name not in draco:
            print(f"{name}: no draco answer in {args.dir}", file=sys.stderr)
            continue
        rows += items[name](args.dir, args.repeats)
    print(f"\nbest of {args.repeats}, wall time of the whole item; ratio = peer / draco\n")
    print("| item | instances | draco ms | peer | peer ms | ratio | goal | agree | details |")
    print("|---|---|---|---|---|---|---|---|---|")
    for key, label, n, peer, ms, agree, note in rows:
        dms = draco[key][1]
        ratio = ms / dms if dms > 0 else float("inf")
        goal = ("-" if "Open3D" in peer else ">= 10x: " + ("met" if ratio >= 10 else "NOT met"))
        print(f"| {label} | {n} | {dms:.3f} | {peer} | {ms:.3f} | {ratio:.1f}x | {goal} | "
              f"{'yes' if agree else 'NO'} | {note} |")


if __name__ == "__main__":
    main()
