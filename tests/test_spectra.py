"""Spectrum CSVs (issue 12 #11, #13): what is refused and how, instead of a traceback or a
silently different spectrum."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import ConfigError, scene_from_dict
from spectral_cam.spectra import load_spectrum_csv, reflectance

pytestmark = pytest.mark.timeout(30)


@pytest.mark.parametrize("text, message", [
    ("400,0.5x\n700,0.5\n", "line 1: unreadable row"),                    # was dropped as a header
    ("wavelength_nm,value\n400,0.5\n400,0.6\n700,0.5\n", "400 nm given twice"),  # kept the last
    ("550,0.5\n550,0.6\n550,0.7\n", "at different wavelengths"),         # was an IndexError
    ("400," + "1" * 140000 + "\n700,0.5\n", "not a readable CSV"),         # was a csv.Error traceback
    ("400,0.5\n700,-0.1\n", "finite and non-negative"),
])
def test_bad_spectrum_files_name_the_problem(tmp_path, text, message):
    path = tmp_path / "spd.csv"
    path.write_text(text)
    with pytest.raises(ConfigError, match=message):
        load_spectrum_csv(path)


def test_a_reflectance_csv_above_1_is_refused_like_the_number_2(tmp_path):
    path = tmp_path / "refl.csv"
    path.write_text("wavelength_nm,reflectance\n400,0.5\n700,1.2\n")
    with pytest.raises(ConfigError, match=r"values must lie in \[0, 1\] \(largest 1.2"):
        reflectance(str(path))
    with pytest.raises(ConfigError, match="must lie in"):
        reflectance(2.0)
    with pytest.raises(ConfigError, match="largest 1.2"):
        scene_from_dict({"scene": {"preset": "flat_field", "reflectance": str(path)}})


def test_a_header_and_comments_are_read_past(tmp_path):
    path = tmp_path / "ok.csv"
    path.write_text("# measured\nwavelength_nm,value\n700,0.9\n400,0.1\n")
    sd = load_spectrum_csv(path, maximum=1.0)
    np.testing.assert_array_equal(sd.wavelengths, [400.0, 700.0])
    np.testing.assert_array_equal(sd.values, [0.1, 0.9])


def test_the_written_out_colour_camera_keys_are_colour_sciences():
    import colour

    from spectral_cam.spectra import COLOUR_CAMERA_KEYS

    assert tuple(colour.MSDS_CAMERA_SENSITIVITIES) == COLOUR_CAMERA_KEYS
