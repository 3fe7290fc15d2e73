#!/usr/bin/env python3
"""Prints the reference colours of tests/mitsuba_spectra.rs: what Mitsuba 3's scalar_rgb variant
loads for each `<spectrum>` of CASES (read back with mi.traverse), and for `blackbody` spectra,
which its RGB variants load but cannot evaluate, what its scalar_spectral variant converges to:
Mitsuba's own blackbody evaluated every nanometre, converted as an emission
(mi.spectrum_list_to_srgb(..., bounded=False, d65=False)). With --render, a 4x4 spectral render
of each blackbody sky is printed beside it (that conversion is what a spectral render averages to).

    /work/venv-mi/bin/python scripts/make_spectrum_refs.py [--render]
"""
import sys

import mitsuba as mi
import numpy as np

# (label, where: bsdf/conductor/area/constant, the property XML) -- the same list as the test's
CASES = [
    ("white", "bsdf", '<spectrum name="reflectance" value="400:0.78, 500:0.78, 600:0.78, 700:0.78"/>'),
    ("ramp", "bsdf", '<spectrum name="reflectance" value="380:0.3, 455.5:0.7, 530:0.2, 780:0.9"/>'),
    ("clamped", "bsdf", '<spectrum name="reflectance" value="400:0.1, 500:0.9, 600:1.4, 700:0.2"/>'),
    ("red", "bsdf", '<spectrum name="reflectance" value="400:0.04, 560:0.067, 600:0.287, 640:0.609, 700:0.642"/>'),
    ("eta", "conductor", '<spectrum name="eta" value="400:1.5, 700:1.2"/>'),
    ("light", "area", '<spectrum name="radiance" value="400:0, 500:8, 600:15.6, 700:18.4"/>'),
    ("flat_light", "area", '<spectrum name="radiance" value="16.032"/>'),
    ("sky", "constant", '<spectrum name="radiance" value="380:0.5, 480:1.5, 780:0.25"/>'),
]
BLACKBODY = [(2000.0, 360.0, 830.0), (5000.0, 360.0, 830.0), (6500.0, 400.0, 700.0)]


def wrap(where, prop):
    if where == "constant":
        return f'<emitter type="constant">{prop}</emitter>'
    if where == "area":
        return f'<shape type="sphere"><emitter type="area">{prop}</emitter></shape>'
    bsdf = "diffuse" if where == "bsdf" else "conductor"
    return f'<shape type="sphere"><bsdf type="{bsdf}">{prop}</bsdf></shape>'


def loaded(where, prop):
    mi.set_variant("scalar_rgb")
    params = mi.traverse(mi.load_string(f'<scene version="3.0.0">{wrap(where, prop)}</scene>'))
    name = prop.split('name="')[1].split('"')[0]
    key = [k for k in params.keys() if k.endswith(f".{name}.value")][0]
    v = params[key]
    return [float(v[i]) for i in range(3)] if hasattr(v, "__len__") else [float(v)] * 3


def blackbody(kelvin, lo, hi, render):
    mi.set_variant("scalar_spectral")
    bb = f'<spectrum type="blackbody" name="radiance"><float name="temperature" value="{kelvin}"/>'
    bb += f'<float name="wavelength_min" value="{lo}"/><float name="wavelength_max" value="{hi}"/></spectrum>'
    sky = f'<emitter type="constant">{bb}</emitter>'
    emitter = mi.load_string(f'<scene version="3.0.0">{sky}</scene>').emitters()[0]
    si = mi.SurfaceInteraction3f()
    wl = [float(w) for w in range(int(lo), int(hi) + 1)]  # Mitsuba's blackbody is 0 outside [lo, hi]
    vals = []
    for i in range(0, len(wl), 4):
        four = (wl[i:i + 4] + [wl[-1]] * 3)[:4]
        si.wavelengths = mi.Spectrum(four)
        vals += list(emitter.eval(si))[:len(wl[i:i + 4])]
    vals = [float(v) for v in vals]
    extra = ""
    if render:
        film = '<film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film>'
        spp = '<sampler type="independent"><integer name="sample_count" value="4096"/></sampler>'
        scene = mi.load_string(f'<scene version="3.0.0"><integrator type="path"/>{sky}<sensor type="perspective">{film}{spp}</sensor></scene>')
        img = np.array(mi.render(scene))
        extra = f"  // spectral render: {img.reshape(-1, img.shape[-1])[:, :3].mean(0)}"
    mi.set_variant("scalar_rgb")
    return list(mi.spectrum_list_to_srgb(wl, vals, False, False)), extra


def main():
    render = "--render" in sys.argv
    print(f"// made by scripts/make_spectrum_refs.py with Mitsuba {mi.__version__}")
    print("const MITSUBA: [(&str, [f32; 3]); %d] = [" % len(CASES))
    for label, where, prop in CASES:
        rgb = loaded(where, prop)
        print(f'    ("{label}", [{", ".join(f"{c:.6}" for c in rgb)}]),')
    print("];")
    print("const MITSUBA_BLACKBODY: [([f64; 3], [f32; 3]); %d] = [" % len(BLACKBODY))
    for kelvin, lo, hi in BLACKBODY:
        rgb, extra = blackbody(kelvin, lo, hi, render)
        print(f'    ([{kelvin}, {lo}, {hi}], [{", ".join(f"{float(c):.6}" for c in rgb)}]),{extra}')
    print("];")


main()
