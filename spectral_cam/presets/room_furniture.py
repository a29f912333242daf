"""Where everything in the room (:mod:`spectral_cam.presets.room`) stands: the camera, the walls,
floor and ceiling, the furniture and the things on the table, as triangle meshes in the room
frame with the materials they name.

:func:`room_layout` draws the room of one ``layout_seed`` in named steps (shell, floor, table
and rug, sofa, painting, bookshelf, floor lamp, sideboard, things on the table) from one
random stream, in a fixed order: a layout seed gives the same room whatever is added after
it. Frame: the floor is z = 0 with x east, y north and z up, its origin under the table's
centre; lengths in metres. Meshes carry texture coordinates in metres on their faces (a
lathe has none: it is shaded smooth).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

import numpy as np

from .. import spectra
from ..errors import ConfigError
from . import room_materials as materials
from .room_materials import CONDUCTOR_METALS, pick, scaled

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..reflectance_sets import ReflectanceSet
    from ..scene import SceneConfig

__all__ = ["Piece", "RoomLayout", "room_layout", "room_view", "box", "quad", "turned_lathe", "TABLE_THINGS"]

ROOM_HEIGHT_M = 2.6
#: The back wall stands this far beyond the look point; the side walls this far either side.
BACK_WALL_M, SIDE_WALL_M = 1.75, 2.3
TABLE_HEIGHT_M = 0.76
#: The table's top: length and width (m).
TABLE_SIZE_M = (1.3, 0.8)
#: The floor lamp's shade: radii at its bottom and top, and their heights (m).
SHADE_RADII_M = (0.2, 0.13)
SHADE_Z_M = (1.38, 1.64)


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


@dataclass
class _Draw:
    """What every step of :func:`room_layout` draws from and adds to: the one random stream, the
    room so far, the reflectance set (and its name) samples are picked from, the ColorChecker
    spectra, the layout seed (textures' seeds derive from it) and the book colours' indices."""

    rng: np.random.Generator
    room: RoomLayout
    samples: "ReflectanceSet"
    set_name: str
    checker: dict
    seed: int
    book_set: list[int]

    def pick(self, lightness, chroma_min=0.0, chroma_max=200.0, exclude=()) -> int:
        return pick(self.rng, self.set_name, lightness, chroma_min, chroma_max, exclude)

    def sample(self, *args, **kwargs):
        """A sample spectrum of the set (:meth:`pick`'s)."""
        return self.samples.sds[self.pick(*args, **kwargs)]


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


# ----------------------------------------------------------------------------- camera
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


# ----------------------------------------------------------------------------- layout
def room_layout(config: "SceneConfig", lens: "ThinLens | None" = None) -> RoomLayout:
    """The room of ``config``'s ``layout_seed``: every piece in the room frame and its
    material (scene-dict entries still to load).

    Raises
    ------
    ConfigError
        When ``scene.object_count`` things do not fit on the table, or the camera would
        stand outside a room this size.
    """
    from ..reflectance_sets import reflectance_set

    s = config.scene
    seed = int(s.layout_seed)
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x400A]))
    room = _empty_room(config, seed)
    samples = reflectance_set(s.object_reflectances)
    draw = _Draw(rng, room, samples, s.object_reflectances, spectra.colorchecker_reflectances(), seed,
                 list(range(len(samples))))
    # the steps' order is the random stream's: a new step goes last, or every room changes
    _shell(draw)
    _floor(draw)
    turn = _table_and_rug(draw)
    sofa_x = _sofa(draw)
    _painting(draw, sofa_x)
    side = _bookshelf(draw)
    _floor_lamp(draw, side)
    _sideboard(draw, side)
    _table_things(draw, s.object_count, turn)
    return room


def _empty_room(config: "SceneConfig", seed: int) -> RoomLayout:
    """The walls' places: the side walls at least 0.5 m beside the camera, the front wall 0.8 m
    behind it; refused when the camera would stand above the ceiling."""
    s = config.scene
    camera = room_view(config).camera_m
    if camera[2] >= ROOM_HEIGHT_M - 0.1:
        raise ConfigError(f"scene.distance_m = {s.distance_m:g} at view_pitch_deg = {s.view_pitch_deg:g} puts the "
                          f"camera {camera[2]:.2f} m high, above the room's {ROOM_HEIGHT_M:g}-m ceiling; come nearer "
                          "or look down less")
    half = max(SIDE_WALL_M, abs(camera[0]) + 0.5)
    east = (-half, half)
    north = (min(-2.0, camera[1] - 0.8), BACK_WALL_M)
    return RoomLayout(east, north, ROOM_HEIGHT_M, _yaw(seed))


def _shell(draw: _Draw) -> None:
    """Walls (a pale paint, the back wall a stronger one), the white ceiling and skirting."""
    room, mats = draw.room, draw.room.materials
    side_paint = draw.sample((62, 90), 3, 30)
    back_paint = draw.sample((45, 80), 15, 32)
    (x0, x1), (y0, y1), H = room.east_m, room.north_m, room.height_m
    white = draw.checker["white 9.5 (.05 D)"]
    mats["wall"] = functools.partial(materials.wall, side_paint, draw.seed)
    mats["back_wall"] = functools.partial(materials.wall, back_paint, draw.seed + 3)
    room.add("wall_back", quad([(x0, y1, 0), (x1, y1, 0), (x1, y1, H), (x0, y1, H)]), "back_wall")
    room.add("wall_left", quad([(x0, y0, 0), (x0, y1, 0), (x0, y1, H), (x0, y0, H)]), "wall")
    room.add("wall_right", quad([(x1, y1, 0), (x1, y0, 0), (x1, y0, H), (x1, y1, H)]), "wall")
    room.add("wall_front", quad([(x1, y0, 0), (x0, y0, 0), (x0, y0, H), (x1, y0, H)]), "wall")
    room.add("ceiling", quad([(x0, y0, H), (x1, y0, H), (x1, y1, H), (x0, y1, H)]), "white")
    mats["white"] = functools.partial(materials.diffuse, white)
    mats["skirting"] = functools.partial(materials.plastic, white, 0.25)
    t, h = 0.015, 0.10
    room.add("skirting_back", box((x0, y1 - t, 0), (x1, y1, h)), "skirting")
    room.add("skirting_front", box((x0, y0, 0), (x1, y0 + t, h)), "skirting")
    room.add("skirting_left", box((x0, y0 + t, 0), (x0 + t, y1 - t, h)), "skirting")
    room.add("skirting_right", box((x1 - t, y0 + t, 0), (x1, y1 - t, h)), "skirting")


def _woods():
    from ..reflectance_sets import reflectance_set

    return list(reflectance_set("usgs_wood").sds)


def _floor(draw: _Draw) -> None:
    """Boards of the USGS pines under one of three stains (k = 1.6 oak, 2.2 honey, 3 walnut)."""
    woods = _woods()
    stain_power = float(draw.rng.choice([1.6, 2.2, 3.0]))
    stained = [scaled(w, power=stain_power) for w in woods]
    floor_ends = woods + stained + [scaled(stained[0], 0.2)]
    stain = float(draw.rng.uniform(0.4, 0.9))
    draw.room.materials["floor"] = functools.partial(materials.floor, floor_ends, draw.seed, round(stain, 3))
    (x0, x1), (y0, y1) = draw.room.east_m, draw.room.north_m
    draw.room.add("floor", quad([(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)]), "floor")


#: The rug's palettes (ColorChecker patches: field, border, motif, outline).
RUG_PALETTES = (("red", "blue", "orange yellow", "black 2 (1.5 D)"),
                ("blue", "moderate red", "neutral 8 (.23 D)", "black 2 (1.5 D)"),
                ("purplish blue", "orange", "light skin", "dark skin"),
                ("moderate red", "bluish green", "yellow", "neutral 3.5 (1.05 D)"))


def _table_and_rug(draw: _Draw) -> float:
    """A dark-stained table turned by ±8° over a patterned rug; returns the table's turn (°)."""
    room, seed = draw.room, draw.seed
    turn = float(draw.rng.uniform(-8, 8))
    dark_woods = [scaled(w, power=3.2) for w in _woods()]
    room.materials["dark_wood"] = functools.partial(materials.dark_wood, dark_woods, seed + 11)
    L, W = TABLE_SIZE_M
    room.add("table_top", box((-L / 2, -W / 2, TABLE_HEIGHT_M - 0.04), (L / 2, W / 2, TABLE_HEIGHT_M), turn, (0, 0, 0)),
             "dark_wood")
    for k, (sx, sy) in enumerate(((-1, -1), (1, -1), (1, 1), (-1, 1))):
        cx, cy = sx * (L / 2 - 0.07), sy * (W / 2 - 0.07)
        room.add(f"table_leg_{k}", box((cx - 0.03, cy - 0.03, 0.006), (cx + 0.03, cy + 0.03, TABLE_HEIGHT_M - 0.04),
                                       turn, (0, 0, 0)), "dark_wood")
    rug_l, rug_w = 2.4, 1.7
    rug_palette = [draw.checker[name] for name in draw.rng.choice(list(RUG_PALETTES))]
    room.materials["rug"] = functools.partial(materials.rug, rug_palette, seed, (340, 480), (rug_l, rug_w))
    room.add("rug", box((-rug_l / 2, -rug_w / 2, 0.0), (rug_l / 2, rug_w / 2, 0.006),
                        turn + float(draw.rng.uniform(-4, 4)), (0, 0, 0)), "rug")
    return turn


def _sofa(draw: _Draw) -> float:
    """A tartan sofa on metal feet against the back wall, with cushions; returns its centre's x."""
    room, rng = draw.room, draw.rng
    xs = float(rng.uniform(-0.45, 0.45))
    sw, sd = 2.1, 0.9
    yb = room.north_m[1] - 0.03
    fabric_a = draw.pick((25, 60), 25)
    fabric_b = draw.pick((10, 35), 0, 200, (fabric_a,))
    fabric_c = draw.pick((70, 95), 0, 20, (fabric_a, fabric_b))
    weave = [draw.samples.sds[fabric_a], draw.samples.sds[fabric_b], draw.samples.sds[fabric_c]]
    room.materials["sofa"] = functools.partial(materials.fabric, weave, draw.seed)
    f = 0.08  # feet
    room.add("sofa_base", box((xs - sw / 2, yb - sd, f), (xs + sw / 2, yb, 0.42)), "sofa")
    room.add("sofa_back", box((xs - sw / 2, yb - 0.22, 0.42), (xs + sw / 2, yb, 0.88)), "sofa")
    for side, name in ((-1, "left"), (1, "right")):
        ax = xs + side * (sw / 2 - 0.11)
        room.add(f"sofa_arm_{name}", box((ax - 0.11, yb - sd, 0.42), (ax + 0.11, yb - 0.22, 0.64)), "sofa")
        for k, fy in enumerate((yb - sd + 0.05, yb - 0.07)):
            fx = xs + side * (sw / 2 - 0.06)
            room.add(f"sofa_foot_{name}_{k}", box((fx - 0.03, fy - 0.03, 0.0), (fx + 0.03, fy + 0.03, f)), "metal_feet")
    room.materials["metal_feet"] = functools.partial(materials.metal, "Al", 0.25)
    inner = sw - 0.44
    for k in range(2):
        cx0 = xs - inner / 2 + k * inner / 2
        room.add(f"sofa_seat_{k}", box((cx0 + 0.01, yb - sd + 0.02, 0.42), (cx0 + inner / 2 - 0.01, yb - 0.23, 0.54)),
                 "sofa")
    _cushions(draw, xs, inner, yb)
    return xs


def _cushions(draw: _Draw, xs: float, inner: float, yb: float) -> None:
    """Two or three plain cushions (a colour woven with its darker self) leaning back 15°."""
    rng = draw.rng
    cushions = int(rng.integers(2, 4))
    for k in range(cushions):
        colour = draw.pick((20, 75), 30)
        key = f"cushion_{k}"
        ends = [draw.samples.sds[colour], scaled(draw.samples.sds[colour], 0.55)]
        draw.room.materials[key] = functools.partial(materials.fabric, ends, draw.seed + 31 + k)
        cx = xs - inner / 2 + (k + 0.5) * inner / cushions + float(rng.uniform(-0.08, 0.08))
        v, fc, uv = box((cx - 0.21, yb - 0.34, 0.55), (cx + 0.21, yb - 0.22, 0.95))
        # leaning back 15° against the sofa's back
        pivot = np.array([cx, yb - 0.22, 0.55])
        a = math.radians(-15.0)
        rot = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
        draw.room.add(key, ((v - pivot) @ rot.T + pivot, fc, uv), key)


#: The ColorChecker patches a painting draws its five colours from.
PAINTING_COLOURS = ("orange", "purplish blue", "moderate red", "yellow green", "orange yellow", "blue", "green",
                    "red", "yellow", "magenta", "cyan", "neutral 8 (.23 D)", "black 2 (1.5 D)")


def _painting(draw: _Draw, sofa_x: float) -> None:
    """A 1 × 0.7 m painting in a black frame on the back wall over the sofa."""
    room, y1 = draw.room, draw.room.north_m[1]
    paint_colours = [draw.checker[n] for n in draw.rng.choice(list(PAINTING_COLOURS), 5, replace=False)]
    room.materials["canvas"] = functools.partial(materials.canvas, paint_colours, draw.seed + 77)
    room.materials["frame"] = functools.partial(materials.diffuse, draw.checker["black 2 (1.5 D)"])
    px, pz = sofa_x + float(draw.rng.uniform(-0.2, 0.2)), 1.45
    room.add("painting", box((px - 0.5, y1 - 0.035, pz - 0.35), (px + 0.5, y1 - 0.005, pz + 0.35)), "canvas")
    for name, lo, hi in (("bottom", (px - 0.54, pz - 0.39), (px + 0.54, pz - 0.35)),
                         ("top", (px - 0.54, pz + 0.35), (px + 0.54, pz + 0.39)),
                         ("left", (px - 0.54, pz - 0.35), (px - 0.5, pz + 0.35)),
                         ("right", (px + 0.5, pz - 0.35), (px + 0.54, pz + 0.35))):
        room.add(f"painting_frame_{name}", box((lo[0], y1 - 0.045, lo[1]), (hi[0], y1 - 0.005, hi[1])), "frame")


@dataclass(frozen=True)
class _Shelf:
    """The bookshelf's place: the side (+1 east, −1 west), its span across the wall (x, both
    orders), along it (y), the front's x, its depth and the height of each board's top."""

    side: float
    x: tuple[float, float]
    y: tuple[float, float]
    front_x: float
    depth: float
    levels: np.ndarray
    board: float


def _bookshelf(draw: _Draw) -> float:
    """A painted bookshelf against a side wall's back end, full of books; returns its side (+1
    east, −1 west), which puts the floor lamp and the sideboard on the other."""
    room = draw.room
    side = float(draw.rng.choice([-1.0, 1.0]))
    x0, x1 = room.east_m
    y1 = room.north_m[1]
    wall_x = x1 if side > 0 else x0
    depth, width, height, board = 0.32, 1.0, 1.95, 0.022
    ya, yz = y1 - 0.06 - width, y1 - 0.06
    xin, xout = wall_x - side * (depth + 0.01), wall_x - side * 0.01
    xa, xz = min(xin, xout), max(xin, xout)
    room.materials["shelf"] = functools.partial(materials.plastic, draw.sample((30, 92), 0, 40), 0.3)
    room.add("shelf_side_0", box((xa, ya, 0), (xz, ya + board, height)), "shelf")
    room.add("shelf_side_1", box((xa, yz - board, 0), (xz, yz, height)), "shelf")
    back_in = xout - side * 0.012
    room.add("shelf_back", box((min(back_in, xout), ya + board, 0.0), (max(back_in, xout), yz - board, height)),
             "shelf")
    levels = np.linspace(0.06, height - board, 6)
    for k, z in enumerate(levels):
        room.add(f"shelf_board_{k}", box((xa, ya + board, z - board), (xz, yz - board, z)), "shelf")
    _books_on_shelves(draw, _Shelf(side, (xa, xz), (ya, yz), xin, depth, levels, board))
    return side


def _books_on_shelves(draw: _Draw, shelf: _Shelf) -> None:
    """Books of the set's colours standing side by side on every board but the top, with gaps."""
    rng, board, side, (ya, yz) = draw.rng, shelf.board, shelf.side, shelf.y
    count = 0
    for k, z in enumerate(shelf.levels[:-1]):
        gap = shelf.levels[k + 1] - board - z
        y = ya + board + float(rng.uniform(0.0, 0.05))
        while True:
            thick = float(rng.uniform(0.018, 0.05))
            if y + thick > yz - board - 0.005:
                break
            if rng.random() < 0.06:  # a gap on the shelf
                y += float(rng.uniform(0.04, 0.12))
                continue
            tall = float(min(gap - 0.015, rng.uniform(0.17, 0.31)))
            deep = float(min(shelf.depth - 0.03, rng.uniform(0.14, 0.24)))
            front = shelf.front_x + side * 0.005
            bx = (front, front + side * deep)
            key = f"book_{count}"
            draw.room.materials[key] = functools.partial(materials.diffuse,
                                                         draw.samples.sds[int(rng.choice(draw.book_set))])
            draw.room.add(key, box((min(bx), y, z), (max(bx), y + thick, z + tall)), key)
            y += thick + 0.002
            count += 1


def _floor_lamp(draw: _Draw, side: float) -> None:
    """A metal floor lamp with a fabric shade in the back corner away from the bookshelf."""
    room, rng = draw.room, draw.rng
    half = room.east_m[1]
    lx, ly = -side * (half - 0.42), room.north_m[1] - 0.42
    lamp_metal = CONDUCTOR_METALS[int(rng.integers(len(CONDUCTOR_METALS)))]
    room.materials["lamp_metal"] = functools.partial(materials.metal, lamp_metal, 0.2)
    room.add("lamp_base", turned_lathe([0.0, 0.15, 0.15, 0.0], [0.0, 0.0, 0.025, 0.025], (lx, ly, 0)), "lamp_metal")
    room.add("lamp_pole", turned_lathe([0.012, 0.012], [0.025, 1.45], (lx, ly, 0), 16), "lamp_metal")
    room.materials["shade"] = functools.partial(materials.diffuse, draw.sample((45, 80), 5, 40))
    room.add("lamp_shade", turned_lathe(list(SHADE_RADII_M), [SHADE_Z_M[0], SHADE_Z_M[1]], (lx, ly, 0)), "shade")
    room.lamp_m = (lx, ly)


def _sideboard(draw: _Draw, side: float) -> None:
    """A painted sideboard with three doors by the other side wall, nearer the camera."""
    room = draw.room
    x0, x1 = room.east_m
    other_x = x0 if side > 0 else x1
    sb_in = other_x + side * 0.46
    sa, sz = min(other_x + side * 0.01, sb_in), max(other_x + side * 0.01, sb_in)
    sy0, sy1 = -1.9, -0.5
    room.materials["sideboard"] = functools.partial(materials.plastic, draw.sample((30, 85), 15), 0.18)
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


# ----------------------------------------------------------------------------- things on the table
@dataclass(frozen=True)
class _Spot:
    """Where a thing stands on the table: its piece's name, size (m), centre (room frame, m)
    and the table's turn (°)."""

    key: str
    size: float
    centre: tuple[float, float]
    turn: float

    @property
    def base(self) -> tuple[float, float, float]:
        return (self.centre[0], self.centre[1], TABLE_HEIGHT_M)


def _table_things(draw: _Draw, count: int, turn: float) -> None:
    """``count`` things (:data:`TABLE_THINGS`) at places drawn apart on the table's top."""
    placed: list[tuple[float, float, float]] = []
    L, W = TABLE_SIZE_M
    for n in range(count):
        for _ in range(500):
            size = float(draw.rng.uniform(0.08, 0.2))
            u, v = draw.rng.uniform(-L / 2 + size / 2 + 0.03, L / 2 - size / 2 - 0.03), draw.rng.uniform(
                -W / 2 + size / 2 + 0.03, W / 2 - size / 2 - 0.03)
            if all(math.hypot(u - a, v - b) > 0.55 * (size + c) for a, b, c in placed):
                break
        else:
            raise ConfigError(f"scene.object_count = {count}: only {n} things fit on the room's table; "
                              "lower scene.object_count")
        placed.append((float(u), float(v), size))
        t_ = math.radians(turn)
        cx, cy = u * math.cos(t_) - v * math.sin(t_), u * math.sin(t_) + v * math.cos(t_)
        kind = tuple(TABLE_THINGS)[int(draw.rng.integers(len(TABLE_THINGS)))]
        TABLE_THINGS[kind](draw, _Spot(f"object_{n}", size, (cx, cy), turn))


def _vase(draw: _Draw, spot: _Spot) -> None:
    from .meshes import vase

    vv, ff = vase(spot.size * 1.3, segments=32)
    draw.room.pieces.append(Piece(spot.key, vv + np.asarray(spot.base), ff, None, spot.key))
    name = CONDUCTOR_METALS[int(draw.rng.integers(len(CONDUCTOR_METALS)))]
    draw.room.materials[spot.key] = functools.partial(materials.metal, name, float(draw.rng.uniform(0.2, 0.35)))


def _bowl(draw: _Draw, spot: _Spot) -> None:
    size = spot.size
    r = size / 2
    prof_r = r * np.concatenate([[0.0], 0.5 + 0.5 * np.sin(np.linspace(0, np.pi / 2, 10))])
    prof_h = size * 0.45 * np.concatenate([[0.0], np.linspace(0, 1, 10) ** 1.5])
    vv, ff, _ = turned_lathe(prof_r, prof_h, spot.base)
    draw.room.pieces.append(Piece(spot.key, vv, ff, None, spot.key))
    draw.room.materials[spot.key] = functools.partial(materials.glazed, draw.sample((25, 80), 25))


def _book_pile(draw: _Draw, spot: _Spot) -> None:
    rng, (cx, cy), size = draw.rng, spot.centre, spot.size
    z = TABLE_HEIGHT_M
    spin = float(rng.uniform(0, 90))
    for b in range(int(rng.integers(2, 4))):
        th = float(rng.uniform(0.02, 0.04))
        w2, d2 = size * float(rng.uniform(0.55, 0.75)), size * float(rng.uniform(0.4, 0.55))
        part = f"{spot.key}_{b}" if b else spot.key
        draw.room.materials[part] = functools.partial(materials.diffuse,
                                                      draw.samples.sds[int(rng.choice(draw.book_set))])
        draw.room.add(part, box((cx - w2, cy - d2, z), (cx + w2, cy + d2, z + th), spot.turn + spin
                                + float(rng.uniform(-10, 10))), part)
        z += th


def _mug(draw: _Draw, spot: _Spot) -> None:
    size = spot.size
    r = size * 0.3
    vv, ff, _ = turned_lathe([0.0, r, r, 0.9 * r, 0.9 * r], [0.0, 0.0, size * 0.7, size * 0.7, 0.01], spot.base)
    draw.room.pieces.append(Piece(spot.key, vv, ff, None, spot.key))
    draw.room.materials[spot.key] = functools.partial(materials.glazed, draw.sample((20, 90)))


#: The things a table holds, by kind: each builder adds its pieces and materials at a spot. The
#: order is the draw's (one of them, uniformly): a new kind goes last, or every room changes.
TABLE_THINGS: dict[str, Callable[[_Draw, _Spot], None]] = {
    "vase": _vase, "bowl": _bowl, "books": _book_pile, "mug": _mug,
}
