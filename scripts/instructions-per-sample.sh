#!/usr/bin/env bash
# Instructions per sample of rdr and of Mitsuba 3 (LLVM variant), counted by callgrind: each
# renderer runs the scene at two sample counts and the difference of the process totals is
# divided by the extra samples, so loading, the BVH build and (for Mitsuba) JIT compilation
# cancel out. One thread each; rdr with the given kernel set, Mitsuba's JIT for the matching CPU
# (haswell:8 for avx2). Valgrind has no AVX-512: use avx2. An oracle run by hand, not a test.
#
#   scripts/instructions-per-sample.sh SCENE SPP_LOW SPP_HIGH [RDR]
#   e.g. scripts/instructions-per-sample.sh env_sphere 4 12
#
# SCENE names ../shared/refs/scenes/SCENE.json and ../shared/refs/mitsuba/SCENE.xml (same film).
# Needs valgrind, and the Mitsuba venv of scripts/mitsuba_time.py (MI_PYTHON, default
# /work/venv-mi/bin/python; DRJIT_LIBLLVM_PATH as there).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
shared=$(realpath -m "${SHARED:-$here/../shared}")
scene=$1 lo=$2 hi=$3 rdr=${4:-$here/target/release/rdr}
py=${MI_PYTHON:-/work/venv-mi/bin/python}
export DRJIT_LIBLLVM_PATH=${DRJIT_LIBLLVM_PATH:-/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
total() { callgrind_annotate --auto=no "$1" 2>/dev/null | awk '/PROGRAM TOTALS/ {gsub(",", "", $1); print $1}'; }
res=$("$rdr" bench "$shared/refs/scenes/$scene.json" --spp 1 --threads 1 | awk '/^render +[0-9]/ {print $2}')
pixels=$(echo "$res" | awk -Fx '{print $1 * $2}')
for s in "$lo" "$hi"; do
  valgrind --tool=callgrind --callgrind-out-file="$tmp/rdr$s" "$rdr" bench "$shared/refs/scenes/$scene.json" \
    --spp "$s" --threads 1 --isa avx2 >/dev/null 2>&1
  # warm Dr.Jit's kernel cache first, so the counted run loads kernels rather than compiling them
  "$py" "$here/scripts/mitsuba_render_once.py" "$scene" "$s" --shared "$shared" >/dev/null 2>&1
  valgrind --tool=callgrind --callgrind-out-file="$tmp/mi$s" "$py" "$here/scripts/mitsuba_render_once.py" \
    "$scene" "$s" --shared "$shared" >/dev/null 2>&1
done
samples=$(( pixels * (hi - lo) ))
r=$(( ($(total "$tmp/rdr$hi") - $(total "$tmp/rdr$lo")) / samples ))
m=$(( ($(total "$tmp/mi$hi") - $(total "$tmp/mi$lo")) / samples ))
echo "$scene: $res, $lo -> $hi spp: rdr (avx2) $r, Mitsuba (haswell:8) $m instructions per sample"
