"""Issue 28 #4: where a colour error lies — the ΔL/ΔC/ΔH split checked against colour-science's
CIE 1976 ΔE, a tone curve detected on the neutral patches and named (darktable's defaults failed
at 8.14 with no hint why), and patches outside sRGB that a pipeline clipped flagged."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest

from spectral_cam.apps.validate import lab_difference_split, plan_from_dict, run_plan, tone_slope

pytestmark = pytest.mark.timeout(180)


def test_the_lightness_chroma_hue_split_adds_up_to_colour_sciences_delta_e_1976():
    """ΔL*² + ΔC*ab² + ΔH*ab² = ΔE*ab² (CIE 15:2004 §8.2.1) with colour-science's CIE 1976 ΔE; a
    pure exposure error is all ΔL, a desaturation all ΔC."""
    import colour

    from spectral_cam.metrics.image_quality import linear_srgb_to_lab

    rng = np.random.default_rng(3)
    reference = rng.uniform(0.05, 0.9, (50, 3))
    test = reference * rng.uniform(0.9, 1.1, (50, 3))
    split = lab_difference_split(test, reference)
    delta_76 = colour.delta_E(linear_srgb_to_lab(test), linear_srgb_to_lab(reference), method="CIE 1976")
    np.testing.assert_allclose(np.sum(split ** 2, axis=1), delta_76 ** 2, rtol=1e-9)
    grey = np.full((4, 3), 0.2) * np.array([[1.0], [2.0], [3.0], [4.0]])
    darker = lab_difference_split(grey * 0.8, grey)
    assert np.all(darker[:, 0] < -1) and np.allclose(darker[:, 1:], 0, atol=1e-3)  # sRGB grey: C* < 1e-3
    colourful = np.array([[0.6, 0.2, 0.1], [0.1, 0.5, 0.2]])
    washed = colourful + 0.5 * (colourful.mean(axis=1, keepdims=True) - colourful)
    assert np.all(lab_difference_split(washed, colourful)[:, 1] < -5)


def test_a_power_law_on_the_neutrals_is_measured():
    """Neutral patches whose luminance is the truth's to the power 0.45 (an sRGB-like encoding read as
    linear) give that slope; a linear develop gives 1; fewer than three neutrals give none."""
    y = np.geomspace(0.03, 0.9, 6)[:, None] * np.ones(3)
    assert tone_slope(y ** 0.45, y) == pytest.approx(0.45, abs=1e-9)
    assert tone_slope(2.0 * y, y) == pytest.approx(1.0, abs=1e-9)
    assert np.isnan(tone_slope(y[:2], y[:2]))


ISP = textwrap.dedent('''
    import numpy as np

    from spectral_cam.isp import ISPConfig, develop
    from spectral_cam.raw import read_raw


    def _linear(path):
        return develop(read_raw(path), ISPConfig(tone="linear", demosaic="bilinear")).linear


    def linear(path):
        return _linear(path)


    def encoded(path):
        """sRGB-encoded values, which the plan declares linear: a tone curve in effect."""
        linear = np.clip(_linear(path), 0, 1)
        return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)


    def clipped(path):
        return np.clip(_linear(path), 0, 1)
    ''')


def test_a_tone_curve_and_gamut_clipping_are_named_not_failed_blindly(tmp_path):
    """On the CIE 2017 samples under D65: the linear develop has a tone slope of 1 and no warning;
    the same image sRGB-encoded but declared linear has ≈ 0.45 (the ColorChecker neutrals the set
    carries as white reference are the only neutrals here, so the ColorChecker set is used) and the
    cell says a tone curve is in effect; clipping to [0, 1] flags the samples outside sRGB."""
    (tmp_path / "diag_isp.py").write_text(ISP)

    def plan(sets):
        return plan_from_dict({"validate": {"illuminants": ["D65"], "cameras": ["nikon_d850"], "reflectance_sets": sets,
                                            "patch_px": 8, "gap_px": 2, "swatches": "none"},
                               "sensor": {"read_noise_e": 0.0, "prnu": 0.0, "dsnu_e": 0.0},
                               "pipeline": [{"name": n, "type": "callable", "function": f"diag_isp:{n}",
                                             "python_path": ["."]} for n in ("linear", "encoded", "clipped")]},
                              base_dir=tmp_path)

    chart = {c.pipeline: c for c in run_plan(plan(["colorchecker"])).cells}
    assert chart["linear"].stats["tone_slope"] == pytest.approx(1.0, abs=0.02)
    assert not any("tone curve" in w for w in chart["linear"].warnings)
    assert chart["encoded"].stats["tone_slope"] == pytest.approx(0.45, abs=0.05)
    assert any(w.startswith("a tone curve") for w in chart["encoded"].warnings)
    assert chart["encoded"].stats["delta_l_mean"] > chart["encoded"].stats["delta_h_mean"]  # the error is lightness
    samples = {c.pipeline: c for c in run_plan(plan(["cie2017"])).cells}
    assert samples["linear"].stats["patches_clipped"] == 0
    outside = np.any((samples["clipped"].reference < 0) | (samples["clipped"].reference > 1), axis=1)
    assert 0 < samples["clipped"].stats["patches_clipped"] <= outside[:99].sum()
    assert any("outside the sRGB gamut" in w for w in samples["clipped"].warnings)


def test_clipping_is_judged_at_the_pipelines_own_edges_not_after_exposure_matching():
    """A channel is clipped where the pipeline's own output sits at its 0 or 1: with the white
    developed at 0.68 (exposure scale 1.46) a truth of 1.014 lies inside the pipeline's range, and
    its 0.998 after matching is a measurement (CIE 2017's TCS25 under D65 was flagged so); the same
    channel at the pipeline's own 1.0 is a clip, and 0 where the truth is negative is one."""
    from spectral_cam.apps.validate import gamut_clipped

    reference = np.array([[1.014, 0.645, 0.147], [1.6, 0.5, 0.2], [-0.05, 0.3, 0.4]])
    scale = 1.46
    test = np.array([[0.998, 0.638, 0.153], [1.0 * scale, 0.5, 0.2], [0.0, 0.3, 0.4]])
    assert gamut_clipped(test, reference, scale=scale).tolist() == [False, True, True]
