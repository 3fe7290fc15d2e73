#!/usr/bin/env bash
# Embree 4 and rdr on identical rays, one thread, in alternating bursts (the manual's
# docs/src/performance.md, "BVH build against Embree" and "Rays against Embree").
#
#   scripts/bvh-vs-embree.sh RAYDIR [BURSTS] [[LABEL=]RDR...]
#
# RAYDIR holds <mesh>_{primary,incoherent,bounce}.rays.f32 from
# ../shared/tools/embree_rays.py (run it once per mesh), or, for a recorded scene, <name>.obj
# and <name>.rays.f32 from `rdr bench SCENE --record-rays RAYDIR/<name>.rays.f32` (its
# triangles, several meshes, and the closest-hit rays its render traced). MESHES (default
# "bunny dragon") names them. For each mesh and each
# burst (default 3): Embree (scripts/embree_time.py, process CPU time) and every rdr binary
# given (default target/release/rdr; LABEL names it in the output, default `rdr`), each with
# --isa avx512 and --isa avx2, all on CPU 0 (`taskset -c 0`). Embree is held to the same
# instruction set through its device configuration (`isa=avx2`; embreex creates its device
# without one, so scripts/embree_config_shim.c, compiled here with cc, passes it in by
# LD_PRELOAD), so each rdr kernel set is compared with Embree on the same set: the AVX2 rows
# are what an AVX2-only machine would see. Prints each burst's lines, then the best per
# column and rdr/Embree ratios (Mrays/s ratios, build as Embree's time / rdr's time, so above
# 1 means rdr is faster).
# EMBREE_PY (default /work/venv-embree/bin/python) runs Embree; ISAS (default "avx512 avx2");
# EMBREE_ROBUST=1 runs Embree in its robust mode (watertight triangles and conservative box
# tests, the guarantees rdr's kernels always give) instead of its default. QUALITIES (default
# "default") lists Embree's build qualities to time, e.g. "default high" (high: its
# spatial-split builder, RTC_BUILD_QUALITY_HIGH, which Mitsuba 3 uses; the shim sets it);
# each is labelled embree-QUALITY, and rdr is compared with each. With EMBREE_ROBUST=1 the
# high quality builds the same tree as the default (Embree 4.4 builds its robust triangles,
# triangle4v, with the plain SAH builder; EMBREE_CONFIG=verbose=3 shows the builder and SAH).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
shared=$(realpath -m "${SHARED:-$here/../shared}")
dir=$1
bursts=${2:-3}
shift $(($# >= 2 ? 2 : $#))
rdrs=("$@")
[ ${#rdrs[@]} -eq 0 ] && rdrs=("$here/target/release/rdr")
py=${EMBREE_PY:-/work/venv-embree/bin/python}
isas=${ISAS:-avx512 avx2}
log=$(mktemp)
shim=$(mktemp --suffix=.so)
cc -shared -fPIC -O2 -o "$shim" "$here/scripts/embree_config_shim.c" -ldl
embree_lib=$("$py" -c 'import embreex, glob, os; print(glob.glob(os.path.join(os.path.dirname(embreex.__file__), "..", "embreex.libs", "libembree4*"))[0])')
robust=()
[ "${EMBREE_ROBUST:-0}" = 1 ] && robust=(--robust)
qualities=${QUALITIES:-default}
for mesh in ${MESHES:-bunny dragon}; do
  files=()
  if [ -f "$dir/$mesh.rays.f32" ] && [ -f "$dir/$mesh.obj" ]; then
    obj=$dir/$mesh.obj
    files=("$dir/$mesh.rays.f32")
  else
    obj=$shared/meshes/$mesh.obj
    for s in primary incoherent bounce; do files+=("$dir/${mesh}_$s.rays.f32"); done
  fi
  for b in $(seq "$bursts"); do
    for isa in $isas; do
      for q in $qualities; do
        EMBREE_LIB=$embree_lib EMBREE_CONFIG="isa=$isa" EMBREE_QUALITY=${q/default/} LD_PRELOAD=$shim \
          taskset -c 0 "$py" "$here/scripts/embree_time.py" "$obj" "${files[@]}" --reps 1 "${robust[@]}" |
          sed "s|^|$mesh embree-$q/$isa |" | tee -a "$log"
      done
    done
    for spec in "${rdrs[@]}"; do
      if [[ $spec == *=* ]]; then label=${spec%%=*} r=${spec#*=}; else label=rdr r=$spec; fi
      for isa in $isas; do
        args=(bench "$obj" --threads 1 --repeat 1 --isa "$isa")
        for f in "${files[@]}"; do args+=(--ray-file "$f"); done
        taskset -c 0 "$r" "${args[@]}" |
          awk -v p="$mesh $label/$isa" \
            '/^build/ {print p, "build", $2, "ms"} /rays.f32/ {print p, $1, "closest", $4, "any", $6, "Mrays/s", $0 ~ /ok$/ ? "" : "NOT-OK"}' |
          tee -a "$log"
      done
    done
  done
done
echo "--- best of $bursts bursts (Mrays/s closest / any; build ms); ratio = rdr / Embree"
awk '
  $3 == "build" { k = $1 " " $2 " build"; if (!(k in b) || $4 < b[k]) b[k] = $4; who[$1 " " $2] = 1; next }
  { k = $1 " " $2 " " $3; if ($5 > c[k]) c[k] = $5; if ($7 > a[k]) a[k] = $7; who[$1 " " $2] = 1; set[$1 " " $3] = 1 }
  END {
    nq = split(quals, qs, " ")
    for (w in who) {
      split(w, p, " "); m = p[1]; split(p[2], li, "/")
      if (li[1] ~ /^embree/) continue
      for (qi = 1; qi <= nq; qi++) {
        e = m " embree-" qs[qi] "/" li[2]
        printf "%s build %s ms vs Embree-%s %s ms: %.2fx its speed\n", w, b[w " build"], qs[qi], b[e " build"], b[e " build"] / b[w " build"]
        for (s in set) { split(s, q, " "); if (q[1] != m) continue
          r = w " " q[2]; t = e " " q[2]
          printf "%s vs Embree-%s %-28s %6.2f / %6.2f vs %6.2f / %6.2f  ratio %.2f / %.2f\n",
            w, qs[qi], q[2], c[r], a[r], c[t], a[t], c[r] / c[t], a[r] / a[t] }
      }
    }
  }' quals="$qualities" "$log" | sort
rm -f "$log" "$shim"
