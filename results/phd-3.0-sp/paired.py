#!/usr/bin/env python3
"""Paired per-run comparison of two filters of one sweep (Python 3 standard library).

    python3 results/phd-3.0-sp/paired.py RUNS_CSV FILTER_A FILTER_B

RUNS_CSV is the runs.csv of an `rfslam sweep` in which both filters (labels as in the
`filter` column) ran on the same runs: run r of both saw the same data (same seed), so the
per-run differences B - A are paired. For each grid point (the sweep's `[grid]` columns) and
particle count N found for both, and for each
metric (position RMSE, heading RMSE, final-map GOSPA, ESS %, ms per recursion, position
RMSE after the rigid SE(2) fit; a metric empty in the file is left out), it prints
a Markdown table with: the per-run means of A and B, the mean of the per-run differences
B - A with a 95 % interval (mean +- 1.96 sd / sqrt(n)), their median, and in how many runs B
is lower than A, and the two-sided exact sign-test p-value of the differences (ties left
out). Runs present for only one filter are left out (and counted).
"""

import csv
import math
import sys
from collections import defaultdict

METRICS = [
    ("pos_rmse_m", "pos RMSE [m]", 3),
    ("head_rmse_deg", "heading RMSE [deg]", 3),
    ("gospa_m", "GOSPA [m]", 2),
    ("ess_pct", "ESS [%]", 1),
    ("time_ms_per_step", "ms / recursion", 4),
    ("pos_rmse_se2_m", "pos RMSE after SE(2) fit [m]", 3),
]


def mean(xs):
    return sum(xs) / len(xs)


def ci95(xs):
    n = len(xs)
    if n < 2:
        return float("nan")
    m = mean(xs)
    return 1.96 * math.sqrt(sum((x - m) ** 2 for x in xs) / (n - 1)) / math.sqrt(n)


def sign_test(diff):
    """Two-sided exact sign test of "B - A is as often negative as positive" (ties left out)."""
    neg, pos = sum(1 for x in diff if x < 0), sum(1 for x in diff if x > 0)
    n, k = neg + pos, min(neg, pos)
    if n == 0:
        return float("nan")
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


def median(xs):
    s = sorted(xs)
    n = len(s)
    return s[n // 2] if n % 2 else 0.5 * (s[n // 2 - 1] + s[n // 2])


def main(argv):
    if len(argv) != 4:
        sys.exit(__doc__)
    path, a, b = argv[1:4]
    rows = defaultdict(dict)  # (grid point, filter, N) -> run -> row
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        grid = [c for c in reader.fieldnames if "." in c]  # grid columns: `scenario.x`, `filter.l.k`
        for r in reader:
            point = tuple((c, r[c]) for c in grid)
            rows[(point, r["filter"], int(r["particles"]))][int(r["run"])] = r
    cells = sorted({(p, n) for (p, f, n) in rows if f == a} & {(p, n) for (p, f, n) in rows if f == b})
    if not cells:
        sys.exit(f"{path}: no particle count with both `{a}` and `{b}`")
    for point, n in cells:
        ra, rb = rows[(point, a, n)], rows[(point, b, n)]
        runs = sorted(set(ra) & set(rb))
        unpaired = len(set(ra) ^ set(rb))
        where = "".join(f", {c} = {v}" for c, v in point)
        print(f"N = {n}{where}: {len(runs)} paired runs" + (f" ({unpaired} unpaired left out)" if unpaired else "") + "\n")
        print(f"| metric | {a} | {b} | {b} - {a} (95 % CI) | median diff | runs {b} lower | sign test p |")
        print("|---|---:|---:|---:|---:|---:|---:|")
        for key, name, d in METRICS:
            if any(ra[r].get(key, "") == "" or rb[r].get(key, "") == "" for r in runs):
                continue
            xa = [float(ra[r][key]) for r in runs]
            xb = [float(rb[r][key]) for r in runs]
            diff = [y - x for x, y in zip(xa, xb)]
            lower = sum(1 for x in diff if x < 0)
            print(
                f"| {name} | {mean(xa):.{d}f} | {mean(xb):.{d}f} | {mean(diff):+.{d}f} ± {ci95(diff):.{d}f}"
                f" | {median(diff):+.{d}f} | {lower} / {len(runs)} | {sign_test(diff):.2g} |"
            )
        print()


if __name__ == "__main__":
    main(sys.argv)
