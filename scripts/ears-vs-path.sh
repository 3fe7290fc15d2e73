#!/usr/bin/env bash
# `path` with learned roulette and splitting (`rr: "ears"`) against plain `path` (issue 39
# item 5; a benchmark, never a test). For each scene and seed both render side by side in
# one run, one thread each, for SECS seconds (`--time-limit`), then `rdr compare` gives each
# image's relative MSE against the reference (cbox_path -> cbox, veach_path -> veach, other
# names -> refs/NAME; a path to an XML/JSON scene -> REF, or its directory's reference.exr).
#
#   scripts/ears-vs-path.sh RDR SECS "SEEDS" SCENE...
#   e.g. scripts/ears-vs-path.sh /tmp/rdr 60 "1 2" caustic_cbox cbox_path
#
# Environment: SPP=N equal spp instead of equal time (figure of merit relMSE x CPU s, from
# /usr/bin/time); REF=PATH (no .exr) the reference of scene files (PATH.var.exr is used when
# it exists); OUT=DIR images and logs (default /tmp/ears-vs-path). Prints a line per image
# and per scene and seed the ratio ears/path. The machine's load is printed before each pair
# (uptime): name it, and the CPU (lscpu), with every figure.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
refs=$(realpath -m "${SHARED:-$here/../shared}")/refs
rdr=$1 secs=$2 seeds=$3
shift 3
out=${OUT:-/tmp/ears-vs-path}
mkdir -p "$out"
lscpu | grep -E '^Model name' || true

for sc in "$@"; do
  case $sc in
    *.xml | *.json) scene=$sc ref=${REF:-$(dirname "$sc")/reference} ;;
    cbox_path) scene=$refs/scenes/$sc.json ref=$refs/cbox ;;
    veach_path) scene=$refs/scenes/$sc.json ref=$refs/veach ;;
    *) scene=$refs/scenes/$sc.json ref=$refs/$sc ;;
  esac
  name=$(basename "${sc%.*}")
  variance=()
  [[ -f $ref.var.exr ]] && variance=(--variance "$ref.var.exr")
  for seed in $seeds; do
    if [[ -n ${SPP:-} ]]; then
      common=(--spp "$SPP" --threads 1 --seed "$seed")
    else
      common=(--spp 1000000 --time-limit "$secs" --threads 1 --seed "$seed")
    fi
    echo "load before $name seed $seed: $(uptime | sed 's/.*load average/load average/')"
    declare -A merit=()
    for tag in path ears; do
      file=$scene select=(--override "{\"integrator\":{\"rr\":\"$tag\"}}")
      [[ $tag == path ]] && select=()
      if [[ $tag == ears && $scene == *.xml ]]; then
        # XML takes no --override: a copy with the property, beside links to the scene's files
        mkdir -p "$out/xml-$name"
        ln -sf "$(realpath "$(dirname "$scene")")"/* "$out/xml-$name/"
        file=$out/xml-$name/ears.xml
        sed 's|<integrator type="path">|&<string name="rr" value="ears"/>|' "$scene" >"$file"
        grep -q 'name="rr"' "$file" || { echo "no <integrator type=\"path\"> in $scene" >&2; exit 1; }
        select=()
      fi
      /usr/bin/time -f 'cpu %U %S' -o "$out/$name.$tag.$seed.time" \
        "$rdr" render "$file" "${common[@]}" "${select[@]}" \
        -o "$out/$name.$tag.$seed.exr" >"$out/$name.$tag.$seed.log" 2>&1 &
    done
    wait
    for tag in path ears; do
      m=$("$rdr" compare "$out/$name.$tag.$seed.exr" "$ref.exr" "${variance[@]}" | grep '^relMSE' | head -1)
      rel=$(grep -oE '[0-9.]+e[-+]?[0-9]+|[0-9]+\.[0-9]+' <<<"$m" | head -1)
      cpu=$(awk '/^cpu/ {print $2 + $3}' "$out/$name.$tag.$seed.time")
      spp=$(grep -oE 'at [0-9]+ spp' "$out/$name.$tag.$seed.log" | head -1)
      merit[$tag]=$rel
      [[ -n ${SPP:-} ]] && merit[$tag]=$(awk -v r="$rel" -v c="$cpu" 'BEGIN {print r * c}')
      echo "$name seed $seed $tag: $m | $spp | cpu $cpu s"
    done
    awk -v n="$name" -v s="$seed" -v e="${merit[ears]}" -v p="${merit[path]}" -v spp="${SPP:-}" \
      'BEGIN {printf "%s seed %s: ears/path %s %.3f\n", n, s, (spp == "" ? "relMSE" : "relMSE x CPU s"), e / p}'
    unset merit
  done
done
