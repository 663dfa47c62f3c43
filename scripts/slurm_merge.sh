#!/bin/bash
# Joins the shards that scripts/slurm_sweep.sh wrote into $OUT/merged (see docs/cluster.md).
# Run it after the array has finished: sbatch --dependency=afterok:<array job id> ...
#SBATCH --job-name=atrium-merge
#SBATCH --cpus-per-task=1
#SBATCH --time=00:30:00
#SBATCH --output=atrium-merge-%j.log
set -euo pipefail

SWEEP=${SWEEP:?set SWEEP to the sweep file on the shared filesystem (sbatch --export=ALL,SWEEP=...)}
OUT=${OUT:-$(dirname "$SWEEP")/sweep-$(basename "$SWEEP" .toml)}
command -v atrium >/dev/null || { echo "atrium is not on PATH (module load, or cargo install --path cli)" >&2; exit 2; }

atrium sweep merge "$OUT/merged" "$OUT"/shard-*
