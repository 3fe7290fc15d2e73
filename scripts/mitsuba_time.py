#!/usr/bin/env python3
"""Mitsuba 3 timed on a reference scene, for side-by-side runs with `rdr bench` (the manual's
docs/src/performance.md, "Rendering against Mitsuba 3"). An oracle run by hand, never by tests or CI.

Setup (once): python3 -m venv /work/venv-mi && /work/venv-mi/bin/pip install mitsuba numpy;
apt-get install libllvm19; export DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1

Usage: /work/venv-mi/bin/python scripts/mitsuba_time.py ../shared/refs/mitsuba/X.xml SPP [--res R]
       [--reps 2] [--variant llvm_ad_rgb] [--llvm-target CPU:WIDTH]
--llvm-target (e.g. haswell:8) makes Dr.Jit's LLVM backend compile for that CPU and vector width
(its C++ `jit_llvm_set_target`, through ctypes) instead of the host's: an AVX2-only machine on an
AVX-512 one, as far as the JIT's code goes (libraries Mitsuba calls pick their own kernels).
Loads the file (spp and, when given, res as parameters), renders once to warm the JIT up, then
`--reps` timed renders (`mi.render` plus evaluation of the image); with --once, one render and
nothing printed (scripts/real_vs_mitsuba.py times the whole process). Prints, for scripts:
    mitsuba wall W s cpu C s samples S
with the best wall clock and the best process CPU time (`time.process_time`, all threads).
"""
import argparse, time


def set_llvm_target(dr, spec):
    """Dr.Jit's `jit_llvm_set_target(cpu, nullptr, width)` (C++ symbol of libdrjit-core)."""
    import ctypes, os, sys

    cpu, width = spec.split(":")
    dr.eval(dr.llvm.Float(1.0) + 1)  # the LLVM backend is up
    lib = ctypes.CDLL(os.path.join(os.path.dirname(dr.__file__), "libdrjit-core.so"))
    set_target = lib["_Z19jit_llvm_set_targetPKcS0_j"]
    set_target.argtypes = [ctypes.c_char_p, ctypes.c_char_p, ctypes.c_uint32]
    set_target(cpu.encode(), None, int(width))
    target_cpu, vector_width = lib["_Z19jit_llvm_target_cpuv"], lib["_Z21jit_llvm_vector_widthv"]
    target_cpu.restype, vector_width.restype = ctypes.c_char_p, ctypes.c_uint32
    print(f"llvm target {target_cpu().decode()} width {vector_width()}", file=sys.stderr)


def timed_render(mi, dr, scene, spp, seed=0):
    """Wall and process CPU seconds (all threads) of `mi.render` with its image evaluated,
    and the image."""
    w0, c0 = time.perf_counter(), time.process_time()
    img = mi.render(scene, spp=spp, seed=seed)
    dr.eval(img)
    dr.sync_thread()
    return time.perf_counter() - w0, time.process_time() - c0, img


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("xml")
    ap.add_argument("spp", type=int)
    ap.add_argument("--res", type=int)
    ap.add_argument("--reps", type=int, default=2)
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--llvm-target")
    ap.add_argument("--once", action="store_true", help="load and render once, untimed (a whole process to time from outside)")
    a = ap.parse_args()
    import mitsuba as mi
    import drjit as dr

    mi.set_variant(a.variant)
    if a.llvm_target:
        set_llvm_target(dr, a.llvm_target)
    # spp as a parameter for files that declare one (a real scene's bench.xml may not: Mitsuba
    # refuses unused parameters); mi.render is given it either way
    params = {"spp": a.spp} if "$spp" in open(a.xml).read() else {}
    if a.res:
        params["res"] = a.res
    scene = mi.load_file(a.xml, **params)
    if a.once:
        timed_render(mi, dr, scene, a.spp)
        return
    timed_render(mi, dr, scene, a.spp)  # JIT warm-up
    best_wall = best_cpu = float("inf")
    for _ in range(a.reps):
        wall, cpu, _ = timed_render(mi, dr, scene, a.spp)
        best_wall, best_cpu = min(best_wall, wall), min(best_cpu, cpu)
    size = scene.sensors()[0].film().crop_size()
    print(f"mitsuba wall {best_wall:.3f} s cpu {best_cpu:.3f} s samples {int(size[0]) * int(size[1]) * a.spp}")


if __name__ == "__main__":
    main()
