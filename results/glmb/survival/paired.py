#!/usr/bin/env python3
"""Paired effect of survival_fov = 1 (runs.csv here, configs/glmb-survival.toml) against the
default 0.95 (../harness/runs.csv, configs/glmb.toml): same seeds, same data, same filter
draws up to the first survival decision. Writes paired.md beside this file."""
import csv, math, os

HERE = os.path.dirname(os.path.abspath(__file__))


def load(p):
    return {(r["filter"], int(float(r["scenario.clutter.rate"])), int(r["seed"])): r for r in csv.DictReader(open(p))}


a = load(os.path.join(HERE, "..", "harness", "runs.csv"))
b = load(os.path.join(HERE, "runs.csv"))
out = ["| filter | clutter | pos RMSE, p_S = 0.95 [m] | pos RMSE, p_S = 1 − 0.95 [m] | GOSPA, p_S = 0.95 [m] | GOSPA, p_S = 1 − 0.95 [m] |",
       "|---|---:|---:|---:|---:|---:|"]
for f in ["glmb-1.0", "glmb-2.0"]:
    for c in [1, 5, 10, 15]:
        cells = []
        for m in ["pos_rmse_m", "gospa_m"]:
            base = [float(a[(f, c, s)][m]) for s in range(1, 51)]
            d = [float(b[(f + "-ps1", c, s)][m]) - float(a[(f, c, s)][m]) for s in range(1, 51)]
            n, mu = len(d), sum(d) / len(d)
            sd = math.sqrt(sum((x - mu) ** 2 for x in d) / (n - 1))
            h = 1.96 * sd / math.sqrt(n)
            cell = f"{mu:+.3f} ± {h:.3f}"
            cells += [f"{sum(base) / n:.3f}", f"**{cell}**" if abs(mu) > h else cell]
        out.append(f"| {f} | {c} | " + " | ".join(cells) + " |")
open(os.path.join(HERE, "paired.md"), "w").write("\n".join(out) + "\n")
