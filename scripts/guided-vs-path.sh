#!/usr/bin/env bash
# Equal-time comparison of `guided` and `path` (the manual's docs/src/integrators.md): for each scene,
# both render side by side, one thread each, for SECS seconds, then `rdr compare` gives the
# relative MSE against the Mitsuba reference (cbox_path -> cbox, veach_path -> veach).
#
#   scripts/guided-vs-path.sh RDR SECS SEED SCENE...    e.g. target/release/rdr 60 3 caustic_cbox env_sphere
#
# Copy RDR out of target/ first if tests may rebuild it meanwhile. Images and logs go to
# ${OUT:-/tmp/guided-vs-path}.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
refs=$(realpath -m "${SHARED:-$here/../shared}")/refs
rdr=$1 secs=$2 seed=$3
shift 3
out=${OUT:-/tmp/guided-vs-path}
mkdir -p "$out"
for sc in "$@"; do
  case $sc in cbox_path) ref=cbox ;; veach_path) ref=veach ;; *) ref=$sc ;; esac
  common=(--spp 1000000 --time-limit "$secs" --threads 1 --seed "$seed")
  "$rdr" render "$refs/scenes/$sc.json" "${common[@]}" -o "$out/$sc.path.$seed.exr" >"$out/$sc.path.$seed.log" 2>&1 &
  "$rdr" render "$refs/scenes/$sc.json" --override '{"integrator":{"type":"guided"}}' "${common[@]}" \
    -o "$out/$sc.guided.$seed.exr" >"$out/$sc.guided.$seed.log" 2>&1 &
  wait
  for i in path guided; do
    m=$("$rdr" compare "$out/$sc.$i.$seed.exr" "$refs/$ref.exr" --variance "$refs/$ref.var.exr" | grep '^relMSE')
    spp=$(grep -oE 'at [0-9]+ spp|final [0-9]+ spp' "$out/$sc.$i.$seed.log" | tr '\n' ' ')
    echo "$sc seed $seed $i: $m | $spp"
  done
done
