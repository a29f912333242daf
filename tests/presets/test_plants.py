"""Issue 37 #3: plants of several morphologies and species, grown procedurally, health in their shape.

References: the morphologies' descriptions (``presets/plants.py``: Esau 1977 for venation,
Douady & Couder 1992 for phyllotaxis, Hsiao 1973 for the shape of water stress).
"""

from __future__ import annotations

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.presets.plants import (HEALTH_SHAPES, MORPHOLOGIES, HealthShape, draw_shape, draw_species,
                                         vein_pattern)
from spectral_cam.presets.vegetation import (CROP_MORPHOLOGIES, SCATTER_MORPHOLOGIES, WEED_MORPHOLOGIES,
                                              plant_species)


def _grow(morphology, seed, state="healthy", size=0.5, species=None):
    rng = np.random.default_rng(seed)
    species = species or draw_species(rng, morphology)
    shape = draw_shape(rng, state)
    plant = MORPHOLOGIES[morphology](rng, size, species, shape)
    return plant, plant.arrays()


@pytest.mark.parametrize("morphology", list(MORPHOLOGIES))
def test_each_morphology_grows_a_plant_of_a_few_thousand_triangles_none_alike(morphology):
    """Five morphologies; a plant is at most 6000 triangles (grass, rosette, upright, cereal ≈
    350–1000; shrub ≈ 3000–5000), stands on the ground within about its size, carries texture coordinates
    in [0, 1] and ages in [0, 1]; only the shrub has bark; two plants of one species differ."""
    assert set(MORPHOLOGIES) >= {"grass", "rosette", "upright", "shrub", "cereal"}
    species = draw_species(np.random.default_rng(1), morphology)
    shapes = []
    for seed in range(8):
        plant, a = _grow(morphology, seed, species=species)
        v = a["vertices"]
        assert 100 < len(a["faces"]) <= 6000
        assert a["faces"].max() < len(v)
        assert v[:, 2].min() > -0.2 * 0.5 and v[:, 2].max() < 1.3 * 0.5
        assert np.abs(v[:, :2]).max() < 1.2 * 0.5
        assert a["uv"].min() >= 0 and a["uv"].max() <= 1 and 0 <= a["age"].min() and a["age"].max() <= 1
        assert (a["wood"].max() > 0) == (morphology == "shrub")
        assert plant.leaves >= 3
        shapes.append((len(v), float(v[:, 2].max())))
    assert len(set(shapes)) == len(shapes)


@pytest.mark.parametrize("morphology", list(MORPHOLOGIES))
def test_health_shows_in_shape(morphology):
    """Over 12 plants of one species: dry plants are shorter (stunting) than healthy ones, have
    fewer leaves (leaf loss) and hold their leaves lower (wilting); stressed ones lie between
    in height."""
    species = draw_species(np.random.default_rng(2), morphology)
    stats = {}
    for state in HEALTH_SHAPES:
        heights, leaves, mean_z = [], [], []
        for seed in range(12):
            plant, a = _grow(morphology, 100 + seed, state, species=species)
            leaf = a["wood"] == 0
            heights.append(a["vertices"][:, 2].max())
            leaves.append(plant.leaves)
            mean_z.append(a["vertices"][leaf, 2].mean())
        stats[state] = np.mean(heights), np.mean(leaves), np.mean(mean_z)
    assert stats["dry"][0] < stats["stressed"][0] < stats["healthy"][0]
    assert stats["dry"][1] < stats["healthy"][1]
    assert stats["dry"][2] < stats["healthy"][2]


def test_shape_draws_follow_the_state_ranges():
    rng = np.random.default_rng(0)
    for state, ranges in HEALTH_SHAPES.items():
        shape = draw_shape(rng, state)
        for key, (low, high) in ranges.items():
            assert low <= getattr(shape, key) <= high
    assert HealthShape().stunt == 1.0


def test_species_scatter_mixes_morphologies_and_rows_keep_one_crop():
    """A scattered scene mixes 2–4 species of different morphologies; a crop field is one crop
    species, its weeds another morphology (grass or upright), never a scaled crop plant."""
    seen = set()
    for seed in range(6):
        config = sc.scene_from_dict({"scene": {"preset": "vegetation", "layout_seed": seed}})
        plants, weeds = plant_species(config, 30)
        assert weeds == [] and 2 <= len({p["morphology"] for p in plants}) <= 4
        assert plants == plant_species(config, 30)[0]
        seen |= {p["morphology"] for p in plants}
        rows = sc.scene_from_dict({"scene": {"preset": "vegetation", "layout": "rows", "layout_seed": seed}})
        crop, weed = plant_species(rows, 20, 8)
        assert len({id(p) for p in crop}) == 1 and crop[0]["morphology"] in CROP_MORPHOLOGIES
        assert all(w["morphology"] in WEED_MORPHOLOGIES and w["morphology"] != crop[0]["morphology"] for w in weed)
    assert seen == set(SCATTER_MORPHOLOGIES)


@pytest.mark.parametrize("venation", ["pinnate", "parallel"])
def test_the_vein_texture_pales_the_midrib_veins_and_base(venation):
    """1 at the base and on the midrib, veins at 0.5–0.6, the lamina between them near 0."""
    w = vein_pattern(venation)
    rows, columns = w.shape
    assert w[0, columns // 2] == pytest.approx(1.0, abs=0.05)  # the base of the midrib
    assert w[rows // 2, columns // 2 - 1: columns // 2 + 1].max() > 0.5  # the midrib halfway
    lamina = w[rows // 3: 2 * rows // 3, int(0.2 * columns): int(0.4 * columns)]
    assert np.median(lamina) < 0.15 and lamina.max() > 0.4  # mostly lamina, crossed by veins


def test_a_cereal_holds_broad_blades_in_two_ranks():
    """Maize and sorghum (Ritchie, Hanway & Benson 1993): the blades leave one stalk alternately
    in two ranks, so their tips lie along one horizontal axis (within 35° of it, either way, for
    at least 80 % of the blades), and a blade is about a tenth as wide as long (its widest
    cross-section over its spine's length: 0.06–0.14)."""
    species = draw_species(np.random.default_rng(3), "cereal")
    for seed in range(4):
        plant, _ = _grow("cereal", seed, species=species)
        blades = [(v, uv) for v, uv in zip(plant.vertices, plant.uv) if np.ptp(uv[:, 1]) > 0 and len(v) >= 55]
        assert 7 <= len(blades) <= 15
        azimuths, ratios = [], []
        for vertices, uv in blades:
            rows = vertices.reshape(-1, 5, 3)  # (steps + 1, 2·sides + 1): across each row
            spine = rows[:, 2]
            length = np.linalg.norm(np.diff(spine, axis=0), axis=1).sum()
            width = np.linalg.norm(rows[:, 0] - rows[:, -1], axis=1).max()
            ratios.append(width / length)
            tip = spine[-1, :2] - spine[0, :2]
            azimuths.append(np.arctan2(tip[1], tip[0]))
        axis = 0.5 * np.angle(np.mean(np.exp(2j * np.array(azimuths))))  # the ranks' axis (mod 180°)
        off = np.abs(np.angle(np.exp(2j * (np.array(azimuths) - axis)))) / 2
        assert np.mean(off < np.radians(35)) >= 0.8
        assert 0.06 <= np.median(ratios) <= 0.14
