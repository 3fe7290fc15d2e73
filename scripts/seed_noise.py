#!/usr/bin/env python3
"""Noise at equal spp, rdr against Mitsuba 3, measured over many seeds rather than one pair.

The relMSE of two seeds of one renderer, mean((a - b)^2 / (b^2 + 0.01)), is heavy-tailed where a
scene has rare high-valued paths (caustics seen through a diffuse bounce, such as the light the
Veach MIS plates reflect onto the wall): one such sample in a dark pixel of one image decides the
figure, and the second image being the reference makes it worse. So this renders 2*PAIRS seeds with
each renderer and prints, per renderer:
- `pair(1,2)`: the one-pair figure (what `mitsuba_convert_check.py` measures);
- the median, mean and maximum of that figure over PAIRS disjoint seed pairs;
- `expected`: its pooled expectation, 2 * mean(var / (m^2 + 0.01)) with `var` each pixel's
  variance over the seeds and `m` the mean of all images of both renderers (stable: the figure
  to compare);
- `outliers`: pixel samples far above the pixel's median over the seeds (an image's excess over
  it, times spp, above 100): how many there are, and the largest;
and the mean of both images (they must agree). The images are kept in OUT as `rdr.npy`, `mitsuba.npy`. An XML scene is made small (its 0.6 spellings that
Mitsuba 3 refuses in Mitsuba 3's form) and the same file is rendered by both; a JSON scene is
rendered by rdr as it is (at --res and --spp) and its Mitsuba form is given with --xml (default:
`rdr convert`'s).
An oracle run by hand, never by tests or CI: Mitsuba is not a dependency.

Usage: DRJIT_LIBLLVM_PATH=... /work/venv-mi/bin/python scripts/seed_noise.py SCENE [--xml XML]
           [--res 48] [--spp 256] [--pairs 16] [--rdr BIN] [--variant llvm_ad_rgb] [--out DIR]
"""
import argparse, os, subprocess, sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("--xml", help="the Mitsuba form of a JSON scene (default: rdr convert's)")
ap.add_argument("--rdr", default=os.path.join(ROOT, "target", "release", "rdr"))
ap.add_argument("--res", type=int, default=48)
ap.add_argument("--spp", type=int, default=256)
ap.add_argument("--pairs", type=int, default=16)
ap.add_argument("--variant", default="llvm_ad_rgb")
ap.add_argument("--out", default="/tmp/rdr-seed-noise")
a = ap.parse_args()

import numpy as np
import mitsuba as mi

mi.set_variant(a.variant)
sys.path.insert(0, HERE)
from mitsuba_oracle import inlined, mitsuba3_form, rel_mse, shrunk  # noqa: E402

os.makedirs(a.out, exist_ok=True)
seeds = range(1, 2 * a.pairs + 1)


def small_xml(path, out):
    with open(out, "w") as f:
        f.write(mitsuba3_form(shrunk(inlined(path), a.res, a.spp, os.path.dirname(os.path.abspath(path)))))
    return out


def read(path):
    return np.array(mi.Bitmap(path))[..., :3]


if a.scene.endswith(".json"):
    xml = a.xml
    if not xml:
        xml = os.path.join(a.out, "converted.xml")
        subprocess.run([a.rdr, "convert", "-q", a.scene, "-o", xml], check=True)
    mxml = small_xml(xml, os.path.join(a.out, "mitsuba.xml"))
    h = mi.load_file(mxml).sensors()[0].film().size()[1]
    rdr_args = [a.scene, "--res", f"{a.res}x{h}", "--spp", str(a.spp)]
else:
    mxml = small_xml(a.scene, os.path.join(a.out, "scene.xml"))
    rdr_args = [mxml]

R = []
for s in seeds:
    out = os.path.join(a.out, f"rdr{s}.exr")
    subprocess.run([a.rdr, "render", "-q", *rdr_args, "-o", out, "--seed", str(s), "--no-state"], check=True, stdout=subprocess.DEVNULL)
    R.append(read(out))
sc = mi.load_file(mxml)
M = [np.array(mi.render(sc, seed=s))[..., :3] for s in seeds]
R, M = np.array(R), np.array(M)
np.save(os.path.join(a.out, "rdr.npy"), R)
np.save(os.path.join(a.out, "mitsuba.npy"), M)
if R.shape != M.shape:
    sys.exit(f"image shapes differ: rdr {R.shape[1:]}, Mitsuba {M.shape[1:]}")
m = np.concatenate([R, M]).mean(0)


def report(name, X):
    pairs = np.array([rel_mse(X[2 * k], X[2 * k + 1]) for k in range(a.pairs)])
    expected = 2 * float(np.mean(X.var(0, ddof=1) / (m**2 + 1e-2)))
    excess = (X.mean(-1) - np.median(X.mean(-1), axis=0)) * a.spp
    big = excess[excess > 100]
    print(
        f"{name:8s} pair(1,2) {pairs[0]:.2e}  over {a.pairs} pairs: median {np.median(pairs):.2e} mean {pairs.mean():.2e}"
        f" max {pairs.max():.2e}  expected {expected:.2e}  outliers {len(big)} (largest {big.max() if len(big) else 0:.0f})"
        f"  mean {X.mean():.5f}"
    )
    return expected


print(f"{a.scene}: {R.shape[2]}x{R.shape[1]} px, {a.spp} spp, seeds 1-{2 * a.pairs}")
er, em = report("rdr", R), report("mitsuba", M)
print(f"expected relMSE of two seeds, rdr / Mitsuba: {er / em:.2f}; relMSE of the two means {rel_mse(R.mean(0), M.mean(0)):.2e}")
