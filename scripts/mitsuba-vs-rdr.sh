#!/usr/bin/env bash
# Mitsuba 3 (LLVM) and rdr on the same reference scenes, side by side (the manual's
# docs/src/performance.md, "Rendering against Mitsuba 3"): per scene and round, scripts/mitsuba_time.py, then `rdr bench`
# (2 threads) under /usr/bin/time; best of ROUNDS (default 2) for each; ratio = rdr's samples
# per CPU second over Mitsuba's (above 1: rdr faster). Mitsuba's CPU time is its process's
# around `mi.render` (scene loaded, JIT warm); rdr's is given both ways: the render alone
# (`rdr bench`'s `render cpu`, all threads; the like-for-like figure) and the whole process
# (start, scene and texture loading, BVH build included).
#
#   scripts/mitsuba-vs-rdr.sh [ROUNDS] [RDR]
#
# ISA=avx2 runs rdr with `--isa avx2` and Mitsuba's JIT for a Haswell CPU, 8 lanes
# (`mitsuba_time.py --llvm-target haswell:8`): an AVX2-only machine on an AVX-512 one.
#
# MI_PY (default /work/venv-mi/bin/python) runs Mitsuba; setup in scripts/mitsuba_time.py.
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
shared=$(realpath -m "${SHARED:-$here/../shared}")
rounds=${1:-2}
rdr=${2:-$here/target/release/rdr}
py=${MI_PY:-/work/venv-mi/bin/python}
isa_rdr=() isa_mi=()
if [ "${ISA:-}" = avx2 ]; then
  isa_rdr=(--isa avx2) isa_mi=(--llvm-target haswell:8)
fi
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
"$rdr" bench "$shared/refs/scenes/cbox_point.json" --spp 1 --threads 1 "${isa_rdr[@]}" | grep '^cpu'
# the smaller of two figures ("inf": none yet)
min() { echo "$1 $2" | awk '{print ($1 < $2 || $2 == "inf") ? $1 : $2}'; }
# scene spp res(for Mitsuba's file; empty: the file's own)
while read -r scene spp res; do
  best_mw=inf best_mc=inf best_rw=inf best_rc=inf best_rr=inf
  for _ in $(seq "$rounds"); do
    read -r mw mc < <("$py" "$here/scripts/mitsuba_time.py" "$shared/refs/mitsuba/$scene.xml" "$spp" ${res:+--res "$res"} "${isa_mi[@]}" |
      awk '{print $3, $6}')
    t=$( { /usr/bin/time -f 'cpu %U %S' "$rdr" bench "$shared/refs/scenes/$scene.json" --spp "$spp" --threads 2 "${isa_rdr[@]}" >/tmp/mvr.out; } 2>&1 | awk '/^cpu/ {print $2 + $3}')
    rw=$(grep -oE 'in [0-9.]+ s' /tmp/mvr.out | head -1 | awk '{print $2}')
    rr=$(awk '/^render cpu/ {print $3}' /tmp/mvr.out)
    [ -n "$rr" ] || rr=$t # an rdr from before the `render cpu` line: the process's
    best_mw=$(min "$mw" "$best_mw") best_mc=$(min "$mc" "$best_mc")
    best_rw=$(min "$rw" "$best_rw") best_rc=$(min "$t" "$best_rc") best_rr=$(min "$rr" "$best_rr")
  done
  ratio=$(echo "$best_mc $best_rc" | awk '{printf "%.2f", $1 / $2}')
  ratio_r=$(echo "$best_mc $best_rr" | awk '{printf "%.2f", $1 / $2}')
  echo "$scene spp $spp: mitsuba wall $best_mw s cpu $best_mc s | rdr wall $best_rw s render cpu $best_rr s process cpu $best_rc s | rdr/mitsuba per CPU s: render ${ratio_r}x, process ${ratio}x"
done <<'LIST'
cbox_point 32 512
cbox_path 64 256
env_sphere 64
caustic_cbox 64 256
LIST
