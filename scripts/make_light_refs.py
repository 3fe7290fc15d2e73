#!/usr/bin/env python3
"""Regenerates the delta-light references in tests/refs/lights/ with Mitsuba 3.

For each emitter (`spot`, `directional`): <name>.xml (the Mitsuba scene), <name>.json (its
RDR171 twin, which tests/delta_lights.rs renders with rdr), <name>.exr (the mean of K
independent passes of Mitsuba's `path` integrator, pass p with seed p) and <name>.var.exr
(per pixel and channel the variance of that mean: the sample variance of the K pass
images / K, as ../shared/refs/README.md describes).

The scene: a diffuse sphere on a diffuse floor (a large sphere) lit only by the emitter;
the spot's beam edge and falloff lie on the floor in view. `directional_small` is
`directional` with a small floor (a sphere of radius 2.5 whose top is where the large
one's is): the scene's bounding sphere, which a directional light's rays start from in
the integrators that trace from the lights, is then a few units across rather than 200.

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_light_refs.py [--passes 8] [--spp 256] [NAME...]
"""
import json
import os

from mitsuba_refs import arguments, mitsuba, perspective_sensor, render_reference

RES = 32
MAX_DEPTH = 8
HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "lights")

CAMERA = {"position": [0.0, 1.5, -4.5], "look_at": [0.0, -0.5, 0.0], "ref_up": [0.0, 1.0, 0.0], "fov": 35.0}
FLOOR = {"center": [0.0, -101.0, 0.0], "radius": 100.0, "albedo": [0.5, 0.5, 0.5]}
SMALL_FLOOR = {"center": [0.0, -3.5, 0.0], "radius": 2.5, "albedo": [0.5, 0.5, 0.5]}
NAMES = ["spot", "directional", "directional_small"]


def floor(name):
    return SMALL_FLOOR if name.endswith("_small") else FLOOR
BALL = {"center": [-0.6, -0.5, 0.0], "radius": 0.5, "albedo": [0.8, 0.4, 0.2]}

SPOT = {"position": [0.3, 3.0, 0.2], "look_at": [0.3, -1.0, 0.0], "intensity": [30.0, 30.0, 30.0],
        "cutoff_angle": 20.0, "beam_width": 10.0}
DIRECTIONAL = {"direction": [1.0, -2.0, 0.5], "irradiance": [2.0, 2.0, 2.0]}


def v(x):
    return ", ".join(str(float(c)) for c in x)


def emitter_xml(name):
    if name == "spot":
        s = SPOT
        return (f'  <emitter type="spot"><transform name="to_world"><lookat origin="{v(s["position"])}" '
                f'target="{v(s["look_at"])}" up="1, 0, 0"/></transform>'
                f'<rgb name="intensity" value="{v(s["intensity"])}"/>'
                f'<float name="cutoff_angle" value="{s["cutoff_angle"]}"/><float name="beam_width" value="{s["beam_width"]}"/></emitter>')
    d = DIRECTIONAL  # directional, directional_small
    return (f'  <emitter type="directional"><vector name="direction" value="{v(d["direction"])}"/>'
            f'<rgb name="irradiance" value="{v(d["irradiance"])}"/></emitter>')


def scene_xml(name):
    c = CAMERA
    fl = floor(name)
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/lights/{name}: made by scripts/make_light_refs.py (do not edit; rerun it).
     {RES}x{RES}, box filter, path max_depth {MAX_DEPTH}; twin: {name}.json -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  <integrator type="path"><integer name="max_depth" value="{MAX_DEPTH}"/></integrator>
{perspective_sensor(c['fov'], v(c['position']), v(c['look_at']), v(c['ref_up']), RES)}
  <shape type="sphere">
    <point name="center" value="{v(fl['center'])}"/><float name="radius" value="{fl['radius']}"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="{v(fl['albedo'])}"/></bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" value="{v(BALL['center'])}"/><float name="radius" value="{BALL['radius']}"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="{v(BALL['albedo'])}"/></bsdf>
  </shape>
{emitter_xml(name)}
</scene>
"""


def scene_json(name):
    light = dict(SPOT, type="spot") if name == "spot" else dict(DIRECTIONAL, type="directional")
    fl = floor(name)
    return {
        "integrator": {"type": "path", "spp": 64, "max_depth": MAX_DEPTH, "lights": [light]},
        "film": {"resolution": [RES, RES], "filter": {"type": "box", "radius": 0.5}},
        "camera": dict(CAMERA, focal_length=1.0),
        "textures": {"floor": {"type": "constant", "color": fl["albedo"]},
                     "ball": {"type": "constant", "color": BALL["albedo"]}},
        "materials": {"floor": {"type": "diffuse", "texture_name": "floor"},
                      "ball": {"type": "diffuse", "texture_name": "ball"}},
        "objects": [
            {"type": "sphere", "center": fl["center"], "radius": fl["radius"], "material_name": "floor"},
            {"type": "sphere", "center": BALL["center"], "radius": BALL["radius"], "material_name": "ball"},
        ],
    }


def main():
    args = arguments(__doc__)
    mi = mitsuba(args.variant)
    os.makedirs(HERE, exist_ok=True)
    for name in NAMES:
        if args.names and name not in args.names:
            continue
        xml_path = os.path.join(HERE, f"{name}.xml")
        with open(xml_path, "w") as f:
            f.write(scene_xml(name))
        with open(os.path.join(HERE, f"{name}.json"), "w") as f:
            json.dump(scene_json(name), f, indent=1)
            f.write("\n")
        render_reference(mi, mi.load_file(xml_path), HERE, name, args.passes, args.spp)


if __name__ == "__main__":
    main()
