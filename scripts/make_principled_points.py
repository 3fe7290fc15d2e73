#!/usr/bin/env python3
"""Writes tests/refs/principled/points.json: Mitsuba 3's own principled (and principledthin) BSDF evaluated
at random direction pairs for a few parameter sets (eval, which includes |cos θo|, and
pdf, radiance transport, in the local shading frame), which tests/principled.rs
compares rdr's implementation with.

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_principled_points.py
"""
import json
import math
import os
import random

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "principled")

# name: Mitsuba parameters (floats, or [r, g, b] for base_color)
SETS = {
    "defaults": {},
    "everything": {"base_color": [0.8, 0.3, 0.1], "roughness": 0.3, "metallic": 0.2, "clearcoat": 0.7,
                   "clearcoat_gloss": 0.5, "sheen": 0.6, "sheen_tint": 0.4, "spec_tint": 0.3, "spec_trans": 0.4},
    "anisotropic_metal": {"base_color": [0.9, 0.6, 0.2], "metallic": 1.0, "roughness": 0.4, "anisotropic": 0.7},
    "glass": {"base_color": [0.9, 0.9, 1.0], "spec_trans": 1.0, "eta": 1.33, "roughness": 0.25},
    "flat_sheen": {"base_color": [0.2, 0.5, 0.3], "flatness": 0.6, "roughness": 0.8, "sheen": 1.0, "specular": 0.3},
    "clearcoat_rates": {"base_color": [0.1, 0.1, 0.6], "roughness": 0.5, "clearcoat": 1.0, "clearcoat_gloss": 0.9,
                        "main_specular_sampling_rate": 0.5, "clearcoat_sampling_rate": 2.0,
                        "diffuse_reflectance_sampling_rate": 0.7},
}
# principledthin
THIN_SETS = {
    "defaults": {},
    "everything": {"base_color": [0.7, 0.3, 0.2], "roughness": 0.35, "spec_trans": 0.6, "eta": 1.4, "spec_tint": 0.3,
                   "sheen": 0.5, "sheen_tint": 0.6, "flatness": 0.4, "diff_trans": 0.8, "anisotropic": 0.5},
    "leaf": {"base_color": [0.2, 0.6, 0.1], "roughness": 0.6, "diff_trans": 1.5,
             "diffuse_transmittance_sampling_rate": 2.0, "specular_reflectance_sampling_rate": 0.5},
    "pane": {"base_color": [0.9, 0.9, 0.9], "roughness": 0.3, "spec_trans": 1.0, "eta": 1.6},
}
PAIRS = 60


def sphere(rng):
    z = rng.uniform(-1, 1)
    phi = rng.uniform(0, 2 * math.pi)
    s = math.sqrt(1 - z * z)
    return [s * math.cos(phi), s * math.sin(phi), z]


def main():
    import mitsuba as mi
    mi.set_variant("scalar_rgb")
    rng = random.Random(1234)
    out = {}
    thin = {}
    for name, params in list(SETS.items()) + [("thin " + k, v) for k, v in THIN_SETS.items()]:
        d = {"type": "principledthin" if name.startswith("thin ") else "principled"}
        for k, v in params.items():
            d[k] = {"type": "rgb", "value": v} if isinstance(v, list) else v
        bsdf = mi.load_dict(d)
        ctx = mi.BSDFContext()
        rows = []
        for _ in range(PAIRS):
            wi, wo = sphere(rng), sphere(rng)
            if rng.random() < 0.5:
                # half the pairs on the same side, where the reflecting lobes live
                wo[2] = math.copysign(wo[2], wi[2])
            if rng.random() < 0.7:
                wi[2] = abs(wi[2])
            si = mi.SurfaceInteraction3f()
            si.wi = mi.Vector3f(wi)
            v = bsdf.eval(ctx, si, mi.Vector3f(wo))
            p = bsdf.pdf(ctx, si, mi.Vector3f(wo))
            rows.append({"wi": wi, "wo": wo, "eval": [float(v[0]), float(v[1]), float(v[2])], "pdf": float(p)})
        (thin if name.startswith("thin ") else out)[name.removeprefix("thin ")] = {"params": params, "pairs": rows}
    os.makedirs(HERE, exist_ok=True)
    with open(os.path.join(HERE, "points.json"), "w") as f:
        json.dump({"mitsuba": mi.__version__, "sets": out, "thin_sets": thin}, f, indent=0)
        f.write("\n")


if __name__ == "__main__":
    main()
