#!/usr/bin/env python3
"""Renders refs/mitsuba/SCENE.xml once at SPP with Mitsuba 3's LLVM variant on one thread, for
scripts/instructions-per-sample.sh to count under callgrind. An oracle run by hand, never by tests
or CI; setup as in scripts/mitsuba_time.py.

Usage: /work/venv-mi/bin/python scripts/mitsuba_render_once.py SCENE SPP [--llvm-target haswell:8]
"""
import argparse, os, sys

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

ap = argparse.ArgumentParser()
ap.add_argument("scene")
ap.add_argument("spp", type=int)
ap.add_argument("--llvm-target", default="haswell:8")
ap.add_argument("--shared", default=os.path.join(HERE, "..", "..", "shared"))
a = ap.parse_args()

import drjit as dr
import mitsuba as mi

from mitsuba_time import set_llvm_target

mi.set_variant("llvm_ad_rgb")
set_llvm_target(dr, a.llvm_target)
dr.set_thread_count(1)
scene = mi.load_file(os.path.join(a.shared, "refs", "mitsuba", a.scene + ".xml"))
dr.eval(mi.render(scene, spp=a.spp))
