#!/usr/bin/env bash
# Submit a chassis-mc study to SLURM as N array tasks plus a dependent summary job.
#
#   deploy/slurm/submit.sh STUDY.toml OUT_DIR N [chassis-mc run flags, e.g. --realisations 100000]
#
# Prints the two job ids ("ARRAY_ID SUMMARY_ID"). The summary job runs only if every shard
# succeeded (afterok); resubmit failed shards with
#   sbatch --array=K run_shard.sbatch STUDY OUT_DIR ...   (they resume where they stopped)
# and then submit summarize.sbatch again.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
if [ $# -lt 3 ]; then
    sed -n '2,10p' "$0" >&2
    exit 2
fi
study=$1
out=$2
shards=$3
shift 3
mkdir -p "$out"
array=$(sbatch --parsable --array="0-$((shards - 1))" --chdir="$out" \
    "$here/run_shard.sbatch" "$(realpath "$study")" "$(realpath "$out")" "$@")
array=${array%%;*}
summary=$(sbatch --parsable --dependency="afterok:$array" --chdir="$out" \
    "$here/summarize.sbatch" "$(realpath "$out")")
echo "$array ${summary%%;*}"
