#!/usr/bin/env python3
"""Embree 4 timed on ray files in process CPU time (for side-by-side bursts with `rdr bench`).

Usage (one thread; `embreex` as in ../shared/tools/embree_rays.py's header):
    taskset -c 0 /work/venv-embree/bin/python scripts/embree_time.py MESH.obj RAYS.rays.f32... [--reps 3] [--robust]
        [--write-distances]

Each `o`/`g` group of the OBJ becomes a mesh of its own (a scene of several meshes, as
`rdr bench SCENE --record-rays` writes them). The build quality is Embree's default unless
scripts/embree_config_shim.c is preloaded with EMBREE_QUALITY=high (Mitsuba 3's choice).
--write-distances writes each file's closest-hit distances beside it (X.rays.f32 -> X.t.f32,
+inf for a miss), which `rdr bench MESH --ray-file X.rays.f32` then checks its hits against.

Builds the mesh `--reps` times (the build is Embree's lazy commit, timed around a first one-ray
query) and traces each file's rays (the format of `rdr bench --ray-file`) with closest and any
hit, best of `--reps`, timing `scene.run` in process CPU time (`time.process_time`) so that time
the OS gives other processes does not count, as rdr's worker CPU time. Prints, for scripts:
    build MS ms
    NAME closest X any Y Mrays/s
"""
import argparse, os, sys, time
import numpy as np



def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("mesh")
    ap.add_argument("rays", nargs="+")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--robust", action="store_true", help="Embree's robust mode (RTC_SCENE_FLAG_ROBUST: watertight, as rdr's triangle test)")
    ap.add_argument("--write-distances", action="store_true", help="write X.t.f32 (closest-hit distances) beside each X.rays.f32")
    a = ap.parse_args()
    from embreex import rtcore as rtc, rtcore_scene as rtcs, mesh_construction as mc

    meshes = load_groups(a.mesh)
    dev = rtc.EmbreeDevice()
    best = float("inf")
    one, up = np.zeros((1, 3), np.float32), np.array([[0, 0, 1]], np.float32)
    for _ in range(a.reps):
        scene = rtcs.EmbreeScene(dev, robust=a.robust)
        for V, F in meshes:
            mc.TriangleMesh(scene, V, F)
        t0 = time.process_time()
        scene.run(one, up, query="OCCLUDED")
        best = min(best, time.process_time() - t0)
    print(f"build {best * 1e3:.1f} ms")
    for path in a.rays:
        R = np.fromfile(path, "<f4").reshape(-1, 6)
        O, D = np.ascontiguousarray(R[:, :3]), np.ascontiguousarray(R[:, 3:])
        if a.write_distances:
            if not path.endswith(".rays.f32"):
                sys.exit(f"--write-distances: '{path}' does not end in .rays.f32")
            t = scene.run(O, D, query="DISTANCE")
            np.where(t < 1e30, t, np.inf).astype("<f4").tofile(path[: -len(".rays.f32")] + ".t.f32")
        rates = []
        for q in ("INTERSECT", "OCCLUDED"):
            t = float("inf")
            for _ in range(a.reps):
                t0 = time.process_time()
                scene.run(O, D, query=q)
                t = min(t, time.process_time() - t0)
            rates.append(len(O) / t / 1e6)
        print(f"{os.path.basename(path)} closest {rates[0]:.2f} any {rates[1]:.2f} Mrays/s")


def load_groups(path):
    """The OBJ's triangles as one (vertices, faces) pair per `o`/`g` group (fans for polygons)."""
    V, groups = [], [[]]
    with open(path, "rb") as f:
        for line in f:
            if line.startswith(b"v "):
                V.append([float(x) for x in line.split()[1:4]])
            elif line.startswith((b"o ", b"g ")):
                if groups[-1]:
                    groups.append([])
            elif line.startswith(b"f "):
                idx = [int(t.split(b"/")[0]) for t in line.split()[1:]]
                idx = [i - 1 if i > 0 else len(V) + i for i in idx]
                groups[-1].extend((idx[0], idx[k], idx[k + 1]) for k in range(1, len(idx) - 1))
    V = np.asarray(V, np.float32)
    out = []
    for F in filter(None, groups):
        F = np.asarray(F, np.int64)
        used, inv = np.unique(F, return_inverse=True)
        out.append((np.ascontiguousarray(V[used]), inv.reshape(F.shape).astype(np.int32)))
    return out


if __name__ == "__main__":
    sys.exit(main())
