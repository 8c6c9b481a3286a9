#!/usr/bin/python3
"""Cost as the mission grows: the whole team live in one process (draco-fleet --simulate) on
missions of several lengths and team sizes; per component the mean, p99 and max time per call
(runtime_stats.json) and the process's peak memory; a table and a plot.

    scripts/scaling.py [--build build] [--out runs/scaling] [--minutes 10,30,60,120]
        [--mission config/missions/marina.yaml] [--mission runs/g5/mission.yaml ...]
        [--set optimizer.max_loops_per_teammate_keyframe=0 ...]

Each mission's robots repeat their patterns (eight times) so that every length is reached; each
run is capped with --duration-s. Writes OUT/scaling.md, OUT/scaling.csv and OUT/scaling.png.
"""
import argparse, csv, json, os, subprocess, sys, time
import yaml

STAGES = ["reader", "cfar", "odometry", "slam", "mapper", "matcher", "exchange", "filter",
          "optimizer", "link"]


def repeated(mission_path, out_path, times=8):
    m = yaml.safe_load(open(mission_path))
    base = os.path.dirname(os.path.abspath(mission_path))
    w = m.get("world")
    if isinstance(w, str) and not os.path.isabs(w):
        m["world"] = os.path.normpath(os.path.join(base, w))
    for r in m["robots"]:
        r["patterns"] = list(r["patterns"]) * times
    m["duration_s"] = 0
    with open(out_path, "w") as f:
        yaml.safe_dump(m, f, sort_keys=False)
    return len(m["robots"])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--build", default="build")
    ap.add_argument("--out", default="runs/scaling")
    ap.add_argument("--minutes", default="10,30,60,120",
                    help="lengths; NAME=LIST per mission (e.g. g8=10,30,60) overrides for one")
    ap.add_argument("--mission", action="append")
    ap.add_argument("--set", action="append", default=[], metavar="NODE.KEY=VALUE",
                    help="passed to draco-fleet (a graph parameter of every robot)")
    ap.add_argument("--reuse", action="store_true",
                    help="keep the runs already in OUT (their scaling_run.json), run the rest")
    a = ap.parse_args()
    missions = a.mission or ["config/missions/marina.yaml"]
    per_mission = {}
    default_minutes = None
    for part in a.minutes.split(";"):
        if "=" in part:
            k, v = part.split("=", 1)
            per_mission[k] = [float(x) for x in v.split(",")]
        else:
            default_minutes = [float(x) for x in part.split(",")]
    minutes = default_minutes or [10.0, 30.0, 60.0, 120.0]
    fleet = os.path.join(a.build, "apps/fleet/draco-fleet")
    os.makedirs(a.out, exist_ok=True)
    rows = []
    for mp in missions:
        name = os.path.basename(os.path.dirname(mp)) if mp.endswith("mission.yaml") else \
            os.path.splitext(os.path.basename(mp))[0]
        long_yaml = os.path.join(a.out, name + "-long.yaml")
        robots = repeated(mp, long_yaml)
        for mins in per_mission.get(name, minutes):
            run = os.path.join(a.out, f"{name}-{int(mins)}min")
            measured = os.path.join(run, "scaling_run.json")
            t0 = time.time()
            if a.reuse and os.path.exists(measured):
                wall_s, rss_kb = json.load(open(measured))["wall_rss"]
            else:
                cmd = ["/usr/bin/time", "-f", "%e %M", fleet, "--simulate", long_yaml,
                       "--duration-s", str(int(mins * 60)), "--mode", "inproc", "--out", run]
                for kv in a.set:
                    cmd += ["--set", kv]
                print("scaling:", " ".join(cmd[3:]), flush=True)
                p = subprocess.run(cmd, capture_output=True, text=True)
                if p.returncode != 0:
                    print(p.stdout[-2000:], p.stderr[-2000:])
                    sys.exit(f"scaling: {name} {mins} min failed")
                wall_s, rss_kb = p.stderr.strip().splitlines()[-1].split()
                json.dump({"wall_rss": [wall_s, rss_kb], "command": cmd[3:]}, open(measured, "w"))
            stats = json.load(open(os.path.join(run, "inproc", "runtime_stats.json")))
            per = {}
            for c in stats["components"]:
                stage = c["id"].split("_", 1)[1]
                if stage not in STAGES:
                    continue
                s = per.setdefault(stage, {"calls": 0, "total_ms": 0.0, "p99_ms": 0.0, "max_ms": 0.0})
                s["calls"] += c["calls"]
                s["total_ms"] += c["total_ms"]
                s["p99_ms"] = max(s["p99_ms"], c["p99_ms"])
                s["max_ms"] = max(s["max_ms"], c["max_ms"])
            for stage, s in per.items():
                rows.append({"mission": name, "robots": robots, "minutes": mins,
                             "mission_s": round(stats["mission_s"], 1), "wall_s": float(wall_s),
                             "peak_rss_mb": round(int(rss_kb) / 1024.0, 1), "stage": stage,
                             "calls": s["calls"],
                             "mean_ms": round(s["total_ms"] / max(1, s["calls"]), 4),
                             "p99_ms": round(s["p99_ms"], 3), "max_ms": round(s["max_ms"], 3)})
            print(f"scaling: {name} {robots} robots {mins:g} min: {wall_s} s wall, "
                  f"{int(rss_kb) / 1024:.0f} MB peak ({time.time() - t0:.0f} s)", flush=True)
    with open(os.path.join(a.out, "scaling.csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    # Table: per mission and stage, mean ms per call at each length; peak memory per length.
    lines = ["| mission | robots | stage | " + " | ".join(f"{m:g} min" for m in minutes) +
             " | growth (longest / shortest) |", "|---|---|---|" + "---|" * (len(minutes) + 1)]
    for mp in missions:
        name = os.path.basename(os.path.dirname(mp)) if mp.endswith("mission.yaml") else \
            os.path.splitext(os.path.basename(mp))[0]
        rs = [r for r in rows if r["mission"] == name]
        have = sorted({r["minutes"] for r in rs})
        robots = rs[0]["robots"]
        for stage in STAGES:
            v = [next((r["mean_ms"] for r in rs if r["stage"] == stage and r["minutes"] == m), None)
                 for m in minutes]
            got = [x for x in v if x is not None]
            if not got:
                continue
            g = got[-1] / got[0] if got[0] > 0 else float("nan")
            lines.append(f"| {name} | {robots} | {stage} | " +
                         " | ".join("-" if x is None else f"{x:.3f} ms" for x in v) + f" | {g:.2f}x |")
        mem = [next((r["peak_rss_mb"] for r in rs if r["minutes"] == m), None) for m in minutes]
        wall = [next((r["wall_s"] for r in rs if r["minutes"] == m), None) for m in minutes]
        for label, vals, unit in (("peak memory", mem, "MB"), ("wall", wall, "s")):
            got = [x for x in vals if x is not None]
            lines.append(f"| {name} | {robots} | {label} | " +
                         " | ".join("-" if x is None else f"{x:.0f} {unit}" for x in vals) +
                         f" | {got[-1] / got[0]:.2f}x |")
    open(os.path.join(a.out, "scaling.md"), "w").write("\n".join(lines) + "\n")
    print("\n".join(lines))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        names = sorted({r["mission"] for r in rows})
        fig, axes = plt.subplots(1, len(names) + 1, figsize=(5 * (len(names) + 1), 4))
        for ax, name in zip(axes, names):
            rs = [r for r in rows if r["mission"] == name]
            for stage in STAGES:
                pts = sorted((r["minutes"], r["mean_ms"]) for r in rs if r["stage"] == stage)
                if pts:
                    ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=stage)
            ax.set_title(f"{name}, {rs[0]['robots']} robots: mean ms per call")
            ax.set_xlabel("mission length (min)")
            ax.set_yscale("log")
            ax.grid(True, alpha=0.3)
        axes[0].legend(fontsize=7)
        ax = axes[-1]
        for name in names:
            pts = sorted({(r["minutes"], r["peak_rss_mb"]) for r in rows if r["mission"] == name})
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker="o", label=name)
        ax.set_title("peak memory of the process (MB)")
        ax.set_xlabel("mission length (min)")
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(a.out, "scaling.png"), dpi=90)
    except ImportError:
        print("scaling: no matplotlib (apt-get install python3-matplotlib): no plot")


if __name__ == "__main__":
    main()
