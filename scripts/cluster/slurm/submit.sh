#!/usr/bin/env bash
# Renders a frame (or an animation) on a Slurm cluster: an array of N shards per frame
# (render.sbatch, requeued with --resume when pre-empted) and a merge job that runs
# when all of them have finished (merge.sbatch). Prints the two job ids.
#
#   scripts/cluster/slurm/submit.sh SCENE OUTDIR N [FIRST_FRAME LAST_FRAME] [-- rdr render options]
#
# Examples:
#   submit.sh scenes/showcase.json out 8 -- --spp 1024
#   submit.sh 'anim/frame_{frame}.json' out 4 0 99 -- --spp 256
#   RDR_FRAME_OVERRIDES=cameras.jsonl submit.sh scene.json out 4 0 99   (line f: frame f's --override)
# Extra sbatch options (partition, time limit) go in SBATCH_* variables or
# RDR_SBATCH_ARGS, e.g. RDR_SBATCH_ARGS="--time=04:00:00 --partition=long".
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
scene=$1 outdir=$2 shards=$3
shift 3
first=0 last=0
if [ $# -ge 2 ] && [ "$1" != "--" ]; then first=$1 last=$2; shift 2; fi
[ "${1:-}" = "--" ] && shift
frames=$(( last - first + 1 ))
mkdir -p "$outdir"
outdir=$(cd "$outdir" && pwd)
# shellcheck disable=SC2086
array=$(sbatch --parsable ${RDR_SBATCH_ARGS:-} --array=0-$(( shards * frames - 1 )) \
  --output="$outdir/render_%a.log" \
  --export=ALL,RDR_SHARDS="$shards",RDR_FIRST_FRAME="$first" \
  "$here/render.sbatch" "$scene" "$outdir" "$@")
array=${array%%;*}
# shellcheck disable=SC2086
merge=$(sbatch --parsable ${RDR_SBATCH_ARGS:-} --dependency=afterok:"$array" --output="$outdir/merge.log" \
  "$here/merge.sbatch" "$outdir")
echo "$array ${merge%%;*}"
