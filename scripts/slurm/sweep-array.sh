#!/bin/bash
# One shard of an rfslam sweep per task of a SLURM job array.
#
#   sbatch --array=1-N scripts/slurm/sweep-array.sh EXPERIMENT OUT_ROOT [rfslam sweep options]
#
# Task t of an array of N tasks runs shard I = t - SLURM_ARRAY_TASK_MIN + 1 of N:
#
#   rfslam sweep EXPERIMENT --shard I/N --out OUT_ROOT/shard-I-of-N --resume \
#       --jobs ${SLURM_CPUS_PER_TASK:-1} --quiet [options]
#
# so --array=1-N and --array=0-(N-1) give the same shards; the array must be one contiguous
# range (a throttle such as %4 is fine, a step or a list with gaps is not). --resume makes a
# requeued or resubmitted task continue its shard instead of starting over. Each job is
# single-threaded (one core per job, as the papers time one recursion); give a task more
# cores with sbatch --cpus-per-task=K and it runs K jobs at once. Extra options (--runs,
# --filters, --particles) are passed to every shard and must be the same for all of them.
#
# Relative paths are relative to the directory sbatch was called from. The binary is
# $RFSLAM, else `rfslam` on the PATH, else target/release/rfslam there.
# Merge the shards afterwards with scripts/slurm/merge.sh (scripts/slurm/submit.sh submits
# both, the merge with --dependency=afterok on the array).
#
#SBATCH --job-name=rfslam-sweep
#SBATCH --cpus-per-task=1
#SBATCH --output=rfslam-sweep-%A_%a.out

set -euo pipefail

if [ $# -lt 2 ]; then
    echo "usage: sbatch --array=1-N $0 EXPERIMENT OUT_ROOT [rfslam sweep options]" >&2
    exit 2
fi
experiment=$1
root=$2
shift 2

for v in SLURM_ARRAY_TASK_ID SLURM_ARRAY_TASK_MIN SLURM_ARRAY_TASK_MAX SLURM_ARRAY_TASK_COUNT; do
    if [ -z "${!v:-}" ]; then
        echo "$v is not set: submit this script as a job array (sbatch --array=1-N ...)" >&2
        exit 2
    fi
done
count=$SLURM_ARRAY_TASK_COUNT
if [ $((SLURM_ARRAY_TASK_MAX - SLURM_ARRAY_TASK_MIN + 1)) -ne "$count" ] || [ "${SLURM_ARRAY_TASK_STEP:-1}" -ne 1 ]; then
    echo "the array must be one contiguous range such as --array=1-$count (got min $SLURM_ARRAY_TASK_MIN, max $SLURM_ARRAY_TASK_MAX, $count tasks)" >&2
    exit 2
fi
index=$((SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN + 1))

cd "${SLURM_SUBMIT_DIR:-.}"
rfslam=${RFSLAM:-$(command -v rfslam || echo target/release/rfslam)}
out="$root/shard-$index-of-$count"
echo "task $SLURM_ARRAY_TASK_ID of array job ${SLURM_ARRAY_JOB_ID:-?} on $(hostname): shard $index/$count of $experiment -> $out"
exec "$rfslam" sweep "$experiment" --shard "$index/$count" --out "$out" --resume \
    --jobs "${SLURM_CPUS_PER_TASK:-1}" --quiet "$@"
