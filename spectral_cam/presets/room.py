"""``room``: a furnished room seen from inside — textured walls, floor and ceiling, a wooden
table on a rug, a fabric sofa with cushions, a bookshelf full of books, a painted sideboard, a
metal floor lamp and things on the table — lit by a ceiling panel and the floor lamp's shade,
both of ``[illuminant]``'s spectrum (a measured LED, fluorescent or incandescent light).

Frame: the room's floor is z = 0 with x east, y north (the camera looks roughly north) and z
up, its origin under the table's centre, which is the look point: the camera stands
``scene.distance_m`` from it, looking down ``scene.view_pitch_deg`` and turned by a yaw of
6–14° to either side drawn by ``layout_seed`` (so one corner is in view). Camera frame as in
:mod:`spectral_cam.presets.outdoor` (:class:`~spectral_cam.presets.outdoor.GroundView`).

Every surface is a triangle mesh whose texture coordinates are metres on its faces, so one
texture keeps its scale on every object; every material is two-sided. Spectra (all measured):

* floor: boards of the USGS pines (``usgs_wood``) in grain (fractal fields stretched 12×
  along the boards, :func:`spectral_cam.textures.grain_maps`), each board its own part of the
  grain and its own stain; a stain is the pine's reflectance raised to a power k (its
  absorbance × k, Beer–Lambert: k = 1.6 oak, 2.2 honey, 3 walnut; the table 3.2), the joints between boards the stained
  wood at a fifth (a shadowed gap);
* walls: a paint drawn from ``scene.object_reflectances`` (L* 62–90, C* 3–30 under D65; the back wall a
  stronger colour, C* 15–32), mixed by low-contrast fBm with the same paint at 0.85 (uneven
  wear) and bump-mapped (plaster); white skirting boards and ceiling (ColorChecker white);
* fabric: a twill-woven tartan of two or three spectra of the set (warp and weft stripes of
  4–40 mm, threads of 1 mm over and under in a 2/2 twill);
* rug: a border and a diamond field of ColorChecker spectra; painting: fractal patches of
  five ColorChecker colours; books and the sideboard: samples of the set;
* metal: ``roughconductor`` with Mitsuba's measured η, k (Al, Cu, Au; Palik).

Light: the ceiling panel is a square 1 m on a side over the table whose radiance gives the
table's top ``illuminance_lux`` at its centre (E/L = 4·A/√(1+A²)·atan(A/√(1+A²)),
:func:`spectral_cam.presets.outdoor.lamp_irradiance_factor`); the floor lamp's shade sends
:data:`LAMP_FLUX_LM` lumens through diffusers closing it below and above. One spectrum lights
the room, so its white balance and ground truth are ``[illuminant]``'s.

References
----------
.. [1] Keshava, N., & Mustard, J. F. (2002). Spectral unmixing. IEEE Signal Processing
   Magazine 19(1), 44–57 (linear mixing of measured spectra).
.. [2] Kokaly, R. F., et al. (2017). USGS Spectral Library Version 7 (woods).
.. [3] CIE 224:2017 (the colour samples); Pascale, D. (2006), BabelColor ColorChecker averages.
.. [4] Howell, J. R., A Catalog of Radiation Heat Transfer Configuration Factors, C-11.
.. [5] Palik, E. D. (1985). Handbook of Optical Constants of Solids (Mitsuba's conductors).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .. import spectra
from .common import PRESETS, reflectance_spectrum, spectrum_dict
from .meshes import set_vertex_normals, vertex_normals

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["Piece", "RoomLayout", "room_layout", "ceiling_lamp", "ROOM_HEIGHT_M", "TABLE_HEIGHT_M"]

ROOM_HEIGHT_M = 2.6
#: The back wall stands this far beyond the look point; the side walls this far either side.
BACK_WALL_M, SIDE_WALL_M = 1.75, 2.3
TABLE_HEIGHT_M = 0.76
#: The ceiling panel: side (m).
PANEL_SIDE_M = 1.0
#: The floor lamp: luminous flux (lm; a 400-lm "40 W" bulb) leaving its shade's diffusers, the share
#: going down, and the shade's radii at its bottom and top (m).
LAMP_FLUX_LM, LAMP_DOWN_SHARE, SHADE_RADII_M = 400.0, 0.6, (0.2, 0.13)
#: Heights of the shade's bottom and top (m).
SHADE_Z_M = (1.38, 1.64)
#: Textures: texels on a side and the metres they span.
FLOOR_TEXELS, FLOOR_SPAN_M = 1024, 6.4
WALL_TEXELS, WALL_SPAN_M = 512, 3.0
FABRIC_TEXELS, FABRIC_SPAN_M = 512, 0.512
CONDUCTOR_METALS = ("Al", "Cu", "Au")


@dataclass
class Piece:
    """One mesh of the room in the room frame (m): name, vertices (n, 3), triangles (m, 3),
    texture coordinates (n, 2, metres on its faces, or None) and material key."""

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    texcoords: np.ndarray | None
    material: str


@dataclass
class RoomLayout:
    """The room of one ``layout_seed``: its walls' places, the camera's yaw, the pieces and
    the materials they name (scene-dict BSDFs), and where the lights are."""

    east_m: tuple[float, float]
    north_m: tuple[float, float]
    height_m: float
    yaw_deg: float
    pieces: list[Piece] = field(default_factory=list)
    materials: dict = field(default_factory=dict)
    lamp_m: tuple[float, float] = (0.0, 0.0)

    def add(self, name, mesh, material):
        vertices, faces, texcoords = mesh
        self.pieces.append(Piece(name, vertices, faces, texcoords, material))


# ----------------------------------------------------------------------------- meshes
def box(lo, hi, turn_deg: float = 0.0, pivot=None):
    """An axis-aligned box from ``lo`` to ``hi`` (room frame, m) turned by ``turn_deg`` about the
    vertical through ``pivot`` (default its centre): 24 vertices, 12 triangles, texture
    coordinates in metres on each face (u along x, or y on the x faces; v along y or z)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    size = hi - lo
    corners = []
    uvs = []
    # each face: (axis, side, in-plane axes (u, v))
    for axis, side, (a, b) in ((0, 0, (1, 2)), (0, 1, (1, 2)), (1, 0, (0, 2)), (1, 1, (0, 2)),
                               (2, 0, (0, 1)), (2, 1, (0, 1))):
        quad = []
        for du, dv in ((0, 0), (1, 0), (1, 1), (0, 1)):
            p = lo.copy()
            p[axis] = hi[axis] if side else lo[axis]
            p[a] = lo[a] + du * size[a]
            p[b] = lo[b] + dv * size[b]
            quad.append(p)
            uvs.append((du * size[a], dv * size[b]))
        corners += quad
    vertices = np.asarray(corners)
    faces = np.asarray([(4 * f, 4 * f + 1, 4 * f + 2) for f in range(6)] + [(4 * f, 4 * f + 2, 4 * f + 3)
                                                                           for f in range(6)], np.uint32)
    if turn_deg:
        pivot = (lo + hi) / 2 if pivot is None else np.asarray(pivot, float)
        vertices = _turn(vertices, turn_deg, pivot)
    return vertices, faces, np.asarray(uvs, float)


def _turn(vertices, turn_deg, pivot):
    t = math.radians(turn_deg)
    rot = np.array([[math.cos(t), -math.sin(t), 0.0], [math.sin(t), math.cos(t), 0.0], [0.0, 0.0, 1.0]])
    return (vertices - pivot) @ rot.T + pivot


def quad(corners):
    """A rectangle through four corners (room frame) with metric texture coordinates."""
    corners = np.asarray(corners, float)
    u = np.linalg.norm(corners[1] - corners[0])
    v = np.linalg.norm(corners[3] - corners[0])
    return corners, np.array([(0, 1, 2), (0, 2, 3)], np.uint32), np.array([(0, 0), (u, 0), (u, v), (0, v)], float)


def turned_lathe(radius, height, centre, segments=32):
    """A surface of revolution (:func:`spectral_cam.presets.meshes.lathe`) standing at ``centre``."""
    from .meshes import lathe

    vertices, faces = lathe(radius, height, segments)
    return vertices + np.asarray(centre, float), faces, None


# ----------------------------------------------------------------------------- spectra
def _scaled(sd, factor: float = 1.0, power: float = 1.0, name: str = ""):
    values = np.clip(np.asarray(sd.values, float), 1e-4, 1.0) ** power * factor
    return spectra.Spectrum(sd.wavelengths, values, name or sd.name)


@functools.lru_cache(maxsize=8)
def _lab(set_name: str) -> np.ndarray:
    """CIELAB (D65) of every sample of a reflectance set."""
    from ..colour_ground_truth import illuminant_white_xyz, reflectance_xyz
    from ..reflectance_sets import reflectance_set

    xyz = reflectance_xyz("D65", list(reflectance_set(set_name).sds)) / illuminant_white_xyz("D65")
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[:, 1] - 16, 500 * (f[:, 0] - f[:, 1]), 200 * (f[:, 1] - f[:, 2])], axis=1)


def _pick(rng, set_name: str, lightness, chroma_min=0.0, chroma_max=200.0, exclude=()):
    """Index of a sample of the set whose L* and C* (D65) lie in the given ranges (the nearest
    in L* when none does)."""
    lab = _lab(set_name)
    chroma = np.hypot(lab[:, 1], lab[:, 2])
    ok = ((lab[:, 0] >= lightness[0]) & (lab[:, 0] <= lightness[1]) & (chroma >= chroma_min)
          & (chroma <= chroma_max))
    ok[list(exclude)] = False
    candidates = np.flatnonzero(ok)
    if candidates.size == 0:
        return int(np.argmin(np.abs(lab[:, 0] - np.mean(lightness))))
    return int(rng.choice(candidates))


# ----------------------------------------------------------------------------- textures
def _twosided(bsdf: dict) -> dict:
    return {"type": "twosided", "bsdf": bsdf}


def _uv(span_u: float, span_v: float | None = None, mi=None):
    span_v = span_u if span_v is None else span_v
    return mi.ScalarTransform4f().scale([1.0 / span_u, 1.0 / span_v, 1.0])


@functools.lru_cache(maxsize=4)
def floor_abundances(seed: int, stain: float) -> np.ndarray:
    """Abundances (5, N, N) of the floor's endmembers — pine beam, pine plywood, both stained,
    the joints — over :data:`FLOOR_SPAN_M`; boards run along axis 0 (v, north)."""
    from ..textures import grain_maps

    n = FLOOR_TEXELS
    texel = FLOOR_SPAN_M / n
    grain = grain_maps(n, [1.0, 1.0], period_px=n / 8, stretch=12.0, seed=seed)  # streaks along axis 0
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0xF100]))
    board_w = max(2, int(round(0.15 / texel)))
    out = np.zeros((5, n, n), np.float32)
    seam = np.zeros((n, n), bool)
    for col0 in range(0, n, board_w):
        cols = slice(col0, min(n, col0 + board_w))
        seam[:, col0] = True
        row = -int(rng.integers(0, int(2.0 / texel)))
        while row < n:
            length = int(rng.uniform(0.9, 2.2) / texel)
            rows = slice(max(row, 0), min(n, row + length))
            if rows.start < rows.stop:
                shift = int(rng.integers(0, n))
                g = np.roll(grain[:, :, cols], shift, axis=1)[:, rows]
                s = float(np.clip(stain + rng.normal(0.0, 0.08), 0.05, 1.0))
                out[0, rows, cols] = g[0] * (1 - s)
                out[1, rows, cols] = g[1] * (1 - s)
                out[2, rows, cols] = g[0] * s
                out[3, rows, cols] = g[1] * s
                if row >= 0:
                    seam[row, cols] = True
            row += length
    out[:, seam] = 0.0
    out[4, seam] = 1.0
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=4)
def tartan_abundances(seed: int, colours: int) -> np.ndarray:
    """A twill-woven tartan (``colours``, N, N) over :data:`FABRIC_SPAN_M`: warp and weft of
    the same sett of stripes (4–40 mm), 1-mm threads crossing in a 2/2 twill."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x7A27]))
    n = FABRIC_TEXELS
    texel_mm = 1000 * FABRIC_SPAN_M / n
    sett = []
    while len(sett) < n:
        colour = int(rng.integers(colours)) if sett else 0
        width = int(max(2, rng.choice([4, 6, 10, 16, 24, 40]) / texel_mm))
        sett += [colour] * width
    sett = np.asarray(sett[:n])
    warp = np.broadcast_to(sett[None, :], (n, n))
    weft = np.broadcast_to(sett[:, None], (n, n))
    i, j = np.indices((n, n))
    over = ((i + j) // 2) % 2 == 0  # 2/2 twill
    threads = np.where(over, warp, weft)
    out = np.stack([(threads == k).astype(np.float32) for k in range(colours)])
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=4)
def rug_abundances(seed: int, rows: int, cols: int) -> np.ndarray:
    """A rug's pattern (4, rows, cols) over its top: field, border, motif, outline (a border
    band with a chequered motif, a field of outlined diamonds)."""
    import cv2

    from ..textures import fbm

    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x2B6]))
    v, u = np.meshgrid((np.arange(rows) + 0.5) / rows, (np.arange(cols) + 0.5) / cols, indexing="ij")
    edge = np.minimum(np.minimum(u, 1 - u) * cols / rows, np.minimum(v, 1 - v))  # in rug heights
    label = np.zeros((rows, cols), np.int32)  # 0 field
    band = (edge > 0.03) & (edge < 0.14)
    label[band] = 1
    cells = float(rng.uniform(18, 30))
    chequer = ((np.floor(u * cols / rows * cells) + np.floor(v * cells)) % 2 == 0)
    label[band & chequer & (edge > 0.06) & (edge < 0.11)] = 2
    label[(edge <= 0.03) | ((edge >= 0.14) & (edge < 0.16))] = 3
    inner = edge >= 0.16
    nx, ny = float(rng.integers(3, 6)), float(rng.integers(2, 4))
    du, dv = np.abs((u * nx) % 1 - 0.5), np.abs((v * ny) % 1 - 0.5)
    diamond = du + dv
    label[inner & (diamond < 0.36)] = 2
    label[inner & (diamond >= 0.30) & (diamond < 0.36)] = 3
    label[inner & (diamond < 0.12)] = 1
    out = np.stack([(label == k).astype(np.float32) for k in range(4)])
    out = np.stack([cv2.GaussianBlur(m, (0, 0), 0.7) for m in out])
    wear = fbm(max(rows, cols), period_px=max(rows, cols) / 3, seed=seed + 5)[:rows, :cols]
    out[0] += 0.15 * np.clip(wear, 0, None)  # worn towards the field's colour
    out /= out.sum(axis=0, keepdims=True)
    out.setflags(write=False)
    return out.astype(np.float32)


def _wall_bsdf(mi, paint, seed: int) -> dict:
    from ..textures import abundance_maps, height_field
    from .common import mixed_bsdf

    worn = _scaled(paint, 0.85)
    maps = abundance_maps(WALL_TEXELS, [0.75, 0.25], period_px=WALL_TEXELS / 3, seed=seed, contrast=1.5)
    height = height_field(WALL_TEXELS, period_px=WALL_TEXELS / 24, seed=seed)
    return mixed_bsdf(mi, [paint, worn], maps, to_uv=_uv(WALL_SPAN_M, mi=mi), height=height, bump_scale=0.004)


# ----------------------------------------------------------------------------- layout
def _yaw(seed: int) -> float:
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x9A3]))
    return float(rng.choice([-1.0, 1.0]) * rng.uniform(6.0, 14.0))


def room_view(config: "SceneConfig"):
    """The camera in the room (:class:`~spectral_cam.presets.outdoor.GroundView` with the
    layout's yaw as heading)."""
    from ..solar import enu_to_camera
    from .outdoor import GroundView

    rotation = enu_to_camera(_yaw(int(config.scene.layout_seed)), config.scene.view_pitch_deg)
    view = rotation.T @ np.array([0.0, 0.0, 1.0])
    return GroundView(rotation, -config.scene.distance_m * view)


def room_layout(config: "SceneConfig", lens: "ThinLens | None" = None) -> RoomLayout:
    """The room of ``config``'s ``layout_seed``: every piece in the room frame and its
    material (scene-dict entries still to load).

    Raises
    ------
    ConfigError
        When ``scene.object_count`` things do not fit on the table, or the camera would
        stand outside a room this size.
    """
    from ..errors import ConfigError
    from ..reflectance_sets import reflectance_set

    s = config.scene
    seed = int(s.layout_seed)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x400A]))
    view = room_view(config)
    camera = view.camera_m
    if camera[2] >= ROOM_HEIGHT_M - 0.1:
        raise ConfigError(f"scene.distance_m = {s.distance_m:g} at view_pitch_deg = {s.view_pitch_deg:g} puts the "
                          f"camera {camera[2]:.2f} m high, above the room's {ROOM_HEIGHT_M:g}-m ceiling; come nearer "
                          "or look down less")
    half = max(SIDE_WALL_M, abs(camera[0]) + 0.5)
    east = (-half, half)
    north = (min(-2.0, camera[1] - 0.8), BACK_WALL_M)
    H = ROOM_HEIGHT_M
    room = RoomLayout(east, north, H, _yaw(seed))
    samples = reflectance_set(s.object_reflectances)
    set_name = s.object_reflectances
    checker = spectra.colorchecker_reflectances()
    white = checker["white 9.5 (.05 D)"]
    mats = room.materials

    # walls, floor, ceiling --------------------------------------------------------------
    side_paint = samples.sds[_pick(rng, set_name, (62, 90), 3, 30)]
    back_index = _pick(rng, set_name, (45, 80), 15, 32)
    back_paint = samples.sds[back_index]
    (x0, x1), (y0, y1) = east, north
    mats["wall"] = lambda mi: _twosided(_wall_bsdf(mi, side_paint, seed))
    mats["back_wall"] = lambda mi: _twosided(_wall_bsdf(mi, back_paint, seed + 3))
    room.add("wall_back", quad([(x0, y1, 0), (x1, y1, 0), (x1, y1, H), (x0, y1, H)]), "back_wall")
    room.add("wall_left", quad([(x0, y0, 0), (x0, y1, 0), (x0, y1, H), (x0, y0, H)]), "wall")
    room.add("wall_right", quad([(x1, y1, 0), (x1, y0, 0), (x1, y0, H), (x1, y1, H)]), "wall")
    room.add("wall_front", quad([(x1, y0, 0), (x0, y0, 0), (x0, y0, H), (x1, y0, H)]), "wall")
    room.add("ceiling", quad([(x0, y0, H), (x1, y0, H), (x1, y1, H), (x0, y1, H)]), "white")
    mats["white"] = lambda mi: _twosided({"type": "diffuse", "reflectance": reflectance_spectrum(white)})
    mats["skirting"] = lambda mi: _twosided({"type": "roughplastic", "distribution": "ggx", "alpha": 0.25,
                                             "int_ior": 1.49, "diffuse_reflectance": reflectance_spectrum(white)})
    t, h = 0.015, 0.10
    room.add("skirting_back", box((x0, y1 - t, 0), (x1, y1, h)), "skirting")
    room.add("skirting_front", box((x0, y0, 0), (x1, y0 + t, h)), "skirting")
    room.add("skirting_left", box((x0, y0 + t, 0), (x0 + t, y1 - t, h)), "skirting")
    room.add("skirting_right", box((x1 - t, y0 + t, 0), (x1, y1 - t, h)), "skirting")

    woods = list(reflectance_set("usgs_wood").sds)
    stain_power = float(rng.choice([1.6, 2.2, 3.0]))
    stained = [_scaled(w, power=stain_power) for w in woods]
    floor_ends = woods + stained + [_scaled(stained[0], 0.2)]
    stain = float(rng.uniform(0.4, 0.9))

    def floor_bsdf(mi):
        from .common import mixed_bsdf

        return _twosided(mixed_bsdf(mi, floor_ends, floor_abundances(seed, round(stain, 3)),
                                    to_uv=_uv(FLOOR_SPAN_M, mi=mi)))

    mats["floor"] = floor_bsdf
    room.add("floor", quad([(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)]), "floor")

    # table on a rug ---------------------------------------------------------------------
    turn = float(rng.uniform(-8, 8))
    dark_woods = [_scaled(w, power=3.2) for w in woods]

    def dark_wood(mi):
        from ..textures import grain_maps
        from .common import mixed_bsdf

        maps = grain_maps(512, [1.0, 1.0], period_px=64, stretch=10.0, seed=seed + 11)
        return _twosided(mixed_bsdf(mi, dark_woods, maps, to_uv=_uv(2.0, mi=mi)))

    mats["dark_wood"] = dark_wood
    L, W = 1.3, 0.8
    room.add("table_top", box((-L / 2, -W / 2, TABLE_HEIGHT_M - 0.04), (L / 2, W / 2, TABLE_HEIGHT_M), turn, (0, 0, 0)),
             "dark_wood")
    for k, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
        cx, cy = sx * (L / 2 - 0.07), sy * (W / 2 - 0.07)
        room.add(f"table_leg_{k}", box((cx - 0.03, cy - 0.03, 0.006), (cx + 0.03, cy + 0.03, TABLE_HEIGHT_M - 0.04),
                                       turn, (0, 0, 0)), "dark_wood")
    rug_l, rug_w = 2.4, 1.7
    rug_palette = [checker[name] for name in rng.choice(
        [("red", "blue", "orange yellow", "black 2 (1.5 D)"), ("blue", "moderate red", "neutral 8 (.23 D)",
                                                                 "black 2 (1.5 D)"),
         ("purplish blue", "orange", "light skin", "dark skin"), ("moderate red", "bluish green", "yellow",
                                                                   "neutral 3.5 (1.05 D)")])]
    rug_rows, rug_cols = 340, 480
    def rug(mi):
        from .common import mixed_bsdf

        return _twosided(mixed_bsdf(mi, rug_palette, rug_abundances(seed, rug_rows, rug_cols),
                                    to_uv=_uv(rug_l, rug_w, mi=mi)))

    mats["rug"] = rug
    room.add("rug", box((-rug_l / 2, -rug_w / 2, 0.0), (rug_l / 2, rug_w / 2, 0.006), turn + float(rng.uniform(-4, 4)),
                        (0, 0, 0)), "rug")

    # sofa against the back wall ---------------------------------------------------------
    xs = float(rng.uniform(-0.45, 0.45))
    sw, sd = 2.1, 0.9
    yb = y1 - 0.03
    fabric_a = _pick(rng, set_name, (25, 60), 25)
    fabric_b = _pick(rng, set_name, (10, 35), 0, 200, (fabric_a,))
    fabric_c = _pick(rng, set_name, (70, 95), 0, 20, (fabric_a, fabric_b))
    weave = [samples.sds[fabric_a], samples.sds[fabric_b], samples.sds[fabric_c]]

    def fabric(mi, ends=weave, seed_=seed):
        from .common import mixed_bsdf

        return _twosided(mixed_bsdf(mi, ends, tartan_abundances(seed_, len(ends)), to_uv=_uv(FABRIC_SPAN_M, mi=mi)))

    mats["sofa"] = fabric
    f = 0.08  # feet
    room.add("sofa_base", box((xs - sw / 2, yb - sd, f), (xs + sw / 2, yb, 0.42)), "sofa")
    room.add("sofa_back", box((xs - sw / 2, yb - 0.22, 0.42), (xs + sw / 2, yb, 0.88)), "sofa")
    for side, name in ((-1, "left"), (1, "right")):
        ax = xs + side * (sw / 2 - 0.11)
        room.add(f"sofa_arm_{name}", box((ax - 0.11, yb - sd, 0.42), (ax + 0.11, yb - 0.22, 0.64)), "sofa")
        for k, fy in enumerate((yb - sd + 0.05, yb - 0.07)):
            fx = xs + side * (sw / 2 - 0.06)
            room.add(f"sofa_foot_{name}_{k}", box((fx - 0.03, fy - 0.03, 0.0), (fx + 0.03, fy + 0.03, f)), "metal_feet")
    mats["metal_feet"] = lambda mi: _twosided({"type": "roughconductor", "distribution": "ggx", "alpha": 0.25,
                                               "material": "Al"})
    inner = sw - 0.44
    for k in range(2):
        cx0 = xs - inner / 2 + k * inner / 2
        room.add(f"sofa_seat_{k}", box((cx0 + 0.01, yb - sd + 0.02, 0.42), (cx0 + inner / 2 - 0.01, yb - 0.23, 0.54)),
                 "sofa")
    cushions = int(rng.integers(2, 4))
    for k in range(cushions):
        colour = _pick(rng, set_name, (20, 75), 30)
        key = f"cushion_{k}"
        mats[key] = functools.partial(fabric, ends=[samples.sds[colour], _scaled(samples.sds[colour], 0.55)],
                                      seed_=seed + 31 + k)
        cx = xs - inner / 2 + (k + 0.5) * inner / cushions + float(rng.uniform(-0.08, 0.08))
        v, fc, uv = box((cx - 0.21, yb - 0.34, 0.55), (cx + 0.21, yb - 0.22, 0.95))
        # leaning back 15° against the sofa's back
        pivot = np.array([cx, yb - 0.22, 0.55])
        a = math.radians(-15.0)
        rot = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
        room.add(key, ((v - pivot) @ rot.T + pivot, fc, uv), key)

    # painting over the sofa -------------------------------------------------------------
    paint_colours = [checker[n] for n in rng.choice(
        ["orange", "purplish blue", "moderate red", "yellow green", "orange yellow", "blue", "green", "red",
         "yellow", "magenta", "cyan", "neutral 8 (.23 D)", "black 2 (1.5 D)"], 5, replace=False)]

    def canvas(mi):
        from ..textures import abundance_maps
        from .common import mixed_bsdf

        maps = abundance_maps(256, [1.0] * 5, period_px=110, seed=seed + 77, contrast=6.0)
        return _twosided(mixed_bsdf(mi, paint_colours, maps, to_uv=_uv(1.0, 0.7, mi=mi)))

    mats["canvas"] = canvas
    mats["frame"] = lambda mi: _twosided({"type": "diffuse", "reflectance": reflectance_spectrum(
        checker["black 2 (1.5 D)"])})
    px, pz = xs + float(rng.uniform(-0.2, 0.2)), 1.45
    room.add("painting", box((px - 0.5, y1 - 0.035, pz - 0.35), (px + 0.5, y1 - 0.005, pz + 0.35)), "canvas")
    for name, lo, hi in (("bottom", (px - 0.54, pz - 0.39), (px + 0.54, pz - 0.35)),
                         ("top", (px - 0.54, pz + 0.35), (px + 0.54, pz + 0.39)),
                         ("left", (px - 0.54, pz - 0.35), (px - 0.5, pz + 0.35)),
                         ("right", (px + 0.5, pz - 0.35), (px + 0.54, pz + 0.35))):
        room.add(f"painting_frame_{name}", box((lo[0], y1 - 0.045, lo[1]), (hi[0], y1 - 0.005, hi[1])), "frame")

    # bookshelf against one side wall, the floor lamp in the other back corner -----------
    side = float(rng.choice([-1.0, 1.0]))
    wall_x = x1 if side > 0 else x0
    depth, width, height, board = 0.32, 1.0, 1.95, 0.022
    ya, yz = y1 - 0.06 - width, y1 - 0.06
    xin, xout = wall_x - side * (depth + 0.01), wall_x - side * 0.01
    xa, xz = min(xin, xout), max(xin, xout)
    shelf_paint = samples.sds[_pick(rng, set_name, (30, 92), 0, 40)]
    mats["shelf"] = lambda mi: _twosided({"type": "roughplastic", "distribution": "ggx", "alpha": 0.3,
                                          "int_ior": 1.49, "diffuse_reflectance": reflectance_spectrum(shelf_paint)})
    room.add("shelf_side_0", box((xa, ya, 0), (xz, ya + board, height)), "shelf")
    room.add("shelf_side_1", box((xa, yz - board, 0), (xz, yz, height)), "shelf")
    back_in = xout - side * 0.012
    room.add("shelf_back", box((min(back_in, xout), ya + board, 0.0), (max(back_in, xout), yz - board, height)),
             "shelf")
    levels = np.linspace(0.06, height - board, 6)
    for k, z in enumerate(levels):
        room.add(f"shelf_board_{k}", box((xa, ya + board, z - board), (xz, yz - board, z)), "shelf")
    book_set = list(range(len(samples)))
    count = 0
    for k, z in enumerate(levels[:-1]):
        gap = levels[k + 1] - board - z
        y = ya + board + float(rng.uniform(0.0, 0.05))
        while True:
            thick = float(rng.uniform(0.018, 0.05))
            if y + thick > yz - board - 0.005:
                break
            if rng.random() < 0.06:  # a gap on the shelf
                y += float(rng.uniform(0.04, 0.12))
                continue
            tall = float(min(gap - 0.015, rng.uniform(0.17, 0.31)))
            deep = float(min(depth - 0.03, rng.uniform(0.14, 0.24)))
            front = xin + side * 0.005
            bx = (front, front + side * deep)
            key = f"book_{count}"
            mats[key] = functools.partial(_book, samples.sds[int(rng.choice(book_set))])
            room.add(key, box((min(bx), y, z), (max(bx), y + thick, z + tall)), key)
            y += thick + 0.002
            count += 1

    lx, ly = -side * (half - 0.42), y1 - 0.42
    lamp_metal = CONDUCTOR_METALS[int(rng.integers(len(CONDUCTOR_METALS)))]
    mats["lamp_metal"] = functools.partial(_metal, lamp_metal, 0.2)
    room.add("lamp_base", turned_lathe([0.0, 0.15, 0.15, 0.0], [0.0, 0.0, 0.025, 0.025], (lx, ly, 0)), "lamp_metal")
    room.add("lamp_pole", turned_lathe([0.012, 0.012], [0.025, 1.45], (lx, ly, 0), 16), "lamp_metal")
    shade_colour = samples.sds[_pick(rng, set_name, (45, 80), 5, 40)]
    mats["shade"] = lambda mi: _twosided({"type": "diffuse", "reflectance": reflectance_spectrum(shade_colour)})
    room.add("lamp_shade", turned_lathe(list(SHADE_RADII_M), [SHADE_Z_M[0], SHADE_Z_M[1]], (lx, ly, 0)), "shade")
    room.lamp_m = (lx, ly)

    # sideboard by the other side wall, nearer the camera -----------------------------------
    other_x = x0 if side > 0 else x1
    sb_in = other_x + side * 0.46
    sa, sz = min(other_x + side * 0.01, sb_in), max(other_x + side * 0.01, sb_in)
    sy0, sy1 = -1.9, -0.5
    cab_index = _pick(rng, set_name, (30, 85), 15)
    mats["sideboard"] = lambda mi: _twosided({"type": "roughplastic", "distribution": "ggx", "alpha": 0.18,
                                              "int_ior": 1.49,
                                              "diffuse_reflectance": reflectance_spectrum(samples.sds[cab_index])})
    room.add("sideboard", box((sa, sy0, 0.1), (sz, sy1, 0.8)), "sideboard")
    face = sb_in + side * 0.02
    for k in range(3):
        d0 = sy0 + 0.01 + k * (sy1 - sy0) / 3
        d1 = d0 + (sy1 - sy0) / 3 - 0.012
        room.add(f"sideboard_door_{k}", box((min(sb_in, face), d0, 0.12), (max(sb_in, face), d1, 0.78)), "sideboard")
        kx = face + side * 0.015
        room.add(f"sideboard_knob_{k}", box((min(face, kx), d1 - 0.06, 0.62), (max(face, kx), d1 - 0.04, 0.64)),
                 "lamp_metal")
    for k, fy in enumerate((sy0 + 0.05, sy1 - 0.05)):
        fx = (sa + sz) / 2
        room.add(f"sideboard_foot_{k}", box((fx - 0.15, fy - 0.03, 0.0), (fx + 0.15, fy + 0.03, 0.1)), "dark_wood")

    # things on the table ----------------------------------------------------------------
    placed: list[tuple[float, float, float]] = []
    for n in range(s.object_count):
        for _ in range(500):
            size = float(rng.uniform(0.08, 0.2))
            u, v = rng.uniform(-L / 2 + size / 2 + 0.03, L / 2 - size / 2 - 0.03), rng.uniform(
                -W / 2 + size / 2 + 0.03, W / 2 - size / 2 - 0.03)
            if all(math.hypot(u - a, v - b) > 0.55 * (size + c) for a, b, c in placed):
                break
        else:
            raise ConfigError(f"scene.object_count = {s.object_count}: only {n} things fit on the room's table; "
                              "lower scene.object_count")
        placed.append((float(u), float(v), size))
        t_ = math.radians(turn)
        cx, cy = u * math.cos(t_) - v * math.sin(t_), u * math.sin(t_) + v * math.cos(t_)
        kind = ("vase", "bowl", "books", "mug")[int(rng.integers(4))]
        key = f"object_{n}"
        base = (cx, cy, TABLE_HEIGHT_M)
        if kind == "vase":
            from .meshes import vase

            vv, ff = vase(size * 1.3, segments=32)
            room.pieces.append(Piece(key, vv + np.asarray(base), ff, None, key))
            metal = CONDUCTOR_METALS[int(rng.integers(len(CONDUCTOR_METALS)))]
            mats[key] = functools.partial(_metal, metal, float(rng.uniform(0.2, 0.35)))
        elif kind == "bowl":
            r = size / 2
            prof_r = r * np.concatenate([[0.0], 0.5 + 0.5 * np.sin(np.linspace(0, np.pi / 2, 10))])
            prof_h = size * 0.45 * np.concatenate([[0.0], np.linspace(0, 1, 10) ** 1.5])
            vv, ff, _ = turned_lathe(prof_r, prof_h, base)
            room.pieces.append(Piece(key, vv, ff, None, key))
            colour = samples.sds[_pick(rng, set_name, (25, 80), 25)]
            mats[key] = functools.partial(_glazed, colour)
        elif kind == "mug":
            r = size * 0.3
            vv, ff, _ = turned_lathe([0.0, r, r, 0.9 * r, 0.9 * r], [0.0, 0.0, size * 0.7, size * 0.7, 0.01], base)
            room.pieces.append(Piece(key, vv, ff, None, key))
            mats[key] = functools.partial(_glazed, samples.sds[_pick(rng, set_name, (20, 90))])
        else:
            z = TABLE_HEIGHT_M
            spin = float(rng.uniform(0, 90))
            for b in range(int(rng.integers(2, 4))):
                th = float(rng.uniform(0.02, 0.04))
                w2, d2 = size * float(rng.uniform(0.55, 0.75)), size * float(rng.uniform(0.4, 0.55))
                part = f"{key}_{b}" if b else key
                mats[part] = functools.partial(_book, samples.sds[int(rng.choice(book_set))])
                room.add(part, box((cx - w2, cy - d2, z), (cx + w2, cy + d2, z + th), turn + spin
                                   + float(rng.uniform(-10, 10))), part)
                z += th
    return room


def _book(colour, mi) -> dict:
    return _twosided({"type": "diffuse", "reflectance": reflectance_spectrum(colour)})


def _glazed(colour, mi) -> dict:
    return _twosided({"type": "roughplastic", "distribution": "ggx", "alpha": 0.12, "int_ior": 1.5,
                      "diffuse_reflectance": reflectance_spectrum(colour)})


def _metal(metal, alpha, mi) -> dict:
    return _twosided({"type": "roughconductor", "distribution": "ggx", "alpha": alpha, "material": metal})


# ----------------------------------------------------------------------------- light
def ceiling_lamp(config: "SceneConfig", view, mi, *, centre=(0.0, 0.0)) -> dict:
    """The ceiling panel (:data:`PANEL_SIDE_M` square, facing down, over ``centre``): its
    radiance L(λ) = E(λ)/F with E the ``[illuminant]`` irradiance of ``illuminance_lux`` and
    F = :func:`~spectral_cam.presets.outdoor.lamp_irradiance_factor` for the drop to the
    table's top, so the table's centre receives ``illuminance_lux`` from it."""
    from .common import light_irradiance
    from .outdoor import lamp_irradiance_factor

    wavelengths, irradiance = light_irradiance(config)
    radiance = irradiance / lamp_irradiance_factor(PANEL_SIDE_M / 2, ROOM_HEIGHT_M - 0.005 - TABLE_HEIGHT_M)
    local = (mi.ScalarTransform4f().translate([centre[0], centre[1], ROOM_HEIGHT_M - 0.005])
             .rotate([1, 0, 0], 180.0).scale([PANEL_SIDE_M / 2, PANEL_SIDE_M / 2, 1.0]))
    return {"type": "rectangle", "to_world": view.transform(mi, local),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": 0.0}},
            "emitter": {"type": "area", "radiance": spectrum_dict((wavelengths, radiance))}}


def lamp_diffusers(config: "SceneConfig", view, mi, centre) -> dict:
    """The floor lamp's light: two Lambertian diffusers closing its shade, the bottom one facing
    down with :data:`LAMP_DOWN_SHARE` of :data:`LAMP_FLUX_LM` lumens of ``[illuminant]``'s
    spectrum, the top one facing up with the rest: a disc of area A sending Φ has
    L = Φ/(π·A), so L(λ) = Φ_v/(π·A) × (the spectral irradiance of 1 lx). (Area lights are
    sampled directly; a bulb inside the shade lit its inside, a small bright surface that
    only paths found by chance: speckles on the walls.)"""
    wavelengths, per_lux = spectra.absolute_irradiance(config.illuminant.spd if config.illuminant.spd != "auto"
                                                       else "D65", 1.0)
    out = {}
    for name, radius, z, share, turn in (("lamp_light_down", SHADE_RADII_M[0], SHADE_Z_M[0] + 0.002, LAMP_DOWN_SHARE,
                                          180.0),
                                         ("lamp_light_up", SHADE_RADII_M[1], SHADE_Z_M[1] - 0.002,
                                          1.0 - LAMP_DOWN_SHARE, 0.0)):
        radiance = LAMP_FLUX_LM * share * per_lux / (math.pi * math.pi * radius ** 2)
        local = (mi.ScalarTransform4f().translate([float(centre[0]), float(centre[1]), z]).rotate([1, 0, 0], turn)
                 .scale([radius, radius, 1.0]))
        out[name] = {"type": "disk", "to_world": view.transform(mi, local),
                     "bsdf": {"type": "diffuse", "reflectance": {"type": "uniform", "value": 0.0}},
                     "emitter": {"type": "area", "radiance": spectrum_dict((wavelengths, radiance))}}
    return out


def _mesh(mi, piece: Piece, bsdf, view, texcoords: bool):
    vertices = view.to_camera(piece.vertices)
    props = mi.Properties()
    props["bsdf"] = bsdf
    mesh = mi.Mesh(piece.name, len(vertices), len(piece.faces), props=props, has_vertex_normals=not texcoords,
                   has_vertex_texcoords=texcoords and piece.texcoords is not None)
    params = mi.traverse(mesh)
    params["vertex_positions"] = mi.Float(np.ascontiguousarray(vertices, dtype=np.float32).ravel())
    params["faces"] = mi.UInt32(np.ascontiguousarray(piece.faces, dtype=np.uint32).ravel())
    if texcoords and piece.texcoords is not None:
        params["vertex_texcoords"] = mi.Float(np.ascontiguousarray(piece.texcoords, dtype=np.float32).ravel())
    params.update()
    return mesh


@PRESETS.register("room", options=("distance_m", "view_pitch_deg", "object_count", "object_reflectances",
                                   "layout_seed"),
                  description="a furnished room (wood floor, painted walls, sofa, table, rug, books, metal lamp) "
                              "lit by a ceiling panel and a floor lamp of [illuminant]'s spectrum")
def room(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """The pieces of :func:`room_layout` as Mitsuba meshes (each material loaded once and shared),
    the ceiling panel over the table and the floor lamp's diffusers."""
    layout = room_layout(config, lens)
    view = room_view(config)
    loaded = {}
    objects = {}
    for piece in layout.pieces:
        if piece.material not in loaded:
            loaded[piece.material] = mi.load_dict(layout.materials[piece.material](mi))
        lathe_piece = piece.texcoords is None
        mesh = _mesh(mi, piece, loaded[piece.material], view, texcoords=not lathe_piece)
        if lathe_piece:  # curved: smooth shading, with normals summed in a fixed order (issue 39 #17)
            set_vertex_normals(mi, mesh, vertex_normals(view.to_camera(piece.vertices), piece.faces))
        objects[piece.name] = mesh
    objects["ceiling_lamp"] = ceiling_lamp(config, view, mi)
    objects.update(lamp_diffusers(config, view, mi, layout.lamp_m))
    return objects
