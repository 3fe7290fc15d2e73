#!/usr/bin/env python3
"""rdr and Mitsuba 3 on the real scenes of ../shared/scenes/real/ (issue 41): each <dir>/scene.xml
(or bench.xml with --bench, or the files given) is copied to OUT with the film made WIDTH pixels
wide (height in proportion), SPP samples per pixel and a <path> to the scene's folder (so both
renderers find its meshes, textures and includes), then rendered by Mitsuba 3 (scalar_rgb, seeds
1 and 2) and by rdr (`rdr render`, seed 1) from that same file. Prints per scene the relative MSE
mean((x - r)^2 / (r^2 + 0.01)) of rdr against the mean of Mitsuba's two images, the noise floor
(Mitsuba's seed 1 against seed 2) and their ratio: an error near half the floor to one floor is
noise (rdr's own noise plus the reference's); well above it the images differ.
An oracle run by hand, never by tests or CI: Mitsuba is not a dependency.

Usage: /work/venv-mi/bin/python scripts/mitsuba_real_scenes.py [--rdr BIN] [--width 96] [--spp 64]
           [--bench] [--out DIR] [SCENE.xml ...]
"""
import argparse, glob, os, re, subprocess, sys, time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
ap = argparse.ArgumentParser()
ap.add_argument("scenes", nargs="*")
ap.add_argument("--rdr", default=os.path.join(ROOT, "target", "release", "rdr"))
ap.add_argument("--shared", default=os.path.join(ROOT, "..", "shared"))
ap.add_argument("--width", type=int, default=96)
ap.add_argument("--spp", type=int, default=64)
ap.add_argument("--bench", action="store_true")
ap.add_argument("--out", default="/tmp/rdr-real-scenes")
a = ap.parse_args()

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
sys.path.insert(0, HERE)
from mitsuba_oracle import prepared, rel_mse  # noqa: E402


def scenes():
    if a.scenes:
        return a.scenes
    name = "bench.xml" if a.bench else "scene.xml"
    return sorted(glob.glob(os.path.join(a.shared, "scenes", "real", "*", name)))


for scene in scenes():
    label = os.path.relpath(scene, os.path.join(a.shared, "scenes", "real"))
    d = os.path.join(a.out, label.replace("/", "_").replace(".xml", ""))
    os.makedirs(d, exist_ok=True)
    small = os.path.join(d, "small.xml")
    try:
        prepared(scene, small, a.width, a.spp)
        t = time.time()
        sc = mi.load_file(small)
        m = [np.array(mi.render(sc, seed=s))[..., :3] for s in (1, 2)]
        tm = time.time() - t
    except Exception as e:
        print(f"{label:28s} MI-ERROR {str(e).strip().splitlines()[0][:160]}", flush=True)
        continue
    out = os.path.join(d, "rdr.exr")
    t = time.time()
    p = subprocess.run([a.rdr, "render", "-q", small, "-o", out, "--seed", "1"], capture_output=True, text=True)
    tr = time.time() - t
    if p.returncode != 0:
        print(f"{label:28s} RDR-ERROR {(p.stderr.strip().splitlines() or [''])[0][:160]}", flush=True)
        continue
    x = np.array(mi.Bitmap(out))[..., :3]
    mi.Bitmap(((m[0] + m[1]) / 2).astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(os.path.join(d, "mitsuba.exr"))
    err, floor = rel_mse(x, (m[0] + m[1]) / 2), rel_mse(m[0], m[1])
    means = " ".join(f"{c:.4f}" for c in x.mean(axis=(0, 1))) + " vs " + " ".join(f"{c:.4f}" for c in ((m[0] + m[1]) / 2).mean(axis=(0, 1)))
    print(f"{label:28s} {x.shape[1]}x{x.shape[0]} {a.spp} spp: relMSE {err:.2e}, floor {floor:.2e}, ratio {err / floor:.2f}; "
          f"mean RGB {means} (Mitsuba {tm:.0f} s for 2, rdr {tr:.0f} s)", flush=True)
