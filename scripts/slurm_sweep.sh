#!/bin/bash
# An atrium sweep as a Slurm job array: one shard of the sweep's trials per array task.
# Submit with the sweep file on a shared filesystem (see docs/cluster.md):
#   jid=$(sbatch --parsable --export=ALL,SWEEP=/shared/me/sweeps/small.toml scripts/slurm_sweep.sh)
#   sbatch --dependency=afterok:$jid --export=ALL,SWEEP=/shared/me/sweeps/small.toml scripts/slurm_merge.sh
#SBATCH --job-name=atrium-sweep
#SBATCH --array=0-7
#SBATCH --cpus-per-task=4
#SBATCH --time=04:00:00
#SBATCH --requeue
#SBATCH --output=atrium-sweep-%A_%a.log
set -euo pipefail

# The sweep file, every file it names and the output folder must be on a filesystem all
# nodes share (home or project space, not a node's /tmp).
SWEEP=${SWEEP:?set SWEEP to the sweep file on the shared filesystem (sbatch --export=ALL,SWEEP=...)}
OUT=${OUT:-$(dirname "$SWEEP")/sweep-$(basename "$SWEEP" .toml)}
# What runs learn from a world is cached here; the default beside the binary is often
# read-only on a cluster. A shared folder lets every task reuse what one built.
export ATRIUM_CACHE_DIR=${ATRIUM_CACHE_DIR:-$HOME/.cache/atrium}
command -v atrium >/dev/null || { echo "atrium is not on PATH (module load, or cargo install --path cli)" >&2; exit 2; }

# Shards split the trials (global trial index % N == I), not the cells: every task runs
# some trials of every cell. --resume lets a requeued or resubmitted task continue
# instead of refusing its own folder; --jobs uses the cores Slurm gave this task.
atrium sweep "$SWEEP" \
    --shard "$SLURM_ARRAY_TASK_ID/$SLURM_ARRAY_TASK_COUNT" \
    --jobs "${SLURM_CPUS_PER_TASK:-1}" \
    --resume \
    --out "$OUT/shard-$SLURM_ARRAY_TASK_ID"
