"""Ground clutter at scale (``[[scene.scatter]]``): stones, clods, straw and grass blades, each
a small procedural mesh made once per variant and placed as Mitsuba ``instance``s of a
``shapegroup``, so a scene holds tens of thousands of them for the memory of a few meshes and
one transform each (10 000 instances: 1.4× the peak memory of one, tests/presets/test_scatter.py).
In the JIT variants of Mitsuba up to 3.9.1 an instance costs a kernel trace of its own (68 s
and 0.6 GB for 1000), so there each variant's copies are merged into one low-polygon mesh
instead (:func:`spectral_cam.presets.assets.use_instances`; ~170 B per triangle).

A scatter entry draws its things over the ground the frame sees (within ``max_distance_m`` of
the camera's foot) as a Poisson process of ``density_per_m2`` (a number, or drawn once per
layout from a distribution), each of a size (its largest horizontal extent, m) drawn from
``size_m``, turned at random about the vertical (tilted a little for stones, clods and grass),
by ``scene.layout_seed`` and the entry's place in the list. Distributions: a number; ``[low,
high]`` or ``{uniform = [low, high]}``; ``{log_uniform = [low, high]}``; ``{lognormal = [mu,
sigma]}`` (of the natural logarithm of the value); ``{normal = [mean, sd]}`` (cut at zero).

Materials are measured spectra (USGS splib07 via :mod:`spectral_cam.reflectance_sets`):
stones the ``usgs_stone`` samples, clods the ``usgs_soils``, straw the dry grass, grass blades
the green lawn grass (two-sided Lambertian: thin blades are seen from both sides).

The segmentation: merged, each variant is a shape ``<name>_<v>`` (class ``name``, which
defaults to the kind). Instanced, every instance is a top-level shape ``<name>_<n>``: the
scalar variants' ``shape_index`` AOV reports the instance's own place in ``scene.shapes()``
(one segment per copy, measured on 3.9.1), while the JIT variants report the shapegroup's
*inner* mesh, named ``<name>`` (:func:`instanced_meshes` lists them for a shape map to add).

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3, plugins ``shapegroup`` and ``instance``.
.. [2] Illian, J., Penttinen, A., Stoyan, H., & Stoyan, D. (2008). Statistical Analysis and
   Modelling of Spatial Point Patterns, §2.4 (the homogeneous Poisson process: a Poisson count
   of points, each uniform over the region).
.. [3] Kokaly, R. F., et al. (2017). USGS Spectral Library Version 7, USGS Data Series 1035.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from ..errors import ConfigError
from ..registry import Registry
from .assets import check_entry_table, fail_key, ground_in_view

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["SCATTER_KINDS", "ScatterSpec", "scatter_from_table", "Distribution", "parse_distribution",
           "scatter_objects", "scatter_layout", "expected_instances", "instanced_meshes", "icosphere",
           "MAX_INSTANCES", "check_instance_budget", "placement"]

#: Most copies (scatter and asset copies together) a scene may hold: an instance costs ~5 kB
#: (measured at 10 000 in scalar_spectral, the scene dict included), a merged copy its
#: triangles (~170 B each, :data:`KIND_TRIANGLES`); the bound also keeps instance ids within
#: the 16-bit segmentation's.
MAX_INSTANCES = 60000
#: Triangles of one thing of each kind (stones and clods: an icosphere of one subdivision, 80
#: faces, smooth-shaded: a few pixels across in any view that holds thousands).
KIND_TRIANGLES = {"stones": 80, "clods": 80, "straw": 96, "grass_blades": 70}
DISTRIBUTIONS = ("uniform", "log_uniform", "lognormal", "normal")


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class Distribution:
    """A scalar distribution: ``kind`` ``constant`` (``a``), ``uniform``/``log_uniform`` on
    [a, b], ``lognormal`` (ln X ~ N(a, b)), ``normal`` (N(a, b) cut at zero)."""

    kind: str
    a: float
    b: float = 0.0

    def draw(self, rng, size=None) -> np.ndarray | float:
        if self.kind == "constant":
            return np.full(size, self.a) if size is not None else self.a
        if self.kind == "uniform":
            return rng.uniform(self.a, self.b, size)
        if self.kind == "log_uniform":
            return np.exp(rng.uniform(math.log(self.a), math.log(self.b), size))
        if self.kind == "lognormal":
            return rng.lognormal(self.a, self.b, size)
        return np.maximum(rng.normal(self.a, self.b, size), 0.0)

    @property
    def high(self) -> float:
        """A value the draws seldom pass (the maximum, or the 99.9 % quantile), for the bounds."""
        if self.kind == "constant":
            return self.a
        if self.kind in ("uniform", "log_uniform"):
            return self.b
        if self.kind == "lognormal":
            return math.exp(self.a + 3.09 * self.b)
        return self.a + 3.09 * self.b

    def to_value(self) -> Any:
        """The scene-file form (round-trips through :func:`parse_distribution`)."""
        if self.kind == "constant":
            return self.a
        return {self.kind: [self.a, self.b]}


def parse_distribution(key: str, value: Any, *, low: float, high: float, unit: str = "") -> Distribution:
    """A distribution from its scene-file form, its values (or support) within [low, high].

    Raises
    ------
    ConfigError
        Naming the forms that are valid.
    """
    forms = ("a number, [low, high] (uniform), {uniform = [low, high]}, {log_uniform = [low, high]}, "
             "{lognormal = [mu, sigma]} (of ln x) or {normal = [mean, sd]}")
    unit = f" {unit}" if unit else ""
    if _number(value):
        if not low <= value <= high:
            fail_key(key, value, f"must lie in [{low:g}, {high:g}]{unit}")
        return Distribution("constant", float(value))
    if isinstance(value, (list, tuple)):
        value = {"uniform": list(value)}
    if not isinstance(value, Mapping) or len(value) != 1:
        fail_key(key, value, f"give {forms}")
    (kind, params), = value.items()
    if kind not in DISTRIBUTIONS:
        fail_key(key, value, f"unknown distribution {kind!r}; give {forms}")
    if not isinstance(params, (list, tuple)) or len(params) != 2 or not all(_number(p) for p in params):
        fail_key(key, value, f"{kind} takes two numbers; give {forms}")
    a, b = float(params[0]), float(params[1])
    if kind in ("uniform", "log_uniform"):
        if not (low <= a <= b <= high) or (kind == "log_uniform" and a <= 0):
            fail_key(key, value, f"give low <= high within [{max(low, 1e-300) if kind == 'log_uniform' else low:g}, "
                              f"{high:g}]{unit}")
    elif b < 0 or b > 10:
        fail_key(key, value, f"{kind}: the spread must lie in [0, 10]")
    dist = Distribution(kind, a, b)
    if kind in ("lognormal", "normal") and not (low <= dist.high <= high and (kind == "lognormal" or a >= 0)):
        fail_key(key, value, f"its 99.9 % quantile {dist.high:g} must lie in [{low:g}, {high:g}]{unit}")
    return dist


# ----------------------------------------------------------------------------- the kinds
#: Every ``[[scene.scatter]]`` kind: name → ``(rng, mi) -> (vertices, faces, bsdf)`` of one
#: variant, in its own frame (z up, its foot at the origin, largest horizontal extent 1).
SCATTER_KINDS = Registry("scatter kind")


def icosphere(subdivisions: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The unit icosphere: vertices (n, 3) and outward triangles (m, 3); 20·4^s triangles."""
    t = (1.0 + 5.0 ** 0.5) / 2.0
    vertices = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t), (0, 1, -t),
                (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4), (11, 10, 2),
             (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8), (3, 8, 9), (4, 9, 5), (2, 4, 11),
             (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    verts = [np.asarray(v, float) / np.linalg.norm(v) for v in vertices]
    for _ in range(subdivisions):
        cache: dict[tuple[int, int], int] = {}

        def middle(i: int, j: int) -> int:
            key = (min(i, j), max(i, j))
            if key not in cache:
                m = verts[i] + verts[j]
                verts.append(m / np.linalg.norm(m))
                cache[key] = len(verts) - 1
            return cache[key]

        new = []
        for a, b, c in faces:
            ab, bc, ca = middle(a, b), middle(b, c), middle(c, a)
            new += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = new
    return np.asarray(verts), np.asarray(faces, dtype=np.uint32)


def _smooth_noise(rng, directions: np.ndarray, octaves: int = 3) -> np.ndarray:
    """A smooth random function on the unit sphere: a sum of random cosine waves of rising
    frequency and falling amplitude (zero mean, about unit spread)."""
    out = np.zeros(len(directions))
    for octave in range(octaves):
        for _ in range(6):
            axis = rng.normal(size=3)
            axis /= np.linalg.norm(axis)
            out += 0.5 ** octave * np.cos((1.5 + 1.5 * octave) * directions @ axis + rng.uniform(0, 2 * np.pi))
    return out / 3.0


def _lump(rng, roughness: float, flatten: float, sink: float, subdivisions: int = 1):
    """A rounded lump: an icosphere displaced by smooth noise, flattened, scaled to unit
    horizontal extent, its bottom ``sink`` of its height below the ground."""
    directions, faces = icosphere(subdivisions)
    radius = 1.0 + roughness * _smooth_noise(rng, directions)
    stretch = np.array([1.0, rng.uniform(0.6, 1.0), flatten * rng.uniform(0.8, 1.2)])
    vertices = directions * radius[:, None] * stretch
    extent = np.ptp(vertices[:, :2], axis=0).max()
    vertices /= extent
    vertices[:, 2] -= vertices[:, 2].min() + sink * np.ptp(vertices[:, 2])
    return vertices, faces


def _measured(set_name: str, prefix: str, rng):
    from ..reflectance_sets import reflectance_set

    samples = reflectance_set(set_name)
    pool = [sd for name, sd in zip(samples.names, samples.sds) if name.startswith(prefix)] or list(samples.sds)
    return pool[rng.integers(len(pool))]


@SCATTER_KINDS.register("stones", description="rounded stones (limestone, basalt, concrete spectra), sunk 15 %")
def _stones(rng, mi):
    from .common import diffuse

    vertices, faces = _lump(rng, roughness=0.12, flatten=0.65, sink=0.15)
    return vertices, faces, diffuse(_measured("usgs_stone", "stone_", rng))


@SCATTER_KINDS.register("clods", description="lumpy soil clods (the USGS soils), sunk 25 %")
def _clods(rng, mi):
    from .common import diffuse

    vertices, faces = _lump(rng, roughness=0.3, flatten=0.5, sink=0.25)
    return vertices, faces, diffuse(_measured("usgs_soils", "soil_", rng))


def _tube(path: np.ndarray, radius: np.ndarray, sides: int = 6):
    """A tube of ``sides`` along the polyline ``path`` (k, 3), radius per point; open ends."""
    tangent = np.gradient(path, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    up = np.array([0.0, 0.0, 1.0])
    normal = np.cross(tangent, up)
    normal /= np.maximum(np.linalg.norm(normal, axis=1, keepdims=True), 1e-12)
    binormal = np.cross(tangent, normal)
    angles = np.linspace(0, 2 * np.pi, sides, endpoint=False)
    ring = np.cos(angles)[None, :, None] * normal[:, None] + np.sin(angles)[None, :, None] * binormal[:, None]
    vertices = (path[:, None] + radius[:, None, None] * ring).reshape(-1, 3)
    faces = []
    for k in range(len(path) - 1):
        for s in range(sides):
            a, b = k * sides + s, k * sides + (s + 1) % sides
            faces += [(a, a + sides, b + sides), (a, b + sides, b)]
    return vertices, np.asarray(faces, dtype=np.uint32)


@SCATTER_KINDS.register("straw", description="bent straw stalks lying on the ground (USGS dry grass)")
def _straw(rng, mi):
    from .common import diffuse

    s = np.linspace(-0.5, 0.5, 9)
    bend = rng.uniform(-0.08, 0.08)
    radius = rng.uniform(0.008, 0.014)
    path = np.stack([s, bend * (1 - (2 * s) ** 2), radius + 0.01 * np.abs(s)], axis=1)
    vertices, faces = _tube(path, np.full(len(s), radius))
    return vertices, faces, {"type": "twosided", "bsdf": diffuse(_measured("usgs_vegetation", "dry_grass", rng))}


@SCATTER_KINDS.register("grass_blades", description="tufts of 3–7 curved, tapering grass blades (USGS lawn grass), "
                                                    "two-sided; size = the tuft's height")
def _grass(rng, mi):
    from .common import diffuse

    blades, rows = int(rng.integers(3, 8)), 6
    vertices, faces = [], []
    for k in range(blades):
        azimuth = rng.uniform(0, 2 * np.pi)
        lean = rng.uniform(0.1, 0.6)
        height = rng.uniform(0.6, 1.0)
        s = np.linspace(0.0, 1.0, rows)
        width = 0.04 * (1 - s) + 0.003
        out = lean * s ** 2 * height
        along = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
        across = np.array([-math.sin(azimuth), math.cos(azimuth), 0.0])
        centre = out[:, None] * along + (s * height)[:, None] * np.array([0.0, 0.0, 1.0])
        left, right = centre - width[:, None] * across, centre + width[:, None] * across
        base = sum(len(v) for v in vertices)
        vertices.append(np.stack([left, right], axis=1).reshape(-1, 3))
        for r in range(rows - 1):
            a = base + 2 * r
            faces += [(a, a + 1, a + 3), (a, a + 3, a + 2)]
    vertices = np.concatenate(vertices)
    scale = max(np.ptp(vertices[:, 2]), 1e-9)  # a tuft's size is its height
    return vertices / scale, np.asarray(faces, dtype=np.uint32), {
        "type": "twosided", "bsdf": diffuse(_measured("usgs_vegetation", "green_lawn", rng))}


#: Tilt (degrees, at most) of each kind's things from upright.
KIND_TILT_DEG = {"stones": 15.0, "clods": 20.0, "straw": 0.0, "grass_blades": 15.0}


# ----------------------------------------------------------------------------- the scene-file entry
SCATTER_KEYS = ("kind", "name", "density_per_m2", "size_m", "max_distance_m", "variants")


@dataclass(frozen=True)
class ScatterSpec:
    """One ``[[scene.scatter]]`` entry (see the module's description)."""

    kind: str
    name: str
    density_per_m2: Distribution
    size_m: Distribution
    max_distance_m: float = 0.0
    variants: int = 4

    def to_table(self) -> dict:
        return {"kind": self.kind, "name": self.name, "density_per_m2": self.density_per_m2.to_value(),
                "size_m": self.size_m.to_value(), "max_distance_m": self.max_distance_m, "variants": self.variants}


def scatter_from_table(table: Any, index: int) -> ScatterSpec:
    """Validate one ``[[scene.scatter]]`` table.

    Raises
    ------
    ConfigError
        For an unknown key or kind, or a value out of range, naming the valid ones.
    """
    where = f"scene.scatter[{index}]"
    if isinstance(table, ScatterSpec):
        return table
    check_entry_table(where, table, SCATTER_KEYS, "give a table: kind = ..., density_per_m2 = ..., size_m = ...")
    kind = table.get("kind")
    if kind not in SCATTER_KINDS:
        fail_key(f"{where}.kind", kind, f"unknown kind; valid: {', '.join(SCATTER_KINDS)}")
    name = table.get("name", kind)
    if not isinstance(name, str) or not name or not name.replace("_", "").isalnum():
        fail_key(f"{where}.name", name, "give a segmentation name of letters, digits and _")
    if "density_per_m2" not in table:
        fail_key(f"{where}.density_per_m2", None, "give the things per square metre of ground")
    density = parse_distribution(f"{where}.density_per_m2", table["density_per_m2"], low=0.0, high=1e5, unit="per m²")
    size = parse_distribution(f"{where}.size_m", table.get("size_m", [0.02, 0.08]), low=1e-4, high=10.0, unit="m")
    max_distance = table.get("max_distance_m", 0.0)
    if not (_number(max_distance) and 0 <= max_distance <= 1e4):
        fail_key(f"{where}.max_distance_m", max_distance, "must lie in [0, 1e4] m (0: 3 × scene.distance_m)")
    variants = table.get("variants", 4)
    if not (isinstance(variants, int) and not isinstance(variants, bool) and 1 <= variants <= 64):
        fail_key(f"{where}.variants", variants, "must be a whole number in 1..64 (distinct meshes of the kind)")
    return ScatterSpec(kind, name, density, size, float(max_distance), variants)


# ----------------------------------------------------------------------------- where they go
def _reach(config: "SceneConfig", max_distance_m: float) -> float:
    return max_distance_m if max_distance_m > 0 else 3.0 * config.scene.distance_m


def _area(box, inside, samples: int = 96) -> float:
    """The region's area (m²) from a regular grid over its box."""
    e0, n0, e1, n1 = box
    grid = np.stack(np.meshgrid(np.linspace(e0, e1, samples), np.linspace(n0, n1, samples)), -1).reshape(-1, 2)
    return float((e1 - e0) * (n1 - n0) * inside(grid).mean())


def expected_instances(config: "SceneConfig", lens: "ThinLens | None" = None) -> list[tuple[str, float]]:
    """(entry, count) for each scatter entry at its density's :attr:`Distribution.high` over
    the ground in view: what :func:`check_instance_budget` holds against :data:`MAX_INSTANCES`."""
    if lens is None:
        from ..optics import ThinLens

        lens = ThinLens.from_config(config.lens, config.sensor)
    out = []
    for k, spec in enumerate(config.scene.scatter):
        box, inside = ground_in_view(config, lens, _reach(config, spec.max_distance_m))
        out.append((f"scene.scatter[{k}] ({spec.kind})", spec.density_per_m2.high * _area(box, inside)))
    return out


def check_instance_budget(config: "SceneConfig", lens: "ThinLens | None" = None) -> None:
    """Refuse a scene whose scatter and asset copies would pass :data:`MAX_INSTANCES`.

    Raises
    ------
    ConfigError
        With each entry's expected count and the remedy.
    """
    counts = expected_instances(config, lens) + [(f"scene.assets[{k}] ({a.name})", float(a.count))
                                                 for k, a in enumerate(config.scene.assets) if a.count > 1]
    total = sum(c for _, c in counts)
    if total > MAX_INSTANCES:
        listed = "; ".join(f"{name}: {count:,.0f}" for name, count in counts)
        raise ConfigError(f"the scatter and asset copies would place about {total:,.0f} things ({listed}), more "
                          f"than {MAX_INSTANCES:,} (each an instance of ~5 kB, or its triangles merged at ~170 B "
                          "each, and an id of the 16-bit segmentation); lower density_per_m2, max_distance_m or count")


@dataclass(frozen=True)
class Placed:
    """One thing on the ground: its variant, foot (east, north, m), size (m), turn about the
    vertical and tilt (degrees)."""

    variant: int
    east_m: float
    north_m: float
    size_m: float
    turn_deg: float
    tilt_deg: float
    tilt_azimuth_deg: float


def scatter_layout(config: "SceneConfig", lens: "ThinLens", index: int) -> list[Placed]:
    """Where entry ``index`` of ``scene.scatter`` puts its things: a Poisson process over the
    ground in view, drawn by ``scene.layout_seed`` and ``index``.

    Raises
    ------
    ConfigError
        When the draw passes :data:`MAX_INSTANCES`.
    """
    spec = config.scene.scatter[index]
    rng = np.random.default_rng(np.random.SeedSequence([config.scene.layout_seed, 0x5CA7, index]))
    density = float(spec.density_per_m2.draw(rng))
    box, inside = ground_in_view(config, lens, _reach(config, spec.max_distance_m))
    e0, n0, e1, n1 = box
    expected = density * (e1 - e0) * (n1 - n0)
    if expected > 50 * MAX_INSTANCES:
        raise ConfigError(f"scene.scatter[{index}].density_per_m2 = {density:g} over {(e1 - e0) * (n1 - n0):.3g} m² "
                          f"would draw ~{expected:,.0f} candidates; lower it or max_distance_m")
    candidates = rng.uniform((e0, n0), (e1, n1), size=(rng.poisson(expected), 2))
    feet = candidates[inside(candidates)] if len(candidates) else candidates
    if len(feet) > MAX_INSTANCES:
        raise ConfigError(f"scene.scatter[{index}] ({spec.kind}) drew {len(feet):,} things, more than {MAX_INSTANCES:,}; "
                          "lower density_per_m2 or max_distance_m")
    n = len(feet)
    sizes = np.asarray(spec.size_m.draw(rng, n), float)
    tilt = KIND_TILT_DEG[spec.kind]
    variants, turns = rng.integers(spec.variants, size=n), rng.uniform(0, 360, n)
    tilts, tilt_azimuths = rng.uniform(0, tilt, n), rng.uniform(0, 360, n)
    return [Placed(int(variants[k]), float(feet[k, 0]), float(feet[k, 1]), float(sizes[k]), float(turns[k]),
                   float(tilts[k]), float(tilt_azimuths[k])) for k in range(n) if sizes[k] > 0]


def placement(item: Placed) -> np.ndarray:
    """The ground-frame 4 × 4 of one placed thing: scaled to its size, turned, tilted, on its foot."""
    from .assets import _rotation

    m = np.eye(4)
    m[:3, :3] = (_rotation(2, item.tilt_azimuth_deg) @ _rotation(0, item.tilt_deg)
                 @ _rotation(2, item.turn_deg - item.tilt_azimuth_deg)) * item.size_m
    m[:3, 3] = (item.east_m, item.north_m, 0.0)
    return m


def scatter_objects(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """Scene-dict entries of every ``[[scene.scatter]]`` entry: per entry and variant, a
    shapegroup ``scatter_<k>_v<v>`` with an instance ``<name>_<n>`` per thing, or (in the JIT
    variants of Mitsuba up to 3.9.1, :func:`~spectral_cam.presets.assets.use_instances`) one
    mesh ``<name>_<v>`` holding the variant's things."""
    from .assets import MeshData, camera_matrix, place_copies
    from .outdoor import GroundView

    camera = camera_matrix(GroundView.from_config(config))
    objects: dict = {}
    for index, spec in enumerate(config.scene.scatter):
        layout = scatter_layout(config, lens, index)
        rng = np.random.default_rng(np.random.SeedSequence([config.scene.layout_seed, 0x3E5B, index]))
        counter = 0
        for v in range(spec.variants):
            vertices, faces, bsdf = SCATTER_KINDS[spec.kind](rng, mi)
            mine = [item for item in layout if item.variant == v]
            if not mine:
                continue
            objects.update(place_copies(mi, camera, MeshData(vertices, faces), bsdf, [placement(item) for item in mine],
                                        name=spec.name, group_key=f"scatter_{index}_v{v}",
                                        merged_key=f"{spec.name}_{v}", first=counter))
            counter += len(mine)
    return objects


def _children(mi, obj) -> list:
    """The Mitsuba objects ``obj`` exposes to a traversal (its plugins' children)."""
    found = []

    # Mitsuba requires this class inside a function: mi.TraversalCallback can be reached only once a
    # variant is set (nothing is registered), and put() appends to this call's list
    class Callback(mi.TraversalCallback):
        def put(self, name, value, flags, *rest):  # noqa: D401 - Mitsuba's callback
            if isinstance(value, mi.Object):
                found.append(value)

    obj.traverse(Callback())
    return found


def instanced_meshes(mi, scene) -> list:
    """The shapes inside ``scene``'s shapegroups: the ones Mitsuba's ``shape_index`` AOV
    reports (by their registry ids, ``dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))``)
    for a ray that meets an instance of them — the instance's own id never shows (measured on
    3.9.1). Each is named (``.id()``) as its scatter entry or asset. A shapegroup is reached
    through the scene's traversal (an instance's own exposes only its ``to_world``)."""
    out = []
    for child in _children(mi, scene):
        if "ShapeGroup" in child.class_name():
            out += [inner for inner in _children(mi, child) if isinstance(inner, mi.Shape)]
    return out
