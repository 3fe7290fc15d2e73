#!/usr/bin/env python3
"""Writes puff.vol beside this script: an 8x8x8 one-channel density in Mitsuba's binary
.vol format (float32), a soft ball of peak 1 at the centre of the unit cube. The manual's
scene-format page uses it in its gridvolume example."""
import math
import os
import struct

N = 8
values = []
for z in range(N):
    for y in range(N):
        for x in range(N):
            # voxel centres at (i + 1/2) / N, as Mitsuba 3 places them
            d = math.dist(((x + 0.5) / N, (y + 0.5) / N, (z + 0.5) / N), (0.5, 0.5, 0.5))
            values.append(max(0.0, 1.0 - 2.0 * d))
out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "puff.vol")
with open(out, "wb") as f:
    f.write(b"VOL" + bytes([3]))
    f.write(struct.pack("<iiiii", 1, N, N, N, 1))
    f.write(struct.pack("<6f", 0, 0, 0, 1, 1, 1))
    f.write(struct.pack(f"<{len(values)}f", *values))
