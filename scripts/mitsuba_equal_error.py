#!/usr/bin/env python3
"""Equal-time error of rdr and Mitsuba 3 (LLVM) on the reference scenes: the comparison that goes
with the samples/s one of scripts/mitsuba-vs-rdr.sh. An oracle run by hand, never by tests or CI;
setup as in scripts/mitsuba_time.py.

Usage: /work/venv-mi/bin/python scripts/mitsuba_equal_error.py [--seeds 4] [--rdr target/release/rdr]
       [--isa avx2] [--scenes SCENE:REF:SPP[:RES] ...]

The two renderers sample differently (rdr: Owen-scrambled Sobol, whose error falls faster than
1/spp; the reference XMLs: Mitsuba's `independent` sampler, error ~ 1/spp), so samples/s alone does
not say which one gets an image of a given error sooner. Per scene:
* rdr renders SPP samples per pixel (refs/scenes/SCENE.json, 2 threads) for each of --seeds seeds;
  its time is `rdr bench`'s `render cpu` (all threads; --isa passed on), best of the seeds' runs;
* Mitsuba (refs/mitsuba/SCENE.xml, RES passed as `res`) is timed at SPP (warm-up render first, as
  mitsuba_time.py, process CPU time around `mi.render`), and then renders, for each seed, the
  spp it fits into rdr's CPU time: M = round(SPP x rdr's time / its own);
* error: relMSE against refs/REF.exr, mean over pixels and channels of (x - ref)^2 / (ref^2 + 0.01),
  less the reference's own share mean(var / (ref^2 + 0.01)) from REF.var.exr, averaged over the
  seeds (Mitsuba's cbox_point image is scaled by 1/4pi first, as the reference was: its XML gives
  the point light's intensity, rdr's JSON its flux).
The ratio Mitsuba's error / rdr's at equal CPU time above 1 means rdr's image is the closer one.
With --isa avx2, Mitsuba's JIT targets a Haswell CPU, 8 lanes (mitsuba_time.py --llvm-target).
Prints one line per scene, for scripts:
    SCENE: rdr N spp cpu C s relMSE E | mitsuba N spp cpu C s, M spp cpu C s relMSE E | samples/s ratio R, equal-time error ratio Q
"""
import argparse, os, re, subprocess, sys, tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

# scene (refs/scenes/SCENE.json, refs/mitsuba/SCENE.xml) : reference : spp [: resolution for the XML]
DEFAULT = ["cbox_point:cbox_point_hq:32:512", "cbox_path:cbox:64:256", "env_sphere:env_sphere:64", "caustic_cbox:caustic_cbox:64:256"]
# Mitsuba's image times this is what the reference and the JSON scene mean (refs README)
MI_SCALE = {"cbox_point": 1 / (4 * np.pi)}


def rel_mse(img, ref, var):
    d = ref * ref + 0.01
    return float(np.mean((img - ref) ** 2 / d) - np.mean(var / d))


def read_exr(mi, path):
    return np.array(mi.Bitmap(path), dtype=np.float64)[..., :3]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", type=int, default=4)
    ap.add_argument("--rdr", default=os.path.join(HERE, "..", "target", "release", "rdr"))
    ap.add_argument("--isa", choices=["avx2", "avx512"])
    ap.add_argument("--shared", default=os.path.join(HERE, "..", "..", "shared"))
    ap.add_argument("--scenes", nargs="+", default=DEFAULT)
    a = ap.parse_args()
    import mitsuba as mi
    import drjit as dr

    from mitsuba_time import set_llvm_target, timed_render

    mi.set_variant("llvm_ad_rgb")
    if a.isa == "avx2":
        set_llvm_target(dr, "haswell:8")
    refs = os.path.join(a.shared, "refs")
    isa = ["--isa", a.isa] if a.isa else []
    tmp = tempfile.mkdtemp()
    for spec in a.scenes:
        name, ref_name, spp, *res = spec.split(":")
        spp = int(spp)
        ref = read_exr(mi, os.path.join(refs, f"{ref_name}.exr"))
        var = read_exr(mi, os.path.join(refs, f"{ref_name}.var.exr"))
        params = {"spp": spp}
        if res:
            params["res"] = int(res[0])
        scene = mi.load_file(os.path.join(refs, "mitsuba", f"{name}.xml"), **params)
        json_scene = os.path.join(refs, "scenes", f"{name}.json")
        rdr_err, rdr_cpu, out = [], float("inf"), os.path.join(tmp, f"{name}.exr")
        for seed in range(a.seeds):
            cmd = [a.rdr, "render", json_scene, "--spp", str(spp), "--seed", str(seed + 1), "--threads", "2", "-q", "-o", out]
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            img = read_exr(mi, out)
            if img.shape != ref.shape:
                sys.exit(f"{name}: rdr's image is {img.shape}, the reference {ref.shape}")
            rdr_err.append(rel_mse(img, ref, var))
            bench = subprocess.run([a.rdr, "bench", json_scene, "--spp", str(spp), "--threads", "2", *isa], check=True, capture_output=True, text=True).stdout
            rdr_cpu = min(rdr_cpu, float(re.search(r"^render cpu\s+([0-9.]+)", bench, re.M).group(1)))

        def mitsuba(n, seed):
            """Process CPU seconds of an n-spp render and its image."""
            _, cpu, img = timed_render(mi, dr, scene, n, seed)
            return cpu, np.array(img, dtype=np.float64)[..., :3] * MI_SCALE.get(name, 1.0)

        mitsuba(spp, 0)  # JIT warm-up
        mi_cpu = min(mitsuba(spp, 0)[0] for _ in range(2))
        m = max(1, round(spp * rdr_cpu / mi_cpu))
        mitsuba(m, 0)
        mi_err, mi_cpu_m = [], float("inf")
        for seed in range(a.seeds):
            t, img = mitsuba(m, seed + 1)
            mi_cpu_m = min(mi_cpu_m, t)
            mi_err.append(rel_mse(img, ref, var))
        e_mi, e_rdr = float(np.mean(mi_err)), float(np.mean(rdr_err))
        print(
            f"{name}: rdr {spp} spp cpu {rdr_cpu:.3f} s relMSE {e_rdr:.3e} | mitsuba {spp} spp cpu {mi_cpu:.3f} s,"
            f" {m} spp cpu {mi_cpu_m:.3f} s relMSE {e_mi:.3e} | samples/s ratio {mi_cpu / rdr_cpu:.2f}, equal-time error ratio {e_mi / e_rdr:.2f}",
            flush=True,
        )


if __name__ == "__main__":
    sys.exit(main())
