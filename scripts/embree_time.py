#!/usr/bin/env python3
"""Embree 4 timed on ray files in process CPU time (for side-by-side bursts with `rdr bench`).

Usage (one thread; `embreex` as in ../shared/tools/embree_rays.py's header):
    taskset -c 0 /work/venv-embree/bin/python scripts/embree_time.py MESH.obj RAYS.rays.f32... [--reps 3] [--robust]

Builds the mesh `--reps` times (the build is Embree's lazy commit, timed around a first one-ray
query) and traces each file's rays (the format of `rdr bench --ray-file`) with closest and any
hit, best of `--reps`, timing `scene.run` in process CPU time (`time.process_time`) so that time
the OS gives other processes does not count, as rdr's worker CPU time. Prints, for scripts:
    build MS ms
    NAME closest X any Y Mrays/s
"""
import argparse, os, sys, time
import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "shared", "tools"))


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mesh")
    ap.add_argument("rays", nargs="+")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--robust", action="store_true", help="Embree's robust mode (RTC_SCENE_FLAG_ROBUST: watertight, as rdr's triangle test)")
    a = ap.parse_args()
    from embree_rays import load_obj
    from embreex import rtcore as rtc, rtcore_scene as rtcs, mesh_construction as mc

    V, F = load_obj(a.mesh)
    dev = rtc.EmbreeDevice()
    best = float("inf")
    one, up = np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32)
    for _ in range(a.reps):
        scene = rtcs.EmbreeScene(dev, robust=a.robust)
        mc.TriangleMesh(scene, V, F)
        t0 = time.process_time()
        scene.run(one, up, query="OCCLUDED")
        best = min(best, time.process_time() - t0)
    print(f"build {best * 1e3:.1f} ms")
    for path in a.rays:
        R = np.fromfile(path, "<f4").reshape(-1, 6)
        O, D = np.ascontiguousarray(R[:, :3]), np.ascontiguousarray(R[:, 3:])
        rates = []
        for q in ("INTERSECT", "OCCLUDED"):
            t = float("inf")
            for _ in range(a.reps):
                t0 = time.process_time()
                scene.run(O, D, query=q)
                t = min(t, time.process_time() - t0)
            rates.append(len(O) / t / 1e6)
        print(f"{os.path.basename(path)} closest {rates[0]:.2f} any {rates[1]:.2f} Mrays/s")


if __name__ == "__main__":
    sys.exit(main())
