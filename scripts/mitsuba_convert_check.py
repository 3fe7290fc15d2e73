#!/usr/bin/env python3
"""Does `rdr convert` write XML that Mitsuba 3 loads and renders as rdr does? For every scene
(.json and .xml) under ../shared/scenes, ../shared/refs/scenes and scenes/ (or those given):
a JSON scene is converted to XML, an XML scene to JSON and back to XML (the round trip users
make). The XML is shrunk to RES pixels wide at SPP samples (the same edit for both renderers),
rendered by Mitsuba 3 (scalar_rgb, two seeds) and by rdr (`rdr render` of the same converted
file), and compared by relative MSE: rdr against Mitsuba, and Mitsuba's seed against seed (the
noise floor). An oracle run by hand, never by tests or CI: Mitsuba is not a dependency.

Usage: /work/venv-mi/bin/python scripts/mitsuba_convert_check.py [--rdr BIN] [--res 48] [--spp 64]
           [--out DIR] [--timeout 300] [SCENE ...]
Prints one line per scene: status, relMSE(rdr, Mitsuba), the floor, and Mitsuba's or rdr's
first error line. Status: ok (within 3× the floor + 1e-3), DIFF, NO-CONVERT (rdr refused), MI-LOAD
(Mitsuba refused the XML), RDR-RENDER.
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


def scenes():
    if a.scenes:
        return a.scenes
    found = []
    for base in [os.path.join(a.shared, "scenes"), os.path.join(a.shared, "refs", "scenes"), os.path.join(ROOT, "scenes")]:
        for ext in ("json", "xml"):
            found += glob.glob(os.path.join(base, "**", "*." + ext), recursive=True)
    return sorted(found)


def run(args):
    p = subprocess.run(args, capture_output=True, text=True, timeout=a.timeout)
    return p.returncode, (p.stderr.strip().splitlines() or [""])[0]


def shrink(xml_text):
    """The film RES wide (height in proportion) and SPP samples."""
    w = re.search(r'<integer name="width" value="(\d+)"', xml_text)
    h = re.search(r'<integer name="height" value="(\d+)"', xml_text)
    if w and h:
        W, H = int(w.group(1)), int(h.group(1))
        nh = max(1, round(H * a.res / W))
        xml_text = xml_text.replace(w.group(0), f'<integer name="width" value="{a.res}"')
        xml_text = xml_text.replace(h.group(0), f'<integer name="height" value="{nh}"')
    return re.sub(r'<integer name="sample_count" value="\d+"', f'<integer name="sample_count" value="{a.spp}"', xml_text)


def rel_mse(x, r):
    return float(np.mean((x - r) ** 2 / (r**2 + 1e-2)))


def check(scene):
    name = re.sub(r"[^A-Za-z0-9_.-]", "_", os.path.relpath(scene, ROOT if scene.startswith(ROOT) else a.shared))
    d = os.path.join(a.out, name)
    os.makedirs(d, exist_ok=True)
    xml = os.path.join(d, "converted.xml")
    if scene.endswith(".json"):
        rc, err = run([a.rdr, "convert", "-q", scene, "-o", xml])
    else:
        js = os.path.join(d, "converted.json")
        rc, err = run([a.rdr, "convert", "-q", scene, "-o", js])
        if rc == 0:
            rc, err = run([a.rdr, "convert", "-q", js, "-o", xml])
    if rc != 0:
        return "NO-CONVERT", None, None, err
    small = os.path.join(d, "small.xml")
    with open(xml) as f:
        text = shrink(f.read())
    with open(small, "w") as f:
        f.write(text)
    note = ""
    try:
        try:
            sc = mi.load_file(small)
        except Exception as e:
            # Mitsuba 0.6's integrators (bdpt, photonmapper, sppm) are not in Mitsuba 3: its
            # image of the scene is path's (the same converged image); rdr renders the file
            m = re.search(r'<integrator type="(bdpt|photonmapper|sppm)">.*?</integrator>', text, re.S)
            if not (m and "Plugin \"" + m.group(1) + "\" not found" in str(e)):
                raise
            note = f"(Mitsuba: path for {m.group(1)})"
            path_xml = os.path.join(d, "small_path.xml")
            with open(path_xml, "w") as f:
                f.write(text.replace(m.group(0), '<integrator type="path"/>'))
            sc = mi.load_file(path_xml)
        m1 = np.array(mi.render(sc, seed=1))[..., :3]
        m2 = np.array(mi.render(sc, seed=2))[..., :3]
    except Exception as e:  # Mitsuba's own message, first line
        return "MI-LOAD", None, None, str(e).strip().splitlines()[0][:200]
    out = os.path.join(d, "rdr.exr")
    rc, err = run([a.rdr, "render", "-q", small, "-o", out, "--seed", "1"])
    if rc != 0:
        return "RDR-RENDER", None, None, err
    x = np.array(mi.Bitmap(out))[..., :3]
    if x.shape != m1.shape:
        return "DIFF", None, None, f"shapes {x.shape} and {m1.shape}"
    mean = (m1 + m2) / 2
    err, floor = rel_mse(x, mean), rel_mse(m1, m2)
    return ("ok" if err <= 3 * floor + 1e-3 else "DIFF"), err, floor, note


counts = {}
for s in scenes():
    try:
        status, err, floor, msg = check(s)
    except subprocess.TimeoutExpired:
        status, err, floor, msg = "TIMEOUT", None, None, ""
    counts[status] = counts.get(status, 0) + 1
    fig = f"{err:.2e} (floor {floor:.2e})" if err is not None else ""
    print(f"{status:11s} {os.path.relpath(s, ROOT)}  {fig}  {msg}", flush=True)
print(" ".join(f"{k}: {v}" for k, v in sorted(counts.items())))
