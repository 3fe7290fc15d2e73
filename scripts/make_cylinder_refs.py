#!/usr/bin/env python3
"""Regenerates the cylinder reference in tests/refs/shapes/ with Mitsuba 3.

cylinder.xml (the Mitsuba scene, which tests/cylinder.rs renders with rdr through its
XML reader), cylinder.json (its JSON twin, rendered too), cylinder.exr (the mean of K
independent passes of Mitsuba's `path` integrator, pass p with seed p) and
cylinder.var.exr (per pixel and channel the variance of that mean: the sample variance
of the K pass images / K).

The scene: three open cylinders on a diffuse floor under a constant sky. A tilted one
with an 8×4 image texture (cylinder_tex.png: its uv), an emitting one lying above (area light sampled by
area), and one with flip_normals whose inside, seen through its open top, is lit and
whose outside (the back of a one-sided diffuse) is black.

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_cylinder_refs.py [--passes 8] [--spp 256]
"""
import os

from mitsuba_refs import arguments, floor_sphere, mitsuba, perspective_sensor, render_reference

RES = 64
MAX_DEPTH = 6
HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "shapes")

CAMERA = {"position": [0.0, 1.6, -4.2], "look_at": [0.0, -0.1, 0.0], "ref_up": [0.0, 1.0, 0.0], "fov": 40.0}
SKY = [0.2, 0.2, 0.25]
FLOOR = {"center": [0.0, -101.0, 0.0], "radius": 100.0, "albedo": [0.5, 0.5, 0.5]}
# (p0, p1, radius, flip_normals, material or None, radiance or None)
# the tilted cylinder's texture: 8×4 texels, each of its own colour (u and v and
# their directions show), magnified, so that Mitsuba's lookup and rdr's
# (both bilinear) agree
TEX_W, TEX_H = 8, 4
CYLINDERS = [
    ([-0.9, -1.0, 0.2], [-0.5, 0.5, 0.5], 0.45, False, "checker", None),
    ([-1.2, 0.9, 0.7], [1.2, 1.1, 0.9], 0.12, False, None, [6.0, 5.0, 4.0]),
    ([0.8, -1.0, 0.0], [0.8, 0.1, 0.0], 0.45, True, "white", None),
]


def v(x):
    return ", ".join(str(float(c)) for c in x)


def scene_xml():
    c = CAMERA
    shapes = []
    for p0, p1, r, flip, mat, rad in CYLINDERS:
        inner = ""
        if mat == "checker":
            inner = ('<bsdf type="diffuse"><texture type="bitmap" name="reflectance">'
                     '<string name="filename" value="cylinder_tex.png"/>'
                     '</texture></bsdf>')
        elif mat == "white":
            inner = '<bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>'
        if rad is not None:
            inner += f'<emitter type="area"><rgb name="radiance" value="{v(rad)}"/></emitter>'
        shapes.append(
            f'  <shape type="cylinder"><point name="p0" value="{v(p0)}"/><point name="p1" value="{v(p1)}"/>'
            f'<float name="radius" value="{r}"/><boolean name="flip_normals" value="{str(flip).lower()}"/>{inner}</shape>')
    shapes = "\n".join(shapes)
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/shapes/cylinder: made by scripts/make_cylinder_refs.py (do not edit; rerun it).
     {RES}x{RES}, box filter, path max_depth {MAX_DEPTH}; twin: cylinder.json -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  <integrator type="path"><integer name="max_depth" value="{MAX_DEPTH}"/></integrator>
{perspective_sensor(c['fov'], v(c['position']), v(c['look_at']), v(c['ref_up']), RES)}
{floor_sphere(FLOOR)}
{shapes}
  <emitter type="constant"><rgb name="radiance" value="{v(SKY)}"/></emitter>
</scene>
"""


def main():
    args = arguments(__doc__, names=False)
    mi = mitsuba(args.variant)
    import numpy as np

    os.makedirs(HERE, exist_ok=True)
    tex = np.zeros((TEX_H, TEX_W, 3), dtype=np.uint8)
    for y in range(TEX_H):
        for x in range(TEX_W):
            tex[y, x] = [40 + 200 * x // (TEX_W - 1), 40 + 200 * y // (TEX_H - 1), 200 if (x + y) % 2 else 40]
    mi.Bitmap(tex).write(os.path.join(HERE, "cylinder_tex.png"))
    xml_path = os.path.join(HERE, "cylinder.xml")
    with open(xml_path, "w") as f:
        f.write(scene_xml())
    render_reference(mi, mi.load_file(xml_path), HERE, "cylinder", args.passes, args.spp)


if __name__ == "__main__":
    main()
