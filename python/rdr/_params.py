"""``rdr.traverse``: the scene parameters that can change between renders."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from . import _rdr


class SceneParameters(Mapping):
    """The editable parameters of a scene, as ``mi.traverse`` gives them: set values
    with ``params[key] = value``, then ``params.update()`` applies them all (the next
    render sees them). Keys are rdr's scene keys, as the JSON and its error messages
    name them (``camera.fov``, ``materials.red.albedo``); see ``keys()``."""

    def __init__(self, scene):
        self._scene = scene
        self._values = dict(_rdr.params(scene))
        self._pending = {}

    def __getitem__(self, key):
        if key in self._pending:
            return self._pending[key]
        return self._values[key]

    def __iter__(self):
        return iter(self._values)

    def __len__(self):
        return len(self._values)

    def __setitem__(self, key, value):
        if key not in self._values:
            raise KeyError(_rdr.not_editable(key))
        if isinstance(value, np.ndarray):
            value = value.tolist()
        self._pending[key] = value

    def __delitem__(self, key):
        raise TypeError("scene parameters cannot be removed")

    def update(self, values=None, **kwargs):
        """Sets ``values`` (a mapping) and ``kwargs`` too, then applies every change
        made since the last update; returns the keys that changed. A value the scene
        refuses raises :class:`rdr.Error` naming its key, and nothing is applied."""
        for k, v in dict(values or {}, **kwargs).items():
            self[k] = v
        changes = list(self._pending.items())
        self._pending.clear()
        if changes:
            _rdr.update(self._scene, changes)
            self._values = dict(_rdr.params(self._scene))
        return [k for k, _ in changes]

    def __repr__(self):
        lines = [f"  {k!r}: {v!r}," for k, v in self.items()]
        return "SceneParameters({\n" + "\n".join(lines) + "\n})"


def traverse(scene) -> SceneParameters:
    """The parameters of ``scene`` that can change between renders (``mi.traverse``)."""
    return SceneParameters(scene)
