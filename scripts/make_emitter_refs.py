#!/usr/bin/env python3
"""Regenerates the textured-emitter references in tests/refs/emitters/ with Mitsuba 3.

Three scenes, each <name>.xml (the Mitsuba scene, which rdr reads too), <name>.json (its
RDR171 twin), <name>.exr (the mean of K independent passes of Mitsuba's `path`, pass p
with seed p) and <name>.var.exr (per pixel and channel the variance of that mean):

* `spot_texture`: Mitsuba's `spot` with a `texture` (an 8×8 image projected over the cone);
* `projector`: Mitsuba's `projector` with a 12×6 `irradiance` image, `fov` 50 on x, `scale` 20;
* `area_texture`: a quad (quad.obj, with uv) whose `area` emitter's `radiance` is an 8×4
  image, seen by the camera and lighting the floor.

The images (<name>_tex.exr, linear) are asymmetric in u and v (a red ramp along u, a green
ramp along v, a blue checker), so a flipped or mirrored lookup changes the image.
The rest of the scene is tests/refs/lights' (a diffuse ball on a large diffuse sphere).

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_emitter_refs.py [--passes 8] [--spp 256] [NAME...]
"""
import json
import os

from mitsuba_refs import arguments, mitsuba, perspective_sensor, render_reference

RES = 32
MAX_DEPTH = 6
HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "emitters")

CAMERA = {"position": [0.0, 1.5, -4.5], "look_at": [0.0, -0.5, 0.0], "ref_up": [0.0, 1.0, 0.0], "fov": 35.0}
FLOOR = {"center": [0.0, -101.0, 0.0], "radius": 100.0, "albedo": [0.5, 0.5, 0.5]}
BALL = {"center": [-0.6, -0.5, 0.0], "radius": 0.5, "albedo": [0.8, 0.4, 0.2]}
NAMES = ["spot_texture", "projector", "area_texture"]
TEX_SIZE = {"spot_texture": (8, 8), "projector": (12, 6), "area_texture": (8, 4)}
TEX_GAIN = {"spot_texture": 1.0, "projector": 1.0, "area_texture": 1.0}

SPOT = {"position": [0.3, 3.0, 0.2], "look_at": [0.3, -1.0, 0.0], "ref_up": [1.0, 0.0, 0.0],
        "intensity": [30.0, 30.0, 30.0], "cutoff_angle": 30.0, "beam_width": 25.0}
PROJ = {"position": [0.0, 3.0, -0.5], "look_at": [0.0, -1.0, 0.3], "ref_up": [0.0, 0.0, 1.0],
        "scale": 20.0, "fov": 50.0}
QUAD_OBJ = """# a 2 x 1.2 quad at z = 1 facing -z (towards the camera), uv over [0, 1]^2
v -1 -0.6 1
v 1 -0.6 1
v 1 0.6 1
v -1 0.6 1
vt 0 0
vt 1 0
vt 1 1
vt 0 1
f 1/1 4/4 3/3 2/2
"""


def v(x):
    return ", ".join(str(float(c)) for c in x)


def texture_pixels(name):
    import numpy as np
    w, h = TEX_SIZE[name]
    img = np.zeros((h, w, 3), dtype=np.float32)
    for row in range(h):
        for col in range(w):
            img[row, col, 0] = 0.1 + 0.9 * (col + 0.5) / w          # red ramp along u
            img[row, col, 1] = 0.1 + 0.9 * (row + 0.5) / h          # green ramp down the rows
            img[row, col, 2] = 0.8 if (col // 2 + row // 2) % 2 == 0 else 0.1
    return img * TEX_GAIN[name]


def emitter_xml(name):
    tex = f'<texture type="bitmap" name="{{}}"><string name="filename" value="{name}_tex.exr"/></texture>'
    if name == "spot_texture":
        s = SPOT
        return (f'  <emitter type="spot"><transform name="to_world"><lookat origin="{v(s["position"])}" '
                f'target="{v(s["look_at"])}" up="{v(s["ref_up"])}"/></transform>'
                f'<rgb name="intensity" value="{v(s["intensity"])}"/>'
                f'<float name="cutoff_angle" value="{s["cutoff_angle"]}"/><float name="beam_width" value="{s["beam_width"]}"/>'
                + tex.format("texture") + '</emitter>')
    if name == "projector":
        s = PROJ
        return (f'  <emitter type="projector"><transform name="to_world"><lookat origin="{v(s["position"])}" '
                f'target="{v(s["look_at"])}" up="{v(s["ref_up"])}"/></transform>'
                f'<float name="scale" value="{s["scale"]}"/><float name="fov" value="{s["fov"]}"/>'
                + tex.format("irradiance") + '</emitter>')
    return (f'  <shape type="obj"><string name="filename" value="quad.obj"/>'
            f'<bsdf type="diffuse"><rgb name="reflectance" value="0, 0, 0"/></bsdf>'
            f'<emitter type="area">' + tex.format("radiance") + '</emitter></shape>')


def scene_xml(name):
    c = CAMERA
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/emitters/{name}: made by scripts/make_emitter_refs.py (do not edit; rerun it).
     {RES}x{RES}, box filter, path max_depth {MAX_DEPTH}; twin: {name}.json -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  <integrator type="path"><integer name="max_depth" value="{MAX_DEPTH}"/></integrator>
{perspective_sensor(c['fov'], v(c['position']), v(c['look_at']), v(c['ref_up']), RES)}
  <shape type="sphere">
    <point name="center" value="{v(FLOOR['center'])}"/><float name="radius" value="{FLOOR['radius']}"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="{v(FLOOR['albedo'])}"/></bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" value="{v(BALL['center'])}"/><float name="radius" value="{BALL['radius']}"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="{v(BALL['albedo'])}"/></bsdf>
  </shape>
{emitter_xml(name)}
</scene>
"""


def scene_json(name):
    tex = {"type": "image", "path": f"{name}_tex.exr", "filter": "bilinear",
           "tex_coordinate_generator": {"type": "uvmapping2d"}}
    textures = {"floor": {"type": "constant", "color": FLOOR["albedo"]},
                "ball": {"type": "constant", "color": BALL["albedo"]},
                "black": {"type": "constant", "color": [0.0, 0.0, 0.0]},
                "image": tex}
    objects = [
        {"type": "sphere", "center": FLOOR["center"], "radius": FLOOR["radius"], "material_name": "floor"},
        {"type": "sphere", "center": BALL["center"], "radius": BALL["radius"], "material_name": "ball"},
    ]
    lights = []
    if name == "spot_texture":
        lights.append(dict(SPOT, type="spot", texture="image"))
    elif name == "projector":
        lights.append(dict(PROJ, type="projector", irradiance="image"))
    else:
        objects.append({"type": "mesh", "path": "quad.obj", "material_name": "black",
                        "light": {"type": "area", "radiance": "image"}})
    return {
        "integrator": {"type": "path", "spp": 64, "max_depth": MAX_DEPTH, "lights": lights},
        "film": {"resolution": [RES, RES], "filter": {"type": "box", "radius": 0.5}},
        "camera": dict(CAMERA, focal_length=1.0),
        "textures": textures,
        "materials": {"floor": {"type": "diffuse", "texture_name": "floor"},
                      "ball": {"type": "diffuse", "texture_name": "ball"},
                      "black": {"type": "diffuse", "texture_name": "black"}},
        "objects": objects,
    }


def main():
    args = arguments(__doc__)
    mi = mitsuba(args.variant)
    os.makedirs(HERE, exist_ok=True)
    with open(os.path.join(HERE, "quad.obj"), "w") as f:
        f.write(QUAD_OBJ)
    for name in NAMES:
        if args.names and name not in args.names:
            continue
        mi.Bitmap(texture_pixels(name), mi.Bitmap.PixelFormat.RGB).write(os.path.join(HERE, f"{name}_tex.exr"))
        xml_path = os.path.join(HERE, f"{name}.xml")
        with open(xml_path, "w") as f:
            f.write(scene_xml(name))
        with open(os.path.join(HERE, f"{name}.json"), "w") as f:
            json.dump(scene_json(name), f, indent=1)
            f.write("\n")
        render_reference(mi, mi.load_file(xml_path), HERE, name, args.passes, args.spp)


if __name__ == "__main__":
    main()
