#!/usr/bin/env python3
"""Writes data/sunsky/hosek_wilkie_rgb.bin, the RGB tables of rdr's `sunsky` emitter, from
Mitsuba 3's wheel's data/sunsky/sunsky_datasets.bin (Hosek–Wilkie sky and sun model data,
BSD-3 (c) 2012-2013 Lukas Hosek and Alexander Wilkie, as packaged by Mitsuba 3, BSD-3).

Layout (little endian): the 8 bytes b"RDRSKY01", then float32 arrays, each C order:
  sky_params [turbidity 10][albedo 2][control point 6][channel 3][parameter 9]
  sky_radiance [10][2][6][3]
  sun_radiance [turbidity 10][segment 45][channel 3][polynomial degree 4][limb power 6]

Only the RGB fields are kept (rdr renders RGB); float64 is narrowed to float32.
Run with the venv that has Mitsuba (only its TensorFile reader is used):
    /work/venv-mi/bin/python scripts/make_sunsky_tables.py [path/to/sunsky_datasets.bin]
"""
import os
import sys

import numpy as np

DEFAULT = "/work/venv-mi/lib/python3.11/site-packages/mitsuba/data/sunsky/sunsky_datasets.bin"
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "sunsky", "hosek_wilkie_rgb.bin")
FIELDS = [("sky_params_rgb", (10, 2, 6, 3, 9)), ("sky_rad_rgb", (10, 2, 6, 3)), ("sun_rad_rgb", (10, 45, 3, 4, 6))]


def main():
    import mitsuba as mi

    mi.set_variant("scalar_rgb")
    path = sys.argv[1] if len(sys.argv) > 1 else DEFAULT
    tf = mi.TensorFile(path)  # the fields' offsets; the float64 data is read here
    blob = bytearray(b"RDRSKY01")
    for name, shape in FIELDS:
        raw = open(path, "rb").read()
        off = tf[name].offset
        a = np.frombuffer(raw, dtype="<f8", count=int(np.prod(shape)), offset=off).reshape(shape)
        assert str(tf[name].dtype).endswith("Float64"), tf[name].dtype
        blob += a.astype("<f4").tobytes()
    with open(OUT, "wb") as f:
        f.write(blob)
    print(f"{OUT}: {len(blob)} bytes", file=sys.stderr)


if __name__ == "__main__":
    main()
