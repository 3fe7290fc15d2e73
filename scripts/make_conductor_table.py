#!/usr/bin/env python3
"""Regenerates NAMED_CONDUCTORS in src/desc/xml/values.rs: Mitsuba's named conductors
(`<string name="material" value="Au"/>`) as RGB η and k.

Each spectrum of Mitsuba's data/ior/<name>.{eta,k}.spd is handed to rdr itself as a
`<spectrum value="λ:v, …">` (so the table comes from rdr's own spectral→RGB conversion,
`values::spectrum_to_rgb`), read back through `rdr convert` to JSON, and printed as Rust.
With --check, Mitsuba 3's scalar_rgb evaluation of the same preset is printed beside it.

Run from the repository root after `cargo build --release`, with the venv that has Mitsuba:
    /work/venv-mi/bin/python scripts/make_conductor_table.py [--check] > /tmp/table.rs
"""
import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile

import mitsuba

DATA = os.path.join(os.path.dirname(mitsuba.__file__), "data", "ior")
RDR = os.path.join("target", "release", "rdr")


def pairs(path):
    out = []
    for line in open(path):
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        w, v = line.split()[:2]
        out.append(f"{float(w)}:{float(v)}")
    return ", ".join(out)


def float_literal(x):
    s = f"{float(x):.5g}"
    return s if any(c in s for c in ".e") else s + ".0"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args()
    names = sorted({os.path.basename(p)[: -len(".eta.spd")] for p in glob.glob(os.path.join(DATA, "*.eta.spd"))})
    shapes = []
    for n in names:
        eta, k = pairs(os.path.join(DATA, f"{n}.eta.spd")), pairs(os.path.join(DATA, f"{n}.k.spd"))
        shapes.append(
            f'<shape type="sphere"><bsdf type="roughconductor" id="{n}"><spectrum name="eta" value="{eta}"/>'
            f'<spectrum name="k" value="{k}"/></bsdf></shape>'
        )
    xml = (
        '<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/>'
        '<integer name="height" value="4"/></film></sensor>' + "".join(shapes) + "</scene>"
    )
    with tempfile.TemporaryDirectory() as d:
        open(os.path.join(d, "t.xml"), "w").write(xml)
        subprocess.run([RDR, "convert", "-q", os.path.join(d, "t.xml"), "-o", os.path.join(d, "t.json")], check=True, stdout=subprocess.DEVNULL)
        mats = json.load(open(os.path.join(d, "t.json")))["materials"]
    if args.check:
        mitsuba.set_variant("scalar_rgb")
        mitsuba.set_log_level(mitsuba.LogLevel.Error)  # its gamut warnings would go to stdout
    print(f"pub const NAMED_CONDUCTORS: [(&str, [f32; 3], [f32; 3]); {len(names)}] = [")
    for n in names:
        m = mats[n]
        eta, k = m["etaT"], m["k"]
        f = lambda v: ", ".join(float_literal(x) for x in v)
        print(f'    ("{n}", [{f(eta)}], [{f(k)}]),')
        if args.check:
            p = mitsuba.traverse(mitsuba.load_dict({"type": "conductor", "material": n}))
            me, mk = list(p["eta.value"]), list(p["k.value"])
            rel = max(abs(a - b) / max(abs(b), 1e-3) for a, b in zip(eta + k, me + mk))
            print(f"    // {n} Mitsuba: [{f(me)}], [{f(mk)}]  max relative difference {rel:.2e}", file=sys.stderr)
    print("];")


if __name__ == "__main__":
    main()
