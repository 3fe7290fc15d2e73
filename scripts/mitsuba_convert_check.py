#!/usr/bin/env python3
"""Do Mitsuba scenes load in rdr, render as Mitsuba 3 renders them, and survive `rdr convert`?
For every scene under ../shared/scenes (Mitsuba XML; `fragments/` folders are includes, not
scenes), ../shared/refs/mitsuba (XML), ../shared/refs/scenes (JSON) and scenes/ (JSON), or those
given, all made RES pixels wide at SPP samples (the same edit for both renderers):
- an XML scene (its Mitsuba 0.6 spellings that Mitsuba 3 refuses put in Mitsuba 3's form,
  `mitsuba_oracle.mitsuba3_form`) is rendered by rdr and by Mitsuba (scalar_rgb, seeds 1 and 2: their difference is
  the noise floor); then converted XML -> JSON -> XML by `rdr convert` (the round trip users
  make), and the converted XML is rendered by Mitsuba (seed 3) and by rdr. Each of the three
  images is compared with the mean of Mitsuba's two images of the original: rdr reads the scene
  as Mitsuba does (`rdr`), the round trip kept the scene for Mitsuba (`trip`) and for rdr (`rdr2`);
- a JSON scene is converted to XML and the XML rendered by both.
Relative MSE mean((x - r)^2 / (r^2 + 0.01)); a figure is within noise at <= 3x the floor + 1e-3, the
floor being Mitsuba's seed-to-seed relMSE or, for an XML scene where rdr is the noisier, the mean
of rdr's and Mitsuba's. Each is one pair's figure, heavy-tailed where a scene has rare bright paths
(a caustic seen through a diffuse bounce): to compare the renderers' noise, use seed_noise.py.
An oracle run by hand, never by tests or CI: Mitsuba is not a dependency.

Usage: /work/venv-mi/bin/python scripts/mitsuba_convert_check.py [--rdr BIN] [--res 48] [--spp 64]
           [--out DIR] [--timeout 300] [SCENE ...]
Prints one line per scene: status, the figures, and the first error line. Status: ok, DIFF (a figure
above noise), RDR-LOAD (rdr refused the scene), NO-CONVERT (the round trip failed), MI-ORIG (Mitsuba
refused the original), MI-LOAD (Mitsuba refused the converted XML), RDR-RENDER (rdr refused it).
"""
import argparse, glob, os, re, subprocess, sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

ap = argparse.ArgumentParser()
ap.add_argument("scenes", nargs="*")
ap.add_argument("--rdr", default=os.path.join(ROOT, "target", "release", "rdr"))
ap.add_argument("--shared", default=os.path.join(ROOT, "..", "shared"))
ap.add_argument("--res", type=int, default=48)
ap.add_argument("--spp", type=int, default=64)
ap.add_argument("--out", default="/tmp/rdr-convert-check")
ap.add_argument("--timeout", type=int, default=300)
a = ap.parse_args()

import numpy as np
import mitsuba as mi

mi.set_variant("scalar_rgb")
sys.path.insert(0, HERE)
from mitsuba_oracle import inlined, mitsuba3_form, rel_mse, shrunk  # noqa: E402


class Failed(Exception):
    def __init__(self, status, msg):
        super().__init__(msg)
        self.status, self.msg = status, msg


def scenes():
    if a.scenes:
        return a.scenes
    sh = a.shared
    found = glob.glob(os.path.join(sh, "scenes", "**", "*.xml"), recursive=True)
    found = [f for f in found if "/fragments/" not in f]
    found += glob.glob(os.path.join(sh, "refs", "mitsuba", "*.xml"))
    found += glob.glob(os.path.join(sh, "refs", "scenes", "*.json"))
    found += glob.glob(os.path.join(ROOT, "scenes", "*.json"))
    return sorted(found)


def run(args, status):
    p = subprocess.run(args, capture_output=True, text=True, timeout=a.timeout)
    if p.returncode != 0:
        raise Failed(status, (p.stderr.strip().splitlines() or [""])[0][:200])


def mitsuba(path, seeds, status):
    """Mitsuba's images of the file. Mitsuba 0.6's integrators (bdpt, photonmapper, sppm) are not in
    Mitsuba 3: its image is then path's (the same converged image); rdr renders the file."""
    with open(path) as f:
        text = f.read()
    try:
        try:
            sc, note = mi.load_file(path), ""
        except Exception as e:
            m = re.search(r'<integrator type="(bdpt|photonmapper|sppm)"\s*(/>|>.*?</integrator>)', text, re.S)
            if not (m and 'Plugin "' + m.group(1) + '" not found' in str(e)):
                raise
            note = f"(Mitsuba: path for {m.group(1)})"
            alt = os.path.splitext(path)[0] + "_path.xml"
            with open(alt, "w") as f:
                f.write(text.replace(m.group(0), '<integrator type="path"/>'))
            sc = mi.load_file(alt)
        return [np.array(mi.render(sc, seed=s))[..., :3] for s in seeds], note
    except Exception as e:  # Mitsuba's own message, first line
        raise Failed(status, str(e).strip().splitlines()[0][:200])


def rdr_image(scene, out, status, seed=1):
    run([a.rdr, "render", "-q", scene, "-o", out, "--seed", str(seed)], status)
    return np.array(mi.Bitmap(out))[..., :3]


def check(scene, d):
    """The figures (name, relMSE) and the floor, and a note."""
    if scene.endswith(".json"):
        xml = os.path.join(d, "converted.xml")
        run([a.rdr, "convert", "-q", scene, "-o", xml], "NO-CONVERT")
        small = os.path.join(d, "small.xml")
        with open(xml) as f:
            text = shrunk(f.read(), a.res, a.spp)
        with open(small, "w") as f:
            f.write(text)
        (m1, m2), note = mitsuba(small, (1, 2), "MI-LOAD")
        figs = [("rdr", rdr_image(small, os.path.join(d, "rdr.exr"), "RDR-RENDER"))]
    else:
        small = os.path.join(d, "original.xml")
        with open(small, "w") as f:
            f.write(mitsuba3_form(shrunk(inlined(scene), a.res, a.spp, os.path.dirname(os.path.abspath(scene)))))
        x = rdr_image(small, os.path.join(d, "rdr.exr"), "RDR-LOAD")
        x2 = rdr_image(small, os.path.join(d, "rdr_seed2.exr"), "RDR-LOAD", seed=2)
        js, xml = os.path.join(d, "converted.json"), os.path.join(d, "converted.xml")
        run([a.rdr, "convert", "-q", small, "-o", js], "NO-CONVERT")
        run([a.rdr, "convert", "-q", js, "-o", xml], "NO-CONVERT")
        (m1, m2), note = mitsuba(small, (1, 2), "MI-ORIG")
        (c,), _ = mitsuba(xml, (3,), "MI-LOAD")
        figs = [("rdr", x), ("trip", c), ("rdr2", rdr_image(xml, os.path.join(d, "rdr2.exr"), "RDR-RENDER"))]
    mean = (m1 + m2) / 2
    for name, img in figs:
        if img.shape != mean.shape:
            raise Failed("DIFF", f"{name}: shapes {img.shape} and {mean.shape}")
    floor = rel_mse(m1, m2)
    if not scene.endswith(".json"):
        # rdr's own noise counts too where it is the larger (two seeds apart: twice one image's)
        floor = max(floor, (rel_mse(x, x2) + floor) / 2)
    return [(name, rel_mse(img, mean)) for name, img in figs], floor, note


counts = {}
for s in scenes():
    label = os.path.relpath(s, ROOT if s.startswith(ROOT) else a.shared)
    d = os.path.join(a.out, re.sub(r"[^A-Za-z0-9_.-]", "_", label))
    os.makedirs(d, exist_ok=True)
    try:
        figs, floor, msg = check(s, d)
        status = "ok" if all(e <= 3 * floor + 1e-3 for _, e in figs) else "DIFF"
        fig = " ".join(f"{n} {e:.2e}" for n, e in figs) + f" (floor {floor:.2e})"
    except Failed as f:
        status, fig, msg = f.status, "", f.msg
    except subprocess.TimeoutExpired:
        status, fig, msg = "TIMEOUT", "", ""
    counts[status] = counts.get(status, 0) + 1
    print(f"{status:10s} {label}  {fig}  {msg}", flush=True)
print(" ".join(f"{k}: {v}" for k, v in sorted(counts.items())))
