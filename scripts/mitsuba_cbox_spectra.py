#!/usr/bin/env python3
"""Oracle check by hand (never in tests/CI): Mitsuba's own cbox with spectral reflectances,
../shared/scenes/real/mitsuba-cbox/scene.xml, rendered by Mitsuba 3 (scalar_rgb) twice with
different seeds and by rdr at the same settings; prints rdr's relMSE against Mitsuba and
Mitsuba's against itself (the noise floor), with `rdr compare`'s metric
mean((x - r)^2 / (r^2 + 0.01)).

    /work/venv-mi/bin/python scripts/mitsuba_cbox_spectra.py [--res 64] [--spp 256]
"""
import argparse
import os
import subprocess
import tempfile

import mitsuba as mi
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ap = argparse.ArgumentParser()
ap.add_argument("--res", type=int, default=64)
ap.add_argument("--spp", type=int, default=256)
ap.add_argument("--rdr", default=os.path.join(HERE, "..", "target", "release", "rdr"))
ap.add_argument("--scene", default=os.path.join(HERE, "..", "..", "shared", "scenes", "real", "mitsuba-cbox", "scene.xml"))
a = ap.parse_args()

mi.set_variant("scalar_rgb")
scene = mi.load_file(a.scene, res=a.res, spp=a.spp)
m1 = np.array(mi.render(scene, seed=1))[..., :3]
m2 = np.array(mi.render(scene, seed=2))[..., :3]
with tempfile.TemporaryDirectory() as d:
    out = os.path.join(d, "rdr.exr")
    subprocess.run([a.rdr, "render", a.scene, "-D", f"res={a.res}", "-D", f"spp={a.spp}", "-o", out, "-q"], check=True)
    r = np.array(mi.Bitmap(out))[..., :3]


def rel_mse(x, ref):
    return float(np.mean((x - ref) ** 2 / (ref ** 2 + 0.01)))


print(f"res {a.res}, spp {a.spp}")
print(f"mean RGB  Mitsuba {m1.reshape(-1, 3).mean(0)}  rdr {r.reshape(-1, 3).mean(0)}")
print(f"relMSE rdr vs Mitsuba {rel_mse(r, m1):.3e}; Mitsuba seed 2 vs seed 1 (noise floor) {rel_mse(m2, m1):.3e}")
