#!/usr/bin/env bash
# Regenerates the committed figures in results/figures/ (the figures of Kaltiokallio et al.
# 2024, PHD-SLAM 3.0, from our runs and reproductions) with `rfslam run` and `rfslam plot`:
#
#   fig1-map-synthetic-phd-3.0.png       Fig. 1: synthetic environment, phd-3.0 N = 1, run seed 1
#   fig2-steps-synthetic-phd-3.0.png     Fig. 2: errors, GOSPA, ID components, ESS over time of
#                                        that run; fig2-steps-synthetic.png: phd-2.0a / 2.0b / 3.0
#                                        N = 1 on the same data (seed 1), as the paper compares them
#   fig3-particles-synthetic-<f>.png     Fig. 3: 100 particle trajectories without resampling,
#                                        phd-2.0a, phd-2.0b, phd-3.0 (seed 1)
#   fig4-map-victoria-park-phd-3.0.png   Fig. 4: Victoria Park, phd-3.0 N = 1 (Table III settings)
#   fig5a-sensitivity-pd.png             Fig. 5a: position RMSE against the assumed pD
#   fig5b-sensitivity-clutter.png        Fig. 5b: position RMSE against the assumed clutter rate
#                                        (results/sensitivity/, synthetic and Victoria Park)
#   table2-pos-rmse.png, table2-gospa.png  Table II as bars with +-1 std over the 100 runs
#
# Needs the phd-slam-synthetic and victoria-park data sets (RFSLAM_DATA, ../shared/data or
# ./data). About 2 minutes on 2 cores (most of it the 100-particle runs of Fig. 3). The runs'
# raw outputs go to results/runs/figures/ (git-ignored). RFSLAM names a built binary;
# OUT another figure directory.
set -euo pipefail
cd "$(dirname "$0")/.."

if [ -z "${RFSLAM:-}" ]; then
    cargo build --release --quiet -p rfslam-cli
    RFSLAM="${CARGO_TARGET_DIR:-target}/release/rfslam"
fi
OUT=${OUT:-results/figures}
RUNS=${RUNS:-results/runs/figures}
mkdir -p "$OUT" "$RUNS"
SYN=scenarios/phd-slam-synthetic.toml

# Figs. 1 and 2: one particle, run seed 1 (run 0 of the Table II sweep), same data for all three.
for f in phd-2.0a phd-2.0b phd-3.0; do
    "$RFSLAM" run --scenario "$SYN" --filter "$f" --particles 1 --seed 1 --save-steps --out "$RUNS/synthetic-$f-n1"
done
"$RFSLAM" plot "$RUNS/synthetic-phd-3.0-n1" --out "$OUT/fig1-map-synthetic-phd-3.0.png"
"$RFSLAM" plot "$RUNS/synthetic-phd-3.0-n1" --kind steps --out "$OUT/fig2-steps-synthetic-phd-3.0.png"
"$RFSLAM" plot "$RUNS/synthetic-phd-2.0a-n1" "$RUNS/synthetic-phd-2.0b-n1" "$RUNS/synthetic-phd-3.0-n1" \
    --kind steps --title "One particle on the synthetic environment (run seed 1)" --out "$OUT/fig2-steps-synthetic.png"

# Fig. 3: 100 particles, no resampling (as Table I), run seed 1.
for f in phd-2.0a phd-2.0b phd-3.0; do
    "$RFSLAM" run --scenario "$SYN" --filter "$f" --particles 100 --seed 1 --set resample_ess_fraction=0 \
        --save-particles --out "$RUNS/synthetic-$f-n100-noresampling"
    "$RFSLAM" plot "$RUNS/synthetic-$f-n100-noresampling" --kind particles \
        --title "$f: 100 particles without resampling (run seed 1)" --out "$OUT/fig3-particles-synthetic-$f.png"
done

# Fig. 4: Victoria Park with the Table III settings of phd-3.0 (configs/table3-victoria-park.toml).
"$RFSLAM" run --scenario scenarios/victoria-park.toml --filter phd-3.0 --particles 1 --seed 1 \
    --set merge=10 --set fov_buffer_range=5 --set fov_buffer_deg=5 --set resample_ess=1 \
    --out "$RUNS/victoria-park-phd-3.0-n1"
"$RFSLAM" plot "$RUNS/victoria-park-phd-3.0-n1" --out "$OUT/fig4-map-victoria-park-phd-3.0.png"

# Fig. 5 from the committed sensitivity summaries: each data set at its own nominal values
# (synthetic pD 0.95, Victoria Park pD0 0.7, clutter 5 per scan for both).
SENS="results/sensitivity/summary.csv results/sensitivity/victoria-park-summary.csv"
KEY=filter.phd-3.0
# shellcheck disable=SC2086
"$RFSLAM" plot $SENS --kind metric --label synthetic --label "Victoria Park" \
    --x $KEY.detection_pd --where $KEY.clutter_rate=5 \
    --title "phd-3.0 N=1: sensitivity to the assumed pD (lambda = 5)" --out "$OUT/fig5a-sensitivity-pd.png"
# shellcheck disable=SC2086
"$RFSLAM" plot $SENS --kind metric --label "synthetic (pD = 0.95)" --label "Victoria Park (pD0 = 0.7)" \
    --x $KEY.clutter_rate --where 1:$KEY.detection_pd=0.95 --where 2:$KEY.detection_pd=0.7 \
    --title "phd-3.0 N=1: sensitivity to the assumed clutter rate" --out "$OUT/fig5b-sensitivity-clutter.png"

# Table II (results/table2/summary.csv) as bars.
"$RFSLAM" plot results/table2 --kind bars --metric pos_rmse_m --log-y \
    --title "Table II: position RMSE (100 runs, resampling at ESS <= 0.2 N)" --out "$OUT/table2-pos-rmse.png"
"$RFSLAM" plot results/table2 --kind bars --metric gospa_m \
    --title "Table II: GOSPA of the final map (c = 20 m, p = 2)" --out "$OUT/table2-gospa.png"
echo "figures in $OUT"
