#!/usr/bin/env python3
"""Regenerates the `sunsky` references in tests/refs/sunsky/ with Mitsuba 3.

Each <name>.xml (the Mitsuba scene, which rdr reads too) with <name>.exr (the mean of K
independent passes of Mitsuba's `path`, pass p with seed p) and <name>.var.exr (per pixel
and channel the variance of that mean), as scripts/mitsuba_refs.py makes them:

* `sunsky`: a diffuse ground (a 20 × 20 rectangle at z = 0) and ball under a sunsky with
  `sun_direction`, turbidity 4, a coloured ground albedo, 64×48;
* `sky_up`: the sky alone (`sun_scale` 0) seen by a wide camera looking up, the sun placed
  by Mitsuba's default place and time with the hour 10, turbidity 6, and a `to_world`
  that turns the sky's +z to the world's +y (a camera at the origin, nothing else).

Run from the repository root with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_sunsky_refs.py [--passes 8] [--spp 256] [NAME...]
"""
import os

from mitsuba_refs import arguments, mitsuba, render_reference

HERE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "refs", "sunsky")
NAMES = ["sunsky", "sky_up"]


def sensor(fov, origin, target, up, w, h):
    return f"""  <sensor type="perspective">
    <float name="fov" value="{fov}"/>
    <string name="fov_axis" value="x"/>
    <transform name="to_world"><lookat origin="{origin}" target="{target}" up="{up}"/></transform>
    <film type="hdrfilm">
      <integer name="width" value="{w}"/><integer name="height" value="{h}"/>
      <string name="pixel_format" value="rgb"/><rfilter type="box"/>
    </film>
    <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
  </sensor>"""


def scene_xml(name):
    if name == "sunsky":
        body = f"""{sensor(40, "4.5, -5.5, 2.6", "0, 0, 0.6", "0, 0, 1", 64, 48)}
  <shape type="rectangle">
    <transform name="to_world"><scale value="10"/></transform>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.45, 0.4"/></bsdf>
  </shape>
  <shape type="sphere">
    <point name="center" value="0, 0, 1"/><float name="radius" value="1"/>
    <bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.7, 0.7"/></bsdf>
  </shape>
  <emitter type="sunsky">
    <vector name="sun_direction" x="-0.5" y="-0.3" z="0.45"/>
    <float name="turbidity" value="4"/>
    <rgb name="albedo" value="0.2, 0.3, 0.15"/>
  </emitter>"""
    else:
        body = f"""{sensor(120, "0, 0, 0", "0, 1, 0", "0, 0, 1", 64, 48)}
  <emitter type="sunsky">
    <float name="hour" value="10"/>
    <float name="turbidity" value="6"/>
    <float name="sun_scale" value="0"/>
    <transform name="to_world"><rotate x="1" angle="-90"/></transform>
  </emitter>"""
    return f"""<?xml version="1.0" encoding="utf-8"?>
<!-- tests/refs/sunsky/{name}: made by scripts/make_sunsky_refs.py (do not edit; rerun it). -->
<scene version="3.0.0">
  <default name="spp" value="256"/>
  <integrator type="path"><integer name="max_depth" value="6"/></integrator>
{body}
</scene>
"""


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
        render_reference(mi, mi.load_file(xml_path), HERE, name, args.passes, args.spp)


if __name__ == "__main__":
    main()
