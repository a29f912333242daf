"""Issue 39 #15: ``render.estimator = "auto"`` takes the adaptive median of means where the passes
are enough, and with fewer only where a probe render measures fireflies. The reference is the Monte-Carlo mean of many more samples (the unbiased
estimator converges to the pixel's integral; Pharr, Jakob & Humphreys 2023, §2.1)."""

from __future__ import annotations

import functools

import numpy as np
import pytest

import spectral_cam as sc
from spectral_cam.render.decisions import AUTO_FIREFLY_SHARE, AUTO_MIN_PASS_SPP, AUTO_MIN_PASSES, decide_estimator

Y = 4  # the camera film's luminance channel (camera R, G, B, then X, Y, Z)


@functools.cache
def _focused_tabletop():
    """The tabletop's scene file at 48 × 32 px, as its plan resolves it (the focus on object_0
    found once: the renders below differ only in spp, seed and estimator, and from the resolved
    focus distance a plan's focus search stops at its first step; the same bits, measured)."""
    from spectral_cam.render.plan import make_plan

    config = sc.load_scene("scenes/tabletop.toml", overrides={
        "sensor.width_px": 48, "sensor.height_px": 32, "render.spp": 16, "render.estimator": "mean",
        "render.bands": "camera", "render.spectral_output": False, "render.diffraction": "off"})
    return make_plan(config, with_depth=False).config


def _tabletop(spp: int, seed: int, estimator: str):
    return _focused_tabletop().replace(**{"render.spp": spp, "render.seed": seed, "render.estimator": estimator})


def _luminance(config) -> tuple[np.ndarray, dict]:
    image = sc.render(config, with_depth=False)
    return np.asarray(image.data, np.float64)[..., Y], image.meta["model_decisions"]["estimator"]


def _no_probe(config, lens):
    raise AssertionError("enough passes: auto must not need a probe")


def test_auto_takes_the_median_from_enough_passes_and_below_that_only_where_a_probe_finds_fireflies():
    tabletop = sc.scene_from_dict({"scene": {"preset": "tabletop"}})
    assert decide_estimator(tabletop, 64, probe=_no_probe)[0] == 8  # the default: 8 passes of 8 spp
    assert decide_estimator(tabletop, 256, probe=_no_probe)[0] in (8, 16)  # 32 spp: no pass multijitter keeps
    # 4 passes of 4 spp, 8 of 4: measured first
    groups, record = decide_estimator(tabletop, 16, probe=lambda config, lens: 0.0)
    assert groups == 1 and record["choice"] == "mean" and record["probe_firefly_share"] == 0.0
    assert "1.7× the mean's noise" in record["reason"]
    assert decide_estimator(tabletop, 32, probe=lambda config, lens: 5e-5)[0] == 1
    groups, record = decide_estimator(tabletop, 16, probe=lambda config, lens: 1e-3)
    assert groups == 4 and record["choice"] == "amon" and record["probe_firefly_share"] == 1e-3
    assert decide_estimator(tabletop, 32, probe=lambda config, lens: AUTO_FIREFLY_SHARE)[0] == 8
    # asked for by name, the median takes 4 passes of 4 spp without a probe
    forced = sc.scene_from_dict({"scene": {"preset": "tabletop"}, "render": {"estimator": "amon"}})
    assert decide_estimator(forced, 16, probe=_no_probe)[0] == 4
    assert (AUTO_MIN_PASSES, AUTO_MIN_PASS_SPP) == (8, 8)


@pytest.mark.timeout(300)
def test_the_probe_tells_caustics_from_a_tabletop_at_16_spp():
    """The glass sphere under a small lamp makes caustic fireflies (its 16-spp mean: 0.05 % of the
    pixels at 160 × 108); the tabletop's scene file at 16 spp holds none to speak of."""
    glass = sc.load_scene("scenes/glass_sphere.toml", overrides={"render.spp": 16})
    groups, record = decide_estimator(glass, 16)
    assert groups == 4 and record["probe_firefly_share"] >= AUTO_FIREFLY_SHARE, record


@pytest.mark.timeout(600)
def test_at_16_spp_auto_is_no_noisier_than_the_mean_where_the_median_of_4_passes_is():
    """The tabletop (glass, metal, saturated rough plastic) at 48 × 32 and 16 spp, against 256 spp:
    the median of 4 pass means of 4 spp is measurably noisier than the mean (1.7×, also at
    160 × 108 against 2048 spp), so auto must take the mean there. (A render costs seconds here
    for the tabletop's scatter, whatever its spp.)"""
    reference, _ = _luminance(_tabletop(256, 9001, "mean"))
    scale = reference.mean()

    def error(estimator: str, seeds=(1, 2)) -> tuple[float, dict]:
        runs = [_luminance(_tabletop(16, seed, estimator)) for seed in seeds]
        return float(np.mean([np.sqrt(np.mean((lum - reference) ** 2)) / scale for lum, _ in runs])), runs[0][1]

    mean, _ = error("mean")
    amon, amon_record = error("amon")
    auto, auto_record = error("auto", seeds=(3,))
    assert amon_record["passes"] == 4 and amon > 1.3 * mean, (amon, mean)
    assert auto_record["choice"] == "mean" and auto < 1.15 * mean, (auto, mean)
    assert auto_record["probe_firefly_share"] < AUTO_FIREFLY_SHARE  # measured, not assumed
