"""The ColorChecker set-up shared by the ISP colour tests and the validation tests: one scene,
one ΔE2000 computed with colour-science directly (the independent reference)."""

from __future__ import annotations

import numpy as np

#: [sensor] keys that switch every noise term off.
NOISE_OFF = {"shot_noise": False, "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0}
WIDTH, HEIGHT, SPP = 144, 96, 256


def colorchecker_tables(**sensor) -> dict:
    """Scene tables of the noise-free-capable ColorChecker test scene (D65, pinhole, auto
    exposure at 0.8 of saturation on the white patch, 144 × 96 px, 256 spp)."""
    return {
        "scene": {"preset": "colorchecker"},
        "illuminant": {"spd": "D65"},
        "lens": {"model": "pinhole"},
        "sensor": {"width_px": WIDTH, "height_px": HEIGHT, **sensor},
        # exposed for the white patch, as a colour-measurement shot is (expose to the right)
        "exposure": {"time_s": "auto", "iso": 100, "auto_fraction": 0.8, "metering": "etr"},
        "render": {"spp": SPP, "seed": 1},
    }


def lab(linear_srgb):
    """CIELAB (D65) of linear sRGB, by colour-science."""
    import colour

    space = colour.models.RGB_COLOURSPACE_sRGB
    return colour.XYZ_to_Lab(colour.RGB_to_XYZ(np.asarray(linear_srgb, float), space), space.whitepoint)


def delta_e_white_matched(test_rgb, reference_rgb, white: int):
    """ΔE2000 per patch (colour-science, CIE 2000) after matching the test's luminance at
    patch ``white`` to the reference's."""
    import colour

    y = np.asarray(colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ)[1]
    test = np.asarray(test_rgb, float) * (reference_rgb[white] @ y) / (np.asarray(test_rgb, float)[white] @ y)
    return np.asarray(colour.delta_E(lab(test), lab(reference_rgb), method="CIE 2000"))
