"""``vegetation``: plants of measured leaf spectra on measured soil, under the sun and sky —
the scene of outdoor and agricultural imaging (crop monitoring, plant health).

Each plant is one triangle mesh (``plant_<n>``; weeds ``weed_<n>``) grown by its species'
morphology (:mod:`spectral_cam.presets.plants`: ``grass``, ``rosette``, ``upright``, ``shrub``,
``cereal``),
drawn by ``scene.layout_seed`` (:func:`plant_species`: 2–4 species a scattered scene, one crop
species a field, its weeds of another morphology), its shape bent by its health (wilting,
curl, leaf loss, stunting). With ``scene.plant_reflectances = "prospect"`` (the
default) a plant's leaves reflect *and transmit* as PROSPECT-D gives for its own biochemistry
(:mod:`spectral_cam.leaves`), drawn per plant by health state — ``dry`` for ``scene.dry_fraction``
of the plants, ``stressed`` for ``scene.stressed_fraction``, else ``healthy`` (:func:`plant_health`,
the datasets' health label) — through the two-sided translucent leaf BSDF
(``render/leaf_bsdf.py``) under a rough dielectric cuticle (n = 1.47, the species' GGX roughness):
in the near infrared a leaf transmits about as much as it reflects, which makes plants glow
against the sun, and the cuticle adds the sheen; veins, midrib and base are paler (a vein
texture over the leaf's UVs), older lower leaves yellower and browner (per-vertex age), shrub
stems bark. With a reflectance set (e.g. ``usgs_vegetation``), the
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

from ..keys import Key, fraction_in
from . import outdoor
from .keys import reflectance_set
from .common import LEAF_SPECTRUM_STEP_NM, PRESETS, bitmap_texture, diffuse, reflectance_spectrum, spectrum_dict
from .meshes import mitsuba_mesh
from .plants import GOLDEN_ANGLE_DEG, MORPHOLOGIES, HealthShape, draw_shape, draw_species, vein_pattern

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["plant_mesh", "vegetation_layout", "plant_health", "plant_species", "GOLDEN_ANGLE_DEG",
           "CROP_MORPHOLOGIES", "WEED_MORPHOLOGIES", "SCATTER_MORPHOLOGIES", "BARK_SAMPLE"]

#: Morphologies a crop row may be (lettuce, beet: rosette; bean, soybean, potato: upright; maize,
#: sorghum: cereal; rows 0.75 m apart are what these crops are sown in, wheat is drilled closer)
#: and those the weeds between the rows are drawn from (never the crop's); a scattered scene's
#: species come from the wild morphologies (no maize in a meadow).
CROP_MORPHOLOGIES = ("rosette", "upright", "cereal")
WEED_MORPHOLOGIES = ("grass", "upright")
SCATTER_MORPHOLOGIES = ("grass", "rosette", "upright", "shrub")
#: The bark of woody stems: no bark spectrum is bundled (data/usgs_splib07/README.md), so the
#: USGS dried oak leaf, a dead, brown plant tissue, stands in.
BARK_SAMPLE = "dry_oak_leaf2_dried_ASD"


def plant_mesh(rng, height_m: float, morphology: str = "rosette", shape: HealthShape | None = None,
               species: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and triangles of one plant about +z, standing on z = 0, about ``height_m``
    tall (:mod:`spectral_cam.presets.plants`; a healthy plant of a species drawn from ``rng``
    unless given)."""
    species = species or draw_species(rng, morphology)
    geometry = MORPHOLOGIES[morphology](rng, height_m, species, shape or HealthShape()).arrays()
    return geometry["vertices"], geometry["faces"]


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


def plant_species(config: "SceneConfig", plants: int, weeds: int = 0) -> tuple[list[dict], list[dict]]:
    """Each plant's and each weed's species (:func:`spectral_cam.presets.plants.draw_species`),
    drawn by ``layout_seed``: a scattered scene has 2–4 species of different
    :data:`SCATTER_MORPHOLOGIES`, each
    plant one of them; a crop field (``layout = "rows"``) one crop species of
    :data:`CROP_MORPHOLOGIES`, its weeds 1–2 species of :data:`WEED_MORPHOLOGIES` other than the
    crop's morphology."""
    rng = np.random.default_rng(np.random.SeedSequence([config.scene.layout_seed, 0x5BEC1E5]))
    if config.scene.layout == "rows":
        crop = draw_species(rng, str(rng.choice(CROP_MORPHOLOGIES)))
        choices = [m for m in WEED_MORPHOLOGIES if m != crop["morphology"]]
        pool = [draw_species(rng, str(m)) for m in rng.permutation(choices)[:int(rng.integers(1, len(choices) + 1))]]
        return [crop] * plants, [pool[int(rng.integers(len(pool)))] for _ in range(weeds)]
    names = list(SCATTER_MORPHOLOGIES)
    pool = [draw_species(rng, str(m)) for m in rng.permutation(names)[:int(rng.integers(2, len(names) + 1))]]
    return [pool[int(rng.integers(len(pool)))] for _ in range(plants)], []


def _split_dry(samples) -> tuple[list, list]:
    dry = [sd for name, sd in zip(samples.names, samples.sds) if name.startswith("dry")]
    green = [sd for name, sd in zip(samples.names, samples.sds) if not name.startswith("dry")]
    return green or dry, dry or green


def _bark():
    from ..reflectance_sets import reflectance_set

    samples = reflectance_set("usgs_vegetation")
    return samples.sds[samples.names.index(BARK_SAMPLE)]


def leaf_material(traits, species: dict, veins, *, wood: bool = False) -> dict:
    """The leaf BSDF of a plant (``render/leaf_bsdf.py``): a cuticle of index
    :data:`~spectral_cam.leaves.CUTICLE_INDEX` and the species' roughness over PROSPECT-D's body
    (:func:`~spectral_cam.leaves.prospect_layers`) of the lamina, the veins
    (:func:`~spectral_cam.leaves.vein_traits`, weighted by the texture ``veins``) and the oldest
    leaf (:func:`~spectral_cam.leaves.aged_traits`, weighted by the mesh's per-vertex
    ``vertex_age``) and, with ``wood``, bark where ``vertex_wood`` is 1."""
    from .. import spectra
    from ..leaves import CUTICLE_INDEX, LEAF_PLUGIN, aged_traits, prospect_layers, vein_traits

    lo, hi = spectra.MITSUBA_RANGE_NM
    wavelengths = np.arange(lo, hi + LEAF_SPECTRUM_STEP_NM / 2, LEAF_SPECTRUM_STEP_NM)
    bsdf = {"type": LEAF_PLUGIN, "eta": CUTICLE_INDEX, "alpha": float(species["alpha"]), "vein": veins,
            "age": {"type": "mesh_attribute", "name": "vertex_age"}}
    old = aged_traits(traits)
    for suffix, leaf in (("", traits), ("_vein", vein_traits(traits)), ("_old", old)):
        rho, tau = prospect_layers(leaf, wavelengths)
        bsdf["reflectance" + suffix] = spectrum_dict((wavelengths, rho))
        bsdf["transmittance" + suffix] = spectrum_dict((wavelengths, tau))
    if wood:
        bsdf["reflectance_wood"] = reflectance_spectrum(_bark())
        bsdf["wood"] = {"type": "mesh_attribute", "name": "vertex_wood"}
    return bsdf


def _plant(mi, name, rng, size, species, shape, bsdf_of, place, view):
    """One plant's mesh: grown by its species' morphology, its BSDF from ``bsdf_of(has_wood)``."""
    geometry = MORPHOLOGIES[species["morphology"]](rng, size, species, shape).arrays()
    wood = bool(geometry["wood"].max() > 0)
    attributes = {"vertex_age": geometry["age"]}
    if wood:
        attributes["vertex_wood"] = geometry["wood"]
    return mitsuba_mesh(mi, name, geometry["vertices"], geometry["faces"], bsdf_of(wood),
                        view.transform(mi, place), texcoords=geometry["uv"], attributes=attributes)


def _stressed(value, scene):
    if isinstance(value, float) and 0.0 <= value <= 1.0 and scene.dry_fraction + value <= 1.0:
        return None
    return "must lie in [0, 1 − dry_fraction]: the fraction of plants with stressed (chlorotic) leaves"


_VEGETATION_KEYS = (
    Key("plant_reflectances", "prospect", "str", "prospect (PROSPECT-D per plant's biochemistry) or a reflectance "
        "set such as usgs_vegetation", (reflectance_set(also=("prospect",)),)),
    Key("dry_fraction", 0.1, "float", "the fraction of plants with dry leaves",
        (fraction_in(0.0, 1.0, "must lie in [0, 1]: the fraction of plants with dry leaves"),)),
    Key("stressed_fraction", 0.2, "float", "the fraction of plants with stressed (chlorotic) leaves", (_stressed,)),
    Key("layout", "scatter", "str", "scatter (plants over the view) or rows (a crop field)",
        (lambda v, s: None if v in ("scatter", "rows") else "valid: scatter (plants drawn over the view), rows (a crop "
         "field: rows 0.75 m apart, a plant every 0.3 m, weeds between)",)),
)


@PRESETS.register("vegetation", options=("distance_m", "view_pitch_deg", "light", "object_count", "object_size",
                                         "soil_reflectances", "layout_seed", "ground"), keys=_VEGETATION_KEYS,
                  description="plants of several species and shapes (grass, rosette, upright, shrub) with PROSPECT-D "
                              "leaves under a cuticle (or measured leaf spectra) on measured soil under the sun and sky")
def vegetation(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """The soil, the plants of :func:`vegetation_layout` and the light."""
    from ..leaves import LeafTraits, draw_traits
    from ..reflectance_sets import reflectance_set

    s = config.scene
    rng = np.random.default_rng(np.random.SeedSequence([s.layout_seed, 0x5011]))
    shape_rng = np.random.default_rng(np.random.SeedSequence([s.layout_seed, 0x5A9E]))
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
    objects = {"ground": outdoor.ground(view, mi, ground_bsdf), **outdoor.far_ground(view, mi, far, seed=config.scene.layout_seed)}
    layout = vegetation_layout(config, lens)
    field = field_layout(config, lens) if s.layout == "rows" else []
    weeds = [item for item in field if item[0].startswith("weed_")]
    species, weed_species = plant_species(config, len(layout), len(weeds))
    veins = {}

    def vein_texture(venation):  # one texture per venation, shared by every plant
        if venation not in veins:
            veins[venation] = mi.load_dict(bitmap_texture(mi, vein_pattern(venation)))
        return veins[venation]

    def measured(sd):  # a measured reflectance only: two-sided Lambertian, no transmission; bark on wood
        def bsdf_of(wood):
            leaf = diffuse(sd)
            if wood:
                leaf = {"type": "blendbsdf", "weight": {"type": "mesh_attribute", "name": "vertex_wood"},
                        "bsdf_0": leaf, "bsdf_1": diffuse(_bark())}
            return {"type": "twosided", "bsdf": leaf}
        return bsdf_of

    health = plant_health(config, len(layout)) if prospect else None
    if weeds:  # the weeds between the rows: healthy leaves of their own
        weed_rng = np.random.default_rng(np.random.SeedSequence([s.layout_seed, 0x3EED]))
        for (name, east, north, size), kind in zip(weeds, weed_species):
            traits = draw_traits(weed_rng, "healthy")
            bsdf_of = ((lambda wood, t=traits, k=kind: leaf_material(t, k, vein_texture(k["venation"]), wood=wood))
                       if prospect else measured(green[0]))
            place = mi.ScalarTransform4f().translate([east, north, 0.0])
            objects[name] = _plant(mi, name, weed_rng, size, kind, draw_shape(shape_rng, "healthy"), bsdf_of, place,
                                   view)
    for n, (east, north, size) in enumerate(layout):
        kind = species[n]
        if prospect:  # reflects and transmits (PROSPECT-D) under a cuticle, the plant's own biochemistry
            state = health[n]["state"]
            traits = LeafTraits(**health[n]["traits"])
            bsdf_of = (lambda wood, t=traits, k=kind: leaf_material(t, k, vein_texture(k["venation"]), wood=wood))
        else:
            is_dry = rng.random() < s.dry_fraction
            pool = dry if is_dry else green
            state = "dry" if is_dry else "healthy"
            bsdf_of = measured(pool[rng.integers(len(pool))])
        place = mi.ScalarTransform4f().translate([east, north, 0.0])
        objects[f"plant_{n}"] = _plant(mi, f"plant_{n}", rng, size, kind, draw_shape(shape_rng, state), bsdf_of,
                                       place, view)
    objects.update(outdoor.light(config, view, mi))
    return objects
