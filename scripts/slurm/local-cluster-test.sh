#!/bin/bash
# Proves the SLURM scripts on a real SLURM: a one-node cluster on localhost.
#
#   sudo scripts/slurm/local-cluster-test.sh            (Debian bookworm; root; needs network)
#
# Installs Debian's slurm-wlm and munge, starts munged (unless one runs), slurmctld and
# slurmd with a minimal slurm.conf for this machine (`slurmd -C`) in a temporary directory
# (its own ports; /etc/slurm is not touched), submits a 3-task array of a small sweep
# through scripts/slurm/sweep-array.sh (as --array=0-2, so the shard numbers come from
# SLURM_ARRAY_TASK_MIN) and scripts/slurm/merge.sh with --dependency=afterok, polls squeue
# until both are done, runs the same sweep unsharded and compares runs.csv and summary.csv
# without their wall-time columns. Stops every daemon it started, whatever happens.
# Not part of CI: `cargo test` never calls it.
#
# Environment: RFSLAM (the binary; default: built with `cargo build --release -p rfslam-cli`),
# EXPERIMENT (default configs/quick.toml), SWEEP_ARGS (default "--runs 4"), KEEP=1 keeps the
# temporary directory.
set -euo pipefail

repo=$(cd "$(dirname "$0")/../.." && pwd)
cd "$repo"
experiment=${EXPERIMENT:-configs/quick.toml}
read -r -a sweep_args <<<"${SWEEP_ARGS:---runs 4}"
shards=3

say() { printf '== %s\n' "$*"; }

if [ "$(id -u)" -ne 0 ]; then
    echo "run as root (installs packages and starts the SLURM daemons)" >&2
    exit 2
fi

say "installing slurm-wlm and munge"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq slurm-wlm munge >/dev/null
dpkg-query -W -f '${Package} ${Version}\n' slurmctld slurmd slurm-client munge

if [ -z "${RFSLAM:-}" ]; then
    say "building rfslam (release)"
    cargo build --release -q -p rfslam-cli
    RFSLAM="${CARGO_TARGET_DIR:-$repo/target}/release/rfslam"
fi
RFSLAM=$(cd "$(dirname "$RFSLAM")" && pwd)/$(basename "$RFSLAM")
export RFSLAM
"$RFSLAM" --version

work=$(mktemp -d /tmp/rfslam-slurm-XXXXXX)
chmod 755 "$work"
started=()
cleanup() {
    local rc=$?
    say "cleaning up"
    if [ -n "${SLURM_CONF:-}" ] && [ -f "$SLURM_CONF" ]; then
        scancel --user=root >/dev/null 2>&1 || true
    fi
    for pid in "${started[@]}"; do
        kill "$pid" 2>/dev/null || true
    done
    for pid in "${started[@]}"; do
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -0 "$pid" 2>/dev/null && kill -9 "$pid" 2>/dev/null || true
    done
    if [ "${KEEP:-0}" = 1 ] || [ $rc -ne 0 ]; then
        echo "files kept in $work"
    else
        rm -rf "$work"
    fi
    say "exit $rc"
}
trap cleanup EXIT

say "munge"
if [ ! -s /etc/munge/munge.key ]; then
    mungekey --create --keyfile=/etc/munge/munge.key
    chown munge:munge /etc/munge/munge.key
    chmod 400 /etc/munge/munge.key
fi
install -d -o munge -g munge -m 755 /run/munge
if munge -n >/dev/null 2>&1; then
    echo "munged is already running: using it"
else
    runuser -u munge -- /usr/sbin/munged --pid-file=/run/munge/munged.pid
    for _ in $(seq 50); do [ -s /run/munge/munged.pid ] && break; sleep 0.1; done
    started+=("$(cat /run/munge/munged.pid)")
    munge -n | unmunge >/dev/null && echo "munged started (pid ${started[-1]})"
fi

say "slurm.conf for one node on localhost"
host=$(hostname -s)
node=$(slurmd -C | head -n 1 | sed -e "s/^NodeName=[^ ]*/NodeName=$host NodeAddr=127.0.0.1/")
mkdir -p "$work/state" "$work/spool" "$work/out"
cat >"$work/slurm.conf" <<CONF
ClusterName=rfslam-local
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
AuthType=auth/munge
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MinJobAge=600
$node State=UNKNOWN
PartitionName=local Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
echo "$node"

say "starting slurmctld and slurmd"
slurmctld -D -i >"$work/slurmctld.stdout" 2>&1 &
started+=($!)
slurmd -D -N "$host" >"$work/slurmd.stdout" 2>&1 &
started+=($!)
for _ in $(seq 60); do
    state=$(sinfo -h -o %T 2>/dev/null || true)
    [ "$state" = idle ] && break
    sleep 1
done
sinfo
if [ "$state" != idle ]; then
    echo "the node did not come up; logs:" >&2
    tail -n 20 "$work/slurmctld.log" "$work/slurmd.log" >&2 || true
    exit 1
fi

say "submitting a $shards-task array of $experiment ${sweep_args[*]} and its merge"
root="$work/out/sharded"
cd "$work"
array=$(sbatch --parsable --array=0-$((shards - 1)) --output="$work/sweep-%A_%a.out" \
    "$repo/scripts/slurm/sweep-array.sh" "$repo/$experiment" "$root" "${sweep_args[@]}")
merge=$(sbatch --parsable --dependency=afterok:"$array" --output="$work/merge-%j.out" \
    "$repo/scripts/slurm/merge.sh" "$root" "$shards")
echo "array job $array, merge job $merge"
for _ in $(seq 600); do
    left=$(squeue -h -j "$array,$merge" 2>/dev/null | wc -l)
    [ "$left" -eq 0 ] && break
    squeue -h -o "%i %j %T" | tr '\n' ';'
    echo
    sleep 2
done
failed=0
for j in "${array}_0" "${array}_1" "${array}_2" "$merge"; do
    line=$(scontrol -o show job "$j" | grep -o 'JobState=[A-Z_]* .*ExitCode=[0-9:]*' | sed 's/ Reason=.*ExitCode=/ ExitCode=/')
    echo "job $j: $line"
    case "$line" in JobState=COMPLETED*) ;; *) failed=1 ;; esac
done
for f in "$work"/sweep-*.out "$work"/merge-*.out; do
    echo "--- $(basename "$f")"
    cat "$f"
done
[ $failed -eq 0 ] || { echo "a SLURM job failed" >&2; exit 1; }

say "the same sweep unsharded"
"$RFSLAM" sweep "$repo/$experiment" "${sweep_args[@]}" --out "$work/out/unsharded" --jobs 1 --quiet

say "comparing merged and unsharded outputs (all columns but wall time)"
# Prints a CSV without the named columns (the outputs quote no field).
drop() {
    awk -F, -v drop="$2" 'BEGIN { n = split(drop, d, " ") }
        NR == 1 { for (i = 1; i <= NF; i++) for (j = 1; j <= n; j++) if ($i == d[j]) skip[i] = 1 }
        { s = ""; for (i = 1; i <= NF; i++) if (!(i in skip)) s = s (s == "" ? "" : ",") $i; print s }' "$1"
}
same=1
for t in "runs.csv:time_ms_per_step" "summary.csv:time_ms time_std_ms"; do
    file=${t%%:*}
    cols=${t#*:}
    if diff <(drop "$root/merged/$file" "$cols") <(drop "$work/out/unsharded/$file" "$cols") >"$work/diff.txt"; then
        echo "$file: identical but for ($cols): $(($(wc -l <"$root/merged/$file") - 1)) rows"
    else
        echo "$file DIFFERS:" && head -n 20 "$work/diff.txt"
        same=0
    fi
done
echo "--- merged summary.csv"
cat "$root/merged/summary.csv"
[ $same -eq 1 ] || exit 1
say "PASS: $shards SLURM shards merged equal the unsharded sweep"
