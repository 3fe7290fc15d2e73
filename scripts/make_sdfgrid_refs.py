#!/usr/bin/env python3
"""Regenerates the sdfgrid reference in tests/refs/shapes/ with Mitsuba 3.

sdfgrid.vol (a torus's signed distance sampled on a 16³ grid over the unit cube,
x fastest: the grid both renderers read), sdfgrid.xml (the Mitsuba scene, which
tests/sdfgrid.rs renders with rdr through its XML reader and through the JSON
`rdr convert` writes of it), sdfgrid.exr (the mean of K independent passes of
Mitsuba's `path` integrator, pass p with seed p) and sdfgrid.var.exr (per pixel and
channel the variance of that mean: the sample variance of the K pass images / K).

The scene: the grid twice on a diffuse floor, under a spherical light and a
constant sky, both rough conductors whose highlights show the normals: squashed by
a non-uniform scale with `smooth` normals (Mitsuba's default), and stretched upwards
with `analytic` normals, which show the facets of the interpolant's gradient. The scales differ per axis, so that
a normal carried to the world by the wrong transform shows.

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_sdfgrid_refs.py [--passes 8] [--spp 256]
"""
import os

from mitsuba_refs import arguments, floor_sphere, mitsuba, perspective_sensor, sphere_light_and_sky, write_and_render

RES = 64
MAX_DEPTH = 6
HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "shapes")

# samples along x, y, z: equal, as Mitsuba 3.9.1 misplaces the voxels of a grid whose
# x and z counts differ (its rays then miss the surface)
GRID = (16, 16, 16)
MAJOR, MINOR = 0.3, 0.14  # the torus's radii in the unit cube, its axis along y
CAMERA = {"position": [0.0, 1.9, -3.2], "look_at": [0.0, -0.45, 0.25], "ref_up": [0.0, 1.0, 0.0], "fov": 36.0}
FLOOR = {"center": [0.0, -101.0, 0.0], "radius": 100.0, "albedo": [0.5, 0.5, 0.5]}
LIGHT = {"center": [-1.5, 3.0, -1.5], "radius": 0.5, "radiance": [12.0, 11.0, 9.0]}
SKY = [0.15, 0.15, 0.2]


def v(x):
    return ", ".join(str(float(c)) for c in x)


def torus_grid(np):
    """The torus's distance at the samples, as a [z, y, x] array."""
    nx, ny, nz = GRID
    z, y, x = np.meshgrid(np.linspace(0, 1, nz), np.linspace(0, 1, ny), np.linspace(0, 1, nx), indexing="ij")
    ring = np.sqrt((x - 0.5) ** 2 + (z - 0.5) ** 2) - MAJOR
    return (np.sqrt(ring**2 + (y - 0.5) ** 2) - MINOR).astype(np.float32)


def scene_xml():
    c = CAMERA
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/shapes/sdfgrid: made by scripts/make_sdfgrid_refs.py (do not edit; rerun it).
     {RES}x{RES}, box filter, path max_depth {MAX_DEPTH} -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  <integrator type="path"><integer name="max_depth" value="{MAX_DEPTH}"/></integrator>
{perspective_sensor(c['fov'], v(c['position']), v(c['look_at']), v(c['ref_up']), RES)}
{floor_sphere(FLOOR)}
  <shape type="sdfgrid">
    <string name="filename" value="sdfgrid.vol"/>
    <transform name="to_world"><scale x="1.8" y="0.9" z="1.5"/><translate x="-1.75" y="-1.0" z="-0.5"/></transform>
    <bsdf type="roughconductor"><string name="material" value="Cu"/><float name="alpha" value="0.12"/></bsdf>
  </shape>
  <shape type="sdfgrid">
    <string name="filename" value="sdfgrid.vol"/>
    <string name="normals" value="analytic"/>
    <transform name="to_world"><scale x="1.2" y="1.4" z="1.2"/><translate x="0.35" y="-0.75" z="-0.3"/></transform>
    <bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.2"/></bsdf>
  </shape>
{sphere_light_and_sky(v(LIGHT['center']), LIGHT['radius'], v(LIGHT['radiance']), v(SKY))}
</scene>
"""


def main():
    args = arguments(__doc__, names=False)
    mi = mitsuba(args.variant)
    import numpy as np

    os.makedirs(HERE, exist_ok=True)
    mi.VolumeGrid(torus_grid(np)[..., None]).write(os.path.join(HERE, "sdfgrid.vol"))
    write_and_render(mi, HERE, "sdfgrid", scene_xml(), args.passes, args.spp)


if __name__ == "__main__":
    main()
