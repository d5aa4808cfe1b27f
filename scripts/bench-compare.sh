#!/usr/bin/env bash
# Side-by-side criterion comparison of one recursion of phd-3.0, rbphd-mf, glmb-2.0 and
# pmbm-slam (crates/rfslam-harness/benches/seam.rs) at an older revision and at the work
# tree, on this machine in one session: both bench binaries are built first, then run in
# alternation ROUNDS times (old, new, old, new, ...), and the median of each run's criterion
# estimate is printed per filter and revision.
#
#   scripts/bench-compare.sh OLD_REV [ROUNDS]
#
# The old revision is checked out in a temporary worktree with its own target directory;
# seam.rs is copied into it (the filters' type names are the same there), and the timing
# harness is the same at both (see below). Data: the papers' synthetic environment where
# the CLI finds it (RFSLAM_DATA, then ../shared/data, then ./data), else the procedural world.
set -euo pipefail
cd "$(dirname "$0")/.."
old=${1:?usage: scripts/bench-compare.sh OLD_REV [ROUNDS]}
rounds=${2:-2}
work=$(mktemp -d /tmp/bench-compare.XXXXXX)
trap 'git worktree remove --force "$work/old" >/dev/null 2>&1 || true' EXIT
git worktree add --detach "$work/old" "$old" >/dev/null
cp crates/rfslam-harness/benches/seam.rs "$work/old/crates/rfslam-harness/benches/seam.rs"
# The same harness at both revisions: the old revision keeps its own rfslam-bench when it
# times each step on its own clone in LargeInput batches (from f2c4bf3 on, and its API is the
# old revision's); an older one gets this revision's batching and recursion_main! copied in
# (it needs FilterBuild and the eval fixtures of that time, as 9166aef has).
if ! grep -q 'BatchSize::LargeInput' "$work/old/crates/rfslam-bench/src/lib.rs"; then
    git show f2c4bf3:crates/rfslam-bench/src/lib.rs >"$work/old/crates/rfslam-bench/src/lib.rs"
fi
grep -q 'name = "seam"' "$work/old/crates/rfslam-harness/Cargo.toml" ||
    printf '\n[[bench]]\nname = "seam"\nharness = false\n' >>"$work/old/crates/rfslam-harness/Cargo.toml"
bin() { # dir -> path of the built seam bench binary
    (cd "$1" && cargo bench -p rfslam-harness --bench seam --no-run --message-format=json 2>/dev/null) |
        grep -o '"executable":"[^"]*seam-[^"]*"' | tail -1 | cut -d'"' -f4
}
old_bin=$(bin "$work/old")
new_bin=$(bin .)
[ -x "$old_bin" ] && [ -x "$new_bin" ] || { echo "bench build failed" >&2; exit 1; }
out="$work/results.tsv"
for r in $(seq 1 "$rounds"); do
    for side in old new; do
        b=$old_bin; [ "$side" = new ] && b=$new_bin
        "$b" --bench --noplot 2>/dev/null | awk -v side="$side" -v r="$r" '
            / one recursion/ { name = $1 }
            /time:/ {
                s = substr($0, index($0, "time:") + 5); gsub(/\[|\]/, "", s); split(s, a, " ")
                print side "\t" r "\t" name "\t" a[3] " " a[4]
            }' >>"$out"
    done
done
echo "filter	revision	round	median"
sort -k3,3 -k1,1 "$out" | awk -F'\t' '{print $3 "\t" $1 "\t" $2 "\t" $4}'
