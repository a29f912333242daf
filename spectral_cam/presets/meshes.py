"""Procedural triangle meshes for the presets (surfaces of revolution), as Mitsuba meshes.

A surface of revolution is a profile (radius, height) swept about the vertical axis; a torus
is the sweep of a circle, a vase the sweep of a smooth curve closed by a base disc. Vertex
normals come from Mitsuba (averaged face normals), so curved objects shade smoothly.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, ``mi.Mesh`` built from Python (vertex_positions,
   faces, vertex_texcoords, ``add_attribute`` read by the ``mesh_attribute`` texture), and
   ``Mesh::recompute_vertex_normals`` (src/render/mesh.cpp).
.. [2] Thürmer, G., & Wüthrich, C. A. (1998). Computing vertex normals from polygonal facets.
   Journal of Graphics Tools 3(1), 43–46.
"""

from __future__ import annotations

import numpy as np

__all__ = ["lathe", "torus", "vase", "vertex_normals", "set_vertex_normals", "mitsuba_mesh"]


def lathe(radius: np.ndarray, height: np.ndarray, segments: int = 48, *, closed_loop: bool = False):
    """Vertices (n, 3) and triangles (m, 3) of the profile ``(radius, height)`` swept about +z.

    ``closed_loop`` joins the profile's last point to its first (a torus's circle)."""
    radius, height = np.asarray(radius, float), np.asarray(height, float)
    angles = np.linspace(0.0, 2 * np.pi, segments, endpoint=False)
    ring = len(radius)
    vertices = np.stack([np.outer(np.cos(angles), radius).ravel(), np.outer(np.sin(angles), radius).ravel(),
                         np.tile(height, segments)], axis=1)
    faces = []
    rows = ring if closed_loop else ring - 1
    for s in range(segments):
        t = (s + 1) % segments
        for k in range(rows):
            k1 = (k + 1) % ring
            a, b, c, d = s * ring + k, t * ring + k, t * ring + k1, s * ring + k1
            faces += [(a, b, c), (a, c, d)]
    return vertices, np.asarray(faces, dtype=np.uint32)


def torus(major_m: float, minor_m: float, segments: int = 48, sides: int = 24):
    """A torus lying on z = 0 (its hole vertical), centred on the z axis."""
    phi = np.linspace(0.0, 2 * np.pi, sides, endpoint=False)
    return lathe(major_m + minor_m * np.cos(phi), minor_m * (1 + np.sin(phi)), segments, closed_loop=True)


def vase(height_m: float, segments: int = 48, points: int = 24):
    """A vase standing on z = 0: a closed base disc and a wall whose radius swells and narrows
    (0.35·h at the base, 0.45·h at a third of its height, 0.2·h at the neck)."""
    t = np.linspace(0.0, 1.0, points)
    wall = height_m * (0.3 + 0.15 * np.sin(np.pi * 1.5 * t) - 0.1 * t)
    radius = np.concatenate([[0.0], wall])
    height = np.concatenate([[0.0], height_m * t])
    return lathe(radius, height, segments)


def vertex_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit vertex normals of a triangle mesh: each face's unit normal weighted by the angle of
    its corner at the vertex, summed and normalised ([2]_, Mitsuba's rule [1]_), in float64 and
    a fixed order, so the same mesh always gets the same bits (Mitsuba's scatter-add on its
    threads does not, see the module docstring).

    Parameters
    ----------
    vertices : numpy.ndarray
        (n, 3) positions (any unit).
    faces : numpy.ndarray
        (m, 3) vertex indices, counter-clockwise seen from the front.

    Returns
    -------
    numpy.ndarray
        (n, 3) float64 unit normals. A degenerate (zero-area) face adds nothing; a vertex that
        only such faces use (or none) gets +z, as no visible triangle interpolates it.

    References
    ----------
    .. [1] Mitsuba 3, ``Mesh::recompute_vertex_normals``.
    .. [2] Thürmer, G., & Wüthrich, C. A. (1998). J. Graphics Tools 3(1), 43–46.

    Examples
    --------
    >>> import numpy as np
    >>> square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    >>> vertex_normals(square, np.array([[0, 1, 2], [0, 2, 3]])).tolist()[0]
    [0.0, 0.0, 1.0]
    """
    points = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    corners = points[faces]  # (m, 3 corners, 3)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    total = np.zeros_like(points)
    for corner in range(3):
        edges = [corners[:, (corner + k) % 3] - corners[:, corner] for k in (1, 2)]
        edges = [np.divide(e, n, out=np.zeros_like(e), where=n > 0)
                 for e in edges for n in [np.linalg.norm(e, axis=1, keepdims=True)]]
        angle = np.arccos(np.clip(np.einsum("ij,ij->i", *edges), -1.0, 1.0))
        for axis in range(3):  # bincount adds in index order: the same sum every time
            total[:, axis] += np.bincount(faces[:, corner], weights=normal[:, axis] * angle, minlength=len(points))
    length = np.linalg.norm(total, axis=1, keepdims=True)
    out = np.divide(total, length, out=np.zeros_like(total), where=length > 0)
    out[length[:, 0] == 0] = (0.0, 0.0, 1.0)
    return out


def set_vertex_normals(mi, mesh, normals: np.ndarray) -> None:
    """Store (n, 3) unit ``normals`` in a Mitsuba ``mesh`` built with ``has_vertex_normals``
    (in the variant's own buffer type), instead of ``mesh.recompute_vertex_normals()``."""
    params = mi.traverse(mesh)
    floats = type(params["vertex_positions"])
    params["vertex_normals"] = floats(np.ascontiguousarray(normals, dtype=np.float32).ravel())
    params.update()


def mitsuba_mesh(mi, name: str, vertices: np.ndarray, faces: np.ndarray, bsdf: dict, to_world=None, *,
                 texcoords: np.ndarray | None = None, attributes: dict | None = None):
    """A Mitsuba mesh of these triangles with ``bsdf`` (a scene-dict entry), placed by
    ``to_world``; with ``texcoords`` (n, 2) per-vertex (u, v) and ``attributes`` (name →
    (n,) or (n, k) per-vertex values, names starting ``vertex_``) that a ``mesh_attribute``
    texture reads."""
    if to_world is not None:
        matrix = np.asarray(to_world.matrix, dtype=float).reshape(4, 4, -1)[..., 0]
        vertices = vertices @ matrix[:3, :3].T + matrix[:3, 3]
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    mesh = mi.Mesh(name, len(vertices), len(faces), props=props, has_vertex_normals=True,
                   has_vertex_texcoords=texcoords is not None)
    params = mi.traverse(mesh)
    # the buffers' own types: mi.Float is a Python float in the scalar variants, an array in the JIT ones
    floats, indices = type(params["vertex_positions"]), type(params["faces"])
    params["vertex_positions"] = floats(np.ascontiguousarray(vertices, dtype=np.float32).ravel())
    params["faces"] = indices(np.ascontiguousarray(faces, dtype=np.uint32).ravel())
    if texcoords is not None:
        params["vertex_texcoords"] = floats(np.ascontiguousarray(texcoords, dtype=np.float32).ravel())
    params.update()
    for key, values in (attributes or {}).items():
        values = np.asarray(values, dtype=np.float32).reshape(len(vertices), -1)
        mesh.add_attribute(key, values.shape[1], floats(np.ascontiguousarray(values).ravel()))
    set_vertex_normals(mi, mesh, vertex_normals(vertices, faces))  # not Mitsuba's: its sums follow the threads
    return mesh
