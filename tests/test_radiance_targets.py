"""Synthetic targets and reflectance sets (spectral_cam.radiance_targets) against their definitions:
Lambertian radiance ρ·E/π band-integrated from colour-science's tables (McCluney 2014 §1.6),
the sizes of the published sets, and monochromatic flat fields (EMVA 1288 §6)."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import colour_ground_truth, spectra
from spectral_cam.radiance_targets import (
    REFLECTANCE_SETS,
    narrow_band_flat,
    reflectance_set,
    synthetic_chart,
)
from spectral_cam.errors import ConfigError


@pytest.mark.timeout(60)
def test_reflectance_sets_and_csv_sets(tmp_path):
    sizes = {name: len(reflectance_set(name)) for name in REFLECTANCE_SETS}
    assert sizes == {"colorchecker": 24, "rawtoaces": 190, "cie2017": 99, "cri": 14, "cqs": 15, "usgs_vegetation": 6,
                     "usgs_soils": 3, "usgs_wood": 2, "usgs_stone": 3}
    path = tmp_path / "mine.csv"
    path.write_text("wavelength_nm,grey,ramp\n380,0.5,0.1\n780,0.5,0.9\n")
    mine = reflectance_set("mine.csv", base_dir=tmp_path)
    assert mine.names == ("grey", "ramp") and len(mine) == 2
    with pytest.raises(ConfigError, match="per cent"):
        (tmp_path / "pct.csv").write_text("wavelength_nm,grey\n380,50\n780,50\n")
        reflectance_set(str(tmp_path / "pct.csv"))
    with pytest.raises(ConfigError, match="valid: colorchecker, rawtoaces, cie2017, cri, cqs"):
        reflectance_set("munsell")


@pytest.mark.timeout(60)
def test_synthetic_chart_is_lambert_radiance_of_the_reflectances():
    refset = reflectance_set("cqs")
    chart = synthetic_chart(refset, "A", illuminance_lux=500.0, bands="400:700:10", patch_px=8, gap_px=2)
    assert chart.n_set == 15 and len(chart.patches) == 16  # + the ColorChecker white reference
    assert chart.patches[chart.white_index].name.endswith(colour_ground_truth.WHITE_PATCH)
    wavelengths, irradiance = spectra.absolute_irradiance("A", 500.0)
    bands = spectra.parse_bands("400:700:10")
    for index in (0, 7, chart.white_index):
        rho = spectra.sample(chart.sds[index], wavelengths)
        expected = spectra.band_integrals(rho * irradiance / np.pi, wavelengths, bands)
        rows, cols = chart.patches[index].interior(0.0)
        block = chart.radiance.data[rows, cols]
        np.testing.assert_allclose(block, np.broadcast_to(expected, block.shape), rtol=1e-6)
    # ground truth and chart order agree: the white reference reads Y ≈ 0.9 of the diffuser
    reference = colour_ground_truth.patch_linear_srgb("A", chart.sds)
    assert reference[chart.white_index] @ [0.2126, 0.7152, 0.0722] == pytest.approx(0.9, abs=0.03)


@pytest.mark.timeout(30)
def test_a_narrow_band_flat_holds_its_radiance_in_one_band():
    image = narrow_band_flat((4, 6), 0.25, 552.0)
    assert image.data.shape == (4, 6, 31)
    lit = np.flatnonzero(image.data[0, 0])
    assert lit.tolist() == [15] and image.wavelengths_nm[15] == 550.0  # nearest band centre
    assert np.all(image.data[..., 15] == np.float32(0.25))


def test_the_reflectance_set_names_scene_validation_knows_are_the_loadable_ones():
    from spectral_cam.radiance_targets import REFLECTANCE_SETS
    from spectral_cam.spectra import REFLECTANCE_SET_NAMES

    assert tuple(REFLECTANCE_SETS) == REFLECTANCE_SET_NAMES
