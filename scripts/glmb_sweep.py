#!/usr/bin/env python3
"""Monte Carlo sweep and report of the delta-GLMB-SLAM experiment (configs/glmb.toml).

The harness's runs.csv has no x / y RMSE, OSPA (c = 0.5, p = 1) or landmark count, so this
script drives `rfslam run` for every (clutter rate, filter, run) of the experiment with the
harness's seeds (run r of master seed m uses run seed m + r, so `rfslam run --seed m+r`
reproduces run r of `rfslam sweep configs/glmb.toml` exactly), scores each run from its
trajectory.csv / map.csv / metrics.json against the world's truth, and writes
OUT/runs.csv, OUT/report.md and SVG figures. Python 3 standard library only.

usage: scripts/glmb_sweep.py [--rfslam BIN] [--runs 50] [--out results/glmb]
       scripts/glmb_sweep.py --report-only --out results/glmb   # re-render from runs.csv
"""

import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

FILTERS = ["glmb-1.0", "glmb-2.0", "lmb-slam"]
# Reference rows (not in the published comparison): FastSLAM 2.0 told the true associations
# (what a filter that never errs in data association achieves on the same data) and dead
# reckoning. Name -> particles (None: the --particles of the sweep).
REFERENCES = {"fastslam-2.0-oracle": None, "dead-reckoning": 1}
CLUTTER = [1, 5, 10, 15]
OSPA_C, OSPA_P = 0.5, 1.0
METRICS = [
    ("x_rmse_m", "x RMSE [m]"),
    ("y_rmse_m", "y RMSE [m]"),
    ("head_rmse_deg", "heading RMSE [deg]"),
    ("pos_rmse_m", "position RMSE [m]"),
    ("ospa_m", "final-map OSPA (c = 0.5, p = 1) [m]"),
    ("landmarks", "estimated landmarks (23 true)"),
    ("ms_per_step", "ms / recursion"),
]


def hungarian(cost):
    """Minimum-cost assignment of a rectangular matrix (rows <= cols); returns row -> col."""
    n, m = len(cost), len(cost[0]) if cost else 0
    inf = float("inf")
    u, v = [0.0] * (n + 1), [0.0] * (m + 1)
    p, way = [0] * (m + 1), [0] * (m + 1)
    for i in range(1, n + 1):
        p[0] = i
        j0 = 0
        minv = [inf] * (m + 1)
        used = [False] * (m + 1)
        while True:
            used[j0] = True
            i0, delta, j1 = p[j0], inf, 0
            for j in range(1, m + 1):
                if not used[j]:
                    cur = cost[i0 - 1][j - 1] - u[i0] - v[j]
                    if cur < minv[j]:
                        minv[j], way[j] = cur, j0
                    if minv[j] < delta:
                        delta, j1 = minv[j], j
            for j in range(m + 1):
                if used[j]:
                    u[p[j]] += delta
                    v[j] -= delta
                else:
                    minv[j] -= delta
            j0 = j1
            if p[j0] == 0:
                break
        while j0:
            j1 = way[j0]
            p[j0] = p[j1]
            j0 = j1
    out = [None] * n
    for j in range(1, m + 1):
        if p[j]:
            out[p[j] - 1] = j - 1
    return out


def ospa(x, y, c=OSPA_C, p=OSPA_P):
    """OSPA distance of order p with cut-off c between point sets x and y."""
    if not x and not y:
        return 0.0
    if not x or not y:
        return c
    a, b = (x, y) if len(x) <= len(y) else (y, x)
    d = [[min(c, math.dist(pa, pb)) ** p for pb in b] for pa in a]
    asg = hungarian(d)
    total = sum(d[i][asg[i]] for i in range(len(a))) + c**p * (len(b) - len(a))
    return (total / len(b)) ** (1.0 / p)


def wrap(a):
    return (a + math.pi) % (2 * math.pi) - math.pi


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def score(run_dir, truth, landmarks):
    traj = read_csv(os.path.join(run_dir, "trajectory.csv"))
    sx = sy = sh = 0.0
    for row in traj:
        t = truth[round(float(row["t"]), 6)]
        sx += (float(row["x"]) - t[0]) ** 2
        sy += (float(row["y"]) - t[1]) ** 2
        sh += wrap(float(row["heading"]) - t[2]) ** 2
    n = len(traj)
    est = [(float(r["x"]), float(r["y"])) for r in read_csv(os.path.join(run_dir, "map.csv"))]
    with open(os.path.join(run_dir, "metrics.json")) as f:
        m = json.load(f)
    return {
        "x_rmse_m": math.sqrt(sx / n),
        "y_rmse_m": math.sqrt(sy / n),
        "head_rmse_deg": math.degrees(math.sqrt(sh / n)),
        "pos_rmse_m": math.sqrt((sx + sy) / n),
        "ospa_m": ospa(est, landmarks),
        "landmarks": len(est),
        "ms_per_step": m["time_ms_per_step"],
        "steps": n,
    }


def sweep(args):
    os.makedirs(args.out, exist_ok=True)
    tmp = tempfile.mkdtemp(prefix="glmb-sweep-")
    sim = os.path.join(tmp, "truth")
    subprocess.run([args.rfslam, "simulate", "--scenario", args.scenario, "--seed", str(args.seed), "--out", sim],
                   check=True, stdout=subprocess.DEVNULL)
    truth = {round(float(r["t"]), 6): (float(r["x"]), float(r["y"]), float(r["heading"]))
             for r in read_csv(os.path.join(sim, "groundtruth.csv"))}
    landmarks = [(float(r["x"]), float(r["y"])) for r in read_csv(os.path.join(sim, "landmarks.csv"))]
    rows = []
    for c in CLUTTER:
        for f in FILTERS + list(REFERENCES):
            n = REFERENCES.get(f) or args.particles
            for r in range(args.runs):
                seed = args.seed + r
                d = os.path.join(tmp, f"{f}-{c}-{r}")
                subprocess.run([args.rfslam, "run", "--scenario", args.scenario, "--filter", f, "--particles",
                                str(n), "--seed", str(seed), "--set", f"scenario.clutter.rate={c}",
                                "--out", d], check=True, stdout=subprocess.DEVNULL)
                s = score(d, truth, landmarks)
                rows.append({"clutter": c, "filter": f, "particles": n, "run": r, "seed": seed, **s})
            print(f"clutter {c} {f}: done", file=sys.stderr)
    with open(os.path.join(args.out, "runs.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)


def mean_ci(v):
    n = len(v)
    mu = sum(v) / n
    sd = math.sqrt(sum((x - mu) ** 2 for x in v) / (n - 1)) if n > 1 else 0.0
    return mu, 1.96 * sd / math.sqrt(n)


def svg(path, title, ylabel, series):
    """A line chart of mean +- 95 % interval against the clutter rate, one line per filter."""
    w, h, ml, mr, mt, mb = 520, 340, 70, 130, 40, 50
    ymax = max(m + e for pts in series.values() for _, m, e in pts) * 1.1 or 1.0
    xs = {c: ml + (w - ml - mr) * i / (len(CLUTTER) - 1) for i, c in enumerate(CLUTTER)}
    Y = lambda v: mt + (h - mt - mb) * (1 - v / ymax)  # noqa: E731
    colours = {"glmb-1.0": "#1f77b4", "glmb-2.0": "#d62728", "lmb-slam": "#2ca02c",
               "fastslam-2.0-oracle": "#7f7f7f", "dead-reckoning": "#bcbd22"}
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="12">',
           f'<rect width="{w}" height="{h}" fill="white"/>',
           f'<text x="{w / 2}" y="20" text-anchor="middle" font-size="14">{title}</text>',
           f'<line x1="{ml}" y1="{h - mb}" x2="{w - mr}" y2="{h - mb}" stroke="black"/>',
           f'<line x1="{ml}" y1="{mt}" x2="{ml}" y2="{h - mb}" stroke="black"/>',
           f'<text x="{(ml + w - mr) / 2}" y="{h - 12}" text-anchor="middle">clutter rate (per scan)</text>',
           f'<text x="16" y="{(mt + h - mb) / 2}" text-anchor="middle" transform="rotate(-90 16 {(mt + h - mb) / 2})">{ylabel}</text>']
    for c, x in xs.items():
        out.append(f'<text x="{x}" y="{h - mb + 16}" text-anchor="middle">{c}</text>')
    for k in range(5):
        v = ymax * k / 4
        out.append(f'<text x="{ml - 6}" y="{Y(v) + 4}" text-anchor="end">{v:.3g}</text>')
        out.append(f'<line x1="{ml}" y1="{Y(v)}" x2="{w - mr}" y2="{Y(v)}" stroke="#ddd"/>')
    for i, (f, pts) in enumerate(series.items()):
        col = colours.get(f, "black")
        off = (i - 2) * 3
        out.append('<polyline fill="none" stroke="%s" stroke-width="2" points="%s"/>'
                   % (col, " ".join(f"{xs[c] + off},{Y(m)}" for c, m, _ in pts)))
        for c, m, e in pts:
            out.append(f'<line x1="{xs[c] + off}" y1="{Y(m - e)}" x2="{xs[c] + off}" y2="{Y(m + e)}" stroke="{col}"/>')
            out.append(f'<circle cx="{xs[c] + off}" cy="{Y(m)}" r="3" fill="{col}"/>')
        out.append(f'<text x="{w - mr + 10}" y="{mt + 20 + 18 * i}" fill="{col}">{f}</text>')
    out.append("</svg>")
    with open(path, "w") as fh:
        fh.write("\n".join(out))


def report(args):
    rows = read_csv(os.path.join(args.out, "runs.csv"))
    for r in rows:
        for k, _ in METRICS:
            r[k] = float(r[k])
    cell = lambda c, f: [r for r in rows if int(r["clutter"]) == c and r["filter"] == f]  # noqa: E731
    runs = len(cell(CLUTTER[0], FILTERS[0]))
    shown = FILTERS + [f for f in REFERENCES if cell(CLUTTER[0], f)]
    steps = int(float(rows[0]["steps"])) if "steps" in rows[0] else 166
    lines = [f"# delta-GLMB-SLAM 1.0 / 2.0 and LMB-SLAM on {args.scenario}", "",
             f"`{args.scenario}`: {runs} Monte Carlo runs per filter and clutter rate, "
             f"{rows[0]['particles']} particles, {steps} steps. Reference rows (not part of the published "
             "comparison): " + ", ".join(f"`{f}`" for f in shown[len(FILTERS):]) + ". "
             "Every cell is the mean over runs ± the 95 % interval "
             "(1.96 sd / sqrt(runs)). RMSEs are over all steps of a run; OSPA (c = 0.5 m, p = 1) and the landmark "
             "count are of the final map; time is one recursion (all particles) on one core. Produced by "
             "`scripts/glmb_sweep.py` (runs.csv beside this file).", ""]
    for key, label in METRICS:
        lines += [f"## {label}", "", "| filter | " + " | ".join(f"clutter {c}" for c in CLUTTER) + " |",
                  "|---|" + "---:|" * len(CLUTTER)]
        series = {}
        for f in shown:
            cells, pts = [], []
            for c in CLUTTER:
                mu, e = mean_ci([r[key] for r in cell(c, f)])
                prec = 4 if key == "ms_per_step" else 3
                cells.append(f"{mu:.{prec}f} ± {e:.{prec}f}")
                pts.append((c, mu, e))
            series[f] = pts
            lines.append(f"| {f} | " + " | ".join(cells) + " |")
        fig = f"fig-{key}.svg"
        svg(os.path.join(args.out, fig), label, label, series)
        lines += ["", f"![{label}]({fig})", ""]
    # Paired differences (same data in run r): the published ordering.
    lines += ["## Paired differences (95 % intervals; negative = the first filter is lower)", "",
              "| metric | pair | " + " | ".join(f"clutter {c}" for c in CLUTTER) + " |",
              "|---|---|" + "---:|" * len(CLUTTER)]
    for key in ["pos_rmse_m", "head_rmse_deg", "ospa_m", "ms_per_step"]:
        pairs = [("glmb-2.0", "glmb-1.0"), ("glmb-2.0", "lmb-slam"), ("glmb-1.0", "lmb-slam")]
        if "fastslam-2.0-oracle" in shown and key != "ms_per_step":
            pairs.append(("glmb-2.0", "fastslam-2.0-oracle"))
        for a, b in pairs:
            cells = []
            for c in CLUTTER:
                ra = {r["run"]: r[key] for r in cell(c, a)}
                rb = {r["run"]: r[key] for r in cell(c, b)}
                mu, e = mean_ci([ra[k] - rb[k] for k in ra if k in rb])
                sig = "**" if abs(mu) > e else ""
                cells.append(f"{sig}{mu:+.4g} ± {e:.2g}{sig}")
            lines.append(f"| {key} | {a} − {b} | " + " | ".join(cells) + " |")
    lines += ["", "Bold: the interval excludes 0.", ""]
    with open(os.path.join(args.out, "tables.md"), "w") as fh:
        fh.write("\n".join(lines))
    print("\n".join(lines))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rfslam", default="target/release/rfslam")
    ap.add_argument("--scenario", default="scenarios/glmb-sim.toml")
    ap.add_argument("--runs", type=int, default=50)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--particles", type=int, default=10)
    ap.add_argument("--out", default="results/glmb")
    ap.add_argument("--report-only", action="store_true")
    args = ap.parse_args()
    if not args.report_only:
        sweep(args)
    report(args)


if __name__ == "__main__":
    main()
