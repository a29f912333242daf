"""Study (d): bokeh noise and the depth-layered remedy (:mod:`spectral_cam.apps.stress.bokeh`).

The remedy itself (``lens.model = "layered"``) is tested in ``tests/render/test_defocus.py``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from spectral_cam.apps.stress.bokeh import BOKEH_CASE, bokeh_study, disc_mask, plot_bokeh
from spectral_cam.errors import ConfigError


def test_disc_mask_is_the_blur_disc_interior():
    mask = disc_mask(40, 23.48)
    y, x = np.mgrid[0:40, 0:40] + 0.5 - 20.0
    assert mask[20, 20] and not mask[0, 0]
    assert np.all(np.hypot(x, y)[mask] < 0.5 * 23.48 - 1.5)
    assert mask.sum() == pytest.approx(math.pi * (0.5 * 23.48 - 1.5) ** 2, rel=0.05)


@pytest.mark.timeout(300)
def test_bokeh_study_thin_lens_noise_follows_the_aperture_fraction(tmp_path, tiny):
    """The study's scene: a pixel inside the 23.5-px disc sees the source through
    p = (r·z_f/(|z − z_f|·R))² of the aperture, so thin-lens noise is √((1 − p)/(p·spp))."""
    settings = tiny.replace(bokeh_thin_spp=(64, 256), bokeh_tracer_spp=(16,), bokeh_remedy_spp=(16,),
                            bokeh_reference_spp=1024)
    result = bokeh_study(settings)
    data = result["data"]
    f, n, zf = BOKEH_CASE["focal_length_mm"] * 1e-3, BOKEH_CASE["f_number"], BOKEH_CASE["focus_distance_m"]
    z, r = BOKEH_CASE["source_depth_m"], BOKEH_CASE["source_radius_m"]
    p = (r * zf / (abs(z - zf) * f / (2 * n))) ** 2
    assert data["aperture_fraction"] == pytest.approx(p, rel=1e-9)
    assert data["coc_px"] == pytest.approx((f / n) * f * abs(z - zf) / (z * (zf - f)) / 6e-6, rel=1e-9)
    for spp, noise in zip(data["thin"]["spp"], data["thin"]["noise"]):
        assert noise == pytest.approx(math.sqrt((1 - p) / (p * spp)), rel=0.25), spp
    assert data["tracer"]["noise"][0] < data["thin"]["noise"][0]  # the light tracer converges faster
    assert {row["study"] for row in result["rows"]} == {"bokeh"}
    # the layered model is named by the key a reader sets (issue 39 #20), not "remedy"
    cases = [row["case"] for row in result["rows"]]
    assert any(case.startswith("lens.model = layered") for case in cases)
    assert not [case for case in cases if "remedy" in case] and "layered, 16 spp" in result["images"]
    files = plot_bokeh(result, tmp_path)
    assert len(files) == 3 and all((tmp_path / name).read_bytes()[:4] == b"\x89PNG" for name in files)
    with pytest.raises(ConfigError, match="too few pixels"):
        bokeh_study(settings.replace(bokeh_px=4))
