"""The textured ground's relief as geometry where the camera resolves it, so that clods and
cracks cast shadows (a bump map only shades: it tilts the normal, and nothing occludes the sun).

The ground of the outdoor presets is one mesh (:func:`displaced_ground`), made the way terrain
renderers make theirs [4]_, [5]_: over the part of the ground the frame sees (widened by
:data:`RELIEF_FRAME_MARGIN`), a quadtree of square cells (:func:`ring_cells`) whose level L has
cells ``cell``·2^L texels on a side (:func:`cell_texels`: about :data:`RELIEF_CELL_PX` pixels at
the look point) and reaches from :data:`RELIEF_RING_START`·2^(L−1) to :data:`RELIEF_RING_START`·2^L
look distances (depth along the view), so that a cell stays 1–2 pixels wide at any distance, out
to the level whose cells reach :data:`RELIEF_RING_END_BAND` of the band's σ (:func:`ring_levels`). Level L's nodes stand on the
height map's band finer than a Gaussian of ``band_texels`` (the clods, cracks and litter edges;
the hollows' gentle swell, rms slope ~0.1, stays a bump), low-passed by a Gaussian of half its
cell (level 0 not at all) so that relief finer than a cell does not alias, and lowered so that
its crests touch the plane z = 0 (:data:`RELIEF_CREST_QUANTILE`): objects and plants stand on the
crests, and no ground comes nearer the camera than that plane, which the plant masks of
``apps/sequence/drift.py`` and the health label rely on. Over the outer half of its range (in
log depth) a level's nodes morph into the next level's surface (geomorphing [5]_), so the
relief, and the share of the ground its facets shadow, fades with distance without a step, and
a fine node on a coarse cell's edge lies on that edge: no crack at the seams. Beyond the height
map the heights are mirrored, as the texture is. Under it all lies the ground square as a flat
backstop just below the deepest node (rings of quads, every one at most
:data:`RELIEF_CHUNK_ASPECT` times as long as wide): the ground beyond the frame and the far end,
and whatever float precision lets slip between triangles (a T-junction's float rounding; no
skirt needed). An object out there stands up to the relief's depth (centimetres) above it,
unseen.

Every vertex has the normal +z: Mitsuba's ``bumpmap`` replaces the component of ∂p/∂u and ∂p/∂v
along the shading normal by the texture's gradient, so with a vertical shading normal a tilted
facet is shaded exactly as the flat plane under the full height map was — the bump still gives
the shading at every scale, texels finer than the mesh included — while the facets give what a
bump cannot: cast shadows, occlusion and parallax.

References
----------
.. [1] Blinn, J. F. (1978). Simulation of wrinkled surfaces. SIGGRAPH '78, 286–292 (bump mapping:
   the normal only).
.. [2] Cook, R. L. (1984). Shade trees. SIGGRAPH '84, 223–231 (displacement: the geometry moves).
.. [3] Mitsuba 3, plugin ``bumpmap`` (``frame``: ∂p/∂u ← ∂p/∂u + n·(∂h/∂u − n·∂p/∂u)).
.. [4] Losasso, F., & Hoppe, H. (2004). Geometry clipmaps: terrain rendering using nested regular
   grids. ACM Transactions on Graphics 23(3), 769–776.
.. [5] Ulrich, T. (2002). Rendering massive terrains using chunked level of detail control.
   SIGGRAPH 2002 course notes (geomorphing between levels; skirts).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["RELIEF_CELL_PX", "RELIEF_CREST_QUANTILE", "RELIEF_RING_START", "GroundRelief", "ReliefBSDF",
           "cell_texels", "band_heights", "ring_levels", "level_heights", "morphed_heights", "ring_cells",
           "ground_mesh", "displaced_ground"]

#: The mesh's cells are about this many pixels wide at the look point: the relief a pixel sees.
RELIEF_CELL_PX = 1.5
#: The mesh covers the frame widened by this share of its half-width and half-height on each
#: side: the sensor's crop margin, and clods just outside the frame that shade it.
RELIEF_FRAME_MARGIN = 0.15
#: Level L of the mesh (cells 2^L times the finest) reaches from this times 2^(L−1) to this
#: times 2^L look distances: its cells are 1–2 pixels wide there, as level 0's at the look point.
RELIEF_RING_START = 1.5
#: Levels go on until their cells are this many times the band's σ; the last morphs into the
#: band low-passed by a Gaussian of its cell, whose slopes (rms 0.04 for the presets' clods of rms
#: slope 0.6: 0.60, 0.26, 0.11, 0.04 at σ = 0, 2, 4, 8 texels) cast no shadow for a sun above
#: ~5°: beyond it the bump map alone shades the ground.
RELIEF_RING_END_BAND = 0.5
#: The flat backstop's quads are cut to at most this many times as long as wide.
RELIEF_CHUNK_ASPECT = 8.0
#: Each level is lowered so that this quantile of its heights touches the plane z = 0 (the few
#: higher crests are cut flat there): the ground lies under the plane the objects stand on.
RELIEF_CREST_QUANTILE = 0.995


@dataclass(frozen=True)
class GroundRelief:
    """What the displaced ground is made of: the bump map's ``height`` (texels of the height map,
    read-only, square), a texel in metres (``texel_m``; the height map spans ``height.shape[0]``
    texels centred on the look point, texel columns east, rows north), the σ of the
    Gaussian whose low-pass stays a bump (``band_texels``), the mesh's cell (``cell``, texels)
    and the frame's half-angle tangents (``tan_half``: width, height) it must cover."""

    height: np.ndarray
    texel_m: float
    band_texels: float
    cell: int
    tan_half: tuple[float, float]

    @property
    def extent_m(self) -> float:
        return float(self.height.shape[0] * self.texel_m)


class ReliefBSDF(dict):
    """A ground's BSDF scene-dict entry (a plain dict to Mitsuba) with the :class:`GroundRelief` of
    its bump map, which :func:`spectral_cam.presets.outdoor.ground` turns into geometry."""

    def __init__(self, bsdf: dict, relief: GroundRelief):
        super().__init__(bsdf)
        self.relief = relief


def cell_texels(relief_texels: int, width_px: int, views: float) -> int:
    """Texels on a side of a mesh cell: :data:`RELIEF_CELL_PX` pixels at the look point, for a
    height map of ``relief_texels`` spanning ``views`` view widths of ``width_px`` pixels
    (at least 1).

    Examples
    --------
    >>> cell_texels(2048, 480, 3.0)  # 1.42 texels a pixel: cells of 2 texels, 1.4 px
    2
    """
    return max(1, int(round(RELIEF_CELL_PX * relief_texels / (views * width_px))))


def band_heights(height: np.ndarray, band_texels: float) -> np.ndarray:
    """The relief finer than a Gaussian of σ = ``band_texels`` texels: ``height`` less its
    low-pass (OpenCV, mirrored at the edges as the texture is), zero mean."""
    import cv2

    field = np.asarray(height, dtype=np.float32)
    return (field - cv2.GaussianBlur(field, (0, 0), float(band_texels), borderType=cv2.BORDER_REFLECT)).astype(
        np.float64)


def ring_levels(relief: GroundRelief) -> int:
    """The coarsest level of the mesh: the first whose cells, ``cell``·2^L texels, reach
    :data:`RELIEF_RING_END_BAND` times the band's σ (0 when the finest cells already do)."""
    return max(0, int(np.ceil(np.log2(RELIEF_RING_END_BAND * relief.band_texels / relief.cell))))


def level_heights(relief: GroundRelief) -> list:
    """Node heights (texels) of every level and of the one after the last (the last morphs into
    it), each on the height map's texels: the band of :func:`band_heights` low-passed by a
    Gaussian of σ = half the level's cell (OpenCV, mirrored; level 0 as it is), lowered by its
    :data:`RELIEF_CREST_QUANTILE` and cut at 0."""
    import cv2

    band = band_heights(relief.height, relief.band_texels).astype(np.float32)
    fields = []
    for level in range(ring_levels(relief) + 2):
        sigma = 0.5 * relief.cell * 2 ** level
        low = band if level == 0 else cv2.GaussianBlur(band, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
        low = low.astype(np.float64)
        fields.append(np.minimum(low - np.quantile(low, RELIEF_CREST_QUANTILE), 0.0))
    return fields


def _mirror(t: np.ndarray, n: int) -> np.ndarray:
    """Texel index ``t`` (any integer) folded into 0 … n − 1 as a mirrored texture is."""
    t = np.mod(t, 2 * n)
    return np.where(t < n, t, 2 * n - 1 - t)


def _at(field: np.ndarray, col: np.ndarray, row: np.ndarray) -> np.ndarray:
    n = field.shape[0]
    return field[_mirror(row, n), _mirror(col, n)]


def _texel_m(relief: GroundRelief, t) -> np.ndarray:
    """Ground coordinate (m) of texel index ``t`` (its centre; the map spans 0 … n − 1)."""
    return (np.asarray(t, dtype=np.float64) + 0.5 - relief.height.shape[0] / 2) * relief.texel_m


def _level_of_depth(view, depth_m: np.ndarray) -> np.ndarray:
    """The continuous level log2(depth / (:data:`RELIEF_RING_START`·look distance)) + 1: level L
    reaches from L to L + 1 (negative near the camera, where level 0 goes on)."""
    look = RELIEF_RING_START * float(np.linalg.norm(view.camera_m))
    return np.log2(np.maximum(depth_m, 1e-9) / look) + 1.0


def morphed_heights(view, relief: GroundRelief, fields: list, level: np.ndarray, col: np.ndarray,
                    row: np.ndarray) -> np.ndarray:
    """Heights (texels) of nodes at texel indices ``col``, ``row`` of cells at ``level``: the
    level's own (``fields`` of :func:`level_heights`) blended by a smoothstep, over the outer
    half of the level's range, into the next level's surface there (its cells cut along the
    south-west–north-east diagonal, linear on each half), which it reaches at the range's end."""
    z = np.empty(len(col))
    for lv in np.unique(level):
        sel = level == lv
        c, r = col[sel], row[sel]
        own, coarse, s = fields[lv], fields[lv + 1], relief.cell * 2 ** (lv + 1)
        i, j = np.floor_divide(c, s) * s, np.floor_divide(r, s) * s
        a, b = (c - i) / s, (r - j) / s
        z00, z01, z10, z11 = _at(coarse, i, j), _at(coarse, i + s, j), _at(coarse, i, j + s), _at(coarse, i + s, j + s)
        target = np.where(a >= b, z00 + a * (z01 - z00) + b * (z11 - z01), z00 + b * (z10 - z00) + a * (z11 - z10))
        depth = view.to_camera(np.stack([_texel_m(relief, c), _texel_m(relief, r), np.zeros(len(c))], -1))[:, 2]
        t = np.clip(2.0 * (_level_of_depth(view, depth) - lv) - 1.0, 0.0, 1.0)
        mu = t * t * (3 - 2 * t)
        z[sel] = (1 - mu) * _at(own, c, r) + mu * target
    return z


def _cell_corners(relief: GroundRelief, i: np.ndarray, j: np.ndarray, s: int) -> np.ndarray:
    """Ground points (m) of the corners of cells (``i``, ``j``) of ``s`` texels: [cell, corner, xyz]."""
    cols = np.stack([i, i + 1, i, i + 1], -1) * s
    rows = np.stack([j, j, j + 1, j + 1], -1) * s
    return np.stack([_texel_m(relief, cols), _texel_m(relief, rows), np.zeros(cols.shape)], -1)


def _split(view, relief: GroundRelief, i, j, level: int, top: int, half_m: float):
    """Of cells (``i``, ``j``) at ``level``: the leaves (kept at this level) and the cells to
    split. A cell is dropped when all its corners lie outside one plane of the widened frame or
    beyond the last level's range (the frame's footprint is convex: what is left meets it, or
    nearly), or outside the ground square; it is a leaf when its nearest corner's continuous
    level (:func:`_level_of_depth`) is at least ``level``, if it lies wholly in the square."""
    corners = _cell_corners(relief, i, j, relief.cell * 2 ** level)
    cam = view.to_camera(corners)
    x, y, z = cam[..., 0], cam[..., 1], cam[..., 2]
    tan_w, tan_h = (t * (1.0 + RELIEF_FRAME_MARGIN) for t in relief.tan_half)
    far = RELIEF_RING_START * float(np.linalg.norm(view.camera_m)) * 2.0 ** top
    outside = ((x > tan_w * z).all(-1) | (-x > tan_w * z).all(-1) | (y > tan_h * z).all(-1)
               | (-y > tan_h * z).all(-1) | (z > far).all(-1))
    in_square = (np.abs(corners[..., :2]) <= half_m).all(-1)
    inside, outside = in_square.all(-1), outside | ~in_square.any(-1)
    nearest = _level_of_depth(view, z.min(-1))
    leaf = ~outside & inside & ((nearest >= level) | (level == 0))
    split = ~outside & ~leaf & (level > 0)
    return (i[leaf], j[leaf]), (i[split], j[split])


def ring_cells(view, relief: GroundRelief, half_m: float) -> list:
    """The mesh's cells: per level L (0 … :func:`ring_levels`), the indices (i, j) of its cells,
    texels i·s … (i + 1)·s east and j·s … (j + 1)·s north, s = ``cell``·2^L; a quadtree from cells
    a quarter of the ground square's half side, split down to each cell's level (:func:`_split`)."""
    top = ring_levels(relief)
    root = max(top, int(np.ceil(np.log2(half_m / (4.0 * relief.cell * relief.texel_m)))))
    s = relief.cell * 2 ** root
    k = int(np.ceil((half_m / relief.texel_m + relief.height.shape[0]) / s)) + 1
    i, j = (a.ravel() for a in np.meshgrid(np.arange(-k, k), np.arange(-k, k)))
    leaves = [None] * (top + 1)
    for level in range(root, -1, -1):
        leaf, (i, j) = _split(view, relief, i, j, level, top, half_m)
        if level <= top:  # above it, a leaf lies beyond ``far``: no leaf (the backstop is there)
            leaves[level] = leaf
        i = np.concatenate([2 * i, 2 * i + 1, 2 * i, 2 * i + 1])
        j = np.concatenate([2 * j, 2 * j, 2 * j + 1, 2 * j + 1])
    return leaves


def _chunks(x0: float, x1: float, y0: float, y1: float) -> list:
    """A rectangle cut across its long side into pieces at most :data:`RELIEF_CHUNK_ASPECT` times
    as long as wide (none when it is empty)."""
    if x1 <= x0 or y1 <= y0:
        return []
    long_x = (x1 - x0) >= (y1 - y0)
    length, width = (x1 - x0, y1 - y0) if long_x else (y1 - y0, x1 - x0)
    cuts = np.linspace(0.0, 1.0, int(np.ceil(length / (RELIEF_CHUNK_ASPECT * width))) + 1)
    if long_x:
        xs = x0 + cuts * (x1 - x0)
        return [(u, v, y0, y1) for u, v in zip(xs[:-1], xs[1:])]
    ys = y0 + cuts * (y1 - y0)
    return [(x0, x1, u, v) for u, v in zip(ys[:-1], ys[1:])]


def backstop_quads(half_m: float, start_m: float) -> np.ndarray:
    """(x0, x1, y0, y1) rectangles (m) covering the ground square of half side ``half_m``: a
    square of half side ``start_m`` and rings around it each twice as wide as the last, every
    piece cut to at most :data:`RELIEF_CHUNK_ASPECT` times as long as wide (Mitsuba's float32
    ray–triangle test is off by ~ε·length·aspect beside a triangle's edges)."""
    inner, grow = np.array([-start_m, start_m, -start_m, start_m]), start_m
    quads = [tuple(inner)]
    while inner[1] < half_m:
        outer = np.clip(inner + np.array([-grow, grow, -grow, grow]), -half_m, half_m)
        quads += (_chunks(outer[0], outer[1], outer[2], inner[2]) + _chunks(outer[0], outer[1], inner[3], outer[3])
                  + _chunks(outer[0], inner[0], inner[2], inner[3]) + _chunks(inner[1], outer[1], inner[2], inner[3]))
        inner, grow = outer, 2.0 * grow
    return np.array(quads, dtype=np.float64)


def _cell_faces(relief: GroundRelief, leaves: list):
    """Unique node texel indices (col, row), each node's finest level, and the faces (facing up,
    two a cell, cut along the south-west–north-east diagonal) of the cells ``leaves``."""
    corners, levels = [], []
    for level, (i, j) in enumerate(leaves):
        s = relief.cell * 2 ** level
        corners.append(np.stack([np.stack([i, j], -1), np.stack([i + 1, j], -1), np.stack([i, j + 1], -1),
                                 np.stack([i + 1, j + 1], -1)], 1) * s)  # v00, v01 (east), v10 (north), v11
        levels.append(np.full(len(i), level))
    corners, levels = np.concatenate(corners), np.concatenate(levels)
    offset = int(np.abs(corners).max()) + 1
    keys = (corners[..., 1] + offset) * (2 * offset + 1) + (corners[..., 0] + offset)
    unique, inverse = np.unique(keys.ravel(), return_inverse=True)
    inverse = inverse.reshape(keys.shape)
    node_level = np.full(len(unique), 1 << 30)
    np.minimum.at(node_level, inverse, np.repeat(levels[:, None], 4, 1))
    col, row = unique % (2 * offset + 1) - offset, unique // (2 * offset + 1) - offset
    v00, v01, v10, v11 = inverse.T
    faces = np.concatenate([np.stack([v00, v01, v11], -1), np.stack([v00, v11, v10], -1)])
    return col, row, node_level, faces


def ground_mesh(view, relief: GroundRelief, half_m: float):
    """Vertices (ground frame, m), faces (facing up) and texture coordinates of the whole ground
    square: the cells of :func:`ring_cells` at :func:`morphed_heights` and the flat backstop of
    :func:`backstop_quads` a texel under the deepest node; the texture coordinates those of a
    ``rectangle`` of half side ``half_m`` (0.5 + position / 2·half), so the ground's BSDF maps
    onto it as before. None when the frame sees no cell."""
    leaves = ring_cells(view, relief, half_m)
    if sum(len(i) for i, _ in leaves) == 0:
        return None
    col, row, level, faces = _cell_faces(relief, leaves)
    z = morphed_heights(view, relief, level_heights(relief), level, col, row) * relief.texel_m
    vertices = np.stack([_texel_m(relief, col), _texel_m(relief, row), z], -1)
    quads = backstop_quads(half_m, relief.extent_m / 8)
    x0, x1, y0, y1 = quads.T
    corners = np.stack([np.stack([x0, y0], -1), np.stack([x1, y0], -1), np.stack([x1, y1], -1),
                        np.stack([x0, y1], -1)], axis=1).reshape(-1, 2)
    base = len(vertices) + 4 * np.arange(len(quads))[:, None]
    quad_faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]])
    floor = float(z.min()) - relief.texel_m
    vertices = np.concatenate([vertices, np.column_stack([corners, np.full(len(corners), floor)])])
    faces = np.concatenate([faces, quad_faces])
    return vertices, faces, 0.5 + vertices[:, :2] / (2.0 * half_m)


def displaced_ground(view, mi, bsdf: ReliefBSDF, half_m: float):
    """The ground square as one Mitsuba mesh named ``ground`` (:func:`ground_mesh`), in the
    camera frame, every vertex normal +z (the module's notes: the bump map shades, the facets
    shadow); a ``rectangle`` when the frame sees none of the height map."""
    from .meshes import set_vertex_normals

    built = ground_mesh(view, bsdf.relief, half_m)
    if built is None:
        return {"type": "rectangle", "bsdf": dict(bsdf),
                "to_world": view.transform(mi, mi.ScalarTransform4f().scale([half_m, half_m, 1.0]))}
    vertices, faces, texcoords = built
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(dict(bsdf))
    mesh = mi.Mesh("ground", len(vertices), len(faces), props=props, has_vertex_normals=True,
                   has_vertex_texcoords=True)
    params = mi.traverse(mesh)
    floats, indices = type(params["vertex_positions"]), type(params["faces"])
    params["vertex_positions"] = floats(np.ascontiguousarray(view.to_camera(vertices), dtype=np.float32).ravel())
    params["faces"] = indices(np.ascontiguousarray(faces, dtype=np.uint32).ravel())
    params["vertex_texcoords"] = floats(np.ascontiguousarray(texcoords, dtype=np.float32).ravel())
    params.update()
    up = np.broadcast_to(view.rotation @ np.array([0.0, 0.0, 1.0]), vertices.shape)
    set_vertex_normals(mi, mesh, up)
    return mesh
