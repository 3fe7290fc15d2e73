"""Helpers shared by the scripts that hold rdr against Mitsuba 3 (an oracle run by hand, never by
tests or CI): a Mitsuba XML scene made small (its includes inlined, the film WIDTH pixels wide,
SPP samples, a <path> to its folder so both renderers find its files) and the relative MSE."""
import os, re

import numpy as np


def value(text, v):
    """An integer property's value, `$name` looked up in the file's <default>s."""
    if v.startswith("$"):
        m = re.search(r'<default name="%s" value="(\d+)"' % re.escape(v[1:]), text)
        return int(m.group(1)) if m else None
    return int(v)


def inlined(path):
    """The file's text with its <include>s' contents in place (their <scene> tags dropped), so
    a film declared in an included fragment (Mitsuba's cbox-rgb.xml) is found and edited."""
    with open(path) as f:
        text = f.read()

    def one(m):
        inner = inlined(os.path.join(os.path.dirname(path), m.group(1)))
        return re.sub(r"<\?xml[^>]*>|<scene[^>]*>|</scene>", "", inner)

    return re.sub(r'<include filename="([^"]+)"\s*/>', one, text)


def shrunk(text, width, spp, folder=None):
    """The scene text with the film `width` pixels wide (height in proportion), `spp` samples per
    pixel and, given a folder, a <path> to it (so relative file names still resolve)."""
    w = re.search(r'(<integer name="width" value=")([^"]+)(")', text)
    h = re.search(r'(<integer name="height" value=")([^"]+)(")', text)
    if w and h:
        W, H = value(text, w.group(2)), value(text, h.group(2))
        nh = max(1, round(H * width / W))
        text = text.replace(w.group(0), f"{w.group(1)}{width}{w.group(3)}", 1)
        text = text.replace(h.group(0), f"{h.group(1)}{nh}{h.group(3)}", 1)
    text = re.sub(r'(<integer name="(?:sample_count|sampleCount)" value=")[^"]+(")', rf"\g<1>{spp}\g<2>", text)
    if folder:
        text = re.sub(r"(<scene[^>]*>)", rf'\1\n<path value="{folder}"/>', text, count=1)
    return text


def prepared(scene, out, width, spp):
    """`scene` (a Mitsuba XML file) made small as `shrunk` says, written to `out`."""
    text = shrunk(inlined(scene), width, spp, os.path.dirname(os.path.abspath(scene)))
    with open(out, "w") as f:
        f.write(text)


def rel_mse(x, r):
    return float(np.mean((x - r) ** 2 / (r**2 + 1e-2)))


def mitsuba3_form(text):
    """The Mitsuba 0.6 spellings of `text` that Mitsuba 3 refuses, in Mitsuba 3's form (both
    renderers then read the same file; rdr reads either): `<lookAt>` as `<lookat>`; a
    `<spectrum>` of three bare numbers (0.6's RGB build read them as RGB) as `<rgb>`; a
    conductor's `extEta` (Mitsuba 3's conductors have none) dropped; the `halton` and `sobol`
    samplers, which Mitsuba 3 has not, as `independent` (the same converged image)."""
    text = text.replace("<lookAt", "<lookat")
    text = re.sub(r'<sampler type="(?:halton|sobol)"', '<sampler type="independent"', text)
    text = re.sub(r'<spectrum(\s+name="[^"]*"\s+value="\s*[-0-9.eE+]+\s*,\s*[-0-9.eE+]+\s*,\s*[-0-9.eE+]+\s*"\s*/>)', r"<rgb\1", text)

    def conductor(m):
        return re.sub(r'\s*<float name="extEta" value="[^"]*"\s*/>', "", m.group(0))

    return re.sub(r'<bsdf type="(?:rough)?conductor".*?</bsdf>', conductor, text, flags=re.S)
