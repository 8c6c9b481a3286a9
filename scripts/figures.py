#!/usr/bin/env python3
"""Compose docs/figures.md from the run folders scripts/results.sh wrote.

    python3 scripts/figures.py OUT [--page docs/figures.md] [--missions runs/missions]

Reads only files the apps write (docs/results.md lists them): OUT/machine.txt and
OUT/steps.tsv (results.sh's record), per mission OUT/<mission>/fleet/fleet_report.md,
fleet/dds/report.md, local-slam/report.md, frontend/precision.csv, frontend/matching.csv,
frontend/possible_loops.csv, team/table3.csv, team/team_loops.csv, logs/sizes-<mission>.out (the
table draco-fleet-sizes prints), and OUT/bench/*.json (Google Benchmark JSON). Standard
library only.
"""

import argparse
import csv
import json
import os
import re
import sys
import textwrap

MISSIONS = ["marina", "airplane"]

# The paper's figures (DRACo-SLAM2), quoted where a table is compared with them.
PAPER_TABLE1 = [  # algorithm, mean ms, max ms
    ("Graph construction & matching", "5.64", "32.76"),
    ("ICP registration (window 3)", "12.69", "358.45"),
]
PAPER_TABLE2 = [  # algorithm, mean s per step, mean executions per step
    ("Graph construction & matching", "< 0.01", "1"),
    ("ICP registration (window 3)", "1.55", "122"),
]
PAPER_TABLE3 = {  # (mission, row) -> alpha, beta, gamma; the paper's USMMA is our marina
    ("marina", "two-step + PCM"): ("1.58", "2.43", "1.88"),
    ("marina", "two-step + GCM"): ("1.43", "1.20", "1.23"),
    ("marina", "full + PCM"): ("1.27", "1.37", "1.52"),
    ("marina", "full + GCM"): ("1.24", "1.41", "1.56"),
    ("airplane", "two-step + PCM"): ("1.32", "1.36", "1.46"),
    ("airplane", "two-step + GCM"): ("1.33", "0.95", "1.31"),
    ("airplane", "full + PCM"): ("1.28", "1.91", "1.63"),
    ("airplane", "full + GCM"): ("1.31", "1.91", "1.65"),
}
PAPER_TABLE4 = [  # message, mean kbit, max kbit
    ("Object map", "1.35", "2.25"),
    ("Point cloud, float32", "9.69", "27.90"),
]

# Benchmarks: which binary, the docs/benchmarks.md section that explains it.
BENCHES = [
    ("objects", "tests/objects/objects_bench", "Object map and object-graph matching"),
    ("cfar", "tests/cfar/cfar_bench", "Local SLAM front end: CFAR and ICP"),
    ("icp", "tests/icp/icp_bench", "Local SLAM front end: CFAR and ICP"),
    ("pose_graph", "tests/pose_graph/pose_graph_bench", "SE(2) pose graph"),
    ("consistency", "tests/consistency/consistency_bench", "Consistency filters (PCM / GCM)"),
    ("registration", "tests/registration/registration_bench",
     "Inter-robot window registration"),
    ("team", "tests/team/team_bench", "Two-step and full PGO"),
]


# ------------------------------------------------------------------------------------------
# Reading


def read_text(path):
    try:
        with open(path, encoding="utf-8") as f:
            return f.read()
    except OSError:
        return None


def read_csv(path):
    text = read_text(path)
    if text is None:
        return None
    return list(csv.DictReader(text.splitlines()))


def read_kv(path):
    out = {}
    for line in (read_text(path) or "").splitlines():
        if "=" in line:
            k, v = line.split("=", 1)
            out[k.strip()] = v.strip()
    return out


def read_steps(path):
    rows = read_csv_tsv(path)
    return {r["step"]: r for r in rows}


def read_csv_tsv(path):
    text = read_text(path)
    if text is None:
        return []
    return list(csv.DictReader(text.splitlines(), delimiter="\t"))


def md_sections(text):
    """Markdown -> list of (level, heading, body lines)."""
    out = []
    level, heading, body = 0, "", []
    for line in (text or "").splitlines():
        m = re.match(r"^(#{1,6}) (.*)$", line)
        if m:
            out.append((level, heading, body))
            level, heading, body = len(m.group(1)), m.group(2).strip(), []
        else:
            body.append(line)
    out.append((level, heading, body))
    return out


def subsection(text, parent_prefix, heading):
    """Body lines of the section titled heading under the first level-2 section whose heading
    starts with parent_prefix (None when absent)."""
    inside = False
    for level, h, body in md_sections(text):
        if level == 2:
            inside = h.startswith(parent_prefix)
        elif inside and h == heading:
            return body
    return None


def section(text, prefix, nth=0):
    """Body lines of the nth section whose heading starts with prefix (None when absent)."""
    found = [b for (_, h, b) in md_sections(text) if h.startswith(prefix)]
    return found[nth] if len(found) > nth else None


def md_tables(lines):
    """Markdown tables in lines -> list of lists of rows (cells stripped)."""
    tables, cur = [], []
    for line in lines or []:
        if line.startswith("|"):
            cur.append(line)
        elif cur:
            tables.append(cur)
            cur = []
    if cur:
        tables.append(cur)
    parsed = []
    for t in tables:
        rows = []
        for line in t:
            cells = [c.strip() for c in line.strip().strip("|").split("|")]
            if all(re.fullmatch(r":?-+:?", c) for c in cells if c):
                continue
            rows.append(cells)
        parsed.append(rows)
    return parsed


def table_lines(lines, index=0):
    """The raw markdown lines of the index-th table in lines (None when absent)."""
    tables, cur = [], []
    for line in lines or []:
        if line.startswith("|"):
            cur.append(line)
        elif cur:
            tables.append(cur)
            cur = []
    if cur:
        tables.append(cur)
    return tables[index] if len(tables) > index else None


def first_paragraph(lines):
    para = []
    for line in lines or []:
        if line.startswith("|") or line.startswith("!["):
            break
        if line.strip():
            para.append(line.strip())
        elif para:
            break
    return " ".join(para)


def mission_name(missions_dir, m):
    text = read_text(os.path.join(missions_dir, m, "mission.yaml")) or ""
    name = re.search(r'^name:\s*"?([^"\n]+)"?', text, re.M)
    seed = re.search(r"^seed:\s*(\d+)", text, re.M)
    info = {}
    try:
        with open(os.path.join(missions_dir, m, "run_info.json"), encoding="utf-8") as f:
            info = json.load(f)
    except (OSError, ValueError):
        pass
    return (name.group(1) if name else m, seed.group(1) if seed else "?",
            info.get("git_describe", "?"))


# ------------------------------------------------------------------------------------------
# Formatting


def cell(c):
    """A table cell: a | inside it (a regular expression in a command) escaped."""
    return str(c).replace("|", "\\|")


def fmt_table(header, rows, align=None):
    align = align or ["---"] * len(header)
    out = ["| " + " | ".join(header) + " |", "|" + "|".join(align) + "|"]
    for r in rows:
        out.append("| " + " | ".join(cell(c) for c in r) + " |")
    return out


def f2(v, d=2):
    try:
        return f"{float(v):.{d}f}"
    except (TypeError, ValueError):
        return "-"


def command_of(steps, name):
    s = steps.get(name)
    if not s:
        return None
    return s["command"]


def step_note(steps, name):
    """'`command`' plus its wall time and a failure mark."""
    s = steps.get(name)
    if not s:
        return f"(step `{name}` did not run)"
    note = f"`{s['command']}` ({s['wall_s']} s wall"
    if s["exit"] != "0":
        note += f", **exit {s['exit']}**"
    return note + ")"


def human_ram(kb):
    try:
        return f"{int(kb) / 1024 / 1024:.1f} GiB"
    except ValueError:
        return "?"


def human_time(ns, unit):
    """Google Benchmark time in its unit -> a readable string."""
    scale = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}[unit]
    s = ns * scale
    if s >= 1.0:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.3g} ms"
    if s >= 1e-6:
        return f"{s * 1e6:.3g} us"
    return f"{s * 1e9:.3g} ns"


# ------------------------------------------------------------------------------------------
# Page sections


class Page:
    def __init__(self, out, missions_dir, page_path):
        self.out = out
        self.missions_dir = missions_dir
        self.page_dir = os.path.dirname(os.path.abspath(page_path))
        self.machine = read_kv(os.path.join(out, "machine.txt"))
        self.steps = read_steps(os.path.join(out, "steps.tsv"))
        self.lines = []
        self.problems = []
        self.fleet = {m: read_text(os.path.join(out, m, "fleet", "fleet_report.md"))
                      for m in MISSIONS}
        self.report = {m: read_text(os.path.join(out, m, "fleet", "dds", "report.md"))
                       for m in MISSIONS}
        self.report_inproc = {m: read_text(os.path.join(out, m, "fleet", "inproc", "report.md"))
                              for m in MISSIONS}

    def w(self, *lines):
        self.lines.extend(lines)

    def missing(self, what, step):
        s = self.steps.get(step)
        if not s and self.machine.get("quick") == "1":
            self.w(f"*Skipped by `--quick`: {what}.*", "")
            return
        why = "did not run" if not s else (
            f"exit {s['exit']}" if s["exit"] != "0" else "wrote no such file")
        self.problems.append(f"{what}: `{step}` {why}")
        self.w(f"*Not available: {what} (`{step}` {why}; see `logs/{step}.err`).*", "")

    # ---- running team figures shared by several sections
    def fleet_robot_rows(self, m, mode="DDS, one daemon"):
        body = section(self.fleet[m], mode)
        t = md_tables(body)
        return t[0] if t else None

    def team_report_table(self, m, heading, index=0, inproc=False):
        text = self.report_inproc[m] if inproc else self.report[m]
        return table_lines(section(text, heading), index)

    # ---- sections
    def header(self):
        mc = self.machine
        self.w("# Figures", "",
               "Every figure of the paper this project reproduces (Tables I-IV, Fig. 3), the "
               "running team's per-robot accuracy and link traffic, and the speed benchmarks, "
               "from one run of `scripts/results.sh` on the commit and machine below. The page "
               "is generated (`scripts/figures.py` composes it from the run folders' CSV, JSON "
               "and Markdown files): regenerate it, do not edit it. Each table names the command "
               "that produced it; docs/results.md says what each file holds.", "")
        wall = mc.get("wall_s")
        wall_text = f"{int(wall) // 60} min {int(wall) % 60} s" if wall and wall.isdigit() else "?"
        names = []
        for m in MISSIONS:
            name, seed, sim = mission_name(self.missions_dir, m)
            names.append(f"{m} (`{name}`, seed {seed}, simulated by draco-sim {sim})")
        rows = [
            ("command", f"`nice -n {mc.get('nice', '0')} {mc.get('invocation', '?')}`"
             if mc.get("nice", "0") != "0" else f"`{mc.get('invocation', '?')}`"),
            ("commit", f"`{mc.get('commit', '?')}`"),
            ("machine", f"{mc.get('nproc', '?')} cores, {mc.get('cpu', '?')}, "
             f"{human_ram(mc.get('ram_kb', '0'))} RAM, {mc.get('os', '?')}"),
            ("build", f"{mc.get('build_type', '?')}, `{mc.get('compiler', '?')}`"),
            ("load average (1, 5, 15 min)",
             f"{mc.get('load_start', '?')} at the start, {mc.get('load_end', '?')} at the end"),
            ("run time", wall_text + " (every step: the last section)"),
            ("missions", "; ".join(names)),
        ]
        if mc.get("quick") == "1":
            rows.append(("mode", "`--quick`: fewer benchmark cases and repetitions, no "
                         "possible-loops count, no sonar frames"))
        self.w(*fmt_table(["", ""], rows), "")
        self.w("The machine is shared: wall times and benchmark figures are slower than on an "
               "idle machine, by up to the load average over the core count. Accuracy figures do "
               "not depend on the load for the in-process team and the offline apps "
               "(deterministic executor); the DDS team runs in lock-step, so its figures may "
               "differ from the in-process run's by the timing of teammates' messages (the "
               "\"DDS against in-process\" tables).", "")

    def team_headline(self, m):
        """The running team (DDS) of mission m in a few numbers, or None."""
        rows = self.fleet_robot_rows(m)
        if not rows:
            return None
        idx = {h: i for i, h in enumerate(rows[0])}
        robots = rows[1:]
        col = lambda name: " / ".join(r[idx[name]] for r in robots)  # noqa: E731
        bps = [float(r[idx["mean bps"]]) for r in robots]
        team_bps = f"{sum(bps):.0f}"
        traffic = md_tables(section(self.report[m], "Traffic per robot"))
        if traffic:
            for r in traffic[0][1:]:
                if r[0] == "team":
                    team_bps = r[3]
        return {"names": " / ".join(r[0] for r in robots), "team": col("team ATE m"),
                "local": col("local ATE m"), "dr": col("DR ATE m"),
                "bps": " / ".join(f"{b:.0f}" for b in bps), "team_bps": team_bps,
                "kbit": f"{sum(float(r[idx['sent kbit']]) for r in robots):,.0f}"}

    def headline(self):
        self.w("## Headline", "")
        for m in MISSIONS:
            h = self.team_headline(m)
            if not h:
                self.missing(f"{m} running team", f"fleet-{m}")
                continue
            self.w(f"- **{m}**, three robot daemons over DDS: team ATE {h['team']} m "
                   f"({h['names']}; local SLAM {h['local']} m, dead reckoning {h['dr']} m); link "
                   f"{h['team_bps']} bps for the team ({h['bps']} bps per robot, {h['kbit']} kbit "
                   "in all; the modem's budget is 62,500 bps, the goal 2,000 bps per robot).")
        t3 = {m: read_csv(os.path.join(self.out, m, "team", "table3.csv")) for m in MISSIONS}
        parts = []
        for m in MISSIONS:
            rows = t3[m]
            if not rows:
                continue
            by = {r["row"]: r for r in rows}
            if "two-step + GCM" in by and "dead reckoning" in by:
                parts.append(f"{m} {f2(by['two-step + GCM']['mean'])} m "
                             f"(dead reckoning {f2(by['dead reckoning']['mean'])} m)")
        if parts:
            self.w("- Table III offline (`draco-team-eval`), two-step PGO + GCM, mean over the "
                   "robots: " + "; ".join(parts) + "; the paper: 1.29 m (USMMA), 1.20 m "
                   "(airplane).")
        self.w("")
        img = self.machine.get("team_map")
        if img and os.path.exists(img):
            rel = os.path.relpath(os.path.abspath(img), self.page_dir)
            self.w(f"![team map of the marina team run]({rel})", "",
                   "*The marina team run over DDS: alpha's team estimate (every robot it "
                   "placed, in its map frame, aligned to ground truth, dashed), the robots' "
                   "maps and objects and the accepted inter-robot loop closures (purple); "
                   "`team_map.png` of `draco-eval` on the DDS run folder.*", "")
        else:
            self.w("*No team-map picture: the marina DDS run wrote no `team_map.png`.*", "")

    def running_team(self):
        self.w("## The running team: per-robot ATE, loop closures, placements, link traffic", "",
               "`draco-fleet MISSION --mode both`: the three robots as three `draco-robot` "
               "daemons over Cyclone DDS on loopback (lock-step on the mission clock, the "
               "acoustic channel model of docs/fleet.md), then the same team in one process. ATE "
               "RMSE in metres after SE(2) alignment; team ATE is the paper's concatenation "
               "protocol (a robot's estimate of itself, then of each teammate it placed, against "
               "the ground truth concatenated the same way). Evaluation: `draco-eval` on each "
               "mode's folder (docs/results.md, \"What report.md contains\").", "")
        for m in MISSIONS:
            self.w(f"### {m}", "")
            if not self.fleet[m]:
                self.missing(f"{m} running team", f"fleet-{m}")
                continue
            self.w(f"Run: {step_note(self.steps, f'fleet-{m}')}; evaluated with "
                   f"{step_note(self.steps, f'eval-{m}-dds')}.", "")
            for title, prefix in (("DDS, one daemon per robot", "DDS, one daemon"),
                                  ("In-process", "in-process")):
                body = section(self.fleet[m], prefix)
                t = table_lines(body, 0)
                if t:
                    self.w(f"{title}:", "", *t, "")
            body = section(self.fleet[m], "DDS against in-process")
            t = table_lines(body, 0)
            if t:
                self.w("DDS against in-process (same result within 10 %):", "", *t, "")
            plc = subsection(self.fleet[m], "DDS, one daemon", "Placements")
            if plc:
                t = table_lines(plc, 0)
                if t:
                    self.w("Placements (DDS run; right: within 2 m and 5 deg of the truth at the "
                           "end):", "", *t, "")
            t = self.team_report_table(m, "Inter-robot loop closures")
            if t:
                self.w("Inter-robot loop closures (DDS run; true positive: within 1.5 m and "
                       "15 deg of the ground-truth relative pose):", "", *t, "")
            t = self.team_report_table(m, "Traffic per robot")
            if t:
                self.w("Link traffic per robot (DDS run; `<robot>.link_stats.json`):", "", *t, "")
            t = self.team_report_table(m, "Accuracy per robot")
            if t:
                self.w("Local SLAM per robot inside the team (DDS run):", "", *t, "")

    def local_slam(self):
        self.w("## Local SLAM alone", "",
               "`draco-local-slam MISSION`: every robot alone through "
               "`config/graphs/local-slam.yaml` (docs/local-slam.md), evaluated by `draco-eval`: "
               "ATE RMSE of the keyframe positions after SE(2) alignment to ground truth, RPE "
               "between consecutive keyframes, DR = dead reckoning at the same keyframe times.",
               "")
        for m in MISSIONS:
            text = read_text(os.path.join(self.out, m, "local-slam", "report.md"))
            t = table_lines(section(text, "Accuracy per robot"))
            if not t:
                self.missing(f"{m} local SLAM alone", f"local-slam-{m}")
                continue
            self.w(f"{m}: {step_note(self.steps, f'local-slam-{m}')}, then "
                   f"{step_note(self.steps, f'eval-{m}-local-slam')}", "", *t, "")

    def table1(self):
        self.w("## Table I: runtime", "",
               "The paper (DRACo2, per execution, on its two simulated missions):", "",
               *fmt_table(["algorithm", "mean ms", "max ms"], PAPER_TABLE1,
                          ["---", "---:", "---:"]), "")
        self.w("Per execution here: the speed benchmarks (section \"Speed\"): one object-graph "
               "matching of 25-30 objects a side (`objects_bench`, `BM_MatchSparseCode/25`, "
               "`/30`) and one window registration at window 3 (`registration_bench`, "
               "`window:3/ambiguity_test:1`):", "")
        rows = []
        bench = self.bench_entries("objects")
        for name in ("BM_MatchSparseCode/25", "BM_MatchSparseCode/30"):
            e = bench.get(name)
            if e:
                rows.append((f"graph construction & matching, `{name}`",
                             human_time(e["cpu_time"], e["time_unit"])))
        bench = self.bench_entries("registration")
        for name in ("BM_WindowRegistration/window:3/ambiguity_test:0",
                     "BM_WindowRegistration/window:3/ambiguity_test:1"):
            e = bench.get(name)
            if e:
                rows.append((f"ICP registration, `{name}`",
                             human_time(e["cpu_time"], e["time_unit"])))
        for m in MISSIONS:
            text = read_text(os.path.join(self.out, "logs", f"frontend-{m}.out")) or ""
            mm = re.search(r"registrations: (\d+), ([0-9.]+) ms mean", text)
            if mm:
                rows.append((f"ICP registration, {m}, every registration of "
                             f"`draco-frontend-eval` (windows 0, 1, 3; {mm.group(1)} runs)",
                             f"{mm.group(2)} ms mean (wall)"))
        if rows:
            self.w(*fmt_table(["algorithm", "CPU time per call (median)"], rows,
                              ["---", "---:"]), "")
        self.w("Per team step of the running team (DDS run, `<robot>.runtime_stats.json`; one "
               "call per second of mission time whether or not there is work; mean and max over "
               "the three robots' calls, wall time on the loaded machine):", "")
        want = ("team.ObjectMapper", "team.GraphMatcher", "team.ScanExchange",
                "team.ConsistencyFilter", "team.TwoStepOptimizer", "slam.LocalSlam",
                "sonar.Cfar", "slam.IcpOdometry")
        rows = []
        for m in MISSIONS:
            t = md_tables(section(self.report[m], "Runtime per component"))
            if not t:
                continue
            for r in t[0][1:]:
                if len(r) >= 5 and r[1] in want:
                    rows.append((m, r[0], f"`{r[1]}`", r[2], r[3], r[4]))
        if rows:
            self.w(*fmt_table(["mission", "component", "type", "calls", "mean ms", "max ms"],
                              rows, ["---", "---", "---", "---:", "---:", "---:"]), "")
            for m in MISSIONS:
                t = md_tables(section(self.report[m], "Runtime per component"))
                if len(t) > 1:
                    rt = "; ".join(f"{r[0]} {r[3]} ({r[2]} s wall)" for r in t[1][1:])
                    self.w(f"- {m}, real-time factor per robot: {rt}.")
            self.w("")
        else:
            self.missing("runtime per component", "eval-marina-dds")

    def table2(self):
        self.w("## Table II: loop-closure work per time step", "",
               "The paper (DRACo2, mean per time step):", "",
               *fmt_table(["algorithm", "mean s", "mean executions"], PAPER_TABLE2,
                          ["---", "---:", "---:"]), "")
        self.w("Here, per team step (one per second of mission time) of the running team, DDS "
               "run, mean / max (`<robot>.agent_steps.csv`, `draco-eval`):", "")
        for m in MISSIONS:
            t = self.team_report_table(m, "Loop-closure work per time step")
            if t:
                self.w(f"{m}:", "", *t, "")
            else:
                self.missing(f"{m} Table II", f"eval-{m}-dds")
        self.w("\"loops accepted\" is the size of the accepted set the step ends with (the "
               "consistency filter decides the whole set again each step), not loops newly "
               "accepted in it; \"PGO steps\" counts the steps that ran the two-step PGO.", "")

    def table3(self):
        self.w("## Table III: ATE, two-step against full PGO, PCM against GCM", "",
               "Offline (`draco-team-eval` on the local SLAM cached by `draco-frontend-eval`): "
               "each robot's view (own trajectory, then the teammates it placed, concatenated "
               "in its frame, one SE(2) alignment), ATE RMSE in metres; the paper's figures for "
               "the same rows in brackets (its USMMA dataset is the marina here; "
               "docs/back-end.md section 3). Every experiment key at its default: the run "
               "folder's `experiment.yaml` holds them.", "")
        for m in MISSIONS:
            rows = read_csv(os.path.join(self.out, m, "team", "table3.csv"))
            self.w(f"### {m}", "")
            if not rows:
                self.missing(f"{m} Table III", f"team-{m}")
                continue
            self.w(f"Command: {step_note(self.steps, f'team-{m}')}, after "
                   f"{step_note(self.steps, f'frontend-{m}')}.", "")
            robots = [k for k in rows[0].keys() if k not in ("row", "mean", "oracle_matching")]
            out = []
            for r in rows:
                paper = PAPER_TABLE3.get((m, r["row"]))
                cells = [r["row"]]
                for i, rb in enumerate(robots):
                    c = f2(r[rb])
                    if paper:
                        c += f" ({paper[i]})"
                    cells.append(c)
                cells.append(f2(r["mean"]))
                out.append(cells)
            self.w(*fmt_table(["row"] + robots + ["mean"], out,
                              ["---"] + ["---:"] * (len(robots) + 1)), "")
            loops = read_text(os.path.join(self.out, m, "team", "team_loops.csv"))
            if loops:
                lr = list(csv.reader(loops.splitlines()))
                # robot,teammates_placed_by,candidates,candidate_tp,pcm_accepted,pcm_tp,
                # gcm_accepted,gcm_tp,pcm_exact,gcm_exact (no header line)
                if lr and lr[0] and lr[0][0] == "robot":
                    lr = lr[1:]
                out = [(r[0], r[1], f"{r[2]} ({r[3]})", f"{r[4]} ({r[5]})", f"{r[6]} ({r[7]})")
                       for r in lr if len(r) >= 8]
                if out:
                    self.w("Inter-robot loops per robot (`team_loops.csv`; true positives in "
                           "brackets):", "",
                           *fmt_table(["robot", "teammates placed by", "candidates",
                                       "PCM accepted", "GCM accepted"], out,
                                      ["---", "---", "---:", "---:", "---:"]), "")
        self.w("The running team's own Table III layout (DDS run: dead reckoning, local SLAM and "
               "its two-step + GCM team estimate per robot) is in the section \"The running "
               "team\" above; per mission:", "")
        for m in MISSIONS:
            t = self.team_report_table(m, "Team ATE")
            if t:
                self.w(f"{m}:", "", *t, "")

    def table4(self):
        self.w("## Table IV: message sizes", "",
               "The paper (DRACo2, its USMMA dataset with simulated three-robot communication):",
               "", *fmt_table(["message", "mean kbit", "max kbit"], PAPER_TABLE4,
                              ["---", "---:", "---:"]), "")
        self.w("The running team, every frame that crossed the link, summed over the robots "
               "(DDS run, `<robot>.link_stats.json`):", "")
        for m in MISSIONS:
            t = self.team_report_table(m, "Message sizes")
            if t:
                self.w(f"{m}:", "", *t, "")
            else:
                self.missing(f"{m} message sizes", f"eval-{m}-dds")
        self.w("Offline, every cached keyframe encoded as a scan reply and the object map and "
               "keyframe poses encoded every 10 s of mission time (`draco-fleet-sizes`, "
               "docs/fleet.md \"Measured sizes\"); the main rows:", "")
        keep = ("(points per scan)", "scan reply, auto (smallest), step 0.05 m",
                "scan reply, auto, scans of >= 30 points", "keyframe poses, update",
                "keyframe poses, full", "object map, full", "(objects in the map)",
                "object map, delta", "object map, every update sent", "heartbeat")
        for m in MISSIONS:
            text = read_text(os.path.join(self.out, "logs", f"sizes-{m}.out"))
            t = md_tables((text or "").splitlines())
            if not t:
                self.missing(f"{m} offline message sizes", f"sizes-{m}")
                continue
            rows = [r[:4] for r in t[0][1:] if r and any(r[0].strip().startswith(k)
                                                           for k in keep)]
            self.w(f"{m}: {step_note(self.steps, f'sizes-{m}')}", "",
                   *fmt_table(["message", "count", "mean bits", "max bits"], rows,
                              ["---", "---:", "---:", "---:"]), "")

    def fig3(self):
        self.w("## Fig. 3: precision and true positives against the overlap threshold", "",
               "Offline (`draco-frontend-eval`): every ordered robot pair's object maps matched, "
               "scans selected and registered at windows 0, 1 and 3; a registration is a "
               "detection at threshold t when valid with overlap >= t, a true positive when "
               "within 1.5 m and 15 deg of the ground-truth relative pose. Cells: precision / "
               "true positives (`precision.csv`; `fig3.png` in the same folder draws them). The "
               "paper's Fig. 3: window 3 finds the most true positives; precision rises with the "
               "threshold (docs/front-end.md section 6).", "")
        for m in MISSIONS:
            self.w(f"### {m}", "")
            rows = read_csv(os.path.join(self.out, m, "frontend", "precision.csv"))
            if not rows:
                self.missing(f"{m} Fig. 3", f"frontend-{m}")
                continue
            self.w(f"Command: {step_note(self.steps, f'frontend-{m}')}", "")
            windows = sorted({int(r["window"]) for r in rows})
            by = {}
            for r in rows:
                by.setdefault(r["threshold"], {})[int(r["window"])] = r
            out = []
            for thr in sorted(by, key=float):
                cells = [thr]
                for wdw in windows:
                    r = by[thr].get(wdw)
                    if not r:
                        cells.append("")
                        continue
                    det = int(r["detections"])
                    prec = f2(r["precision"]) if det > 0 else "-"
                    cells.append(f"{prec} / {r['true_positives']}")
                out.append(cells)
            self.w(*fmt_table(["overlap >="] + [f"window {wdw}" for wdw in windows], out,
                              ["---:"] * (len(windows) + 1)), "")
            match = read_csv(os.path.join(self.out, m, "frontend", "matching.csv"))
            if match:
                right = sum(1 for r in match if r.get("correct") == "1")
                out = [(r["own"], r["teammate"], r["shared_objects"], r["status"], r["inliers"],
                        f"{f2(r['err_m'])} / {f2(r['err_deg'])}", r["registrations"])
                       for r in match]
                self.w(f"Object-graph matching per ordered pair (`matching.csv`; right: within "
                       f"2 m and 10 deg of the true map-to-map transform; {right} of "
                       f"{len(match)} pairs matched right; `chained`: placed through a teammate "
                       "that matches both, as the running team shares its transforms):", "",
                       *fmt_table(["own", "teammate", "true shared objects", "status",
                                   "inliers", "error m / deg", "registrations"], out,
                                  ["---", "---", "---:", "---", "---:", "---:", "---:"]), "")
            possible = read_csv(os.path.join(self.out, m, "frontend", "possible_loops.csv"))
            if possible:
                out = [(r["own"], r["teammate"], r["possible"], r["pairs_tested"],
                        f2(r["best_overlap"]), f"{r['true_positives']} / {r['detections']}")
                       for r in possible]
                self.w("Loops a perfect matcher could close per ordered pair (ground-truth "
                       "seeded registration of every keyframe pair in range, window 3, overlap "
                       ">= 0.85; `possible_loops.csv`) against what the pipeline found:", "",
                       *fmt_table(["own", "teammate", "possible", "pairs tested",
                                   "best overlap", "found TP / detections"], out,
                                  ["---", "---", "---:", "---:", "---:", "---:"]), "")
        self.w("The running team's registrations against the threshold (DDS run, "
               "`<robot>.registrations.csv`, every registration the scan exchanges ran, before "
               "outlier rejection; precision / true positives):", "")
        for m in MISSIONS:
            t = self.team_report_table(m, "Registrations against the overlap threshold")
            if t:
                self.w(f"{m}:", "", *t, "")

    def bench_entries(self, name):
        """Benchmark name -> entry (the median when repeated)."""
        text = read_text(os.path.join(self.out, "bench", f"{name}.json"))
        if not text:
            return {}
        try:
            data = json.loads(text)
        except ValueError:
            return {}
        out, plain = {}, {}
        for b in data.get("benchmarks", []):
            if b.get("run_type") == "aggregate":
                if b.get("aggregate_name") == "median":
                    out[b["run_name"]] = b
            else:
                plain.setdefault(b.get("run_name", b["name"]), b)
        for k, v in plain.items():
            out.setdefault(k, v)
        return out

    def speed(self):
        self.w("## Speed", "",
               "Google Benchmarks of docs/benchmarks.md (which explains each case, its goal and "
               "its peer), median of the repetitions, `--benchmark_min_time=0.05`. CPU time, "
               "and wall time where the case measures it (`UseRealTime`). Counters as the "
               "benchmark reports them.", "")
        for name, binary, doc in BENCHES:
            entries = self.bench_entries(name)
            self.w(f"### {name} (docs/benchmarks.md, \"{doc}\")", "")
            if not entries:
                self.missing(f"{name} benchmark", f"bench-{name}")
                continue
            self.w(f"Command: {step_note(self.steps, f'bench-{name}')}", "")
            rows = []
            for run_name, e in entries.items():
                unit = e.get("time_unit", "ns")
                counters = []
                skip = {"name", "run_name", "run_type", "repetitions", "repetition_index",
                        "threads", "iterations", "real_time", "cpu_time", "time_unit",
                        "family_index", "per_family_instance_index", "aggregate_name",
                        "aggregate_unit", "label", "error_occurred", "error_message"}
                for k, v in e.items():
                    if k in skip or not isinstance(v, (int, float)):
                        continue
                    counters.append(f"{k} {v:.4g}")
                rows.append((f"`{run_name}`", human_time(e["cpu_time"], unit),
                             human_time(e["real_time"], unit), ", ".join(counters)))
            self.w(*fmt_table(["benchmark", "CPU", "wall", "counters"], rows,
                              ["---", "---:", "---:", "---"]), "")
        sims = [self.steps[f"sim-{m}"] for m in MISSIONS if f"sim-{m}" in self.steps]
        if sims:
            self.w("Simulator (docs/benchmarks.md, \"Simulator\"; with pictures, so a few "
                   "seconds over `--no-pictures`): " + "; ".join(
                       f"`{s['command']}` {s['wall_s']} s wall" for s in sims) + ".", "")
        else:
            self.w("Simulator: not timed here (the recorded missions were reused; "
                   "docs/benchmarks.md, \"Simulator\", has its figures and command).", "")
        data = read_text(os.path.join(self.out, "bench", "objects.json"))
        if data:
            try:
                ctx = json.loads(data).get("context", {})
                self.w(f"Benchmark context: {ctx.get('num_cpus', '?')} CPUs at "
                       f"{ctx.get('mhz_per_cpu', '?')} MHz, load average "
                       f"{', '.join(f'{x:.2f}' for x in ctx.get('load_avg', []))} when "
                       "`objects_bench` started.", "")
            except ValueError:
                pass

    def steps_section(self):
        self.w("## The steps", "",
               "Every command `scripts/results.sh` ran, in order, with its wall time and exit "
               "code (stdout and stderr of each in `OUT/logs/<step>.out`, `.err`):", "")
        rows = []
        for s in read_csv_tsv(os.path.join(self.out, "steps.tsv")):
            rows.append((s["step"], f"`{s['command']}`", s["wall_s"], s["exit"]))
        self.w(*fmt_table(["step", "command", "wall s", "exit"], rows,
                          ["---", "---", "---:", "---:"]), "")
        failed = [s for s in self.steps.values() if s["exit"] != "0"]
        if failed or self.problems:
            self.w("Not reproduced in this run:", "")
            for s in failed:
                self.w(f"- `{s['step']}` exited {s['exit']}"
                       + (" (draco-fleet: DDS and in-process results differ by more than 10 %)"
                          if s["step"].startswith("fleet-") and s["exit"] == "3" else ""))
            for p in self.problems:
                self.w(f"- {p}")
            self.w("")

    def readme_block(self):
        """The README's headline: the marina team in three lines."""
        h = self.team_headline("marina")
        if not h:
            return "The marina team run failed: see docs/figures.md.\n"
        text = (f"The marina mission, three robot daemons over DDS, at commit "
                f"`{self.machine.get('commit', '?')}`: team ATE {h['team']} m for {h['names']} "
                f"(local SLAM {h['local']} m, dead reckoning {h['dr']} m); the link carried "
                f"{h['kbit']} kbit, {h['team_bps']} bps for the team ({h['bps']} bps per robot; "
                "goal 2,000 bps per robot). Every table: docs/figures.md.")
        return "\n".join(textwrap.wrap(text, 95, break_on_hyphens=False)) + "\n"

    def compose(self):
        self.header()
        self.headline()
        self.running_team()
        self.local_slam()
        self.table1()
        self.table2()
        self.table3()
        self.table4()
        self.fig3()
        self.speed()
        self.steps_section()
        out = []
        for line in self.lines:
            if len(line) <= 100 or line.startswith(("|", "#", "![")):
                out.append(line)
            elif line.startswith("- "):
                out.extend(textwrap.wrap(line, 100, subsequent_indent="  ",
                                         break_on_hyphens=False, break_long_words=False))
            else:
                out.extend(textwrap.wrap(line, 100, break_on_hyphens=False,
                                         break_long_words=False))
        text = "\n".join(out).rstrip() + "\n"
        return re.sub(r"\n{3,}", "\n\n", text)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", help="the folder scripts/results.sh wrote (--out)")
    ap.add_argument("--page", default="docs/figures.md")
    ap.add_argument("--missions", default="runs/missions")
    ap.add_argument("--readme", help="also rewrite this file's headline block (README.md)")
    a = ap.parse_args()
    if not os.path.isfile(os.path.join(a.out, "steps.tsv")):
        sys.exit(f"figures.py: {a.out} has no steps.tsv: not a scripts/results.sh folder")
    page = Page(a.out, a.missions, a.page)
    text = page.compose()
    tmp = a.page + ".partial"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, a.page)
    print(f"figures.py: wrote {a.page}")
    if a.readme:
        readme = read_text(a.readme)
        begin, end = "<!-- headline: scripts/results.sh writes this block -->", "<!-- /headline -->"
        if readme is None or begin not in readme or end not in readme:
            sys.exit(f"figures.py: {a.readme} has no headline block ({begin} ... {end})")
        head, rest = readme.split(begin, 1)
        _, tail = rest.split(end, 1)
        with open(a.readme + ".partial", "w", encoding="utf-8") as f:
            f.write(head + begin + "\n" + page.readme_block() + end + tail)
        os.replace(a.readme + ".partial", a.readme)
        print(f"figures.py: updated the headline of {a.readme}")


if __name__ == "__main__":
    main()
