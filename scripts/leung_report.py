#!/usr/bin/env python3
"""Report of the Leung et al. experiment (configs/leung.toml) from a sweep's runs.csv.

Reads only CSV/TOML written by `rfslam sweep` (Python 3.11 standard library):

    python3 scripts/leung_report.py SWEEP_DIR [--landmarks 10] [--svg OUT_DIR] > report.md

Per filter and clutter level, over the Monte Carlo runs: position RMSE (each run's RMSE over
its steps), the final-map OSPA error of Leung et al. eq. (33) with c from [metrics] gospa_c,
the estimated landmark count, and ms per recursion, each as mean with a 95 % interval
mean +- 1.96 sd / sqrt(runs) (normal approximation over runs). Paired differences between
filters use the same interval on the per-run differences (every filter sees the same data
in run r).

OSPA from the GOSPA parts in runs.csv: GOSPA (alpha = 2) and OSPA minimise the same
assignment of the smaller set under min(d, c)^p, so with k = truth - gospa_missed pairs
closer than c, loc = gospa_loc_m^p and n_est = k + gospa_false:
    e = sqrt((loc + c^2 (min(n, n_est) - k) + c^2 |n - n_est|) / n),   n = |M_g|  (eq. 33).
"""

import argparse
import csv
import math
import os
import sys
import tomllib
from collections import defaultdict

Z95 = 1.96


def mean_ci(xs):
    n = len(xs)
    m = sum(xs) / n
    if n < 2:
        return m, float("nan")
    sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (n - 1))
    return m, Z95 * sd / math.sqrt(n)


def fmt(mc, digits=2):
    m, h = mc
    return f"{m:.{digits}f} ± {h:.{digits}f}"


def ospa33(row, n_truth, c, p):
    missed = int(row["gospa_missed"])
    false = int(row["gospa_false"])
    k = n_truth - missed
    n_est = k + false
    loc = float(row["gospa_loc_m"]) ** p if k > 0 else 0.0
    cut = loc + c**p * (min(n_truth, n_est) - k)
    return ((cut + c**p * abs(n_truth - n_est)) / n_truth) ** (1.0 / p), n_est


def svg_bars(title, unit, groups, series, values, path):
    """A grouped bar chart with 95 % whiskers: groups (x), series (bars), values[(g, s)] = (m, h)."""
    w, h, left, bottom, top = 760, 330, 60, 60, 30
    ymax = max(m + (hh if hh == hh else 0) for (m, hh) in values.values()) * 1.1 or 1.0
    plot_h = h - bottom - top
    gw = (w - left - 20) / len(groups)
    bw = gw * 0.8 / len(series)
    colours = ["#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860", "#da8bc3", "#8c8c8c"]
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" font-size="11">']
    out.append(f'<text x="{w / 2}" y="18" text-anchor="middle" font-size="13">{title}</text>')
    for t in range(6):
        v = ymax * t / 5
        y = top + plot_h * (1 - t / 5)
        out.append(f'<line x1="{left}" y1="{y:.1f}" x2="{w - 20}" y2="{y:.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{left - 5}" y="{y + 4:.1f}" text-anchor="end">{v:.1f}</text>')
    out.append(f'<text x="14" y="{top + plot_h / 2}" transform="rotate(-90 14 {top + plot_h / 2})" text-anchor="middle">{unit}</text>')
    for gi, g in enumerate(groups):
        x0 = left + gi * gw + gw * 0.1
        out.append(f'<text x="{left + gi * gw + gw / 2:.1f}" y="{h - bottom + 18}" text-anchor="middle">{g}</text>')
        for si, s in enumerate(series):
            if (g, s) not in values:
                continue
            m, hh = values[(g, s)]
            x = x0 + si * bw
            y = top + plot_h * (1 - m / ymax)
            out.append(f'<rect x="{x:.1f}" y="{y:.1f}" width="{bw * 0.9:.1f}" height="{top + plot_h - y:.1f}" fill="{colours[si % len(colours)]}"/>')
            if hh == hh:
                y1 = top + plot_h * (1 - (m + hh) / ymax)
                y2 = top + plot_h * (1 - max(m - hh, 0) / ymax)
                xc = x + bw * 0.45
                out.append(f'<line x1="{xc:.1f}" y1="{y1:.1f}" x2="{xc:.1f}" y2="{y2:.1f}" stroke="black"/>')
    for si, s in enumerate(series):
        x = left + si * (w - left) / len(series)
        out.append(f'<rect x="{x:.1f}" y="{h - 22}" width="10" height="10" fill="{colours[si % len(colours)]}"/>')
        out.append(f'<text x="{x + 14:.1f}" y="{h - 13}">{s}</text>')
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("sweep_dir")
    ap.add_argument("--landmarks", type=int, default=None, help="true landmark count (default: world.landmarks)")
    ap.add_argument("--svg", default=None, help="write pos_rmse.svg and ospa.svg into this directory")
    a = ap.parse_args()

    with open(os.path.join(a.sweep_dir, "experiment.resolved.toml"), "rb") as f:
        resolved = tomllib.load(f)
    metrics = resolved.get("metrics", {})
    c, p = float(metrics.get("gospa_c", 3.0)), float(metrics.get("gospa_p", 2.0))
    scen = resolved.get("scenario", {})
    n_truth = a.landmarks or int(scen.get("world", {}).get("landmarks", 10))

    rows = list(csv.DictReader(open(os.path.join(a.sweep_dir, "runs.csv"))))
    grid_col = "scenario.clutter.rate"
    order = []
    data = defaultdict(dict)  # (nc, filter) -> run -> record
    for r in rows:
        key = (float(r[grid_col]), r["filter"])
        if r["filter"] not in order:
            order.append(r["filter"])
        e, n_est = ospa33(r, n_truth, c, p)
        data[key][int(r["run"])] = {
            "pos": float(r["pos_rmse_m"]),
            "ospa": e,
            "count": n_est,
            "ms": float(r["time_ms_per_step"]),
            "ess": float(r["ess_pct"]),
        }
    levels = sorted({k[0] for k in data})
    runs = min(len(v) for v in data.values())

    def col(nc, f, what):
        d = data[(nc, f)]
        return [d[r][what] for r in sorted(d)]

    def paired(nc, f1, f2, what):
        d1, d2 = data[(nc, f1)], data[(nc, f2)]
        common = sorted(set(d1) & set(d2))
        return mean_ci([d1[r][what] - d2[r][what] for r in common])

    print("# Leung et al. (multi-feature RB-PHD weighting): 2-D transposition\n")
    print(
        f"`configs/leung.toml` on `scenarios/leung-2d.toml`, {runs} Monte Carlo runs per row (run r: seed 1 + r, the "
        f"same data for every filter), 25 particles. Every figure is the mean over runs with its 95 % interval "
        f"mean ± 1.96 sd/√runs (normal approximation over runs). Position RMSE: each run's RMSE over its 400 steps. "
        f"OSPA: eq. (33) of the paper on the final map, c = {c:g} m, normalised by the {n_truth} true landmarks "
        f"(computed from the GOSPA parts in runs.csv by `scripts/leung_report.py`). Landmark count: the final map's "
        f"(Gaussians of weight > 0.5; existence probability > 0.5 for the FastSLAM baselines; truth {n_truth}). "
        f"ms per recursion: mean wall time of one filter step, single-threaded (`--jobs 1`) on a 2-core machine that "
        f"was running other sweeps at the same time.\n"
    )
    for nc in levels:
        print(f"## Nc = {nc:g} clutter per scan\n")
        print("| filter | pos RMSE [m] | OSPA c=3 [m] | landmarks | ms / recursion | ESS % |")
        print("|---|---:|---:|---:|---:|---:|")
        for f in order:
            if (nc, f) not in data:
                continue
            print(
                f"| {f} | {fmt(mean_ci(col(nc, f, 'pos')))} | {fmt(mean_ci(col(nc, f, 'ospa')))} | "
                f"{fmt(mean_ci(col(nc, f, 'count')), 1)} | {fmt(mean_ci(col(nc, f, 'ms')), 3)} | "
                f"{mean_ci(col(nc, f, 'ess'))[0]:.0f} |"
            )
        print()

    pairs = [
        ("rbphd-mf-multi", "rbphd-mf-single"),
        ("rbphd-mf-multi", "rbphd-mf-empty"),
        ("rbphd-mf-single", "rbphd-mf-empty"),
        ("rbphd-mf-empty", "dead-reckoning"),
        ("rbphd-mf-multi", "mh-fastslam"),
        ("rbphd-mf-multi", "fastslam-1.0"),
        ("mh-fastslam", "fastslam-1.0"),
        ("rbphd-mf-multi", "phd-1.0-eq46"),
    ]
    print("## Paired differences (A − B, per run, mean ± 95 % interval)\n")
    print("| Nc | A − B | pos RMSE [m] | OSPA [m] | landmarks |")
    print("|---|---|---:|---:|---:|")
    for nc in levels:
        for f1, f2 in pairs:
            if (nc, f1) in data and (nc, f2) in data:
                print(
                    f"| {nc:g} | {f1} − {f2} | {fmt(paired(nc, f1, f2, 'pos'))} | "
                    f"{fmt(paired(nc, f1, f2, 'ospa'))} | {fmt(paired(nc, f1, f2, 'count'), 1)} |"
                )
    print()
    print("## Cost of the multi-feature weighting\n")
    print("| Nc | ms multi | ms single | ratio of means | per-run ratio (mean ± 95 %) |")
    print("|---|---:|---:|---:|---:|")
    for nc in levels:
        if (nc, "rbphd-mf-multi") in data and (nc, "rbphd-mf-single") in data:
            m1, m2 = mean_ci(col(nc, "rbphd-mf-multi", "ms")), mean_ci(col(nc, "rbphd-mf-single", "ms"))
            dm, ds = data[(nc, "rbphd-mf-multi")], data[(nc, "rbphd-mf-single")]
            ratio = mean_ci([dm[r]["ms"] / ds[r]["ms"] for r in sorted(set(dm) & set(ds))])
            print(f"| {nc:g} | {fmt(m1, 3)} | {fmt(m2, 3)} | {m1[0] / m2[0]:.2f} | {fmt(ratio)} |")
    print()

    if a.svg:
        os.makedirs(a.svg, exist_ok=True)
        groups = [f"Nc = {nc:g}" for nc in levels]
        for what, title, unit in [
            ("pos", "Position RMSE (mean, 95 % interval)", "m"),
            ("ospa", f"Final-map OSPA, eq. (33), c = {c:g} m (mean, 95 % interval)", "m"),
            ("count", f"Estimated landmark count (truth {n_truth})", "landmarks"),
        ]:
            values = {}
            for nc, g in zip(levels, groups):
                for f in order:
                    if (nc, f) in data:
                        values[(g, f)] = mean_ci(col(nc, f, what))
            svg_bars(title, unit, groups, order, values, os.path.join(a.svg, f"{what}.svg"))


if __name__ == "__main__":
    sys.exit(main())
