"""What the scripts/make_*_refs.py share: their command line, the perspective sensor of
their scenes, and a reference rendered as ../shared/refs/README.md describes it: the mean
of K independent passes of Mitsuba 3 (pass p with seed p) as <name>.exr and, per pixel and
channel, the variance of that mean (the passes' sample variance / K) as <name>.var.exr.

An oracle for the tests, run by hand with the venv that has Mitsuba; never by the tests or CI.
"""
import argparse
import os
import sys


def arguments(description, names=True, passes=8, spp=256):
    """`--passes K --spp N --variant V [NAME...]`, parsed."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--passes", type=int, default=passes)
    ap.add_argument("--spp", type=int, default=spp)
    ap.add_argument("--variant", default="scalar_rgb")
    if names:
        ap.add_argument("names", nargs="*")
    return ap.parse_args()


def mitsuba(variant):
    """The `mitsuba` module set to `variant`."""
    import mitsuba as mi

    mi.set_variant(variant)
    return mi


def perspective_sensor(fov, origin, target, up, res, fov_axis="y", indent="  "):
    """A perspective sensor (`origin`, `target`, `up` as XML vector strings) with a box-filtered
    `res`×`res` RGB film and an independent sampler taking `$spp` samples."""
    axis = f'\n{indent}  <string name="fov_axis" value="{fov_axis}"/>' if fov_axis else ""
    return f"""{indent}<sensor type="perspective">
{indent}  <float name="fov" value="{fov}"/>{axis}
{indent}  <transform name="to_world">
{indent}    <lookat origin="{origin}" target="{target}" up="{up}"/>
{indent}  </transform>
{indent}  <film type="hdrfilm">
{indent}    <integer name="width" value="{res}"/><integer name="height" value="{res}"/>
{indent}    <string name="pixel_format" value="rgb"/><rfilter type="box"/>
{indent}  </film>
{indent}  <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
{indent}</sensor>"""


def render_reference(mi, scene, out_dir, name, passes, spp):
    """Renders `scene` (a loaded Mitsuba scene) `passes` times and writes <name>.exr and
    <name>.var.exr into `out_dir`; returns the mean."""
    import numpy as np

    print(f"{name}: rendering", file=sys.stderr, flush=True)
    images = np.stack([np.array(mi.render(scene, seed=p, spp=spp), dtype=np.float64)[..., :3] for p in range(passes)])
    mean = images.mean(axis=0)
    var = images.var(axis=0, ddof=1) / passes
    # written synchronously (write_bitmap's background writer can hang at exit)
    for image, suffix in [(mean, ".exr"), (var, ".var.exr")]:
        mi.Bitmap(image.astype(np.float32), mi.Bitmap.PixelFormat.RGB).write(os.path.join(out_dir, name + suffix))
    rel = np.sqrt((var / (mean**2 + 0.01)).mean())
    print(f"{name}: {passes}x{spp} spp, relMSE-noise {rel:.2e}, mean {mean.mean(axis=(0, 1))}", file=sys.stderr, flush=True)
    return mean


def floor_sphere(floor, indent="  "):
    """A large diffuse sphere as the floor: `floor` a dict of `center`, `radius` and `albedo`."""
    v = lambda x: ", ".join(str(float(c)) for c in x)  # noqa: E731
    return f"""{indent}<shape type="sphere">
{indent}  <point name="center" value="{v(floor['center'])}"/>
{indent}  <float name="radius" value="{floor['radius']}"/>
{indent}  <bsdf type="diffuse"><rgb name="reflectance" value="{v(floor['albedo'])}"/></bsdf>
{indent}</shape>"""


def sphere_light_and_sky(center, radius, radiance, sky, indent="  "):
    """A spherical area light (`center`, `radiance` as XML vector strings) and a constant sky."""
    return f"""{indent}<shape type="sphere">
{indent}  <point name="center" value="{center}"/><float name="radius" value="{radius}"/>
{indent}  <emitter type="area"><rgb name="radiance" value="{radiance}"/></emitter>
{indent}</shape>
{indent}<emitter type="constant"><rgb name="radiance" value="{sky}"/></emitter>"""


def write_and_render(mi, out_dir, name, xml_text, passes, spp):
    """Writes the scene `xml_text` as <name>.xml into `out_dir` and renders its reference
    there (`render_reference`)."""
    xml_path = os.path.join(out_dir, name + ".xml")
    with open(xml_path, "w") as f:
        f.write(xml_text)
    return render_reference(mi, mi.load_file(xml_path), out_dir, name, passes, spp)
