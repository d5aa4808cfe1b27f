#!/usr/bin/env python3
"""Position error before and after the loop closure (step 515 of glmb-sim) of glmb-1.0,
glmb-2.0, fastslam-2.0-oracle (N = 10) and dead reckoning, seeds 1-20, clutter 1/5/10/15:
runs the filters with `rfslam run --save-steps` (the harness's seeds: the runs equal the
sweep's runs 0-19 of configs/glmb.toml) and writes phase.csv and phase.md beside this file.

usage: results/glmb/proposal/phase.py [--rfslam BIN] [--work DIR]
       results/glmb/proposal/phase.py --steer 8 --clutter 5   # -> phase-steer8.csv / .md
"""
import argparse, csv, math, os, subprocess

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.normpath(os.path.join(HERE, "..", "..", ".."))
FILTERS = ["glmb-1.0", "glmb-2.0", "fastslam-2.0-oracle", "dead-reckoning"]
CLUTTER, SEEDS, CLOSE = [1, 5, 10, 15], range(1, 21), 515


def ci(v):
    n = len(v)
    m = sum(v) / n
    sd = math.sqrt(sum((x - m) ** 2 for x in v) / (n - 1))
    return f"{m:+.2f} ± {1.96 * sd / math.sqrt(n):.2f}"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rfslam", default=os.path.join(ROOT, "target", "release", "rfslam"))
    ap.add_argument("--work", default="/tmp/glmb-phase")
    ap.add_argument("--steer", type=float, help="scenario.motion.sigma_steer_deg (default: the scenario's)")
    ap.add_argument("--clutter", type=int, nargs="*", default=CLUTTER)
    a = ap.parse_args()
    clutter = a.clutter
    tag = "" if a.steer is None else f"-steer{a.steer:g}"
    extra = [] if a.steer is None else ["--set", f"scenario.motion.sigma_steer_deg={a.steer}"]
    rows = []
    for c in clutter:
        for s in SEEDS:
            for f in FILTERS:
                out = os.path.join(a.work, f"{f}{tag}-{c}-{s}")
                if not os.path.exists(os.path.join(out, "steps.csv")):
                    n = "1" if f == "dead-reckoning" else "10"
                    subprocess.run([a.rfslam, "run", "--scenario", os.path.join(ROOT, "scenarios", "glmb-sim.toml"),
                                    "--filter", f, "--particles", n, "--seed", str(s), "--set",
                                    f"scenario.clutter.rate={c}", *extra, "--save-steps", "--out", out],
                                   check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
                e = [float(r["pos_err_m"]) for r in csv.DictReader(open(os.path.join(out, "steps.csv")))]
                rows.append({"clutter": c, "seed": s, "filter": f,
                             "pre_rmse_m": math.sqrt(sum(x * x for x in e[:CLOSE]) / CLOSE),
                             "post_rmse_m": math.sqrt(sum(x * x for x in e[CLOSE:]) / len(e[CLOSE:])),
                             "err_at_closure_m": e[CLOSE], "final_err_m": e[-1]})
    with open(os.path.join(HERE, f"phase{tag}.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)
    idx = {(r["clutter"], r["seed"], r["filter"]): r for r in rows}
    lines = ["| filter | clutter | RMSE steps 0-514 [m] | RMSE steps 515-825 [m] | error at step 515 [m] |",
             "|---|---:|---:|---:|---:|"]
    for c in clutter:
        for f in FILTERS:
            v = [idx[(c, s, f)] for s in SEEDS]
            lines.append(f"| {f} | {c} | {ci([r['pre_rmse_m'] for r in v])[1:]} | {ci([r['post_rmse_m'] for r in v])[1:]} "
                         f"| {ci([r['err_at_closure_m'] for r in v])[1:]} |")
    lines += ["", "Paired differences (mean ± 95 % interval over the 20 runs):", "",
              "| pair | clutter | before the closure [m] | after [m] |", "|---|---:|---:|---:|"]
    for c in clutter:
        for x, y in [("glmb-2.0", "glmb-1.0"), ("glmb-2.0", "fastslam-2.0-oracle"), ("glmb-2.0", "dead-reckoning"),
                     ("fastslam-2.0-oracle", "dead-reckoning")]:
            d = [(idx[(c, s, x)], idx[(c, s, y)]) for s in SEEDS]
            lines.append(f"| {x} − {y} | {c} | {ci([p['pre_rmse_m'] - q['pre_rmse_m'] for p, q in d])} "
                         f"| {ci([p['post_rmse_m'] - q['post_rmse_m'] for p, q in d])} |")
    open(os.path.join(HERE, f"phase{tag}.md"), "w").write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
