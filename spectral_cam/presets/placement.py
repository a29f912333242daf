"""Meshes into the scene: one Mitsuba mesh of :class:`~spectral_cam.presets.mesh_files.MeshData`
(:func:`asset_mesh`), and many copies of one (:func:`place_copies`) as Mitsuba instances of a
``shapegroup`` or as one merged mesh (:func:`use_instances` says which), spread over the ground
the frame sees (:func:`ground_in_view`). Shared by users' assets
(:mod:`spectral_cam.presets.assets`) and ground clutter (:mod:`spectral_cam.presets.scatter`).

Frames: the ground frame of :class:`spectral_cam.presets.outdoor.GroundView` (east, north, up;
metres) and the presets' camera frame (:func:`camera_matrix` maps one to the other).

References
----------
.. [1] Mitsuba 3 plugins ``shapegroup`` and ``instance``; mitsuba3 issue #1017 and pull request
   #1945 (instances in the JIT variants).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .mesh_files import MeshData

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["asset_mesh", "ground_in_view", "camera_matrix", "use_instances", "merge_copies", "place_copies",
           "VIEW_MARGIN"]


def asset_mesh(mi, name: str, data: MeshData, bsdf: dict, matrix: np.ndarray | None = None):
    """A Mitsuba mesh of ``data`` (its positions and normals moved by the 4 × 4 ``matrix``, a
    rotation, uniform scale and translation), with texture coordinates and the
    ``vertex_color`` attribute where it has them."""
    vertices, normals = data.vertices, data.normals
    if matrix is not None:
        vertices = vertices @ matrix[:3, :3].T + matrix[:3, 3]
        if normals is not None:
            normals = normals @ matrix[:3, :3].T
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    mesh = mi.Mesh(name, len(vertices), len(data.faces), props=props, has_vertex_normals=True,
                   has_vertex_texcoords=data.uv is not None)
    mesh.set_id(name)  # a scene dict's key names it too; a shapegroup's inner mesh keeps this one
    params = mi.traverse(mesh)
    floats, indices = type(params["vertex_positions"]), type(params["faces"])  # the variant's own (scalar too)
    if data.colours is not None:
        mesh.add_attribute("vertex_color", 3, floats(np.ascontiguousarray(data.colours, dtype=np.float32).ravel()))
        params = mi.traverse(mesh)
    params["vertex_positions"] = floats(np.ascontiguousarray(vertices, dtype=np.float32).ravel())
    params["faces"] = indices(np.ascontiguousarray(data.faces, dtype=np.uint32).ravel())
    if data.uv is not None:
        params["vertex_texcoords"] = floats(np.ascontiguousarray(data.uv, dtype=np.float32).ravel())
    params.update()
    if normals is not None and np.all(np.isfinite(normals)):
        unit = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        params["vertex_normals"] = floats(np.ascontiguousarray(unit, dtype=np.float32).ravel())
        params.update()
    else:  # ours, in a fixed order: Mitsuba's sums follow its threads' timing (issue 39 #17)
        from .meshes import set_vertex_normals, vertex_normals

        set_vertex_normals(mi, mesh, vertex_normals(vertices, data.faces))
    return mesh


# ----------------------------------------------------------------------------- copies
#: Fraction of the frame (each way) a copy's foot may lie beyond and still be drawn (its body
#: reaches into view).
VIEW_MARGIN = 1.1


def ground_in_view(config: "SceneConfig", lens: "ThinLens", reach_m: float):
    """``(box, inside)``: a ground-frame box ``(east0, north0, east1, north1)`` around the ground
    the frame (grown by :data:`VIEW_MARGIN`) sees within ``reach_m`` of the camera's foot, and a
    function telling which (n, 2) ground points lie in that region."""
    from .outdoor import GroundView

    view = GroundView.from_config(config)
    half_x = VIEW_MARGIN * lens.sensor_width_m / (2 * lens.image_distance_m)
    half_y = VIEW_MARGIN * lens.sensor_height_m / (2 * lens.image_distance_m)
    foot = view.camera_m[:2]

    def inside(points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        ground = np.concatenate([points, np.zeros((len(points), 1))], axis=1)
        camera = view.to_camera(ground)
        z = camera[:, 2]
        in_frame = (z > 0) & (np.abs(camera[:, 0]) <= half_x * z) & (np.abs(camera[:, 1]) <= half_y * z)
        return in_frame & (np.hypot(*(points - foot).T) <= reach_m)

    # the frame's outline cast onto the ground, each ray held to reach_m: the region's bounding box
    t = np.linspace(-1.0, 1.0, 17)
    edge = np.concatenate([np.stack([t, np.full_like(t, s)], 1) for s in (-1, 1)]
                          + [np.stack([np.full_like(t, s), t], 1) for s in (-1, 1)])
    points = [foot]
    for u, v in edge:
        direction = view.rotation.T @ np.array([u * half_x, v * half_y, 1.0])
        horizontal = np.hypot(*direction[:2])
        if direction[2] < 0:
            hit = view.camera_m + (-view.camera_m[2] / direction[2]) * direction
            if np.hypot(*(hit[:2] - foot)) <= reach_m:
                points.append(hit[:2])
                continue
        if horizontal > 1e-12:
            points.append(foot + reach_m * direction[:2] / horizontal)
    points = np.asarray(points)
    return (*points.min(axis=0), *points.max(axis=0)), inside


def camera_matrix(view) -> np.ndarray:
    """4 × 4: ground frame → the presets' camera frame (:meth:`GroundView.transform` in NumPy)."""
    m = np.eye(4)
    m[:3, :3] = view.rotation
    m[:3, 3] = -view.rotation @ view.camera_m
    return m


def use_instances(mi) -> bool:
    """Whether copies become Mitsuba ``instance``s of a ``shapegroup`` (else one merged mesh).

    Instances hold a transform each (measured in ``scalar_spectral``: 10 000 instances of a
    528-triangle stone peaked at 165 MB against 118 MB for one). In the JIT variants of
    Mitsuba up to 3.9.1, though, every instance is traced into the kernel as a virtual-call
    target of its own: 300 instances took 17 s and 258 MB, 1000 took 68 s and 732 MB (llvm,
    32² px, 1 spp), where 10 000 copies merged into one mesh took 18 s and 1.0 GB (mitsuba3
    issue #1017; pull request #1945, "Resolve instancing at the scene level", came after
    3.9.1). So: instances in the scalar variants and in Mitsuba releases after 3.9.1, merged
    copies in the JIT variants before.
    """
    import re

    if mi.variant().startswith("scalar"):
        return True
    version = tuple(int(part) for part in re.findall(r"\d+", str(mi.__version__))[:3])
    return version > (3, 9, 1)


def merge_copies(data: MeshData, matrices) -> MeshData:
    """One mesh holding ``data`` moved by each 4 × 4 matrix (rotation, uniform scale, move)."""
    mats = np.asarray(matrices, dtype=np.float64).reshape(-1, 4, 4)
    k, n = len(mats), len(data.vertices)
    vertices = np.einsum("kij,nj->kni", mats[:, :3, :3], data.vertices) + mats[:, None, :3, 3]
    faces = data.faces[None] + (np.arange(k, dtype=np.int64) * n)[:, None, None]
    out = MeshData(vertices.reshape(-1, 3), faces.reshape(-1, 3), texture_file=data.texture_file,
                   texture=data.texture, colour=data.colour)
    if data.normals is not None:
        out.normals = np.einsum("kij,nj->kni", mats[:, :3, :3], data.normals).reshape(-1, 3)
    if data.uv is not None:
        out.uv = np.tile(data.uv, (k, 1))
    if data.colours is not None:
        out.colours = np.tile(data.colours, (k, 1))
    return out


def place_copies(mi, camera: np.ndarray, data: MeshData, bsdf: dict, placements, *, name: str, group_key: str,
                 merged_key: str, first: int = 0) -> dict:
    """Scene-dict entries of ``data`` at each ground-frame 4 × 4 in ``placements`` (``camera``:
    :func:`camera_matrix`): a shapegroup ``group_key`` holding mesh ``name`` and instances
    ``<name>_<first + n>`` where :func:`use_instances`, else one mesh ``merged_key`` (named
    ``name``) holding every copy."""
    if use_instances(mi):
        entries = {group_key: {"type": "shapegroup", name: asset_mesh(mi, name, data, bsdf)}}
        ref = {"type": "ref", "id": group_key}
        for n, local in enumerate(placements):
            entries[f"{name}_{first + n}"] = {"type": "instance", "shapegroup": ref,
                                              "to_world": mi.ScalarTransform4f(camera @ local)}
        return entries
    return {merged_key: asset_mesh(mi, name, merge_copies(data, [camera @ local for local in placements]), bsdf)}
