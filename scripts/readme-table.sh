#!/usr/bin/env bash
# Prints the README results table generated from results/**/summary.csv (and the published
# tables the experiments name), or, with --update README.md, replaces the text between the
# lines <!-- results-table:begin --> and <!-- results-table:end --> of README.md.
# Every argument goes to the `results-table` binary (crates/results-table):
#   scripts/readme-table.sh                                   # print the table
#   scripts/readme-table.sh --update README.md                # rewrite the README section
#   scripts/readme-table.sh --experiment table2 --experiment table1   # these, in this order
# Run from anywhere: it works in the repository root.
set -euo pipefail
cd "$(dirname "$0")/.."
exec cargo run --quiet --release -p results-table -- "$@"
