"""The textured ground's relief as geometry where the camera resolves it, so that clods and
cracks cast shadows (a bump map only shades: it tilts the normal, and nothing occludes the sun).

The ground of the outdoor presets is one mesh (:func:`displaced_ground`): near the look point, over
the cells of the height map that the frame sees (widened by :data:`RELIEF_FRAME_MARGIN`), a grid of
cells :func:`cell_texels` texels on a side (about :data:`RELIEF_CELL_PX` pixels at the look point)
whose nodes stand at the height map's heights — its band finer than a Gaussian of
``band_texels`` (the clods, cracks and litter edges; the hollows' gentle swell, rms slope ~0.1,
stays a bump), lowered so that its crests touch the plane z = 0 (:data:`RELIEF_CREST_QUANTILE`):
objects and plants stand on the crests as on the plane before, and no ground comes nearer the
camera than that plane, which the plant masks of ``apps/sequence/drift.py`` and the health label
rely on; around it, the rest of the ground square as flat quads. The patch is flat along its rim
(:data:`RELIEF_FLAT_CELLS` cells, then a smoothstep over :data:`RELIEF_TAPER_CELLS`) and the
quads' hole lies one cell inside that rim, so the two overlap where both are the plane z = 0 and
no ray slips between them.

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
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["RELIEF_CELL_PX", "RELIEF_CREST_QUANTILE", "GroundRelief", "ReliefBSDF", "cell_texels", "band_heights", "patch_cells",
           "patch_mesh", "surround_quads", "ground_mesh", "displaced_ground"]

#: The mesh's cells are about this many pixels wide at the look point: the relief a pixel sees.
RELIEF_CELL_PX = 1.5
#: The patch covers the frame widened by this share of its half-width and half-height on each
#: side: the sensor's crop margin, and clods just outside the frame that shade it.
RELIEF_FRAME_MARGIN = 0.15
#: Cells of the patch's rim that stay flat (where the surrounding quads overlap it), and cells
#: of the smoothstep from there to the full relief (a slope of ~0.1 down to the sunk surface).
RELIEF_FLAT_CELLS, RELIEF_TAPER_CELLS = 2, 16
#: Towards the height map's edge (where a low view sees the patch end) the relief fades out over
#: this share of its half-side: a gradient of brightness, not a line, where cast shadows stop.
RELIEF_BORDER_FADE = 0.4
#: The flat quads around the patch are cut to at most this many times as long as wide.
RELIEF_CHUNK_ASPECT = 8.0
#: And where the patch reaches farther than this many times the look point's distance (depth
#: along the view), it fades out from there to its farthest node: cells a fraction of a pixel.
RELIEF_FAR_START = 1.3
#: The relief is lowered so that this quantile of its nodes touches the plane z = 0 (the few
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


def _node_coords(relief: GroundRelief) -> np.ndarray:
    """Ground coordinates (m) of the mesh's node lines: node k stands on texel centre k·cell."""
    n = relief.height.shape[0]
    return ((np.arange(0, n, relief.cell) + 0.5) / n - 0.5) * relief.extent_m


def patch_cells(view, relief: GroundRelief):
    """The cells the frame sees: ``(r0, first, last)``, cell rows ``r0 …`` (north) each from
    column ``first[i]`` to ``last[i]`` (east, inclusive), or None when the frame sees none. A cell
    counts when its centre, on z = 0, lies in the frame widened by :data:`RELIEF_FRAME_MARGIN`;
    the frame's footprint on a plane is convex, so each row's cells are one run."""
    lines = _node_coords(relief)
    centres = (lines[:-1] + lines[1:]) / 2
    east, north = np.meshgrid(centres, centres)  # [row (north), column (east)]
    cam = view.to_camera(np.stack([east, north, np.zeros_like(east)], axis=-1))
    z = cam[..., 2]
    tan_w, tan_h = (t * (1.0 + RELIEF_FRAME_MARGIN) for t in relief.tan_half)
    seen = (z > 0) & (np.abs(cam[..., 0]) < tan_w * z) & (np.abs(cam[..., 1]) < tan_h * z)
    rows = np.flatnonzero(seen.any(axis=1))
    if rows.size == 0:
        return None
    rows = np.arange(rows[0], rows[-1] + 1)
    first = np.array([np.argmax(seen[r]) if seen[r].any() else -1 for r in rows])
    last = np.array([seen.shape[1] - 1 - np.argmax(seen[r, ::-1]) if seen[r].any() else -1 for r in rows])
    keep = first >= 0  # a convex footprint has no empty row inside; kept safe anyway
    if not keep.all():
        rows, first, last = rows[keep], first[keep], last[keep]
        rows = rows[0] + np.arange(len(rows))
    return int(rows[0]), first, last


def patch_mesh(relief: GroundRelief, r0: int, first: np.ndarray, last: np.ndarray, view=None):
    """Vertices (ground frame, m), faces (facing up) of the displaced cells: each node at
    ``w``·min(b − b₉₉.₅, 0)·``texel_m``, b the band of :func:`band_heights` and b₉₉.₅ its
    :data:`RELIEF_CREST_QUANTILE` over the patch's nodes, ``w`` 0 within
    :data:`RELIEF_FLAT_CELLS` cells of the patch's edge and rising by a smoothstep over
    :data:`RELIEF_TAPER_CELLS`, over the outer :data:`RELIEF_BORDER_FADE` of the height map and,
    with the ``view``, beyond :data:`RELIEF_FAR_START` look distances (the depth along the view),
    so the rim is the plane z = 0 and the rest lies under it."""
    import cv2

    lines = _node_coords(relief)
    c0, c1 = int(first.min()), int(last.max()) + 1  # the cells' bounding box, columns c0 … c1 − 1
    cells = np.zeros((len(first), c1 - c0), bool)
    for i, (a, b) in enumerate(zip(first, last)):
        cells[i, a - c0:b - c0 + 1] = True
    padded = np.pad(cells, 1)
    used = padded[:-1, :-1] | padded[:-1, 1:] | padded[1:, :-1] | padded[1:, 1:]  # nodes of a patch cell
    inner = padded[:-1, :-1] & padded[:-1, 1:] & padded[1:, :-1] & padded[1:, 1:]  # all four cells in it
    distance = cv2.distanceTransform(np.pad(inner, 1).astype(np.uint8), cv2.DIST_L2, 5)[1:-1, 1:-1]
    t = np.clip((distance - RELIEF_FLAT_CELLS) / RELIEF_TAPER_CELLS, 0.0, 1.0)
    rows_t = (r0 + np.arange(cells.shape[0] + 1)) * relief.cell  # node rows and columns in texels
    cols_t = (c0 + np.arange(cells.shape[1] + 1)) * relief.cell
    n = relief.height.shape[0]
    inset = np.minimum.outer(np.minimum(rows_t, n - 1 - rows_t), np.minimum(cols_t, n - 1 - cols_t)) / (n / 2)
    t *= np.clip(inset / RELIEF_BORDER_FADE, 0.0, 1.0)  # fades out before the height map ends
    north, east = np.meshgrid(lines[r0:r0 + cells.shape[0] + 1], lines[c0:c1 + 1], indexing="ij")
    if view is not None:  # a low view: fade out from RELIEF_FAR_START look distances to the farthest node
        depth = view.to_camera(np.stack([east, north, np.zeros_like(east)], axis=-1))[..., 2]
        start, end = RELIEF_FAR_START * float(np.linalg.norm(view.camera_m)), float(depth[used].max())
        if end > start:
            t *= np.clip((end - depth) / (end - start), 0.0, 1.0)
    weight = t * t * (3 - 2 * t)
    band = band_heights(relief.height, relief.band_texels)[np.ix_(rows_t, cols_t)]
    band = np.minimum(band - np.quantile(band[used], RELIEF_CREST_QUANTILE), 0.0)  # under z = 0, crests on it
    index = np.full(used.shape, -1, np.int64)
    index[used] = np.arange(used.sum())
    vertices = np.stack([east[used], north[used], (weight * band * relief.texel_m)[used]], axis=-1)
    v00, v01 = index[:-1, :-1][cells], index[:-1, 1:][cells]  # (row, column): north, east
    v10, v11 = index[1:, :-1][cells], index[1:, 1:][cells]
    faces = np.concatenate([np.stack([v00, v01, v11], -1), np.stack([v00, v11, v10], -1)])  # counter-clockwise
    return vertices, faces


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


def surround_quads(relief: GroundRelief, r0: int, first: np.ndarray, last: np.ndarray, half_m: float):
    """(x0, x1, y0, y1) rectangles (m) that cover the ground square of half side ``half_m`` but
    the patch's cells one cell inside its edge (which the patch keeps flat): a strip a row
    between the hole and the patch's inset bounding box, then rings around the box each twice as
    wide as the last out to the square's edge, every piece cut to at most
    :data:`RELIEF_CHUNK_ASPECT` times as long as wide. Mitsuba's float32 ray–triangle test is
    off by ~ε·length·aspect beside a triangle's edges: a 200 m × 1.5 m quad beside the patch let
    rays through 1 mm inside its edge, 200 m strips a row high 154 of 20 000 vertical rays."""
    lines = _node_coords(relief)
    cell = float(lines[1] - lines[0])
    rows, west, east = len(first), int(first.min()) + 1, int(last.max())  # node columns of the box, inset
    box = np.array([lines[west], lines[east], lines[r0 + 1], max(lines[r0 + rows - 1], lines[r0 + 1])])
    quads = []
    for i in range(1, rows - 1):
        y0, y1 = lines[r0 + i], lines[r0 + i + 1]
        a, b = first[i] + 1, last[i]  # the hole: cells a … b − 1, node columns a … b
        parts = [(box[0], box[1])] if b - a < 1 else [(box[0], lines[a]), (lines[b], box[1])]
        for x0, x1 in parts:
            quads += _chunks(x0, x1, y0, y1)
    inner, grow = box, cell
    while inner[0] > -half_m or inner[1] < half_m or inner[2] > -half_m or inner[3] < half_m:
        outer = np.clip(inner + np.array([-grow, grow, -grow, grow]), -half_m, half_m)
        quads += (_chunks(outer[0], outer[1], outer[2], inner[2]) + _chunks(outer[0], outer[1], inner[3], outer[3])
                  + _chunks(outer[0], inner[0], inner[2], inner[3]) + _chunks(inner[1], outer[1], inner[2], inner[3]))
        inner, grow = outer, 2.0 * grow
    return np.array(quads, dtype=np.float64)


def ground_mesh(view, relief: GroundRelief, half_m: float):
    """Vertices (ground frame, m), faces (facing up) and texture coordinates of the whole ground
    square: the displaced patch (:func:`patch_mesh`) and the flat quads around it
    (:func:`surround_quads`); the texture coordinates those of a ``rectangle`` of half side
    ``half_m`` (0.5 + position / 2·half), so the ground's BSDF maps onto it as before. None when
    the frame sees no cell."""
    cells = patch_cells(view, relief)
    if cells is None:
        return None
    vertices, faces = patch_mesh(relief, *cells, view=view)
    quads = surround_quads(relief, *cells, half_m)
    x0, x1, y0, y1 = quads.T
    corners = np.stack([np.stack([x0, y0], -1), np.stack([x1, y0], -1), np.stack([x1, y1], -1),
                        np.stack([x0, y1], -1)], axis=1).reshape(-1, 2)
    base = len(vertices) + 4 * np.arange(len(quads))[:, None]
    quad_faces = np.concatenate([base + [0, 1, 2], base + [0, 2, 3]])
    vertices = np.concatenate([vertices, np.column_stack([corners, np.zeros(len(corners))])])
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
