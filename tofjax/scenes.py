"""Scenes for full frames (:meth:`tofjax.Camera.returns`): built-in geometry and its primitives.

Camera coordinates: the lens centre at the origin, +z along the optical axis, +x right, +y up.
Built-in scenes (distances in m, angles in degrees): :func:`wall`, :func:`tilted_plane`,
:func:`step_edge`, :func:`box_on_floor`, :func:`sphere`, :func:`corner` (with two-bounce light).
Compose your own from :class:`Plane`, :class:`Sphere` and :class:`Box` in a :class:`SceneGeometry`
(a new kind of surface is one subclass of :class:`AbstractPrimitive` with its ``intersect``);
:data:`BUILTIN_SCENES` lists each built-in scene's parameters and their allowed ranges.
:func:`moving` makes a scene move during the frame (a :class:`MovingScene`: every phase image sees
it where it is then; docs/model.md, "A camera in time: motion").
"""

from ._scene import (
    BUILTIN_SCENES, AbstractPrimitive, Box, Patches, Plane, Rays, SceneGeometry, Sphere, Surface, box_on_floor, corner,
    pixel_rays, resolution, sphere, step_edge, surface, surface_from_depth, tilted_plane, wall)
from ._motion import MovingScene, moving

__all__ = ["AbstractPrimitive", "BUILTIN_SCENES", "Box", "MovingScene", "Patches", "Plane", "Rays", "SceneGeometry",
           "Sphere", "Surface", "box_on_floor", "corner", "moving", "pixel_rays", "resolution", "sphere", "step_edge", "surface", "surface_from_depth",
           "tilted_plane", "wall"]
