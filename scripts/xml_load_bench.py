#!/usr/bin/env python3
"""How Mitsuba XML loading time grows with the file: scenes of 1x, 10x and 100x the size.

Two kinds of scene, each at three sizes: one plugin holding N <float> properties (each warned
about as unknown), and N instances of one shapegroup (with the same scene converted to JSON by
`rdr convert` as the anchor: same scene, other reader). Each file is rendered at 8x8, 1 spp, and
the best CPU time (user + system) of REPEAT runs is printed per binary, the binaries taking
turns. Loading is linear when each 10x step costs about 10x.

Usage:
    python3 scripts/xml_load_bench.py [--floats N] [--instances N] [--repeat K] BINARY...
A measurement run by hand, never by tests or CI.
"""
import argparse
import os
import resource
import subprocess
import sys
import tempfile

HEAD = """<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="2"/></integrator>
<sensor type="perspective"><float name="fov" value="40"/>
<transform name="to_world"><lookat origin="0,0,50" target="0,0,0" up="0,1,0"/></transform>
<sampler type="independent"><integer name="sample_count" value="1"/></sampler>
<film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
"""
TAIL = '<emitter type="constant"/>\n</scene>\n'


def floats(n):
    body = "".join(f'  <float name="f{i}" value="{i}.5"/>\n' for i in range(n))
    return HEAD + '<shape type="sphere"><bsdf type="diffuse">\n' + body + "</bsdf></shape>\n" + TAIL


def instances(n):
    group = '<shape type="shapegroup" id="g"><shape type="sphere"><float name="radius" value="0.1"/></shape></shape>\n'
    body = "".join(
        f'<shape type="instance"><ref id="g"/><transform name="to_world">'
        f'<translate x="{i % 100 * 0.3 - 15:.1f}" y="{i // 100 % 100 * 0.3 - 15:.1f}" z="{-(i // 10000)}"/>'
        f"</transform></shape>\n"
        for i in range(n)
    )
    return HEAD + group + body + TAIL


def cpu_seconds(binary, scene, out, limit):
    """CPU seconds of one render, or None past `limit` wall seconds (killed)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    cmd = [binary, "render", scene, "-o", out, "-q"]
    try:
        subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, timeout=limit, check=True)
    except subprocess.TimeoutExpired:
        return None
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--floats", type=int, default=1500, help="<float> elements at 1x (default 1500)")
    ap.add_argument("--instances", type=int, default=200, help="instances at 1x (default 200)")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--limit", type=float, default=120, help="wall seconds after which a binary is given up on")
    ap.add_argument("binaries", nargs="+")
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="rdr-xml-bench-")
    scenes = []
    for scale in (1, 10, 100):
        for kind, make, n in (("floats", floats, a.floats), ("instances", instances, a.instances)):
            path = os.path.join(tmp, f"{kind}{n * scale}.xml")
            with open(path, "w") as f:
                f.write(make(n * scale))
            scenes.append((f"{kind} {n * scale}", path))
            if kind == "instances":
                twin = path[:-4] + ".json"
                subprocess.run([a.binaries[-1], "convert", path, "-o", twin, "-q"], check=True, capture_output=True)
                scenes.append((f"{kind} {n * scale} (JSON)", twin))
    out = os.path.join(tmp, "out.exr")
    print(f"{'scene':<26} {'MB':>6} " + " ".join(f"{os.path.basename(b):>16}" for b in a.binaries))
    gave_up = set()  # (binary, kind of scene): past the limit on a smaller one
    for name, path in scenes:
        kind = (name.split()[0], path.endswith(".json"))
        best = [None] * len(a.binaries)
        for _ in range(a.repeat):
            for i, b in enumerate(a.binaries):
                if (i, kind) in gave_up:
                    continue
                t = cpu_seconds(b, path, out, a.limit)
                if t is None:
                    gave_up.add((i, kind))
                elif best[i] is None or t < best[i]:
                    best[i] = t
        cells = [f"{t:15.3f}s" if (i, kind) not in gave_up else f"{'> %g s' % a.limit:>16}" for i, t in enumerate(best)]
        print(f"{name:<26} {os.path.getsize(path) / 1e6:6.2f} " + " ".join(cells), flush=True)


if __name__ == "__main__":
    main()
