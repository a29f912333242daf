"""Plants of several morphologies, grown procedurally so that no two are alike: the geometry of the
``vegetation`` preset's plants (issue 37 #3).

Five morphologies (:data:`MORPHOLOGIES`, a :class:`~spectral_cam.registry.Registry` of growers
``(rng, size_m, species, shape) -> PlantGeometry``):

* ``grass`` — a monocot tussock: 3–7 tillers round the crown, each of 2–4 long narrow blades
  (5–10 % as wide as long, nearly parallel-sided, tapering at the tip) rising steeply and
  arching over under their own weight, V-folded along the midrib; parallel veins.
* ``rosette`` — the issue-24 plant: 6–11 lanceolate leaves set round a short axis by the golden
  angle (137.5°, Douady & Couder 1992), rising 25–65° and drooping; pinnate veins.
* ``upright`` — a dicot with a green stem, 5–9 nodes with internodes shortening upwards, leaves
  alternate (distichous), spiral (golden angle) or opposite-decussate by species, each an ovate
  blade (widest at a third of its length) on a petiole, smaller towards the apex; pinnate veins.
* ``shrub`` — woody: a trunk that forks recursively (2–3 branches a fork, 3 levels, branch
  lengths ×0.6–0.8 and radii ×0.65 a level, splayed 25–45° and bent towards the light — a
  stochastic branching in the manner of Honda 1971 and Prusinkiewicz & Lindenmayer 1990), many
  small elliptic leaves along and at the end of the twigs; bark on the stems.
* ``cereal`` — a row-crop cereal at mid-season (maize, sorghum): one green stalk with 7–14
  blades a tenth as wide as long, alternate in two ranks, the middle ones the longest, arching
  over, and a whorl of young leaves at the top (Ritchie, Hanway & Benson 1993); parallel veins.

Every leaf is a blade swept along a spine whose pitch falls from its rise angle towards its
tip (droop), its cross-section a V-fold plus a roll (curl) of the margins; its texture
coordinates run across (u, 0–1) and along (v, 0–1) it so a vein texture can pale its midrib,
veins and base (:func:`vein_pattern`). Per-vertex ``age`` (0 young – 1 the plant's oldest leaf:
lower and outer leaves are older; tips brown on unhealthy plants) and ``wood`` (1 on bark)
drive the leaf BSDF (``render/leaf_bsdf.py``).

Health shows in shape as well as in biochemistry (:data:`HEALTH_SHAPES`): a stressed plant wilts
(leaves droop more and rise less), rolls its leaves, drops some of its oldest and is shorter; a
dry plant more so (Hsiao 1973, "Plant responses to water stress", Annu. Rev. Plant Physiol. 24,
519–570: turgor loss, leaf rolling, senescence of older leaves, reduced growth; Kadioglu et al.
2012, leaf rolling, Plant Signal. Behav. 7(3), 353–357).

A plant stays a few thousand triangles (tests/presets/test_plants.py).

References
----------
.. [1] Prusinkiewicz, P., & Lindenmayer, A. (1990). The Algorithmic Beauty of Plants. Springer
   (branching structures, phyllotaxis).
.. [2] Honda, H. (1971). Description of the form of trees by the parameters of the tree-like
   body. Journal of Theoretical Biology 31(2), 331–338.
.. [3] Douady, S., & Couder, Y. (1992). Phyllotaxis as a physical self-organized growth process.
   Physical Review Letters 68(13), 2098.
.. [4] Esau, K. (1977). Anatomy of Seed Plants, 2nd ed., Wiley, ch. 19 (leaf venation: pinnate
   netted veins of dicots, parallel veins of monocots).
.. [5] Ritchie, S. W., Hanway, J. J., & Benson, G. O. (1993). How a corn plant develops. Iowa State
   University Special Report 48 (one stalk, leaves alternate in two ranks, V-stages by collars).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..registry import Registry

__all__ = ["MORPHOLOGIES", "PlantGeometry", "HealthShape", "HEALTH_SHAPES", "draw_shape", "draw_species",
           "vein_pattern", "grid_faces", "GOLDEN_ANGLE_DEG"]

GOLDEN_ANGLE_DEG = 137.50776

#: Every plant morphology: name → grower ``(rng, size_m, species, shape) -> PlantGeometry``.
MORPHOLOGIES = Registry("plant morphology")


@dataclass
class PlantGeometry:
    """A plant's triangles about +z, standing on z = 0, with texture coordinates and the leaf
    BSDF's per-vertex weights."""

    vertices: list = field(default_factory=list)
    faces: list = field(default_factory=list)
    uv: list = field(default_factory=list)
    age: list = field(default_factory=list)
    wood: list = field(default_factory=list)
    leaves: int = 0

    def add(self, vertices, faces, uv, age, wood=0.0, leaf=False) -> None:
        offset = sum(len(v) for v in self.vertices)
        n = len(vertices)
        self.vertices.append(np.asarray(vertices, float))
        self.faces.append(np.asarray(faces, np.int64) + offset)
        self.uv.append(np.broadcast_to(np.asarray(uv, float), (n, 2)))
        self.age.append(np.broadcast_to(np.asarray(age, float), (n,)))
        self.wood.append(np.broadcast_to(np.asarray(wood, float), (n,)))
        self.leaves += bool(leaf)

    def arrays(self) -> dict:
        """``vertices`` (n, 3), ``faces`` (m, 3) uint32, ``uv`` (n, 2), ``age`` and ``wood`` (n,)."""
        return {"vertices": np.concatenate(self.vertices), "faces": np.concatenate(self.faces).astype(np.uint32),
                "uv": np.concatenate(self.uv), "age": np.clip(np.concatenate(self.age), 0, 1),
                "wood": np.concatenate(self.wood)}


# ----------------------------------------------------------------------------- health in shape
@dataclass(frozen=True)
class HealthShape:
    """How a plant's health shows in its shape.

    Attributes
    ----------
    wilt : float
        0–1: leaves rise less (× 1 − 0.6·wilt) and droop more (+ 70°·wilt).
    curl : float
        Roll of the leaf margins (radians at the margin, added to the species').
    leaf_loss : float
        Share of leaves lost, the oldest first.
    stunt : float
        Height and leaf-length factor (1: full size).
    tip_burn : float
        Age added at a leaf's tip (necrotic tips), growing as v⁴ along the blade.
    """

    wilt: float = 0.0
    curl: float = 0.0
    leaf_loss: float = 0.0
    stunt: float = 1.0
    tip_burn: float = 0.0


#: Ranges (uniform draws) of :class:`HealthShape` per health state.
HEALTH_SHAPES: dict[str, dict[str, tuple[float, float]]] = {
    "healthy": {"wilt": (0.0, 0.1), "curl": (0.0, 0.15), "leaf_loss": (0.0, 0.05), "stunt": (0.9, 1.0),
                "tip_burn": (0.0, 0.1)},
    "stressed": {"wilt": (0.3, 0.6), "curl": (0.4, 0.9), "leaf_loss": (0.1, 0.3), "stunt": (0.7, 0.9),
                 "tip_burn": (0.3, 0.7)},
    "dry": {"wilt": (0.7, 1.0), "curl": (1.0, 1.8), "leaf_loss": (0.3, 0.6), "stunt": (0.55, 0.8),
            "tip_burn": (0.5, 1.0)},
}


def draw_shape(rng: np.random.Generator, state: str) -> HealthShape:
    """A plant's :class:`HealthShape` for its health state (``healthy``, ``stressed``, ``dry``)."""
    ranges = HEALTH_SHAPES[state]
    return HealthShape(**{key: float(rng.uniform(*ranges[key])) for key in ranges})


# ----------------------------------------------------------------------------- species
#: Per morphology: the cuticle's GGX roughness range (Bousquet et al. 2005: σ 0.1–0.5 by species;
#: Comar et al. 2014: wheat 0.18–0.46, sorghum 0.27–0.56; glossy evergreen shrubs at the smooth
#: end), the venation of its leaves and the traits a species draws, in order: ``(name, "uniform",
#: (low, high))``, ``(name, "integers", (low, high))`` (high excluded) or ``(name, "choice",
#: options)``. ``width`` is the blade's width over its length as each grower uses it (grass and
#: rosette: the half-width; upright, shrub and cereal: the whole width).
SPECIES_RANGES = {
    "grass": {"alpha": (0.2, 0.45), "venation": "parallel",
              "traits": (("width", "uniform", (0.025, 0.05)), ("arch", "uniform", (0.8, 1.4)))},
    "rosette": {"alpha": (0.2, 0.4), "venation": "pinnate", "traits": (("width", "uniform", (0.14, 0.22)),)},
    "upright": {"alpha": (0.25, 0.5), "venation": "pinnate",
                "traits": (("phyllotaxis", "choice", ("alternate", "spiral", "opposite")),
                           ("width", "uniform", (0.4, 0.6)), ("nodes", "integers", (5, 10)))},
    "shrub": {"alpha": (0.1, 0.3), "venation": "pinnate",
              "traits": (("width", "uniform", (0.35, 0.55)), ("children", "integers", (2, 4)))},
    # maize and sorghum: a blade about a tenth as wide as long (a maize ear leaf about 9 cm × 90 cm),
    # 8–13 leaves showing at mid-season (V8–V12; Ritchie, Hanway & Benson 1993)
    "cereal": {"alpha": (0.27, 0.56), "venation": "parallel",
               "traits": (("width", "uniform", (0.08, 0.12)), ("leaves", "integers", (8, 14)),
                          ("arch", "uniform", (0.8, 1.3)))},
}


def draw_species(rng: np.random.Generator, morphology: str) -> dict:
    """A species of a morphology: what its plants share (cuticle roughness, venation, leaf
    proportions, phyllotaxis), drawn once and reused for every plant of it
    (:data:`SPECIES_RANGES`)."""
    MORPHOLOGIES.check(morphology)
    ranges = SPECIES_RANGES[morphology]
    species = {"morphology": morphology, "alpha": float(rng.uniform(*ranges["alpha"])),
               "venation": ranges["venation"]}
    for name, kind, values in ranges["traits"]:
        if kind == "uniform":
            species[name] = float(rng.uniform(*values))
        elif kind == "integers":
            species[name] = int(rng.integers(*values))
        else:
            species[name] = str(rng.choice(list(values)))
    return species


# ----------------------------------------------------------------------------- building blocks
def grid_faces(rows: int, columns: int, offset: int = 0) -> np.ndarray:
    """Two triangles per cell of a rows × columns vertex grid (row-major)."""
    i, j = np.meshgrid(np.arange(rows - 1), np.arange(columns - 1), indexing="ij")
    a = (offset + i * columns + j).ravel()
    return np.concatenate([np.stack([a, a + columns, a + columns + 1], 1),
                           np.stack([a, a + columns + 1, a + 1], 1)]).astype(np.int64)


def _blade(base, azimuth, elevation, length, width, *, droop=0.0, fold=0.0, roll=0.0, steps=10, sides=2,
           profile="lanceolate"):
    """Vertices ((steps + 1)·(2·sides + 1), 3), triangles and (u, v) of a blade.

    Its spine leaves ``base`` towards ``azimuth`` at ``elevation`` (radians) and bends down by
    ``droop`` (radians, at the tip, growing as s^1.5); its half-width is ``width``·length·p(s)
    for the ``profile``; its cross-section is a V-fold of ``fold`` plus a roll of ``roll``
    radians at the margin (curl: margins up)."""
    s = np.linspace(0.0, 1.0, steps + 1)
    t = np.linspace(-1.0, 1.0, 2 * sides + 1)
    pitch = elevation - droop * s ** 1.5
    along = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
    across = np.array([-math.sin(azimuth), math.cos(azimuth), 0.0])
    direction = np.cos(pitch)[:, None] * along + np.sin(pitch)[:, None] * np.array([0.0, 0.0, 1.0])
    steps_xyz = 0.5 * (direction[1:] + direction[:-1]) * (length / steps)
    spine = np.asarray(base, float) + np.concatenate([np.zeros((1, 3)), np.cumsum(steps_xyz, axis=0)])
    normal = np.cross(direction, across)
    if profile == "grass":  # parallel-sided, tapering over its last third, narrower at the sheath
        half = width * length * np.sqrt(np.clip(1 - s ** 3, 0, 1)) * (0.75 + 0.25 * np.minimum(s / 0.1, 1))
    elif profile == "ovate":  # widest at a third of its length, a rounded base
        half = width * length * np.sin(np.pi * s ** 0.75) ** 0.8
    elif profile == "elliptic":
        half = width * length * np.sin(np.pi * s) ** 0.8
    else:  # lanceolate
        half = width * length * np.sin(np.pi * s) ** 0.7
    tau = np.abs(t)
    if abs(roll) < 1e-6:
        x, y = tau * math.cos(fold), tau * math.sin(fold)
    else:
        x = (np.sin(fold + roll * tau) - math.sin(fold)) / roll
        y = (math.cos(fold) - np.cos(fold + roll * tau)) / roll
    x = np.sign(t) * x
    points = (spine[:, None, :] + (half[:, None] * x[None, :])[..., None] * across
              + (half[:, None] * y[None, :])[..., None] * normal[:, None, :])
    u, v = np.meshgrid((t + 1) / 2, s)
    return points.reshape(-1, 3), grid_faces(steps + 1, 2 * sides + 1), np.stack([u.ravel(), v.ravel()], 1), s


def _leaf(plant: PlantGeometry, base, azimuth, elevation, length, width, age, shape: HealthShape, *, droop=0.0,
          fold=0.0, roll=0.0, steps=10, sides=2, profile="lanceolate"):
    """Add one leaf blade to ``plant``, its wilting, curl and tip burn from ``shape``."""
    points, faces, uv, s = _blade(base, azimuth, elevation * (1 - 0.6 * shape.wilt), length, width,
                                  droop=droop + math.radians(70) * shape.wilt, fold=fold, roll=roll + shape.curl,
                                  steps=steps, sides=sides, profile=profile)
    ages = age + shape.tip_burn * np.repeat(s, 2 * sides + 1) ** 4
    plant.add(points, faces, uv, ages, leaf=True)


def _tube(plant: PlantGeometry, points, radii, *, sides=5, wood=0.0, age=0.0) -> None:
    """A tapered tube along a polyline (a stem or branch); texture coordinates at the midrib's
    base (a vein texture's palest point) so a green stem shades as a leaf's veins."""
    points = np.asarray(points, float)
    tangent = np.gradient(points, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    reference = np.where(np.abs(tangent[:, 2:3]) < 0.9, np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0]))
    a = np.cross(tangent, reference)
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b = np.cross(tangent, a)
    phi = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    ring = (np.cos(phi)[None, :, None] * a[:, None, :] + np.sin(phi)[None, :, None] * b[:, None, :])
    vertices = points[:, None, :] + np.asarray(radii, float)[:, None, None] * ring
    k, n = len(points), sides
    faces = []
    for i in range(k - 1):
        for j in range(n):
            p, q = i * n + j, i * n + (j + 1) % n
            faces += [(p, q, q + n), (p, q + n, p + n)]
    plant.add(vertices.reshape(-1, 3), np.asarray(faces), (0.5, 0.0), age, wood=wood)


def _kept(rng, count: int, loss: float) -> np.ndarray:
    """Which of ``count`` leaves, ordered oldest first, a plant keeps after losing about ``loss``
    of them (the oldest most likely: probability 2·loss·(1 − rank))."""
    rank = np.arange(count) / max(count - 1, 1)
    lost = rng.random(count) < np.clip(2 * loss * (1 - rank), 0, 1)
    lost[-1] = False  # the youngest stays
    return ~lost


# ----------------------------------------------------------------------------- morphologies
@MORPHOLOGIES.register("grass", description="a tussock of tillers with long narrow arching blades (monocot)")
def grass(rng, size_m: float, species: dict, shape: HealthShape) -> PlantGeometry:
    plant = PlantGeometry()
    height = size_m * shape.stunt
    tillers = int(rng.integers(3, 8))
    for k in range(tillers):
        r = 0.04 * size_m * math.sqrt(rng.random())
        theta = rng.uniform(0, 2 * np.pi)
        base = np.array([r * math.cos(theta), r * math.sin(theta), 0.0])
        blades = int(rng.integers(2, 5))
        keep = _kept(rng, blades, shape.leaf_loss)
        facing = rng.uniform(0, 360)
        for j in range(blades):  # j = 0 the oldest, outermost
            if not keep[j]:
                continue
            level = j / max(blades - 1, 1)
            azimuth = math.radians(facing + 180.0 * j + rng.normal(0, 25))  # distichous blades
            length = height * rng.uniform(0.7, 1.2) * (0.75 + 0.25 * level)
            elevation = math.radians(rng.uniform(62, 85))
            droop = math.radians(rng.uniform(50, 100)) * species["arch"] * (1.2 - 0.4 * level)
            _leaf(plant, base, azimuth, elevation, length, species["width"], 0.8 * (1 - level), shape, droop=droop,
                  fold=math.radians(rng.uniform(15, 35)), steps=10, sides=1, profile="grass")
    return plant


@MORPHOLOGIES.register("rosette", description="lanceolate leaves round a short axis by the golden angle")
def rosette(rng, size_m: float, species: dict, shape: HealthShape) -> PlantGeometry:
    plant = PlantGeometry()
    height = size_m * shape.stunt
    count = int(rng.integers(6, 12))
    keep = _kept(rng, count, shape.leaf_loss)
    start = rng.uniform(0, 360)
    for k in range(count):  # k = 0 the lowest, oldest leaf
        level = k / count
        base = np.array([0.0, 0.0, height * (0.05 + 0.45 * level)])
        azimuth = math.radians(start + k * GOLDEN_ANGLE_DEG + rng.normal(0, 8))
        length = height * rng.uniform(0.45, 0.7) * (1.0 - 0.3 * level)
        rise, droop = math.radians(rng.uniform(25, 65)), math.radians(rng.uniform(35, 70))
        fold, roll = math.radians(rng.uniform(5, 20)), rng.uniform(-0.3, 0.6)
        if keep[k]:
            _leaf(plant, base, azimuth, rise, length, species["width"], 0.9 * (1 - level) ** 1.5, shape, droop=droop,
                  fold=fold, roll=roll, steps=10, sides=2, profile="lanceolate")
    return plant


@MORPHOLOGIES.register("upright", description="a green stem with ovate leaves on petioles (dicot)")
def upright(rng, size_m: float, species: dict, shape: HealthShape) -> PlantGeometry:
    plant = PlantGeometry()
    height = size_m * shape.stunt * rng.uniform(0.7, 0.9)
    nodes = max(3, species["nodes"] + int(rng.integers(-1, 2)))
    lean = rng.uniform(0, math.radians(12))
    lean_dir = rng.uniform(0, 2 * np.pi)
    sag = shape.wilt * 0.25  # a wilting stem bows
    z = np.linspace(0, 1, 9)
    offset = height * (math.sin(lean) * z + sag * z ** 2)
    stem = np.stack([offset * math.cos(lean_dir), offset * math.sin(lean_dir), height * z * (1 - 0.3 * sag)], 1)
    radius = 0.012 * size_m * (1 - 0.55 * z)
    _tube(plant, stem, radius, sides=6)
    # node heights: internodes shortening upwards
    positions = 1 - (1 - np.linspace(0.12, 0.95, nodes)) ** 1.3
    keep = _kept(rng, nodes, shape.leaf_loss)
    start = rng.uniform(0, 360)
    for k, p in enumerate(positions):
        if not keep[k]:
            continue
        at = np.array([np.interp(p, z, stem[:, i]) for i in range(3)])
        if species["phyllotaxis"] == "opposite":
            azimuths = [start + 90.0 * k, start + 90.0 * k + 180.0]
        elif species["phyllotaxis"] == "alternate":
            azimuths = [start + 180.0 * k]
        else:
            azimuths = [start + GOLDEN_ANGLE_DEG * k]
        level = k / max(nodes - 1, 1)
        for azimuth_deg in azimuths:
            azimuth = math.radians(azimuth_deg + rng.normal(0, 10))
            length = size_m * shape.stunt * rng.uniform(0.4, 0.55) * (1 - 0.5 * level)
            petiole = length * rng.uniform(0.15, 0.3)
            rise = math.radians(rng.uniform(35, 60)) * (1 - 0.6 * shape.wilt)
            tip = at + petiole * np.array([math.cos(rise) * math.cos(azimuth), math.cos(rise) * math.sin(azimuth),
                                           math.sin(rise)])
            _tube(plant, np.stack([at, 0.5 * (at + tip), tip]), np.full(3, 0.2 * radius[0] + 0.001 * size_m), sides=4)
            _leaf(plant, tip, azimuth, math.radians(rng.uniform(5, 30)), length, species["width"] / 2,
                  0.85 * (1 - level) ** 1.3, shape, droop=math.radians(rng.uniform(25, 55)),
                  fold=math.radians(rng.uniform(5, 15)), roll=rng.uniform(-0.2, 0.4), steps=8, sides=2,
                  profile="ovate")
    # the apex: two small young leaves
    for j in range(2):
        azimuth = math.radians(start + 90.0 * nodes + 180.0 * j)
        _leaf(plant, stem[-1], azimuth, math.radians(60), 0.1 * height, species["width"] / 2, 0.0, shape,
              droop=math.radians(20), steps=4, sides=1, profile="ovate")
    return plant


def _direction(vector, angle, azimuth):
    """``vector`` turned by ``angle`` away from itself, towards ``azimuth`` about it."""
    v = vector / np.linalg.norm(vector)
    reference = np.array([0.0, 0.0, 1.0]) if abs(v[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    a = np.cross(v, reference)
    a /= np.linalg.norm(a)
    b = np.cross(v, a)
    return math.cos(angle) * v + math.sin(angle) * (math.cos(azimuth) * a + math.sin(azimuth) * b)


@MORPHOLOGIES.register("shrub", description="woody stems forking recursively, many small leaves on the twigs")
def shrub(rng, size_m: float, species: dict, shape: HealthShape) -> PlantGeometry:
    plant = PlantGeometry()
    height = size_m * shape.stunt
    leaf_length = 0.14 * size_m * shape.stunt
    twigs = []

    def grow(start, direction, length, radius, level, phase):
        bend = np.array([0.0, 0.0, 0.25 if level < 3 else -0.1])  # towards the light; the last twigs sag
        d = direction / np.linalg.norm(direction)
        mid = start + 0.5 * length * d
        end = start + length * (d + bend * 0.5) / np.linalg.norm(d + bend * 0.5)
        _tube(plant, np.stack([start, mid, end]), np.array([radius, 0.85 * radius, 0.7 * radius]),
              sides=5 if level < 2 else 4, wood=1.0)
        if level == 3:
            twigs.append((start, end, level))
            return
        if level >= 1:
            twigs.append((start, end, level))
        children = species["children"] + int(rng.random() < 0.3)
        for c in range(children):
            azimuth = phase + c * 2 * np.pi / children + rng.normal(0, 0.3)
            child = _direction(end - start, math.radians(rng.uniform(25, 45)), azimuth)
            child = child + np.array([0.0, 0.0, 0.3])
            grow(end, child, length * rng.uniform(0.6, 0.8), 0.65 * radius, level + 1,
                 phase + math.radians(GOLDEN_ANGLE_DEG))

    grow(np.zeros(3), np.array([rng.normal(0, 0.1), rng.normal(0, 0.1), 1.0]), 0.35 * height, 0.025 * size_m, 0,
         rng.uniform(0, 2 * np.pi))
    # leaves along the outer twigs, more at the ends; the inner (lower) ones older
    anchors = []
    for start, end, level in twigs:
        n = int(rng.integers(4, 8)) if level == 3 else int(rng.integers(2, 4))
        for f in rng.uniform(0.3 if level == 3 else 0.5, 1.0, n):
            anchors.append((start + f * (end - start), end - start, level))
    order = np.argsort([a[0][2] for a in anchors])  # lowest first: oldest
    keep = _kept(rng, len(anchors), shape.leaf_loss)
    for rank, index in enumerate(order):
        if not keep[rank]:
            continue
        point, axis, level = anchors[index]
        azimuth = math.atan2(axis[1], axis[0]) + rng.normal(0, 1.2)
        _leaf(plant, point, azimuth, math.radians(rng.uniform(10, 50)), leaf_length * rng.uniform(0.7, 1.2),
              species["width"] / 2, 0.8 * (1 - rank / max(len(order) - 1, 1)), shape,
              droop=math.radians(rng.uniform(10, 40)), roll=rng.uniform(0.0, 0.4), steps=4, sides=1,
              profile="elliptic")
    return plant


@MORPHOLOGIES.register("cereal", description="a row-crop cereal (maize, sorghum): one stalk, broad arching blades "
                                              "in two ranks")
def cereal(rng, size_m: float, species: dict, shape: HealthShape) -> PlantGeometry:
    """Maize or sorghum at mid-season: one stalk (they seldom tiller in rows) carrying
    ``species["leaves"]`` blades alternate in two ranks (distichous, 180° apart), the collars
    spaced up the lower two thirds of the plant; the middle blades the longest (about 0.9 of the
    plant's height), lower ones spreading flatter, all arching over; a rolled whorl of young
    leaves at the top (Ritchie, Hanway & Benson 1993)."""
    plant = PlantGeometry()
    height = size_m * shape.stunt
    top = height * rng.uniform(0.55, 0.7)
    lean, lean_dir = rng.uniform(0, math.radians(6)), rng.uniform(0, 2 * np.pi)
    z = np.linspace(0, 1, 7)
    offset = top * math.sin(lean) * z
    stalk = np.stack([offset * math.cos(lean_dir), offset * math.sin(lean_dir), top * z], 1)
    _tube(plant, stalk, 0.014 * size_m * (1 - 0.5 * z), sides=6)
    count = max(3, species["leaves"] + int(rng.integers(-1, 2)))
    keep = _kept(rng, count, shape.leaf_loss)
    start = rng.uniform(0, 360)
    for k in range(count):  # k = 0 the lowest, oldest blade
        if not keep[k]:
            continue
        level = k / max(count - 1, 1)
        at = np.array([np.interp(level, z, stalk[:, i]) for i in range(3)])
        azimuth = math.radians(start + 180.0 * k + rng.normal(0, 15))
        length = height * rng.uniform(0.8, 1.0) * (0.55 + 0.45 * math.sin(math.pi * (0.15 + 0.7 * level)))
        elevation = math.radians(rng.uniform(35, 55) + 25 * level)  # lower blades spread flatter
        droop = math.radians(rng.uniform(55, 90)) * species["arch"] * (1.1 - 0.4 * level)
        _leaf(plant, at, azimuth, elevation, length, species["width"] / 2, 0.85 * (1 - level) ** 1.2, shape,
              droop=droop, fold=math.radians(rng.uniform(10, 25)), roll=rng.uniform(-0.1, 0.2), steps=10, sides=2,
              profile="grass")
    for j in range(2):  # the whorl
        azimuth = math.radians(start + 180.0 * (count + j))
        _leaf(plant, stalk[-1], azimuth, math.radians(80), 0.25 * height, species["width"] / 4, 0.0, shape,
              droop=math.radians(25), fold=math.radians(40), steps=6, sides=1, profile="grass")
    return plant


# ----------------------------------------------------------------------------- veins
def vein_pattern(venation: str, size: tuple[int, int] = (256, 128), veins: int = 9) -> np.ndarray:
    """A leaf's vein weight over its texture (rows along the blade, v = 0 the base; columns across,
    u = 0.5 the midrib): 1 on the midrib and at the base, 0.6 on the veins, 0 on the lamina between.

    ``pinnate`` (dicots): a midrib and ``veins`` pairs of secondary veins leaving it at about 45°
    and curving towards the tip; ``parallel`` (monocots): a midrib and parallel veins along the
    blade (Esau 1977, ch. 19). Both pale at the base (the petiole or sheath junction)."""
    rows, columns = size
    v = (np.arange(rows) + 0.5)[:, None] / rows
    u = (np.arange(columns) + 0.5)[None, :] / columns
    across = np.abs(u - 0.5) * 2  # 0 at the midrib, 1 at the margin
    texel = 1.0 / columns
    midrib = np.exp(-0.5 * ((u - 0.5) / (2.0 * texel)) ** 2) * (1 - 0.6 * v)
    if venation == "parallel":
        phase = across * veins
        lines = np.exp(-0.5 * ((phase - np.round(phase)) / (veins * 0.9 * texel)) ** 2) * 0.5
        base = np.clip(1 - v / 0.12, 0, 1) ** 2
    else:
        # secondaries: v = v0 + 0.35·across^0.8 (leaving the midrib, bending towards the tip)
        phase = (v - 0.35 * across ** 0.8) * veins
        width = veins * 1.2 / rows
        lines = np.exp(-0.5 * ((phase - np.round(phase)) / width) ** 2) * 0.6 * (across < 0.93) * (v > 0.03)
        base = np.clip(1 - v / 0.08, 0, 1) ** 2
    weight = np.maximum(np.maximum(midrib, lines), base) * np.ones((rows, columns))
    return np.clip(weight, 0.0, 1.0).astype(np.float32)
