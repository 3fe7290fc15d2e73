#!/usr/bin/env python3
"""Participating media against Mitsuba 3 (issue 38's benchmark, never a test): the three
media references (../shared/refs/mitsuba/{fog_cbox,milk_sphere,smoke_grid}.xml) rendered
by Mitsuba 3 LLVM (`volpath`/`volpathmis`, as the files say) and by rdr from the same XML
at the same spp. Per scene and renderer: samples per CPU second and relMSE against the
reference (`rdr compare`), and relMSE x CPU seconds, the error at equal CPU time if error
falls as 1/spp (lower is better). CPU time: rdr's whole process (getrusage of the child:
start, loading, BVH, render, writing); Mitsuba's process CPU time around `mi.render` with its
image evaluated, after a warm-up render (JIT compiled). The renderers alternate, --reps times, rep r
with seed r: CPU time is the best of the reps, relMSE the mean over them (one image's relMSE is
dominated by a few firefly pixels and swings by several times from seed to seed).

Usage: DRJIT_LIBLLVM_PATH=/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1 \
       /work/venv-mi/bin/python scripts/media_vs_mitsuba.py [--spp 64] [--reps 6] [--rdr target/release/rdr]
Setup of the venv in scripts/mitsuba_time.py. Name the CPU (lscpu) and the load with every figure.
"""
import argparse, os, re, resource, subprocess, sys, tempfile, time

HERE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES = ["fog_cbox", "milk_sphere", "smoke_grid"]


def rel_mse(rdr, image, ref):
    r = subprocess.run([rdr, "compare", image, ref], capture_output=True, text=True)
    m = re.search(r"relMSE\s+([0-9.eE+-]+)", r.stdout)
    if not m:
        sys.exit(f"rdr compare {image} {ref}: {r.stderr.strip()}")
    return float(m.group(1))


def child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--reps", type=int, default=6)
    ap.add_argument("--rdr", default=os.path.join(HERE, "target/release/rdr"))
    ap.add_argument("--scenes", default=",".join(SCENES))
    a = ap.parse_args()
    shared = os.path.realpath(os.environ.get("SHARED", os.path.join(HERE, "../shared")))
    os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
    import mitsuba as mi
    import drjit as dr

    mi.set_variant("llvm_ad_rgb")
    tmp = tempfile.mkdtemp(prefix="media-bench-")
    print(f"spp {a.spp}, {a.reps} seeds (CPU: best, relMSE: mean); load average {os.getloadavg()[0]:.1f} at start", flush=True)
    for name in a.scenes.split(","):
        xml = os.path.join(shared, "refs/mitsuba", name + ".xml")
        ref = os.path.join(shared, "refs", name + ".exr")
        scene = mi.load_file(xml, spp=a.spp)
        size = scene.sensors()[0].film().crop_size()
        samples = int(size[0]) * int(size[1]) * a.spp
        dr.eval(mi.render(scene, spp=a.spp, seed=99))  # JIT warm-up
        mi_cpu, rdr_cpu, e_mi, e_rdr = float("inf"), float("inf"), [], []
        for rep in range(a.reps):
            # alternating, so both see the same load; a seed per repetition
            c0 = time.process_time()
            img = mi.render(scene, spp=a.spp, seed=rep)
            dr.eval(img)
            dr.sync_thread()
            mi_cpu = min(mi_cpu, time.process_time() - c0)
            mi_path = os.path.join(tmp, f"{name}_mitsuba.exr")
            mi.util.write_bitmap(mi_path, img, write_async=False)
            e_mi.append(rel_mse(a.rdr, mi_path, ref))
            rdr_path = os.path.join(tmp, f"{name}_rdr.exr")
            c0 = child_cpu()
            subprocess.run([a.rdr, "render", xml, "--spp", str(a.spp), "--seed", str(rep), "-q", "-o", rdr_path], check=True, stdout=subprocess.DEVNULL)
            rdr_cpu = min(rdr_cpu, child_cpu() - c0)
            e_rdr.append(rel_mse(a.rdr, rdr_path, ref))
        # fireflies make one image's relMSE swing by several times: the mean over the seeds
        m_mi, m_rdr = sum(e_mi) / len(e_mi), sum(e_rdr) / len(e_rdr)
        print(
            f"{name:12} mitsuba {samples / mi_cpu / 1e3:8.1f} k samples/CPU s relMSE {m_mi:.3e} ({min(e_mi):.2e}-{max(e_mi):.2e}) x cpu {m_mi * mi_cpu:.3e} | "
            f"rdr {samples / rdr_cpu / 1e3:8.1f} k samples/CPU s relMSE {m_rdr:.3e} ({min(e_rdr):.2e}-{max(e_rdr):.2e}) x cpu {m_rdr * rdr_cpu:.3e} | "
            f"rdr/mitsuba samples per CPU s {mi_cpu / rdr_cpu:.2f}x, error at equal CPU time {m_rdr * rdr_cpu / (m_mi * mi_cpu):.2f}x",
            flush=True,
        )
    print(f"load average {os.getloadavg()[0]:.1f} at end", file=sys.stderr)


if __name__ == "__main__":
    main()
