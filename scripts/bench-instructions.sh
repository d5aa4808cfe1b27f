#!/usr/bin/env bash
# Instructions executed by one run of each filter at an older revision and at the work tree,
# counted by valgrind's cachegrind (exact and repeatable, unlike wall time on a shared or
# virtual machine, where side-by-side criterion rounds of scripts/bench-compare.sh spread by
# more than 10 %). Each filter runs `rfslam run --scenario SCENARIO --particles N --seed 1`
# (the whole run: every recursion, plus loading and writing); dead-reckoning's count on the
# same run is subtracted, which leaves the filter's recursions (and its construction). The
# two revisions' trajectory.csv must agree within 1e-6 in every cell (the same work: no
# association decided otherwise; the largest difference is printed), else the script stops.
#
#   scripts/bench-instructions.sh OLD_REV [N] [SCENARIO] [FILTER...]
#
# Defaults: N = 10, scenarios/phd-slam-synthetic.toml, the four filters of the seam bench
# (phd-3.0 rbphd-mf glmb-2.0 pmbm-slam). Needs valgrind (not a dependency of the project:
# `apt install valgrind`). The old revision is built in a temporary worktree with its own
# target directory (OLD_BIN=path skips that build).
set -euo pipefail
cd "$(dirname "$0")/.."
old=${1:?usage: scripts/bench-instructions.sh OLD_REV [N] [SCENARIO] [FILTER...]}
n=${2:-10}
scenario=${3:-scenarios/phd-slam-synthetic.toml}
shift $(($# < 3 ? $# : 3))
filters=("$@")
[ ${#filters[@]} -gt 0 ] || filters=(phd-3.0 rbphd-mf glmb-2.0 pmbm-slam)
command -v valgrind >/dev/null || { echo "valgrind is needed (apt install valgrind)" >&2; exit 1; }
work=$(mktemp -d /tmp/bench-instructions.XXXXXX)
if [ -z "${OLD_BIN:-}" ]; then
    trap 'git worktree remove --force "$work/old" >/dev/null 2>&1 || true' EXIT
    git worktree add --detach "$work/old" "$old" >/dev/null
    (cd "$work/old" && CARGO_TARGET_DIR="$work/target" cargo build --release -p rfslam-cli --quiet)
    OLD_BIN="$work/target/release/rfslam"
fi
cargo build --release -p rfslam-cli --quiet
NEW_BIN=target/release/rfslam
count() { # bin filter out -> instructions
    valgrind --tool=cachegrind --cache-sim=no --cachegrind-out-file="$3.cg" \
        "$1" run --scenario "$scenario" --filter "$2" --particles "$([ "$2" = dead-reckoning ] && echo 1 || echo "$n")" \
        --seed 1 --out "$3" >/dev/null 2>"$3.log"
    grep -o 'I *refs: *[0-9,]*' "$3.log" | tr -d ', ' | cut -d: -f2
}
printf 'filter\t%s\tnew\tchange\tlargest trajectory difference\n' "$old"
dr_old=$(count "$OLD_BIN" dead-reckoning "$work/dr-old")
dr_new=$(count "$NEW_BIN" dead-reckoning "$work/dr-new")
printf 'dead-reckoning (subtracted)\t%s\t%s\t\n' "$dr_old" "$dr_new"
for f in "${filters[@]}"; do
    a=$(count "$OLD_BIN" "$f" "$work/$f-old")
    b=$(count "$NEW_BIN" "$f" "$work/$f-new")
    diff=$(paste -d, "$work/$f-old/trajectory.csv" "$work/$f-new/trajectory.csv" | awk -F, '
        NR == 1 { half = NF / 2; next }
        { for (i = 2; i <= half; i++) { d = $i - $(i + half); if (d < 0) d = -d; if (d > m) m = d } }
        END { printf "%.3g", m }')
    awk -v d="$diff" 'BEGIN { exit !(d < 1e-6) }' ||
        { echo "$f: the two revisions' trajectories differ by $diff: not the same work" >&2; exit 1; }
    awk -v f="$f" -v a="$a" -v b="$b" -v da="$dr_old" -v db="$dr_new" -v d="$diff" \
        'BEGIN { x = a - da; y = b - db; printf "%s\t%.0f\t%.0f\t%+.2f %%\t%s\n", f, x, y, 100 * (y - x) / x, d }'
done
