#!/usr/bin/env python3
"""rdr against Mitsuba 3 (LLVM) on the real scenes (../shared/scenes/real/*/bench.xml, the same
file for both) and the small reference scenes: samples per CPU second and relMSE at equal CPU
time (the manual's docs/src/performance.md). An oracle run by hand, never by tests or CI; setup
as in scripts/mitsuba_time.py (DRJIT_LIBLLVM_PATH is set here if unset).

Usage: /work/venv-mi/bin/python scripts/real_vs_mitsuba.py [--rounds 3] [--seeds 2]
       [--rdr BIN [BIN ...]] [--isa avx2] [--refs /work/perf-refs] [--ref-spp 1024]
       [--scenes NAME ...] [--no-mitsuba]

Per scene, `--rounds` rounds, each running every --rdr binary in turn and Mitsuba (alternated,
best of the rounds kept for each):
* rdr: `rdr bench FILE --spp SPP` (load, build and render, no file written), the CPU time
  (user + system, all threads) of the whole process, from the child's rusage;
* Mitsuba: `mi.render` in this process after a warm-up render (process CPU time, all threads,
  as scripts/mitsuba_time.py), and the whole process too: a fresh Python loading and rendering
  the file once (scripts/mitsuba_time.py --once, the child's rusage: interpreter start, import,
  load, JIT compilation and render).
samples/s ratio = Mitsuba's CPU seconds / rdr's at the same spp (above 1: rdr takes more
samples per CPU second); `vs render` against Mitsuba's warm `mi.render`, `vs process` against
its whole process. rdr is always its whole process.
Error at equal CPU time, for the first --rdr binary: rdr renders SPP with seeds 1..--seeds
(`rdr render`, its image); Mitsuba renders M = round(SPP x rdr's CPU s / Mitsuba's warm
`mi.render` CPU s) spp with the same seeds; relMSE = mean over pixels and channels of
(x - ref)^2 / (ref^2 + 0.01), less the reference's own share, averaged over the seeds. Ratio
above 1: rdr's image is the closer one.
References: the real scenes' are Mitsuba's own renders (--ref-spp, two halves with seeds 1000 and
1001: their mean is the reference, their squared half-difference / 4 the variance of the mean),
made on first use and kept in --refs (outside the repository); the small scenes' are
../shared/refs (as scripts/mitsuba_equal_error.py).
--isa avx2 runs rdr's AVX2 kernels (`rdr bench --isa avx2`; the images come from `rdr render`,
which picks its own kernels: they trace the same hits) and Mitsuba's JIT for a Haswell CPU,
8 lanes. The load average is printed with every round: the machine is shared.
"""
import argparse, os, resource, subprocess, sys, tempfile, time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")

from mitsuba_equal_error import DEFAULT as SMALL, MI_SCALE, read_exr, rel_mse  # noqa: E402

REAL = ["cornell-box", "veach-mis", "modern-hall", "spaceship", "mitsuba-cbox"]
SPP = 64


def child_cpu(cmd):
    """Runs cmd (output kept) and returns (user + system CPU seconds of it, its stdout)."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run(cmd, check=True, capture_output=True, text=True).stdout
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), out


def cpu_description():
    """The CPU model, family/model and the wide vector sets it has (/proc/cpuinfo)."""
    info = {}
    for line in open("/proc/cpuinfo"):
        k, _, v = line.partition(":")
        info.setdefault(k.strip(), v.strip())
    flags = info.get("flags", "").split()
    wide = [f for f in ("avx2", "fma", "avx512f", "avx512vl", "avx512bw") if f in flags]
    return f"{info.get('model name')} (family {info.get('cpu family')} model {info.get('model')}; {' '.join(wide)})"


def load():
    return "load %.2f %.2f %.2f" % os.getloadavg()


class Scene:
    """Where one scene's files are, for rdr and Mitsuba, and its reference."""

    def __init__(self, name, rdr_file, mi_file, mi_params, ref, var, spp, scale=1.0):
        self.name, self.rdr_file, self.mi_file, self.mi_params = name, rdr_file, mi_file, mi_params
        self.ref, self.var, self.spp, self.scale = ref, var, spp, scale


def scenes(a):
    out = []
    real = os.path.join(a.shared, "scenes", "real")
    for name in a.scenes or REAL + [s.split(":")[0] for s in SMALL]:
        if name in REAL:
            f = os.path.join(real, name, "bench.xml")
            out.append(Scene(name, f, f, {}, os.path.join(a.refs, f"{name}.exr"), os.path.join(a.refs, f"{name}.var.exr"), SPP))
            continue
        spec = next((s for s in SMALL if s.split(":")[0] == name), None)
        if spec is None:
            sys.exit(f"--scenes: unknown scene '{name}' (real: {' '.join(REAL)}; small: {' '.join(s.split(':')[0] for s in SMALL)})")
        _, ref_name, spp, *res = spec.split(":")
        refs = os.path.join(a.shared, "refs")
        params = {"res": int(res[0])} if res else {}
        out.append(
            Scene(
                name,
                os.path.join(refs, "scenes", f"{name}.json"),
                os.path.join(refs, "mitsuba", f"{name}.xml"),
                params,
                os.path.join(refs, f"{ref_name}.exr"),
                os.path.join(refs, f"{ref_name}.var.exr"),
                int(spp),
                MI_SCALE.get(name, 1.0),
            )
        )
    return out


def make_reference(mi, s, spp):
    """Mitsuba's reference of a real scene: two halves of spp, their mean and its variance."""
    scene = mi.load_file(s.mi_file, **s.mi_params)
    halves = [np.array(mi.render(scene, spp=spp // 2, seed=1000 + k), dtype=np.float64)[..., :3] for k in range(2)]
    mi.Bitmap(((halves[0] - halves[1]) ** 2 / 4).astype(np.float32)).write(s.var)
    tmp = s.ref + ".part.exr"
    mi.Bitmap(((halves[0] + halves[1]) / 2).astype(np.float32)).write(tmp)
    os.replace(tmp, s.ref)  # the reference exists only once its variance does


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--rdr", nargs="+", default=[os.path.join(HERE, "..", "target", "release", "rdr")])
    ap.add_argument("--isa", choices=["avx2", "avx512"])
    ap.add_argument("--shared", default=os.path.join(HERE, "..", "..", "shared"))
    ap.add_argument("--refs", default="/work/perf-refs")
    ap.add_argument("--ref-spp", type=int, default=1024)
    ap.add_argument("--scenes", nargs="+")
    ap.add_argument("--no-mitsuba", action="store_true", help="rdr binaries against each other only")
    a = ap.parse_args()
    import mitsuba as mi
    import drjit as dr

    from mitsuba_time import set_llvm_target, timed_render

    mi.set_variant("llvm_ad_rgb")
    mi_target = []
    if a.isa == "avx2":
        set_llvm_target(dr, "haswell:8")
        mi_target = ["--llvm-target", "haswell:8"]
    isa = ["--isa", a.isa] if a.isa else []
    os.makedirs(a.refs, exist_ok=True)
    cpu_line = subprocess.run([a.rdr[0], "bench", scenes(a)[0].rdr_file, "--spp", "1", "--threads", "1", *isa], check=True, capture_output=True, text=True).stdout
    print("cpu:", cpu_description(), "|", *[l for l in cpu_line.splitlines() if l.startswith("cpu")], "|", mi.__version__, load(), flush=True)
    tmp = tempfile.mkdtemp()
    for s in scenes(a):
        if not os.path.exists(s.ref):
            print(f"{s.name}: making the reference ({a.ref_spp} spp, Mitsuba) ...", flush=True)
            make_reference(mi, s, a.ref_spp)
        scene = None if a.no_mitsuba else mi.load_file(s.mi_file, **s.mi_params)
        if scene is not None:
            timed_render(mi, dr, scene, s.spp)  # JIT warm-up
        best_rdr = [float("inf")] * len(a.rdr)
        best_mi = best_mi_proc = float("inf")
        for r in range(a.rounds):
            times = []
            for i, rdr in enumerate(a.rdr):
                t, _ = child_cpu([rdr, "bench", s.rdr_file, "--spp", str(s.spp), "--seed", str(r + 1), *isa])
                best_rdr[i] = min(best_rdr[i], t)
                times.append(f"{t:.2f}")
            if scene is not None:
                best_mi = min(best_mi, timed_render(mi, dr, scene, s.spp, r + 1)[1])
                once = [sys.executable, os.path.join(HERE, "mitsuba_time.py"), s.mi_file, str(s.spp), "--once", *mi_target]
                once += ["--res", str(s.mi_params["res"])] if "res" in s.mi_params else []
                best_mi_proc = min(best_mi_proc, child_cpu(once)[0])
            print(f"  {s.name} round {r + 1}: rdr cpu {' '.join(times)} s | {load()}", flush=True)
        rdrs = " ".join(f"{t:.2f}" for t in best_rdr)
        if scene is None:
            ratios = " ".join(f"{best_rdr[0] / t:.3f}" for t in best_rdr)
            print(f"{s.name}: {s.spp} spp, rdr process cpu {rdrs} s | first binary's time / each one's: {ratios}", flush=True)
            continue
        ref, var = read_exr(mi, s.ref), read_exr(mi, s.var)
        out = os.path.join(tmp, f"{s.name}.exr")
        e_rdr = []
        for seed in range(1, a.seeds + 1):
            subprocess.run([a.rdr[0], "render", s.rdr_file, "--spp", str(s.spp), "--seed", str(seed), "-q", "-o", out], check=True, stdout=subprocess.DEVNULL)
            e_rdr.append(rel_mse(read_exr(mi, out), ref, var))
        m = max(1, round(s.spp * best_rdr[0] / best_mi))
        timed_render(mi, dr, scene, m)  # warm-up at this spp
        e_mi = [rel_mse(np.array(timed_render(mi, dr, scene, m, seed)[2], dtype=np.float64)[..., :3] * s.scale, ref, var) for seed in range(1, a.seeds + 1)]
        er, em = float(np.mean(e_rdr)), float(np.mean(e_mi))
        print(
            f"{s.name}: {s.spp} spp, rdr process cpu {rdrs} s, mitsuba render cpu {best_mi:.2f} s, process cpu {best_mi_proc:.2f} s"
            f" | samples/s rdr/mitsuba: vs render {' '.join(f'{best_mi / t:.2f}' for t in best_rdr)},"
            f" vs process {' '.join(f'{best_mi_proc / t:.2f}' for t in best_rdr)}"
            f" | equal cpu: rdr {s.spp} spp relMSE {er:.3e}, mitsuba {m} spp relMSE {em:.3e}, mitsuba/rdr {em / er:.2f} | {load()}",
            flush=True,
        )


if __name__ == "__main__":
    sys.exit(main())
