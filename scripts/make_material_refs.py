#!/usr/bin/env python3
"""Regenerates the material references in tests/refs/materials/ with Mitsuba 3.

For each material: <name>.xml (the Mitsuba scene), <name>.json (its RDR171 twin, which
tests/materials_render.rs renders with rdr), <name>.exr (the mean of K independent passes
of Mitsuba's `path` integrator, pass p with seed p) and <name>.var.exr (per pixel and
channel the variance of that mean: the sample variance of the K pass images / K, as
../shared/refs/README.md describes).

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_material_refs.py [--passes 8] [--spp 256] [NAME...]
"""
import json
import os

from mitsuba_refs import arguments, mitsuba, perspective_sensor, render_reference

RES = 32
# the principled and blendbsdf scenes (tests/principled.rs) are 64×64
RES_LARGE = 64
MAX_DEPTH = 8
HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "materials")

# the scene around each material: a unit sphere at the origin on a large diffuse
# sphere (the floor), lit by a small emitting sphere and a constant sky
CAMERA = {"position": [0.0, 0.6, -4.5], "look_at": [0.0, 0.0, 0.0], "ref_up": [0.0, 1.0, 0.0], "fov": 30.0}
LIGHT = {"center": [2.0, 3.0, -2.0], "radius": 0.5, "radiance": [20.0, 20.0, 20.0]}
SKY = [0.3, 0.3, 0.3]
FLOOR = {"center": [0.0, -101.0, 0.0], "radius": 100.0, "albedo": [0.5, 0.5, 0.5]}

GOLD_ETA = [0.143, 0.374, 1.442]
GOLD_K = [3.983, 2.385, 1.603]
CU_ETA = [0.20365, 0.92203, 1.1017]
CU_K = [3.8845, 2.4632, 2.1396]

# name: (Mitsuba <bsdf> XML, rdr material JSON, extra rdr textures)
MATERIALS = {
    "conductor": (
        f'<bsdf type="conductor"><rgb name="eta" value="{GOLD_ETA[0]}, {GOLD_ETA[1]}, {GOLD_ETA[2]}"/>'
        f'<rgb name="k" value="{GOLD_K[0]}, {GOLD_K[1]}, {GOLD_K[2]}"/></bsdf>',
        {"type": "conductor", "eta": GOLD_ETA, "k": GOLD_K},
        {},
    ),
    # a named conductor: Mitsuba reads its own spectral table; the JSON twin has rdr's
    # row for "Cu" (src/desc/xml/values.rs NAMED_CONDUCTORS), so rdr rendering the XML
    # checks that row against Mitsuba
    "conductor_cu": (
        '<bsdf type="conductor"><string name="material" value="Cu"/></bsdf>',
        {"type": "conductor", "eta": CU_ETA, "k": CU_K},
        {},
    ),
    "thindielectric": (
        '<bsdf type="thindielectric"><float name="int_ior" value="1.5"/><float name="ext_ior" value="1.0"/></bsdf>',
        {"type": "thindielectric", "eta": 1.5},
        {},
    ),
    "roughdielectric": (
        '<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/>'
        '<float name="int_ior" value="1.5"/><float name="ext_ior" value="1.0"/></bsdf>',
        {"type": "roughdielectric", "distribution": "ggx", "alpha_x": 0.2, "alpha_y": 0.2, "eta": 1.5},
        {},
    ),
    "plastic": (
        '<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.8, 0.3, 0.1"/>'
        '<float name="int_ior" value="1.49"/><float name="ext_ior" value="1.0"/></bsdf>',
        {"type": "plastic", "texture_name": "albedo", "eta": 1.49},
        {"albedo": [0.8, 0.3, 0.1]},
    ),
    "roughplastic": (
        '<bsdf type="roughplastic"><string name="distribution" value="beckmann"/><float name="alpha" value="0.15"/>'
        '<rgb name="diffuse_reflectance" value="0.1, 0.3, 0.8"/>'
        '<float name="int_ior" value="1.5"/><float name="ext_ior" value="1.0"/></bsdf>',
        {"type": "roughplastic", "distribution": "beckmann", "alpha": 0.15, "texture_name": "albedo", "eta": 1.5},
        {"albedo": [0.1, 0.3, 0.8]},
    ),
}

# principled and blendbsdf (rendered by tests/principled.rs); a checkerboard in Mitsuba's
# (u, v) is, in rdr's v (which runs the other way), scale (sx, −sy) and delta (0, sy)
CHECKER_XML = ('<texture type="checkerboard" name="{key}"><float name="color0" value="{a}"/>'
               '<float name="color1" value="{b}"/><transform name="to_uv"><scale x="4" y="4"/></transform></texture>')


def checker_json(a, b):
    # read as a float (a weight, a roughness), Mitsuba's checkerboard (its eval_1) has the
    # colours the other way round from its eval, which rdr's checkerboard follows
    return {"type": "checkerboard", "color0": [b, b, b], "color1": [a, a, a],
            "tex_coordinate_generator": {"type": "uvmapping2d", "scale": [4, -4], "delta": [0, 4]}}


LARGE = {
    "principled_coat": (
        '<bsdf type="principled"><rgb name="base_color" value="0.8, 0.3, 0.1"/><float name="roughness" value="0.4"/>'
        '<float name="metallic" value="0.3"/><float name="clearcoat" value="0.8"/><float name="clearcoat_gloss" value="0.6"/>'
        '<float name="sheen" value="0.5"/><float name="sheen_tint" value="0.5"/><float name="spec_tint" value="0.4"/></bsdf>',
        {"type": "principled", "base_color": [0.8, 0.3, 0.1], "roughness": 0.4, "metallic": 0.3, "clearcoat": 0.8,
         "clearcoat_gloss": 0.6, "sheen": 0.5, "sheen_tint": 0.5, "spec_tint": 0.4},
        {},
    ),
    "principled_glass": (
        '<bsdf type="principled"><rgb name="base_color" value="0.9, 0.95, 1.0"/>'
        + CHECKER_XML.format(key="roughness", a=0.2, b=0.6)
        + '<float name="spec_trans" value="0.8"/><float name="eta" value="1.4"/></bsdf>',
        {"type": "principled", "base_color": [0.9, 0.95, 1.0], "roughness": "rough", "spec_trans": 0.8, "eta": 1.4},
        {"rough": checker_json(0.2, 0.6)},
    ),
    # black base and specular 0 (η = 1: no main specular lobe), so the sphere shows the
    # clearcoat and the sheen alone: what the deliberate-error runs of tests/principled.rs
    # need to be seen
    "principled_sheen_coat": (
        '<bsdf type="principled"><rgb name="base_color" value="0, 0, 0"/><float name="specular" value="0"/>'
        '<float name="clearcoat" value="1"/><float name="clearcoat_gloss" value="0.3"/><float name="sheen" value="1"/></bsdf>',
        {"type": "principled", "base_color": 0, "specular": 0, "clearcoat": 1, "clearcoat_gloss": 0.3, "sheen": 1},
        {},
    ),
    # a thin shell: specular and diffuse transmission through both faces
    "principledthin": (
        '<bsdf type="principledthin"><rgb name="base_color" value="0.3, 0.7, 0.2"/><float name="roughness" value="0.4"/>'
        '<float name="spec_trans" value="0.5"/><float name="diff_trans" value="1.0"/><float name="eta" value="1.4"/>'
        '<float name="sheen" value="0.5"/></bsdf>',
        {"type": "principledthin", "base_color": [0.3, 0.7, 0.2], "roughness": 0.4, "spec_trans": 0.5, "diff_trans": 1.0,
         "eta": 1.4, "sheen": 0.5},
        {},
    ),
    "blendbsdf": (
        '<bsdf type="blendbsdf">' + CHECKER_XML.format(key="weight", a=0.1, b=0.9)
        + '<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/>'
        '<rgb name="diffuse_reflectance" value="0.7, 0.1, 0.1"/><float name="int_ior" value="1.5"/><float name="ext_ior" value="1.0"/></bsdf>'
        '<bsdf type="principled"><rgb name="base_color" value="0.9, 0.7, 0.3"/><float name="metallic" value="1"/>'
        '<float name="roughness" value="0.3"/></bsdf></bsdf>',
        {"type": "blendbsdf", "weight": "w", "material_names": ["plastic", "metal"]},
        {"w": checker_json(0.1, 0.9)},
    ),
}
# textured roughness (64×64, rendered by tests/materials_render.rs from the XML, which is
# what it checks: Mitsuba's float textures on roughconductor and roughdielectric; no JSON twin)
RAMP_XML = ('<texture type="bitmap" name="{key}"><string name="filename" value="../bump/ramp.exr"/>'
            '<boolean name="raw" value="true"/></texture>')
XML_ONLY = {
    # anisotropic: alpha_u a checkerboard, alpha_v a bitmap (a ramp 0 → 1 along u)
    "rough_textured_conductor": (
        '<bsdf type="roughconductor"><string name="distribution" value="ggx"/>'
        + CHECKER_XML.format(key="alpha_u", a=0.03, b=0.4) + RAMP_XML.format(key="alpha_v")
        + f'<rgb name="eta" value="{CU_ETA[0]}, {CU_ETA[1]}, {CU_ETA[2]}"/>'
        f'<rgb name="k" value="{CU_K[0]}, {CU_K[1]}, {CU_K[2]}"/></bsdf>'
    ),
    # isotropic: alpha a checkerboard
    "rough_textured_dielectric": (
        '<bsdf type="roughdielectric"><string name="distribution" value="beckmann"/>'
        + CHECKER_XML.format(key="alpha", a=0.02, b=0.5)
        + '<float name="int_ior" value="1.5"/><float name="ext_ior" value="1.0"/></bsdf>'
    ),
}
BLEND_PARTS = {
    "plastic": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.2, "texture_name": "red", "eta": 1.5},
    "metal": {"type": "principled", "base_color": [0.9, 0.7, 0.3], "metallic": 1, "roughness": 0.3},
}

# twosided: two unit quads (quad.obj), one turned to the camera, one away from it
TWOSIDED_XML = (
    '<bsdf type="twosided"><bsdf type="roughplastic"><string name="distribution" value="ggx"/>'
    '<float name="alpha" value="0.3"/><rgb name="diffuse_reflectance" value="0.8, 0.2, 0.2"/>'
    '<float name="int_ior" value="1.5"/><float name="ext_ior" value="1.0"/></bsdf>'
    '<bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.7, 0.2"/></bsdf></bsdf>'
)
QUADS = [
    # row-major 4×4 placing quad.obj (the unit square in xy, normal +z) : facing −z (camera) or +z
    ("front", [-1, 0, 0, -0.6, 0, 1, 0, 0.0, 0, 0, -1, 0, 0, 0, 0, 1]),
    ("back", [1, 0, 0, 0.6, 0, 1, 0, 0.0, 0, 0, 1, 0, 0, 0, 0, 1]),
]
QUAD_OBJ = "v -0.5 -0.5 0\nv 0.5 -0.5 0\nv 0.5 0.5 0\nv -0.5 0.5 0\nf 1 2 3 4\n"


def xml_matrix(m):
    return ", ".join(str(float(x)) for x in m)


def scene_xml(name, shapes_xml, res=RES):
    c = CAMERA
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/materials/{name}: made by scripts/make_material_refs.py (do not edit; rerun it).
     {res}x{res}, box filter, path max_depth {MAX_DEPTH}; twin: {name}.json -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  <integrator type="path"><integer name="max_depth" value="{MAX_DEPTH}"/></integrator>
{perspective_sensor(c['fov'], *(', '.join(map(str, c[k])) for k in ('position', 'look_at', 'ref_up')), res)}
  <shape type="sphere">
    <point name="center" x="{LIGHT['center'][0]}" y="{LIGHT['center'][1]}" z="{LIGHT['center'][2]}"/>
    <float name="radius" value="{LIGHT['radius']}"/>
    <emitter type="area"><rgb name="radiance" value="{', '.join(map(str, LIGHT['radiance']))}"/></emitter>
  </shape>
  <shape type="sphere">
    <point name="center" x="{FLOOR['center'][0]}" y="{FLOOR['center'][1]}" z="{FLOOR['center'][2]}"/>
    <float name="radius" value="{FLOOR['radius']}"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="{', '.join(map(str, FLOOR['albedo']))}"/></bsdf>
  </shape>
{shapes_xml}
  <emitter type="constant"><rgb name="radiance" value="{', '.join(map(str, SKY))}"/></emitter>
</scene>
"""


def scene_json(material, textures, objects, res=RES):
    tex = {"floor": {"type": "constant", "color": FLOOR["albedo"]}, "sky": {"type": "constant", "color": SKY}}
    tex.update({k: v if isinstance(v, dict) else {"type": "constant", "color": v} for k, v in textures.items()})
    mats = {"floor": {"type": "diffuse", "texture_name": "floor"}}
    mats.update(material)
    objs = [
        {"type": "sphere", "center": LIGHT["center"], "radius": LIGHT["radius"],
         "light": {"type": "area", "radiance": LIGHT["radiance"]}},
        {"type": "sphere", "center": FLOOR["center"], "radius": FLOOR["radius"], "material_name": "floor"},
    ] + objects
    return {
        # no point light: without "lights" RDR171 JSON has a default one, which Mitsuba has not
        "integrator": {"type": "path", "spp": 64, "max_depth": MAX_DEPTH, "lights": []},
        "film": {"resolution": [res, res], "filter": {"type": "box", "radius": 0.5}},
        "camera": dict(CAMERA, focal_length=1.0),
        "textures": tex,
        "materials": mats,
        "environment_map": {"texture_name": "sky"},
        "objects": objs,
    }


def scenes():
    for name, (bsdf, mat, textures) in MATERIALS.items():
        shapes = f'  <shape type="sphere"><point name="center" x="0" y="0" z="0"/><float name="radius" value="1"/>{bsdf}</shape>'
        yield name, scene_xml(name, shapes), scene_json({"m": mat}, textures,
                                                         [{"type": "sphere", "center": [0, 0, 0], "radius": 1, "material_name": "m"}])
    for name, (bsdf, mat, textures) in LARGE.items():
        shapes = f'  <shape type="sphere"><point name="center" x="0" y="0" z="0"/><float name="radius" value="1"/>{bsdf}</shape>'
        mats = {"m": mat}
        if name == "blendbsdf":
            mats.update(BLEND_PARTS)
            textures = dict(textures, red=[0.7, 0.1, 0.1])
        sphere = {"type": "sphere", "center": [0, 0, 0], "radius": 1, "material_name": "m"}
        if "checkerboard" in json.dumps(textures):
            # Mitsuba's uv on the sphere (as rdr reads XML spheres), for the checkerboard
            sphere["uv_frame"] = [1, 0, 0, 0, 1, 0, 0, 0, 1]
        yield name, scene_xml(name, shapes, RES_LARGE), scene_json(mats, textures, [sphere], RES_LARGE)
    shapes = "\n".join(
        f'  <shape type="obj"><string name="filename" value="quad.obj"/>'
        f'<transform name="to_world"><matrix value="{xml_matrix(m)}"/></transform>{TWOSIDED_XML}</shape>'
        for _, m in QUADS
    )
    mats = {
        "red": {"type": "roughplastic", "distribution": "ggx", "alpha": 0.3, "texture_name": "red", "eta": 1.5},
        "green": {"type": "diffuse", "texture_name": "green"},
        "m": {"type": "twosided", "material_name": "red", "back_material_name": "green"},
    }
    objs = [{"type": "mesh", "path": "quad.obj", "transform": m, "material_name": "m"} for _, m in QUADS]
    yield "twosided", scene_xml("twosided", shapes), scene_json(mats, {"red": [0.8, 0.2, 0.2], "green": [0.2, 0.7, 0.2]}, objs)


def main():
    args = arguments(__doc__)
    mi = mitsuba(args.variant)
    with open(os.path.join(HERE, "quad.obj"), "w") as f:
        f.write(QUAD_OBJ)
    for name, bsdf in XML_ONLY.items():
        if args.names and name not in args.names:
            continue
        shapes = f'  <shape type="sphere"><point name="center" x="0" y="0" z="0"/><float name="radius" value="1"/>{bsdf}</shape>'
        xml_path = os.path.join(HERE, f"{name}.xml")
        with open(xml_path, "w") as f:
            f.write(scene_xml(name, shapes, RES_LARGE).replace(f"; twin: {name}.json", "; no JSON twin"))
        render_reference(mi, mi.load_file(xml_path), HERE, name, args.passes, args.spp)
    for name, xml, js in scenes():
        if args.names and name not in args.names:
            continue
        xml_path = os.path.join(HERE, f"{name}.xml")
        with open(xml_path, "w") as f:
            f.write(xml)
        with open(os.path.join(HERE, f"{name}.json"), "w") as f:
            json.dump(js, f, indent=1)
            f.write("\n")
        render_reference(mi, mi.load_file(xml_path), HERE, name, args.passes, args.spp)


if __name__ == "__main__":
    main()
