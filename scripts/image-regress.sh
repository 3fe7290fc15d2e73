#!/usr/bin/env bash
# Before/after image comparison for refactors that must change no image.
#
#   scripts/image-regress.sh record DIR [RDR]   render every scene into DIR with binary RDR
#   scripts/image-regress.sh compare OLD NEW     compare two recorded folders
#   scripts/image-regress.sh check REV           record REV (built in a temporary worktree)
#                                               and the working tree, then compare
#
# Scenes: ../shared/refs/scenes/*.json, scenes/*.json and ../shared/scenes/rdr171/data/*.json,
# each in the default profile and, where the scene's integrator allows it, `--compat rdr171`;
# small spp (SPP, default 2), 2 threads, seed 0. A scene that fails to load must fail the same
# way on both sides (its error message is recorded). Default-profile EXRs must decode to the
# same pixel values (float32 bits); `--compat rdr171` EXRs must be byte-identical files.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
shared=$(realpath -m "${SHARED:-$here/../shared}")
spp=${SPP:-2}

scenes() {
  local d
  for d in "$shared/refs/scenes" "$here/scenes" "$shared/scenes/rdr171/data"; do
    [ -d "$d" ] && ls "$d"/*.json
  done
}

record() {
  local out=$1 rdr=${2:-$here/target/release/rdr}
  mkdir -p "$out"
  local s name
  while read -r s; do
    name=$(basename "$(dirname "$s")")_$(basename "$s" .json)
    for prof in physical rdr171; do
      local args=(render "$s" --spp "$spp" --threads 2 --seed 0 -q -o "$out/$name.$prof.exr")
      [ "$prof" = rdr171 ] && args+=(--compat rdr171)
      if ! "$rdr" "${args[@]}" >/dev/null 2>"$out/$name.$prof.err"; then
        rm -f "$out/$name.$prof.exr"
      fi
      # error texts name the scene's path, which is the same on both sides
    done
  done < <(scenes)
  # variants that exercise filters, profiles and light sampling on two scenes
  local i=0 v
  for s in "$here/scenes/cornell.json" "$shared/refs/scenes/cbox_path.json" "$shared/refs/scenes/env_sphere.json"; do
    [ -f "$s" ] || continue
    for v in '{"film":{"filter":{"type":"gaussian","radius":1.5}}}' \
             '{"film":{"filter":{"type":"mitchell","radius":2}}}' \
             '{"integrator":{"type":"path","profile":"NEE"}}' \
             '{"integrator":{"type":"path","profile":"RW","max_depth":6}}' \
             '{"integrator":{"type":"intersection_test","light_samples":2,"light_sampling":"uniform"}}'; do
      i=$((i + 1))
      name=variant${i}_$(basename "$s" .json)
      if ! "$rdr" render "$s" --spp "$spp" --threads 2 --seed 7 -q --override "$v" -o "$out/$name.physical.exr" \
        >/dev/null 2>"$out/$name.physical.err"; then
        rm -f "$out/$name.physical.exr"
      fi
    done
  done
  # every deterministic integrator on scenes with glass, smooth normals, a sky and a point light
  # (`guided` is left out: its training schedule follows the wall clock)
  for s in "$here/scenes/showcase.json" "$shared/refs/scenes/cbox_path.json" "$shared/refs/scenes/glass_sphere.json" \
           "$shared/refs/scenes/caustic_cbox.json" "$shared/refs/scenes/env_sphere.json" "$shared/refs/scenes/cbox_point.json"; do
    [ -f "$s" ] || continue
    for integ in bdpt ptracer photon sppm intersection_test; do
      name=integrator_${integ}_$(basename "$s" .json)
      if ! "$rdr" render "$s" --spp "$spp" --threads 2 --seed 3 -q --override "{\"integrator\":{\"type\":\"$integ\"}}" \
        -o "$out/$name.physical.exr" >/dev/null 2>"$out/$name.physical.err"; then
        rm -f "$out/$name.physical.exr"
      fi
    done
  done
  echo "recorded $(ls "$out"/*.exr | wc -l) images in $out"
}

compare() {
  local old=$1 new=$2 fail=0 n=0 f base
  (cd "$here" && cargo build --release --quiet --example exr_equal)
  for f in "$old"/*.err; do
    base=$(basename "$f" .err)
    n=$((n + 1))
    if ! cmp -s "$f" "$new/$base.err"; then
      echo "DIFFERENT ERRORS: $base"; diff "$f" "$new/$base.err" || true; fail=1; continue
    fi
    if [ -f "$old/$base.exr" ] || [ -f "$new/$base.exr" ]; then
      if [ ! -f "$old/$base.exr" ] || [ ! -f "$new/$base.exr" ]; then
        echo "ONLY ONE SIDE RENDERED: $base"; fail=1; continue
      fi
      case $base in
        *.rdr171) cmp -s "$old/$base.exr" "$new/$base.exr" || { echo "BYTES DIFFER: $base.exr"; fail=1; } ;;
        *) "$here/target/release/examples/exr_equal" "$old/$base.exr" "$new/$base.exr" || { echo "PIXELS DIFFER: $base.exr"; fail=1; } ;;
      esac
    fi
  done
  if [ $fail = 0 ]; then
    echo "identical: $n scene/profile runs ($(ls "$old"/*.exr | wc -l) images) give the same pixels"
  else
    echo "FAILED: images differ"
  fi
  return $fail
}

case ${1:-} in
  record) record "$2" "${3:-}" ;;
  compare) compare "$2" "$3" ;;
  check)
    rev=$2
    tmp=$(mktemp -d)
    trap 'git -C "$here" worktree remove --force "$tmp/src" >/dev/null 2>&1 || true; rm -rf "$tmp"' EXIT
    git -C "$here" worktree add --detach "$tmp/src" "$rev" >/dev/null
    (cd "$tmp/src" && cargo build --release --quiet --bin rdr)
    (cd "$here" && cargo build --release --quiet --bin rdr)
    record "$tmp/old" "$tmp/src/target/release/rdr"
    record "$tmp/new" "$here/target/release/rdr"
    compare "$tmp/old" "$tmp/new"
    ;;
  *) sed -n '2,13p' "$0"; exit 2 ;;
esac
