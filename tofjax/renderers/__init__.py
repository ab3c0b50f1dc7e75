"""Real renderers behind tofjax's frames (issue 51 item 3; docs/renderers.md): depth, segmentation
and, where the renderer has them, normals, in the form a ToF camera takes (:class:`Render`).

- :mod:`tofjax.renderers.mujoco`: MuJoCo's OpenGL renderer (``mujoco.Renderer``), headless with
  ``MUJOCO_GL=egl`` or ``osmesa``: a named camera's planar (Z) depth and geom ids, at a tofjax
  camera's resolution and intrinsics or at the MuJoCo camera's own (``pip install "tofjax[mujoco]"``).
- :mod:`tofjax.renderers.open3d`: Open3D's ``RaycastingScene`` (Embree, on the CPU): triangle
  meshes cast along a tofjax camera's own rays (its lens distortion and sub-pixel rays included) or
  a pinhole's; radial distances, normals, geometry ids, and a frame's :class:`tofjax.Returns`
  (``pip install "tofjax[open3d]"``; ``tofjax render --mesh`` uses it).

Each backend is an optional extra, imported only when its module is: ``import tofjax`` and ``import
tofjax.renderers`` import neither MuJoCo nor Open3D, and a missing one is named in one line
(:class:`MissingExtra`, an ``ImportError``).
"""

from __future__ import annotations

import importlib

from ._render import DEPTH_TYPES, MissingExtra, Render

__all__ = ["DEPTH_TYPES", "MissingExtra", "Render", "mujoco", "open3d"]

_BACKENDS = ("mujoco", "open3d")


def __getattr__(name: str):
    if name in _BACKENDS:
        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module 'tofjax.renderers' has no attribute {name!r}")
