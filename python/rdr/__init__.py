"""rdr, a physically based CPU ray tracer, from Python with Mitsuba 3's habits.

    import rdr
    scene = rdr.load_file("scenes/showcase.json")
    image = rdr.render(scene, spp=16)          # float32 NumPy array (H, W, 3)
    rdr.write("showcase.exr", image)

Images are bit for bit those of ``rdr render`` for the same scene, spp and seed.
See docs/src/python.md for the API and every difference from Mitsuba's.
"""

from __future__ import annotations

import json as _json
import os as _os
import warnings as _warnings
from collections.abc import Mapping as _Mapping

import numpy as _np

from . import _rdr
from ._rdr import Error, Scene

__version__ = _rdr.__version__
__all__ = [
    "Error",
    "Image",
    "RenderInterrupted",
    "Scene",
    "SceneParameters",
    "compare",
    "load_dict",
    "load_file",
    "read",
    "render",
    "traverse",
    "write",
]


class RenderInterrupted(KeyboardInterrupt):
    """Ctrl-C during ``render``: the render stopped between passes; ``.image`` holds
    the passes that finished (``.spp`` of them per pixel)."""

    def __init__(self, image: "Image", spp: int):
        super().__init__(f"render interrupted after {spp} spp (the finished passes are in .image)")
        self.image = image
        self.spp = spp


class Image(_np.ndarray):
    """A float32 (H, W, C) NumPy array of linear RGB (and feature channels, named by
    ``.channels``) that shows itself in Jupyter, tone-mapped to 8-bit sRGB."""

    def __array_finalize__(self, obj):
        self.channels = getattr(obj, "channels", ("R", "G", "B"))

    def _repr_png_(self):
        if self.ndim != 3 or self.shape[2] < 3:
            return None
        return _rdr.png_bytes(_np.ascontiguousarray(self[..., :3], dtype=_np.float32).view(_np.ndarray))


def _warn(lines):
    for line in lines:
        _warnings.warn(line, stacklevel=3)


def _param_text(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (list, tuple, _np.ndarray)):
        return ", ".join(str(v) for v in _np.ravel(value))
    return str(value)


def load_file(path, overrides=(), **params) -> Scene:
    """Loads a scene file (rdr JSON, or Mitsuba XML by its ``.xml`` extension).

    Keyword arguments set the XML's ``<default>`` parameters (``$name``), as Mitsuba's
    ``load_file`` and ``rdr render -D name=value`` do; ``overrides`` are JSON objects
    (text or dicts) merged into a JSON scene, as ``rdr render --override`` takes them."""
    texts = [o if isinstance(o, str) else _json.dumps(o) for o in overrides]
    defines = [(k, _param_text(v)) for k, v in params.items()]
    scene = _rdr.load_file(_os.fspath(path), texts, defines)
    _warn(scene.warnings)
    return scene


def load_dict(d: dict) -> Scene:
    """Loads a scene from a dict: Mitsuba's scene dictionary (``{"type": "scene", ...}``)
    or rdr's JSON scene as a dict. Relative file names resolve against the working
    directory; messages name the scene ``<dict>``."""
    if not isinstance(d, _Mapping):
        raise TypeError(f"load_dict takes a dict, not {type(d).__name__}")
    base = _os.getcwd()
    if d.get("type") == "scene":
        scene = _rdr.load_mitsuba_dict(d, "<dict>", base)
    else:
        scene = _rdr.load_json(_json.dumps(d, default=_json_default), "<dict>", base)
    _warn(scene.warnings)
    return scene


def _json_default(value):
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"a value of type {type(value).__name__} in a scene dict (give numbers, strings, lists or dicts)")


def render(scene: Scene, spp=None, seed=0, threads=None, integrator=None, time_limit=None, aovs=(), progress=None) -> Image:
    """Renders ``scene``: a float32 NumPy array (H, W, 3), or (H, W, 3 + C) with
    feature buffers (``aovs``: "albedo", "normal", "position", "depth"; ``.channels``
    names them), made without a copy of the render's pixels.

    ``spp`` and ``seed`` as ``rdr render --spp --seed`` (the image depends on scene, spp
    and seed only); ``threads`` workers (all cores by default) of a pool of this call's
    own; ``integrator`` another integrator, a type name or rdr's JSON ``integrator``
    object as a dict; ``time_limit`` seconds (no pass starts that would end after it);
    ``progress(done, total)`` is called with samples finished about 20 times a second.
    The GIL is released while rendering. Ctrl-C stops between passes and raises
    :class:`RenderInterrupted`, whose ``.image`` holds the finished passes."""
    if isinstance(integrator, str):
        integrator = {"type": integrator}
    text = None if integrator is None else _json.dumps(integrator, default=_json_default)
    if isinstance(aovs, str):
        aovs = [aovs]
    array, channels, interrupted, spp_done, notes = _rdr.render(
        scene, spp, seed, threads, text, time_limit, list(aovs), progress
    )
    _warn(notes)
    image = array.view(Image)
    image.channels = tuple(channels)
    if interrupted:
        raise RenderInterrupted(image, spp_done)
    return image


def write(path, image) -> None:
    """Writes an (H, W, 3) image as ``rdr render -o`` would: ``.exr`` float32 RGB
    (bit for bit the CLI's file for the same pixels), ``.png`` 8-bit sRGB."""
    _rdr.write(_os.fspath(path), _as_rgb(image, "write"))


def read(path) -> Image:
    """Reads an EXR (as stored) or PNG/JPEG (from sRGB) image as linear float32 (H, W, 3)."""
    return _rdr.read(_os.fspath(path)).view(Image)


def compare(image, reference) -> float:
    """The relative MSE of ``image`` against ``reference``, mean((x - r)^2 / (r^2 + 0.01))
    over pixels and channels: ``rdr compare``'s metric."""
    return _rdr.compare(_as_rgb(image, "compare"), _as_rgb(reference, "compare"))


def _as_rgb(image, what):
    a = _np.asarray(image)
    if a.ndim != 3 or a.shape[2] < 3:
        raise Error(f"{what}: expected an image of shape (H, W, 3), found {a.shape}")
    return _np.ascontiguousarray(a[..., :3], dtype=_np.float32)


from ._params import SceneParameters, traverse  # noqa: E402
