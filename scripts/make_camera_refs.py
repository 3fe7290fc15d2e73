#!/usr/bin/env python3
"""Mitsuba 3 references for the camera tests (tests/cameras.rs): the shared Cornell box
(../shared/refs/mitsuba/cbox_path.xml) seen through a thin lens and an orthographic camera,
64x64, `path` with max_depth 12. Writes tests/refs/cameras/<name>.xml (the scene as rendered),
<name>.exr (the mean of K passes of independent seeds) and <name>.var.exr (the variance of
that mean), as ../shared/refs/README.md describes for the shared references.

  python3 -m venv venv && venv/bin/pip install mitsuba numpy
  DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 venv/bin/python scripts/make_camera_refs.py

An oracle for the tests, never run by them or by CI."""
import os
import re
import sys

from mitsuba_refs import mitsuba, render_reference

here = os.path.dirname(os.path.abspath(__file__))
out_dir = os.path.join(here, "..", "tests", "refs", "cameras")
shared = os.path.join(here, "..", "..", "shared")
PASSES, SPP = 8, 1024

SENSORS = {
    # focus on the plane 6 units ahead (the tall box's front); the back wall (7.8) blurs
    "cbox_thinlens": """<sensor type="thinlens">
    <float name="fov" value="19.5"/>
    <string name="fov_axis" value="y"/>
    <float name="aperture_radius" value="0.1"/>
    <float name="focus_distance" value="6.0"/>
    <transform name="to_world">
      <lookat origin="0, 1, 6.8" target="0, 1, 0" up="0, 1, 0"/>
    </transform>
    FILM
  </sensor>""",
    # a 2.2-unit window: camera space [-1, 1]² scaled by 1.1
    "cbox_ortho": """<sensor type="orthographic">
    <transform name="to_world">
      <scale value="1.1"/>
      <lookat origin="0, 1, 6.8" target="0, 1, 0" up="0, 1, 0"/>
    </transform>
    FILM
  </sensor>""",
}
FILM = """<film type="hdrfilm">
      <integer name="width" value="64"/>
      <integer name="height" value="64"/>
      <string name="pixel_format" value="rgb"/>
      <rfilter type="box"/>
    </film>
    <sampler type="independent">
      <integer name="sample_count" value="$spp"/>
    </sampler>"""


def main():
    mi = mitsuba("llvm_ad_rgb" if os.environ.get("DRJIT_LIBLLVM_PATH") else "scalar_rgb")
    base = open(os.path.join(shared, "refs", "mitsuba", "cbox_path.xml")).read()
    # the shared meshes, seen from tests/refs/cameras/
    base = base.replace('value="../../scenes/', 'value="../../../../shared/scenes/')
    names = sys.argv[1:] or list(SENSORS)
    for name in names:
        xml = re.sub(r"<sensor .*?</sensor>", SENSORS[name].replace("FILM", FILM), base, flags=re.S)
        xml = xml.replace('<default name="res" value="256"/>', "")
        path = os.path.join(out_dir, name + ".xml")
        open(path, "w").write(xml)
        render_reference(mi, mi.load_file(path, spp=SPP), out_dir, name, PASSES, SPP)

if __name__ == "__main__":
    main()
