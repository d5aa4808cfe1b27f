#!/bin/bash
# Merges the shards written by scripts/slurm/sweep-array.sh into OUT_ROOT/merged
# (runs.csv, summary.csv, report.md: those of the unsharded sweep).
#
#   sbatch --dependency=afterok:ARRAY_JOB_ID scripts/slurm/merge.sh OUT_ROOT N
#
# or directly, without SLURM: scripts/slurm/merge.sh OUT_ROOT N. Every directory
# OUT_ROOT/shard-I-of-N that exists is merged; `rfslam merge` lists the jobs of a missing
# or unfinished shard and fails (rerun that task: the sweep resumes where it stopped).
# The binary is $RFSLAM, else `rfslam` on the PATH, else target/release/rfslam.
#
#SBATCH --job-name=rfslam-merge
#SBATCH --cpus-per-task=1
#SBATCH --output=rfslam-merge-%j.out

set -euo pipefail

if [ $# -ne 2 ]; then
    echo "usage: $0 OUT_ROOT N" >&2
    exit 2
fi
root=$1
count=$2

cd "${SLURM_SUBMIT_DIR:-.}"
rfslam=${RFSLAM:-$(command -v rfslam || echo target/release/rfslam)}
dirs=()
for i in $(seq 1 "$count"); do
    if [ -d "$root/shard-$i-of-$count" ]; then
        dirs+=("$root/shard-$i-of-$count")
    fi
done
if [ ${#dirs[@]} -eq 0 ]; then
    echo "no shard directories $root/shard-*-of-$count" >&2
    exit 1
fi
exec "$rfslam" merge "${dirs[@]}" --out "$root/merged"
