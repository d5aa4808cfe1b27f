#!/usr/bin/env bash
# Full reproductions of the published tables. For each experiment name (default: table1
# table2) runs `rfslam sweep configs/<config>.toml` into results/runs/<name>/ (resumable: rerun
# the script after an interruption), then copies runs.csv, summary.csv, invocations.csv,
# report.md and the resolved configuration into results/<name>/, appending results/<name>/discussion.md to the report
# when it exists. JOBS (default 2) sets the number of parallel jobs.
#
# Names: table1, table2 (configs/<name>.toml) and table3 (alias table3-victoria-park:
# configs/table3-victoria-park.toml, results in results/table3/; needs the victoria-park
# data set, see docs/datasets.md). Table III was run with `JOBS=1 scripts/reproduce.sh table3`.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p rfslam-cli
experiments=("$@")
[ ${#experiments[@]} -gt 0 ] || experiments=(table1 table2)
for name in "${experiments[@]}"; do
  case "$name" in
    table3 | table3-victoria-park) exp=table3; config=table3-victoria-park ;;
    *) exp="$name"; config="$name" ;;
  esac
  out="results/runs/$exp"
  start=$(date +%s)
  ./target/release/rfslam sweep "configs/$config.toml" --jobs "${JOBS:-2}" --out "$out" --resume
  echo "$exp: $(( $(date +%s) - start )) s wall time"
  mkdir -p "results/$exp"
  cp "$out/summary.csv" "$out/experiment.resolved.toml" "$out/invocations.csv" "$out/runs.csv" "results/$exp/"
  cp "$out/report.md" "results/$exp/report.md"
  if [ -f "results/$exp/discussion.md" ]; then
    { echo; cat "results/$exp/discussion.md"; } >> "results/$exp/report.md"
  fi
done
