#!/usr/bin/env python3
"""Regenerates the references in tests/refs/bump/ with Mitsuba 3 (tests/bump.rs, tests/masks.rs).

Writes three small textures it computes itself (EXR, linear):
  heights.exr  - a height field 0.5 + 0.5 sin(2π·3s) sin(2π·2t), for `bumpmap`;
  normals.exr  - tangent-space normals (n + 1)/2 tilting mostly along s (stripes in s,
                 a weaker tilt in t), for `normalmap`;
  leaf.exr     - a binary leaf-shaped opacity (an ellipse with a round hole), for `mask`;
  ramp.exr     - a grey opacity rising from 0 to 1 along s, for a fractional `mask`;
and three scenes with their references (<name>.exr the mean of K passes, <name>.var.exr
the variance of that mean, as scripts/make_material_refs.py):
  bumpmap.xml   - a rectangle, diffuse under a bump map, lit from the side;
  normalmap.xml - the same rectangle, roughplastic under a normal map;
  mask.xml      - a masked leaf quad over a floor under a small light: the leaf-shaped
                  shadow. Rendered with `volpath` (whose shadow rays pass through masked
                  surfaces, as rdr's rays do); rdr renders it with `path`;
  mask_half.xml - two fractional masks over a floor (volpath): a quad of opacity 0.5
                  (a half shadow) and one with ramp.exr's opacity (a graded shadow);
  aniso_rect.xml, aniso_sphere.xml - anisotropic principled and roughconductor lobes,
                  which follow the surface's dp/du (tests/principled.rs).

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_bump_refs.py [--passes 8] [--spp 256] [NAME...]
"""
import os


import numpy as np

from mitsuba_refs import arguments, mitsuba, perspective_sensor, render_reference

RES = 64
HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "bump")
TEX = 64


def grid(n):
    s = (np.arange(n) + 0.5) / n
    return np.meshgrid(s, s)  # [row][col]: x = column, y = row


def heights():
    x, y = grid(TEX)
    h = 0.5 + 0.5 * np.sin(2 * np.pi * 3 * x) * np.sin(2 * np.pi * 2 * y)
    return np.repeat(h[..., None], 3, axis=2)


def normals():
    x, y = grid(TEX)
    n = np.stack([1.0 * np.sin(2 * np.pi * 3 * x), 0.3 * np.cos(2 * np.pi * 2 * y), np.ones_like(x)], axis=2)
    n /= np.linalg.norm(n, axis=2, keepdims=True)
    return (n + 1) / 2


def ramp():
    x, _ = grid(TEX)
    return np.repeat(x[..., None], 3, axis=2)


def leaf():
    x, y = grid(TEX)
    inside = ((x - 0.5) / 0.45) ** 2 + ((y - 0.5) / 0.22) ** 2 < 1
    hole = (x - 0.68) ** 2 + (y - 0.5) ** 2 < 0.09 ** 2
    a = (inside & ~hole).astype(np.float64)
    return np.repeat(a[..., None], 3, axis=2)


def header(name, integrator, camera):
    origin, target = camera
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/bump/{name}: made by scripts/make_bump_refs.py (do not edit; rerun it). -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  {integrator}
{perspective_sensor(35, origin, target, "0, 1, 0", RES, fov_axis=None)}
"""


SIDE_LIGHT = """  <shape type="sphere">
    <point name="center" x="3" y="0.5" z="1.5"/><float name="radius" value="0.4"/>
    <emitter type="area"><rgb name="radiance" value="30, 30, 30"/></emitter>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="0.15, 0.15, 0.15"/></emitter>
"""

PATH = '<integrator type="path"><integer name="max_depth" value="6"/></integrator>'


def scenes():
    quad = '<transform name="to_world"><rotate y="1" angle="-20"/></transform>'
    yield "bumpmap", header("bumpmap", PATH, ("0, 0, 3.0", "0, 0, 0")) + f"""  <shape type="rectangle">
    {quad}
    <bsdf type="bumpmap">
      <texture type="bitmap"><string name="filename" value="heights.exr"/></texture>
      <float name="scale" value="0.15"/>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>
    </bsdf>
  </shape>
{SIDE_LIGHT}</scene>
"""
    yield "normalmap", header("normalmap", PATH, ("0, 0, 3.0", "0, 0, 0")) + f"""  <shape type="rectangle">
    {quad}
    <bsdf type="normalmap">
      <texture name="normalmap" type="bitmap"><string name="filename" value="normals.exr"/></texture>
      <bsdf type="roughplastic">
        <string name="distribution" value="ggx"/><float name="alpha" value="0.25"/>
        <rgb name="diffuse_reflectance" value="0.6, 0.5, 0.3"/>
      </bsdf>
    </bsdf>
  </shape>
{SIDE_LIGHT}</scene>
"""
    volpath = '<integrator type="volpath"><integer name="max_depth" value="6"/></integrator>'
    yield "mask", header("mask", volpath, ("0, 4.5, 3.5", "0, 0, 0")) + """  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="2.5"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.8, 0.8"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="1"/><translate y="1"/></transform>
    <bsdf type="mask">
      <texture name="opacity" type="bitmap"><string name="filename" value="leaf.exr"/></texture>
      <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.6, 0.1"/></bsdf></bsdf>
    </bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" x="0" y="4" z="0"/><float name="radius" value="0.15"/>
    <emitter type="area"><rgb name="radiance" value="400, 400, 400"/></emitter>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="0.05, 0.05, 0.05"/></emitter>
</scene>
"""

    yield "mask_half", header("mask_half", volpath, ("0, 4.5, 3.5", "0, 0, 0")) + """  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale value="2.5"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.8, 0.8"/></bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale x="0.5" y="1" z="0.9"/><translate x="-0.65" y="1"/></transform>
    <bsdf type="mask">
      <float name="opacity" value="0.5"/>
      <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.6, 0.1"/></bsdf></bsdf>
    </bsdf>
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><rotate x="1" angle="-90"/><scale x="0.5" y="1" z="0.9"/><translate x="0.65" y="1"/></transform>
    <bsdf type="mask">
      <texture name="opacity" type="bitmap"><string name="filename" value="ramp.exr"/></texture>
      <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.2, 0.1"/></bsdf></bsdf>
    </bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" x="0" y="4" z="0"/><float name="radius" value="0.15"/>
    <emitter type="area"><rgb name="radiance" value="400, 400, 400"/></emitter>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="0.05, 0.05, 0.05"/></emitter>
</scene>
"""

    # anisotropic lobes along the surface's dp/du (Mitsuba's shading frame): a rectangle
    # turned about its normal (its u axis at 25° in the picture), principled on the left
    # half, roughconductor on the right; and a sphere seen from above its equator, the
    # principled lobe stretched along its parallels
    aniso = """<bsdf type="principled">
      <rgb name="base_color" value="0.8, 0.5, 0.3"/><float name="roughness" value="0.45"/>
      <float name="metallic" value="0.8"/><float name="anisotropic" value="0.9"/>
    </bsdf>"""
    key = """  <shape type="sphere">
    <point name="center" x="1.2" y="1.4" z="2.4"/><float name="radius" value="0.25"/>
    <emitter type="area"><rgb name="radiance" value="60, 60, 60"/></emitter>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="0.1, 0.1, 0.1"/></emitter>
"""
    front = """  <shape type="sphere">
    <point name="center" x="0.3" y="0.8" z="3.5"/><float name="radius" value="0.25"/>
    <emitter type="area"><rgb name="radiance" value="60, 60, 60"/></emitter>
  </shape>
  <emitter type="constant"><rgb name="radiance" value="0.1, 0.1, 0.1"/></emitter>
"""
    yield "aniso_rect", header("aniso_rect", PATH, ("0, 0, 3.0", "0, 0, 0")) + f"""  <shape type="rectangle">
    <transform name="to_world"><scale x="0.4" y="0.7"/><rotate z="1" angle="25"/><translate x="-0.7"/></transform>
    {aniso}
  </shape>
  <shape type="rectangle">
    <transform name="to_world"><scale x="0.4" y="0.7"/><rotate z="1" angle="25"/><translate x="0.7"/></transform>
    <bsdf type="roughconductor">
      <string name="distribution" value="ggx"/><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.4"/>
    </bsdf>
  </shape>
{front}</scene>
"""
    yield "aniso_sphere", header("aniso_sphere", PATH, ("0, 2.2, 2.2", "0, 0, 0")) + f"""  <shape type="sphere">
    <float name="radius" value="0.9"/>
    {aniso}
  </shape>
{key}</scene>
"""


def main():
    args = arguments(__doc__)
    mi = mitsuba(args.variant)
    os.makedirs(HERE, exist_ok=True)
    for name, img in [("heights", heights()), ("normals", normals()), ("leaf", leaf()), ("ramp", ramp())]:
        mi.Bitmap(img.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(os.path.join(HERE, f"{name}.exr"))
    for name, xml in scenes():
        if args.names and name not in args.names:
            continue
        path = os.path.join(HERE, f"{name}.xml")
        with open(path, "w") as f:
            f.write(xml)
        render_reference(mi, mi.load_file(path), HERE, name, args.passes, args.spp)


if __name__ == "__main__":
    main()
