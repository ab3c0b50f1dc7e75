"""Open3D's ray caster behind a ToF camera (issue 51 item 3; docs/renderers.md, "Open3D"): triangle
meshes in ``open3d.t.geometry.RaycastingScene`` (Embree, on the CPU, no display), cast along a
:class:`tofjax.Camera`'s own pixel rays (:func:`tofjax.optics.frame_rays`: its lens distortion and
its sub-pixel rays included) or a pinhole's.

What it gives: the distance along each ray, i.e. the **radial** distance for unit rays from the lens
centre (``depth_type="z"`` projects it on the axis), the hit triangle's normal, the geometry id
(the order the meshes were added in, from 0) and the triangle. Embree casts in float32; the hit is
then recomputed in float64 on the hit triangle's plane (t = n . (v0 - o) / n . d with the mesh's
float64 vertices), so a distance is exact to float64 rounding wherever the triangle is right (a
ray grazing an edge may still take its neighbour's). :func:`returns` makes a frame's
:class:`tofjax.Returns` from every sub-pixel ray, as ``camera.returns`` does for tofjax's own scenes
(flying pixels at depth edges included); ``tofjax render --mesh`` uses it.

Coordinates are tofjax's camera frame: the lens centre at the origin, +x right, +y up, +z along the
optical axis, metres. A mesh is placed there by a ``pose``: a 4 x 4 matrix, or ``(x, y, z, rx, ry,
rz)``, the mesh turned by rx, then ry, then rz degrees about the camera frame's x, y and z axes and
then moved by (x, y, z) m (:func:`pose_matrix`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ._render import Render, camera_intrinsics, pinhole_directions, require

o3d = require("open3d", "open3d", "tofjax.renderers.open3d")

__all__ = ["MESH_SUFFIXES", "MeshScene", "pose_matrix", "read_mesh", "render", "returns"]

#: The mesh files :func:`read_mesh` reads (Open3D's reader; ``tofjax render --mesh``).
MESH_SUFFIXES = (".obj", ".ply", ".stl", ".off", ".gltf", ".glb")
_INVALID = o3d.t.geometry.RaycastingScene.INVALID_ID


def pose_matrix(pose=None) -> np.ndarray:
    """A 4 x 4 rigid transform from ``pose``: ``None`` (the identity), a 4 x 4 matrix, or six numbers
    ``(x, y, z, rx, ry, rz)`` (m and degrees): R = Rz Ry Rx, turning about the fixed axes x, then y,
    then z, then the translation (x, y, z)."""
    if pose is None:
        return np.eye(4)
    a = np.asarray(pose, dtype=float)
    if a.shape == (4, 4):
        if not (np.all(np.isfinite(a)) and np.allclose(a[3], [0, 0, 0, 1])
                and np.allclose(a[:3, :3] @ a[:3, :3].T, np.eye(3), atol=1e-9)):
            raise ValueError("pose: a 4 x 4 matrix must be finite and rigid (an orthonormal rotation, last row 0 0 0 1)")
        return a
    if a.shape != (6,) or not np.all(np.isfinite(a)):
        raise ValueError(f"pose = {pose!r}: allowed six finite numbers (x, y, z in m, rx, ry, rz in degrees) or a "
                         "4 x 4 matrix")
    rx, ry, rz = np.radians(a[3:])
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    turn_x = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    turn_y = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    turn_z = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    out = np.eye(4)
    out[:3, :3] = turn_z @ turn_y @ turn_x
    out[:3, 3] = a[:3]
    return out


def read_mesh(path) -> tuple[np.ndarray, np.ndarray]:
    """The vertices ``(n, 3)`` (float64) and triangles ``(m, 3)`` of a mesh file (:data:`MESH_SUFFIXES`,
    Open3D's reader; OBJ coordinates are read as float32 by it); ``ValueError`` in one line naming the
    file where there is none, it is no mesh Open3D reads, or it holds no triangle."""
    path = Path(path)
    if path.suffix.lower() not in MESH_SUFFIXES:
        raise ValueError(f"{path}: not a mesh file tofjax reads: allowed {', '.join(MESH_SUFFIXES)}")
    if not path.is_file():
        raise ValueError(f"{path}: no such file")
    with o3d.utility.VerbosityContextManager(o3d.utility.VerbosityLevel.Error):
        mesh = o3d.io.read_triangle_mesh(str(path))
    vertices, triangles = np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.triangles, dtype=np.int64)
    if triangles.shape[0] == 0:
        raise ValueError(f"{path}: holds no triangles Open3D can read")
    if not np.all(np.isfinite(vertices)):
        raise ValueError(f"{path}: has non-finite vertex coordinates")
    return vertices, triangles


def _arrays(mesh) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(mesh, str | Path):
        return read_mesh(mesh)
    if isinstance(mesh, o3d.geometry.TriangleMesh):
        return np.asarray(mesh.vertices, dtype=float), np.asarray(mesh.triangles, dtype=np.int64)
    if isinstance(mesh, o3d.t.geometry.TriangleMesh):
        return (mesh.vertex.positions.numpy().astype(float), mesh.triangle.indices.numpy().astype(np.int64))
    if isinstance(mesh, tuple | list) and len(mesh) == 2:
        v, t = np.asarray(mesh[0], dtype=float), np.asarray(mesh[1])
        if v.ndim != 2 or v.shape[1] != 3 or t.ndim != 2 or t.shape[1] != 3 or not np.issubdtype(t.dtype, np.integer):
            raise ValueError(f"a mesh as (vertices, triangles) must be (n, 3) numbers and (m, 3) integers, got "
                             f"{v.shape} and {t.shape} {t.dtype}")
        if t.size and (t.min() < 0 or t.max() >= len(v)):
            raise ValueError(f"a mesh's triangles index vertices 0 to {len(v) - 1}: found {t.min()} to {t.max()}")
        return v, t.astype(np.int64)
    raise TypeError(f"a mesh is a file path, an open3d TriangleMesh (legacy or tensor) or (vertices, triangles), got "
                    f"{type(mesh).__name__}")


class MeshScene:
    """Triangle meshes to cast rays into: ``MeshScene([mesh, ...], poses=[...])`` or :meth:`add`
    one at a time. Each mesh's geometry id is its index (the segmentation's id)."""

    def __init__(self, meshes=(), poses=None):
        self._scene = o3d.t.geometry.RaycastingScene()
        self._vertices: list[np.ndarray] = []
        self._triangles: list[np.ndarray] = []
        poses = [None] * len(meshes) if poses is None else list(poses)
        if len(poses) != len(meshes):
            raise ValueError(f"{len(meshes)} meshes and {len(poses)} poses: allowed one pose per mesh")
        for mesh, pose in zip(meshes, poses, strict=True):
            self.add(mesh, pose)

    def add(self, mesh, pose=None) -> int:
        """Add ``mesh`` (a path, an Open3D triangle mesh or ``(vertices, triangles)``) placed by ``pose``
        (:func:`pose_matrix`) in the camera frame; returns its geometry id."""
        vertices, triangles = _arrays(mesh)
        m = pose_matrix(pose)
        vertices = vertices @ m[:3, :3].T + m[:3, 3]
        gid = self._scene.add_triangles(o3d.core.Tensor(vertices.astype(np.float32)),
                                        o3d.core.Tensor(triangles.astype(np.uint32)))
        if gid != len(self._vertices):  # Open3D numbers them in order; the refinement relies on it
            raise RuntimeError(f"Open3D gave geometry id {gid} to mesh {len(self._vertices)}")
        self._vertices.append(vertices)
        self._triangles.append(triangles)
        return gid

    @property
    def geometries(self) -> int:
        """How many meshes the scene holds."""
        return len(self._vertices)

    def cast(self, directions, origins=None) -> dict:
        """The first hit of every ray (``directions`` ``(..., 3)``, from ``origins``, default the lens
        centre): ``t`` (the distance in units of the direction's length, float64; inf: no hit),
        ``normal`` (unit, facing the ray; NaN: no hit), ``geometry_ids`` and ``primitive_ids``
        (int64; -1: no hit)."""
        if not self._vertices:
            raise ValueError("the mesh scene is empty: add a mesh first")
        d = np.asarray(directions, dtype=float)
        o = np.zeros_like(d) if origins is None else np.broadcast_to(np.asarray(origins, dtype=float), d.shape)
        hit = self._scene.cast_rays(o3d.core.Tensor(np.concatenate([o, d], axis=-1).astype(np.float32)))
        gid = hit["geometry_ids"].numpy().astype(np.int64)
        pid = hit["primitive_ids"].numpy().astype(np.int64)
        ok = gid != _INVALID
        gid, pid = np.where(ok, gid, -1), np.where(ok, pid, -1)
        t = np.full(d.shape[:-1], np.inf)
        normal = np.full(d.shape, np.nan)
        # Refine in float64 on the hit triangle's plane.
        offsets = np.cumsum([0] + [len(v) for v in self._vertices])
        vertices = np.concatenate(self._vertices)
        triangles = np.concatenate([tri + off for tri, off in zip(self._triangles, offsets, strict=False)])
        first = np.cumsum([0] + [len(tri) for tri in self._triangles])
        tri = triangles[first[gid[ok]] + pid[ok]]
        v0, v1, v2 = vertices[tri[:, 0]], vertices[tri[:, 1]], vertices[tri[:, 2]]
        n = np.cross(v1 - v0, v2 - v0)
        n = n / np.linalg.norm(n, axis=-1, keepdims=True)
        dk, ok_o = d[ok], o[ok]
        nd = np.einsum("ij,ij->i", n, dk)
        t_embree = hit["t_hit"].numpy().astype(float)[ok]
        grazing = np.abs(nd) < 1e-12 * np.linalg.norm(dk, axis=-1)
        t[ok] = np.where(grazing, t_embree, np.einsum("ij,ij->i", n, v0 - ok_o) / np.where(grazing, 1.0, nd))
        normal[ok] = np.where((nd > 0.0)[:, None], -n, n)
        return {"t": t, "normal": normal, "geometry_ids": gid, "primitive_ids": pid}


def _scene_of(scene) -> MeshScene:
    if isinstance(scene, MeshScene):
        return scene
    if isinstance(scene, list | tuple) and not (len(scene) == 2 and isinstance(scene[0], np.ndarray)):
        return MeshScene(scene)
    return MeshScene([scene])


def render(scene, camera=None, *, intrinsics: dict | None = None, depth_type: str = "radial") -> Render:
    """``scene`` (a :class:`MeshScene`, a mesh or a list of meshes) seen by ``camera`` (a
    :class:`tofjax.Camera`: each pixel's centre ray, through its lens' distortion; its intrinsics)
    or by a pinhole of ``intrinsics`` (a dict with ``width``, ``height``, ``fx``, ``fy``, ``cx``,
    ``cy``, OpenCV's convention, e.g. :func:`tofjax.optics.intrinsics`' without distortion): the
    distance along each ray (``depth_type="radial"``) or its planar depth (``"z"``), normals,
    geometry ids (``segmentation``) and triangles (``extra["primitive_ids"]``)."""
    from ._render import pinhole_intrinsics

    if (camera is None) == (intrinsics is None):
        raise ValueError("give camera (a tofjax.Camera) or intrinsics (a pinhole's), one of them")
    if camera is not None:
        import tofjax as tj

        intrinsics = camera_intrinsics(camera)
        directions = np.asarray(tj.optics.frame_rays(camera.params, camera.settings, subpixel_samples=1).centre,
                                dtype=float)
    else:
        if any(intrinsics.get("dist_coeffs") or ()):
            raise ValueError("intrinsics with distortion: give the tofjax.Camera instead, whose rays include it")
        intrinsics = pinhole_intrinsics(*(intrinsics[k] for k in ("width", "height", "fx", "fy", "cx", "cy")))
        directions = pinhole_directions(intrinsics)
    hit = _scene_of(scene).cast(directions)
    depth = hit["t"] if depth_type == "radial" else hit["t"] * directions[..., 2]
    return Render(depth, depth_type, intrinsics, hit["geometry_ids"].astype(np.int32), hit["normal"], directions,
                  "open3d", {"primitive_ids": hit["primitive_ids"]})


def returns(camera, scene, *, reflectivity: float = 0.9, reflectivity_table=None, sun_direction=None):
    """Every pixel's returns (:class:`tofjax.Returns`) from ``scene`` on ``camera``: the direct return
    of each of its sub-pixel rays (``frame.subpixel_samples``), through its lens' distortion, as
    ``camera.returns`` makes them from tofjax's own scenes. Each mesh is Lambertian, of
    ``reflectivity_table[geometry id]`` where the mapping names it, else ``reflectivity``;
    ``sun_direction``: the background light's direction (as ``camera.returns``'). No two-bounce light."""
    import jax.numpy as jnp

    import tofjax as tj

    from .._framegeometry import surface_returns
    from .._scene import Surface, _nonzero, unit_vector
    from .._schema import checked_range

    rho_default = float(checked_range(reflectivity, "reflectivity", 0.0, 1.0))
    table = {int(k): float(checked_range(v, f"reflectivity_table[{k}]", 0.0, 1.0))
             for k, v in (reflectivity_table or {}).items()}
    rays = tj.optics.frame_rays(camera.params, camera.settings)
    mesh = _scene_of(scene)

    def seen(directions):
        hit = mesh.cast(np.asarray(directions, dtype=float))
        rho = np.full(hit["t"].shape, rho_default)
        for key, value in table.items():
            rho[hit["geometry_ids"] == key] = value
        normal = np.where(np.isfinite(hit["normal"]), hit["normal"], 0.0)
        return hit["t"], normal, rho

    t, normal, rho = seen(rays.samples)
    centre_t, centre_normal, centre_rho = seen(rays.centre)
    if sun_direction is None:
        ambient = np.ones_like(t)
    else:
        sun = np.asarray(checked_range(sun_direction, "sun_direction"), dtype=float)
        if sun.shape != (3,):
            raise ValueError(f"sun_direction has shape {sun.shape}: allowed three numbers (dx, dy, dz)")
        _nonzero(sun, "sun_direction")
        ambient = np.maximum(-np.einsum("...k,k->...", normal, np.asarray(unit_vector(sun))), 0.0)
    surf = Surface(*(jnp.asarray(x) for x in (t, normal, rho, ambient, centre_t, centre_normal, centre_rho)))
    return surface_returns(camera.params, camera.settings, surf, rays)
