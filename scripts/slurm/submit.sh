#!/bin/bash
# Submits a sharded sweep to SLURM: an array of N shard tasks (sweep-array.sh) and a merge
# job (merge.sh) that starts when every task has succeeded (--dependency=afterok).
#
#   scripts/slurm/submit.sh EXPERIMENT OUT_ROOT N [rfslam sweep options]
#
# Results: OUT_ROOT/shard-I-of-N/ per task, OUT_ROOT/merged/{runs,summary}.csv, report.md.
# sbatch options (partition, time limit, account, cores per task) come from sbatch's
# environment variables, e.g. SBATCH_PARTITION=short SBATCH_TIMELIMIT=2:00:00; run it from
# the repository (paths are relative to the directory of submission).
set -euo pipefail

if [ $# -lt 3 ]; then
    echo "usage: $0 EXPERIMENT OUT_ROOT N [rfslam sweep options]" >&2
    exit 2
fi
experiment=$1
root=$2
count=$3
shift 3
here=$(dirname "$0")

array=$(sbatch --parsable --array=1-"$count" "$here/sweep-array.sh" "$experiment" "$root" "$@")
array=${array%%;*}
merge=$(sbatch --parsable --dependency=afterok:"$array" "$here/merge.sh" "$root" "$count")
merge=${merge%%;*}
echo "submitted array job $array ($count shards of $experiment) and merge job $merge -> $root/merged"
