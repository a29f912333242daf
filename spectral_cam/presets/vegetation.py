"""``vegetation``: plants of measured leaf spectra on measured soil, under the sun and sky —
the scene of outdoor and agricultural imaging (crop monitoring, plant health).

Each plant is one triangle mesh of 6–11 leaves set round its stem by the golden angle
(137.5°, the phyllotaxis of most broad-leaved plants), each leaf a lanceolate blade whose width
follows sin(πs)^0.7 along its length, rising at 25–65° and drooping under its own weight, with
a slight V-fold along the midrib, cupped or rolled across (curl), each of its own length. With ``scene.plant_reflectances = "prospect"`` (the
default) a plant's leaves reflect *and transmit* as PROSPECT-D gives for its own biochemistry
(:mod:`spectral_cam.leaves`), drawn per plant by health state — ``dry`` for ``scene.dry_fraction``
of the plants, ``stressed`` for ``scene.stressed_fraction``, else ``healthy`` (:func:`plant_health`,
the datasets' health label) — through the two-sided translucent leaf BSDF
(``render/leaf_bsdf.py``): in the near infrared a leaf transmits about as much as it reflects,
which makes plants glow against the sun. With a reflectance set (e.g. ``usgs_vegetation``), the
leaves share one measured reflectance (its ``dry_*`` samples for ``dry_fraction``) and are
two-sided Lambertian reflectors that transmit nothing. The soil is one sample of
``scene.soil_reflectances`` drawn by ``scene.layout_seed``.

Plants stand where rays through the middle 90 % of the frame meet the ground, no nearer to
each other than 0.4 of their sizes (``scene.object_size``: fractions of the view's width at
the look point), ``scene.object_count`` of them.

References
----------
.. [1] Kokaly, R. F., et al. (2017). USGS Spectral Library Version 7, USGS Data Series 1035
   (the bundled leaf and soil spectra, ``spectral_cam/data/usgs_splib07``).
.. [3] Féret, J.-B., et al. (2017). PROSPECT-D. Remote Sensing of Environment 193, 204–215.
.. [2] Douady, S., & Couder, Y. (1992). Phyllotaxis as a physical self-organized growth process.
   Physical Review Letters 68(13), 2098 (the golden-angle leaf arrangement).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from . import outdoor
from .common import PRESETS, diffuse, leaf_bsdf
from .meshes import mitsuba_mesh

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["plant_mesh", "vegetation_layout", "plant_health", "GOLDEN_ANGLE_DEG"]

GOLDEN_ANGLE_DEG = 137.50776
#: Samples along and across each leaf blade.
LEAF_STEPS, LEAF_SIDES = 10, 2


def _leaf(base, azimuth: float, length: float, rise: float, droop: float, fold: float, curl: float = 0.0):
    """Vertices of one blade, (LEAF_STEPS + 1) × (2·LEAF_SIDES + 1), rows along its length; ``curl``
    cups the blade across (its edges rise by curl × half-width, more towards the tip)."""
    s = np.linspace(0.0, 1.0, LEAF_STEPS + 1)[:, None]
    t = np.linspace(-1.0, 1.0, 2 * LEAF_SIDES + 1)[None, :]
    width = 0.18 * length * np.sin(np.pi * s) ** 0.7
    along = np.array([math.cos(azimuth), math.sin(azimuth), 0.0])
    across = np.array([-math.sin(azimuth), math.cos(azimuth), 0.0])
    reach = s * length * math.cos(rise)
    height = (s * length * math.sin(rise) - droop * length * s ** 2 + fold * width * np.abs(t)
              + curl * width * t ** 2 * (0.5 + s))
    points = (base + reach[..., None] * along + (width * t)[..., None] * across
              + height[..., None] * np.array([0.0, 0.0, 1.0]))
    return points.reshape(-1, 3)


def _grid_faces(rows: int, columns: int, offset: int) -> np.ndarray:
    faces = []
    for i in range(rows - 1):
        for j in range(columns - 1):
            a = offset + i * columns + j
            faces += [(a, a + columns, a + columns + 1), (a, a + columns + 1, a + 1)]
    return np.asarray(faces, dtype=np.uint32)


def plant_mesh(rng, height_m: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of one plant about +z, standing on z = 0, about ``height_m``
    tall (its leaves reach about 0.6·height out from the stem)."""
    count = int(rng.integers(6, 12))
    start = rng.uniform(0, 360)
    vertices, faces = [], []
    for k in range(count):
        level = k / count
        base = np.array([0.0, 0.0, height_m * (0.05 + 0.45 * level)])
        azimuth = math.radians(start + k * GOLDEN_ANGLE_DEG + rng.normal(0, 8))
        length = height_m * rng.uniform(0.45, 0.7) * (1.0 - 0.3 * level)
        blade = _leaf(base, azimuth, length, math.radians(rng.uniform(25, 65)), rng.uniform(0.3, 0.7),
                      rng.uniform(0.05, 0.2), curl=rng.uniform(-0.2, 0.5))
        faces.append(_grid_faces(LEAF_STEPS + 1, 2 * LEAF_SIDES + 1, sum(len(v) for v in vertices)))
        vertices.append(blade)
    return np.concatenate(vertices), np.concatenate(faces)


#: A crop-row field: the rows' spacing and the plants' along a row (m), the most rows and plants,
#: the weeds between the rows per crop plant and their size against a crop plant's.
ROW_SPACING_M, PLANT_SPACING_M, MAX_FIELD_PLANTS = 0.75, 0.3, 400
WEEDS_PER_PLANT, WEED_SIZE = 0.3, 0.35


def _ground_footprint(config: "SceneConfig", lens: "ThinLens") -> tuple[float, float, float, float]:
    """(east_min, east_max, north_min, north_max) of the ground the frame sees, no farther than
    6·``distance_m`` (rays above the horizon are cut there)."""
    view = outdoor.GroundView.from_config(config)
    half_x, half_y = lens.sensor_width_m / (2 * lens.image_distance_m), lens.sensor_height_m / (2 * lens.image_distance_m)
    reach = 6.0 * config.scene.distance_m
    points = []
    for x in np.linspace(-half_x, half_x, 9):
        for y in np.linspace(-half_y, half_y, 9):
            d = view.rotation.T @ np.array([x, y, 1.0])
            t = -view.camera_m[2] / d[2] if d[2] < 0 else np.inf
            p = view.camera_m + min(t, reach / np.linalg.norm(d)) * d
            points.append(p[:2])
    points = np.array(points)
    return float(points[:, 0].min()), float(points[:, 0].max()), float(points[:, 1].min()), float(points[:, 1].max())


def field_layout(config: "SceneConfig", lens: "ThinLens") -> list[tuple[str, float, float, float]]:
    """A crop field: rows running north every :data:`ROW_SPACING_M`, a crop plant every
    :data:`PLANT_SPACING_M` along them (jittered by a tenth, a few missing), weeds scattered
    between the rows; over the ground the frame sees. Sizes are ``scene.object_size`` of
    :data:`ROW_SPACING_M` (crop) and :data:`WEED_SIZE` of that (weeds).

    Returns
    -------
    list of (name, east, north, size)
        ``plant_<n>`` for the crop, ``weed_<n>`` for the weeds.
    """
    rng = np.random.default_rng(np.random.SeedSequence([config.scene.layout_seed, 0xF1E1D]))
    e0, e1, n0, n1 = _ground_footprint(config, lens)
    items, plants = [], 0
    first_row = math.floor(e0 / ROW_SPACING_M)
    for row in range(first_row, math.ceil(e1 / ROW_SPACING_M) + 1):
        for k in range(math.floor(n0 / PLANT_SPACING_M), math.ceil(n1 / PLANT_SPACING_M) + 1):
            if rng.random() < 0.05 or plants >= MAX_FIELD_PLANTS:
                continue  # a gap in the row
            size = ROW_SPACING_M * rng.uniform(*config.scene.object_size) * 4
            east = row * ROW_SPACING_M + rng.normal(0, 0.03)
            north = k * PLANT_SPACING_M + rng.normal(0, 0.1 * PLANT_SPACING_M)
            items.append((f"plant_{plants}", east, north, size))
            plants += 1
    for w in range(int(WEEDS_PER_PLANT * plants)):
        row = rng.integers(first_row, math.ceil(e1 / ROW_SPACING_M) + 1)
        east = (row + rng.uniform(0.3, 0.7)) * ROW_SPACING_M
        size = ROW_SPACING_M * rng.uniform(*config.scene.object_size) * 4 * WEED_SIZE
        items.append((f"weed_{w}", east, rng.uniform(n0, n1), size))
    return items


def vegetation_layout(config: "SceneConfig", lens: "ThinLens"):
    """(east, north, size) of each plant in the ground frame (m), drawn by ``layout_seed``
    (:func:`spectral_cam.presets.outdoor.scatter_on_ground`), or the crop plants of
    :func:`field_layout` for ``scene.layout = "rows"``.

    Raises
    ------
    ConfigError
        When ``scene.object_count`` plants of ``scene.object_size`` do not fit in the view.
    """
    if config.scene.layout == "rows":
        return [(e, n, z) for name, e, n, z in field_layout(config, lens) if name.startswith("plant_")]
    rng = np.random.default_rng(np.random.SeedSequence([config.scene.layout_seed, 0x1EAF5]))
    return list(outdoor.scatter_on_ground(config, lens, rng, margin=0.9, spacing=0.4, centre_height=0.0,
                                          noun="plants"))


def plant_health(config: "SceneConfig", count: int) -> list[dict]:
    """Each plant's health state and PROSPECT-D biochemistry, drawn by ``layout_seed``: ``dry``
    for ``scene.dry_fraction`` of them, ``stressed`` for ``scene.stressed_fraction``, else
    ``healthy`` (:data:`spectral_cam.leaves.HEALTH_STATES`); the health label of datasets.

    Returns
    -------
    list of dict
        ``{"plant": "plant_<n>", "state": ..., "traits": {n, cab, car, ant, brown, cw, cm}}``.
    """
    from ..leaves import draw_traits

    s = config.scene
    rng = np.random.default_rng(np.random.SeedSequence([s.layout_seed, 0x4EA1]))
    plants = []
    for n in range(count):
        u = rng.random()
        state = "dry" if u < s.dry_fraction else "stressed" if u < s.dry_fraction + s.stressed_fraction else "healthy"
        plants.append({"plant": f"plant_{n}", "state": state, "traits": draw_traits(rng, state).to_dict()})
    return plants


def _split_dry(samples) -> tuple[list, list]:
    dry = [sd for name, sd in zip(samples.names, samples.sds) if name.startswith("dry")]
    green = [sd for name, sd in zip(samples.names, samples.sds) if not name.startswith("dry")]
    return green or dry, dry or green


@PRESETS.register("vegetation", options=("distance_m", "view_pitch_deg", "light", "object_count", "object_size",
                                         "plant_reflectances", "soil_reflectances", "dry_fraction",
                                         "stressed_fraction", "layout_seed", "ground", "layout"),
                  description="plants of PROSPECT-D leaves (or measured leaf spectra) on measured soil under the sun "
                              "and sky")
def vegetation(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """The soil, the plants of :func:`vegetation_layout` and the light."""
    from ..leaves import LeafTraits, draw_traits
    from ..reflectance_sets import reflectance_set

    s = config.scene
    rng = np.random.default_rng(np.random.SeedSequence([s.layout_seed, 0x5011]))
    prospect = s.plant_reflectances == "prospect"
    green, dry = ([], []) if prospect else _split_dry(reflectance_set(s.plant_reflectances))
    soils = reflectance_set(s.soil_reflectances)
    view = outdoor.GroundView.from_config(config)
    soil = soils.sds[rng.integers(len(soils))]  # drawn whatever the ground: the layout's draws stay the same
    if s.ground == "textured":
        ground_bsdf = outdoor.textured_ground_bsdf(config, lens, mi)
    elif s.ground == "checker":
        from .tabletop import checker_ground_bsdf

        ground_bsdf = checker_ground_bsdf(config, lens, mi)
    else:
        ground_bsdf = diffuse(soil)
    far = diffuse(0.25) if s.ground == "checker" else diffuse(soil)
    objects = {"ground": outdoor.ground(view, mi, ground_bsdf), **outdoor.far_ground(view, mi, far)}
    layout = vegetation_layout(config, lens)
    health = plant_health(config, len(layout)) if prospect else None
    if s.layout == "rows":  # the weeds between the rows: healthy leaves of their own
        weed_rng = np.random.default_rng(np.random.SeedSequence([s.layout_seed, 0x3EED]))
        for name, east, north, size in field_layout(config, lens):
            if name.startswith("weed_"):
                vertices, faces = plant_mesh(weed_rng, size)
                leaf = leaf_bsdf(draw_traits(weed_rng, "healthy")) if prospect else diffuse(green[0])
                place = mi.ScalarTransform4f().translate([east, north, 0.0])
                objects[name] = mitsuba_mesh(mi, name, vertices, faces, leaf, view.transform(mi, place))
    for n, (east, north, size) in enumerate(layout):
        if prospect:  # reflects and transmits (PROSPECT-D), the plant's own biochemistry
            leaf = leaf_bsdf(LeafTraits(**health[n]["traits"]))
        else:  # a measured reflectance only: two-sided Lambertian, no transmission
            pool = dry if rng.random() < s.dry_fraction else green
            leaf = {"type": "twosided", "bsdf": diffuse(pool[rng.integers(len(pool))])}
        vertices, faces = plant_mesh(rng, size)
        place = mi.ScalarTransform4f().translate([east, north, 0.0])
        objects[f"plant_{n}"] = mitsuba_mesh(mi, f"plant_{n}", vertices, faces, leaf, view.transform(mi, place))
    objects.update(outdoor.light(config, view, mi))
    return objects
