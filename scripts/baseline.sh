#!/usr/bin/env bash
# Bit-identity guard for refactors: run a few short slices of the committed experiments and
# keep their runs.csv, then check later builds against them, every column but the wall time.
#
#   scripts/baseline.sh record DIR   # before the refactor: sweeps the slices into DIR
#   scripts/baseline.sh check DIR    # before each commit: sweeps them again, compares with DIR
#
# RFSLAM (default target/release/rfslam, built here if missing) is the binary; the data sets
# are found as the CLI finds them (RFSLAM_DATA, then ../shared/data, then ./data), and a slice
# whose data are missing is skipped with a note. Exit 1 when a slice differs, listing the
# first differing rows.
set -euo pipefail
cd "$(dirname "$0")/.."

usage() { echo "usage: $0 record|check DIR" >&2; exit 2; }
[ $# -eq 2 ] || usage
mode=$1
dir=$2
case $mode in record | check) ;; *) usage ;; esac

RFSLAM=${RFSLAM:-target/release/rfslam}
if [ ! -x "$RFSLAM" ]; then
  cargo build --release -p rfslam-cli --quiet
fi

# name | experiment | extra sweep arguments
slices=(
  "quick|configs/quick.toml|"
  "table2|configs/table2.toml|--runs 1 --particles 1,10"
  "map-easy|configs/map-easy.toml|--runs 1"
  "glmb|configs/glmb.toml|--runs 1"
  "leung|configs/leung.toml|--runs 2"
  "victoria-park|configs/table3-victoria-park.toml|--runs 1 --particles 1,5"
  "pmbm|configs/pmbm.toml|--runs 1 --particles 1,10"
  "relative-position|configs/relative-position.toml|--runs 2"
  "radio5g|configs/radio5g.toml|--runs 1 --particles 1,10"
)

# runs.csv without the wall-time column, rows sorted: what must not change.
strip_time() {
  awk -F, 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == "time_ms_per_step") t = i }
           { line = ""; for (i = 1; i <= NF; i++) if (i != t) line = line (line == "" ? "" : ",") $i; print line }' "$1" |
    { IFS= read -r header; echo "$header"; sort; }
}

status=0
for s in "${slices[@]}"; do
  IFS='|' read -r name exp extra <<<"$s"
  if [ "$mode" = record ]; then out="$dir/$name"; else out=$(mktemp -d)/$name; fi
  rm -rf "$out"
  mkdir -p "$(dirname "$out")"
  # shellcheck disable=SC2086
  if ! "$RFSLAM" sweep "$exp" $extra --jobs 0 --quiet --out "$out" >"$out.log" 2>&1; then
    if grep -qi 'not found\|no such file' "$out.log"; then
      echo "$name: skipped (data missing: $(head -n 1 "$out.log"))"
      continue
    fi
    echo "$name: the sweep failed:" >&2
    cat "$out.log" >&2
    exit 1
  fi
  if [ "$mode" = record ]; then
    echo "$name: recorded $(($(wc -l <"$out/runs.csv") - 1)) rows"
  elif [ ! -f "$dir/$name/runs.csv" ]; then
    echo "$name: no baseline in $dir (record it first)"
    status=1
  elif diff <(strip_time "$dir/$name/runs.csv") <(strip_time "$out/runs.csv") >"$out.diff"; then
    echo "$name: identical ($(($(wc -l <"$out/runs.csv") - 1)) rows)"
  else
    echo "$name: DIFFERS from the baseline; first lines of the diff ($out.diff):"
    head -n 6 "$out.diff"
    status=1
  fi
done
exit $status
