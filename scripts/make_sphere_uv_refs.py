#!/usr/bin/env python3
"""Regenerates two references in tests/refs/shapes/ with Mitsuba 3 (tests/mitsuba_xml.rs).

sphere_uv.xml - two analytic spheres with cylinder_tex.png (an 8×4 image of its uv) as
                diffuse reflectance under a white sky: one unrotated, one under a
                to_world rotation and scale. Mitsuba's sphere uv is (φ/2π, θ/π) in the
                object frame (z the pole), so the rotation turns the texture with it.
onesided.xml  - four rectangles seen from behind, tilted towards a small light: bare
                `roughconductor`, `conductor` and `plastic` (black from behind: Mitsuba's
                are one-sided) and a `twosided` roughconductor (which reflects).
Each <name>.exr is the mean of K passes, <name>.var.exr the variance of that mean.

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_sphere_uv_refs.py [--passes 16] [--spp 256]
"""
import os

from mitsuba_refs import arguments, mitsuba, render_reference

import numpy as np

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "shapes")


def header(name, width, height, origin, max_depth):
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/shapes/{name}: made by scripts/make_sphere_uv_refs.py (do not edit; rerun it). -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  <integrator type="path"><integer name="max_depth" value="{max_depth}"/></integrator>
  <sensor type="perspective">
    <float name="fov" value="40"/>
    <transform name="to_world"><lookat origin="{origin}" target="0, 0, 0" up="0, 1, 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="{width}"/><integer name="height" value="{height}"/>
      <string name="pixel_format" value="rgb"/><rfilter type="box"/></film>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
  </sensor>
"""


def scenes():
    tex = '<bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="cylinder_tex.png"/></texture></bsdf>'
    yield "sphere_uv", header("sphere_uv", 64, 32, "0, 0.5, 4", 2) + f"""  <shape type="sphere">
    <point name="center" x="-1.1" y="0" z="0"/><float name="radius" value="0.9"/>
    {tex}
  </shape>
  <shape type="sphere">
    <transform name="to_world"><rotate x="1" angle="70"/><rotate y="1" angle="30"/><scale value="0.9"/><translate x="1.1"/></transform>
    {tex}
  </shape>
  <emitter type="constant"><rgb name="radiance" value="1, 1, 1"/></emitter>
</scene>
"""
    bsdfs = [
        '<bsdf type="roughconductor"><float name="alpha" value="0.3"/></bsdf>',
        '<bsdf type="conductor"/>',
        '<bsdf type="plastic"/>',
        '<bsdf type="twosided"><bsdf type="roughconductor"><float name="alpha" value="0.3"/></bsdf></bsdf>',
    ]
    rects = ""
    for i, b in enumerate(bsdfs):
        x = -0.96 + 0.64 * i
        # normal away from the camera (at +z), tilted up towards the light behind it
        rects += f"""  <shape type="rectangle">
    <transform name="to_world"><scale value="0.28"/><rotate x="1" angle="-150"/><translate x="{x}"/></transform>
    {b}
  </shape>
"""
    yield "onesided", header("onesided", 64, 32, "0, 0.3, 3.5", 4) + rects + """  <shape type="sphere">
    <point name="center" x="0" y="2.5" z="2.5"/><float name="radius" value="0.5"/>
    <emitter type="area"><rgb name="radiance" value="20, 20, 20"/></emitter>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="0.2, 0.2, 0.2"/></emitter>
</scene>
"""


def main():
    args = arguments(__doc__, passes=16)
    mi = mitsuba(args.variant)
    for name, xml in scenes():
        if args.names and name not in args.names:
            continue
        path = os.path.join(HERE, f"{name}.xml")
        with open(path, "w") as f:
            f.write(xml)
        render_reference(mi, mi.load_file(path), HERE, name, args.passes, args.spp)


if __name__ == "__main__":
    main()
