#!/usr/bin/env python3
"""Hot instructions that follow a wide load from memory: where a profile shows stalled copies.

A load that reads memory written shortly before by narrower (or differently placed) stores
cannot take its value from them (no store-to-load forwarding) and waits until they reach the
cache. With `perf record -e cpu-clock` (this VM has no hardware counters) the waiting load's
samples land on the instruction after it, so a copy through the stack shows up as a hot
instruction right after a `vmovups`/`movsd`/... load. This lists those, hottest first, for
`perf annotate` and `objdump -d -l --start-address=...` to take apart.

Usage:
    perf record -e cpu-clock -F 10000 -o perf.data target/release/rdr bench SCENE --spp 16 --threads 1
    python3 scripts/perf_stalls.py perf.data [MIN_PERCENT] [COUNT]
Prints `PERCENT ADDRESS  after: LOAD | HOT INSTRUCTION`, the percentage of all samples.
A diagnostic run by hand, never by tests or CI.
"""
import re
import subprocess
import sys

WIDE_LOAD = re.compile(
    r"(vmovups|vmovaps|movups|movaps|vmovdqu|vmovdqa|vmovsd|movsd|vmovq)\s+-?0x[0-9a-f]+\((%rsp|%r\w+)\),%[xyz]?mm"
)


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    data = sys.argv[1]
    min_pct = float(sys.argv[2]) if len(sys.argv) > 2 else 0.15
    count = int(sys.argv[3]) if len(sys.argv) > 3 else 40
    out = subprocess.run(
        ["perf", "annotate", "-i", data, "--stdio", "--percent-type", "global-period"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    rows, prev = [], None
    for line in out.splitlines():
        m = re.match(r"\s*([\d.]+)\s*:\s*([0-9a-f]+):\s*(.*)", line)
        if not m:
            continue
        pct, addr, ins = float(m.group(1)), m.group(2), m.group(3)
        if pct >= min_pct and prev is not None and WIDE_LOAD.search(prev):
            rows.append((pct, addr, prev, ins))
        prev = ins
    rows.sort(reverse=True)
    for pct, addr, load, ins in rows[:count]:
        print(f"{pct:5.2f} {addr}  after: {load}   | {ins}")


if __name__ == "__main__":
    main()
