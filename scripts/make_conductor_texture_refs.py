#!/usr/bin/env python3
"""Regenerates the textured-conductor reference in tests/refs/materials/ with Mitsuba 3.

conductor_eta.exr and conductor_k.exr (4×2 texels of η and k, linear, beyond 1: a
conductor's index), conductor_textured.xml (a rough conductor rectangle, and a smooth
conductor sphere, whose `eta` and `k` are those bitmaps; lit by a small sphere and a dim
sky) and conductor_textured.exr / .var.exr (the mean of K passes of Mitsuba's `path`, pass
p with seed p, and the variance of that mean). tests/conductor_textures.rs renders the
XML with rdr.

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_conductor_texture_refs.py [--passes 8] [--spp 256]
"""
import os

from mitsuba_refs import arguments, mitsuba, perspective_sensor, sphere_light_and_sky, write_and_render

RES = 64
HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "materials")

# per texel (row-major, 2 rows of 4): η and k of gold-, copper-, aluminium- and
# silver-like metals and four made-up ones
ETA = [[0.14, 0.37, 1.44], [0.2, 0.92, 1.1], [1.66, 0.88, 0.52], [0.16, 0.14, 0.13],
       [2.5, 2.0, 1.5], [0.5, 1.5, 0.8], [1.0, 0.3, 2.2], [3.0, 3.0, 0.6]]
K = [[3.98, 2.39, 1.6], [3.9, 2.45, 2.14], [9.22, 6.27, 4.84], [4.0, 3.2, 2.5],
     [1.0, 2.0, 3.0], [2.5, 0.8, 1.2], [0.6, 4.5, 2.0], [5.0, 1.0, 1.0]]


def bitmap(name, filename):
    return (f'<texture type="bitmap" name="{name}"><string name="filename" value="{filename}"/>'
            '<string name="filter_type" value="bilinear"/></texture>')


def scene_xml():
    textures = bitmap("eta", "conductor_eta.exr") + bitmap("k", "conductor_k.exr")
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/materials/conductor_textured: made by scripts/make_conductor_texture_refs.py (do not edit; rerun it).
     {RES}x{RES}, box filter, path max_depth 4 -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
{perspective_sensor(40, "0, -3.5, 3.5", "0, 0, 0", "0, 0, 1", RES)}
  <shape type="rectangle">
    <transform name="to_world"><scale x="2.2" y="1.4" z="1"/></transform>
    <bsdf type="roughconductor"><float name="alpha" value="0.25"/><string name="distribution" value="ggx"/>{textures}</bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" value="0, -0.4, 0.6"/><float name="radius" value="0.55"/>
    <bsdf type="conductor">{textures}</bsdf>
  </shape>
{sphere_light_and_sky("1.2, 1.5, 2.5", 0.5, "10, 10, 9", "0.3, 0.3, 0.35")}
</scene>
"""


def main():
    args = arguments(__doc__, names=False)
    mi = mitsuba(args.variant)
    import numpy as np

    os.makedirs(HERE, exist_ok=True)
    for name, values in [("conductor_eta.exr", ETA), ("conductor_k.exr", K)]:
        texels = np.array(values, dtype=np.float32).reshape(2, 4, 3)
        mi.Bitmap(texels, mi.Bitmap.PixelFormat.RGB).write(os.path.join(HERE, name))
    write_and_render(mi, HERE, "conductor_textured", scene_xml(), args.passes, args.spp)


if __name__ == "__main__":
    main()
