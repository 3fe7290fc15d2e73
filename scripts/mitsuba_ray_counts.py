#!/usr/bin/env python3
"""Rays per sample of Mitsuba 3's `path` integrator on a scene (issue 40's breakdown; an oracle
run by hand, never by tests or CI), to set beside `rdr bench --record-rays` (closest-hit rays)
and `rdr bench`'s rays per sample (closest + shadow).

Usage: DRJIT_LIBLLVM_PATH=... /work/venv-mi/bin/python scripts/mitsuba_ray_counts.py SCENE.xml SPP MAX_DEPTH

Mitsuba's path loop is replayed one segment at a time in Python with Mitsuba's own scene,
sensor, sampler, BSDF sampling and emitter sampling, following the policy of its path.cpp: an
emitter sample (a shadow ray wherever its pdf is not 0) at every vertex with a smooth BSDF while
depth + 1 < max_depth; roulette once depth >= 5 after the increment, survival
min(max(throughput) * eta^2, 0.95). The active lanes are counted before each closest-hit query.
"""
import os, sys
os.environ.setdefault("DRJIT_LIBLLVM_PATH", "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1")
import drjit as dr, mitsuba as mi  # noqa: E402
mi.set_variant('llvm_ad_rgb')


def count(mask):
    c = dr.count(mask)
    return int(c[0]) if hasattr(c, "__getitem__") else int(c)


path, spp = sys.argv[1], int(sys.argv[2])
max_depth = int(sys.argv[3]) if len(sys.argv) > 3 else 65
scene = mi.load_file(path)
sensor = scene.sensors()[0]
film = sensor.film(); sampler = sensor.sampler().clone()
w, h = film.crop_size()
n = w * h * spp
sampler.seed(1, n)
idx = dr.arange(mi.UInt32, n) // spp
pos = mi.Vector2f(mi.Float(idx % w), mi.Float(idx // w)) + sampler.next_2d()
ray, _ = sensor.sample_ray(0.0, sampler.next_1d(), pos / mi.Vector2f(w, h), sampler.next_2d())
active = mi.Bool(True)
depth = mi.UInt32(0); beta = mi.Spectrum(1.0); eta = mi.Float(1.0)
closest = shadow = 0
si = scene.ray_intersect(ray, active); closest += n
ctx = mi.BSDFContext()
while True:
    bsdf = si.bsdf(ray)
    active_next = active & (depth + 1 < max_depth) & si.is_valid()
    active_em = active_next & mi.has_flag(bsdf.flags(), mi.BSDFFlags.Smooth)
    ds, _ = scene.sample_emitter_direction(si, sampler.next_2d(), False, active_em)
    shadow += count(active_em & (ds.pdf != 0))
    bs, bw = bsdf.sample(ctx, si, sampler.next_1d(), sampler.next_2d(), active_next)
    ray = si.spawn_ray(si.to_world(bs.wo))
    beta *= bw; eta *= bs.eta
    depth[si.is_valid()] += 1
    tmax = dr.max(beta)
    q = dr.minimum(tmax * eta * eta, 0.95)
    rr = depth >= 5
    beta[rr] *= dr.rcp(q)
    active = active_next & (~rr | (sampler.next_1d() < q)) & (tmax != 0)
    c = count(active)
    if c == 0:
        break
    closest += c
    si = scene.ray_intersect(ray, active)
    dr.eval(si, beta, eta, depth, active)
print(f"{path}: {spp} spp, closest {closest/n:.3f} shadow {shadow/n:.3f} total {(closest+shadow)/n:.3f} rays per sample")
