#!/usr/bin/env python3
"""Regenerates the mesh attribute reference in tests/refs/shapes/ with Mitsuba 3.

mesh_attribute.ply (a bumpy 6×6 grid whose properties make attributes by Mitsuba's PLY
rules: per vertex `tint_r tint_g tint_b` -> vertex_tint_color, `shade_x` ->
vertex_shade (one channel); per face `r g b` -> face_color, `rough_1` -> face_rough
(one channel), plus `quality`, which names no attribute), mesh_attribute.xml (three
copies of it: a diffuse reading vertex_tint_color, a diffuse reading the grey
vertex_shade scaled by 0.9, a rough conductor whose roughness is face_rough and whose
specular reflectance is face_color; lit by a small sphere and a dim sky), and
mesh_attribute.exr / .var.exr (the mean of K passes of Mitsuba's `path`, pass p with
seed p, and the variance of that mean). tests/mesh_attribute.rs renders the XML with rdr.

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_mesh_attribute_refs.py [--passes 8] [--spp 256]
"""
import math
import os

from mitsuba_refs import arguments, mitsuba, perspective_sensor, sphere_light_and_sky, write_and_render

RES = 64
N = 6  # vertices per side
HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "shapes")


def ply_text():
    verts, faces = [], []
    for j in range(N):
        for i in range(N):
            x, y = -1 + 2 * i / (N - 1), -1 + 2 * j / (N - 1)
            z = 0.15 * math.sin(2.1 * x + 0.7) * math.cos(1.7 * y)
            tint = (0.1 + 0.8 * i / (N - 1), 0.1 + 0.8 * j / (N - 1), 0.9 - 0.4 * ((i + j) % 3) / 2)
            shade = 0.15 + 0.8 * ((i * 7 + j * 3) % N) / (N - 1)
            verts.append(f"{x:.6f} {y:.6f} {z:.6f} {tint[0]:.4f} {tint[1]:.4f} {tint[2]:.4f} {shade:.4f} {i + j}")
    for j in range(N - 1):
        for i in range(N - 1):
            a, b, c, d = j * N + i, j * N + i + 1, (j + 1) * N + i + 1, (j + 1) * N + i
            k = j * (N - 1) + i
            rgb = (0.3 + 0.6 * (k % 3) / 2, 0.3 + 0.6 * (k % 4) / 3, 0.9 - 0.5 * (k % 5) / 4)
            rough = 0.03 + 0.4 * ((k * 5) % 7) / 6
            # two triangles per quad, with the same values (Mitsuba reads triangles only)
            for tri in ((a, b, c), (a, c, d)):
                faces.append(f"3 {tri[0]} {tri[1]} {tri[2]} {rgb[0]:.4f} {rgb[1]:.4f} {rgb[2]:.4f} {rough:.4f}")
    head = [
        "ply", "format ascii 1.0", "comment tests/refs/shapes/mesh_attribute: made by scripts/make_mesh_attribute_refs.py",
        f"element vertex {N * N}", "property float x", "property float y", "property float z",
        "property float tint_r", "property float tint_g", "property float tint_b", "property float shade_x",
        "property float quality",
        f"element face {2 * (N - 1) ** 2}", "property list uchar int vertex_indices",
        "property float r", "property float g", "property float b", "property float rough_1", "end_header",
    ]
    return "\n".join(head + verts + faces) + "\n"


def shape(to_world, bsdf):
    return f"""  <shape type="ply">
    <string name="filename" value="mesh_attribute.ply"/>
    <transform name="to_world">{to_world}</transform>
    {bsdf}
  </shape>"""


def scene_xml():
    tint = '<bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_tint_color"/></texture></bsdf>'
    shade = ('<bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"><string name="name" value="vertex_shade"/>'
             '<float name="scale" value="0.9"/></texture></bsdf>')
    metal = ('<bsdf type="roughconductor"><string name="material" value="Al"/>'
             '<texture type="mesh_attribute" name="alpha"><string name="name" value="face_rough"/></texture>'
             '<texture type="mesh_attribute" name="specular_reflectance"><string name="name" value="face_color"/></texture></bsdf>')
    shapes = "\n".join([
        shape('<translate x="-1.1" y="1.1" z="0"/>', tint),
        shape('<translate x="1.1" y="1.1" z="0"/>', shade),
        shape('<translate x="0" y="-1.1" z="0"/>', metal),
    ])
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/shapes/mesh_attribute: made by scripts/make_mesh_attribute_refs.py (do not edit; rerun it).
     {RES}x{RES}, box filter, path max_depth 4 -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  <integrator type="path"><integer name="max_depth" value="4"/></integrator>
{perspective_sensor(45, "0, -3, 6", "0, 0, 0", "0, 1, 0", RES)}
{shapes}
{sphere_light_and_sky("0.6, 0.1, 3", 0.4, "12, 11, 10", "0.15, 0.15, 0.2")}
</scene>
"""


def main():
    args = arguments(__doc__, names=False)
    mi = mitsuba(args.variant)
    os.makedirs(HERE, exist_ok=True)
    with open(os.path.join(HERE, "mesh_attribute.ply"), "w") as f:
        f.write(ply_text())
    write_and_render(mi, HERE, "mesh_attribute", scene_xml(), args.passes, args.spp)


if __name__ == "__main__":
    main()
