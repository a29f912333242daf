"""Spectrum CSVs (issue 12 #11, #13): what is refused and how, instead of a traceback or a
silently different spectrum."""

from __future__ import annotations

import numpy as np
import pytest

from spectral_cam import ConfigError, scene_from_dict
from spectral_cam import spectra
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


def test_the_written_out_illuminant_and_patch_names_are_colour_sciences():
    import colour

    from spectral_cam.spectra import (
        COLORCHECKER_PATCH_NAMES,
        COLORCHECKER_SET,
        COLOUR_ILLUMINANT_KEYS,
        COLOUR_LIGHT_SOURCE_KEYS,
        colorchecker_reflectances,
        illuminant_names,
    )

    assert tuple(colour.SDS_ILLUMINANTS) == COLOUR_ILLUMINANT_KEYS
    assert tuple(colour.SDS_LIGHT_SOURCES) == COLOUR_LIGHT_SOURCE_KEYS
    assert tuple(colour.SDS_COLOURCHECKERS[COLORCHECKER_SET]) == COLORCHECKER_PATCH_NAMES
    assert tuple(colorchecker_reflectances()) == COLORCHECKER_PATCH_NAMES
    assert illuminant_names() == sorted({*colour.SDS_ILLUMINANTS, *colour.SDS_LIGHT_SOURCES}, key=str.casefold)


def _outcome(function, spec):
    """None when ``function(spec)`` succeeds, else its ConfigError's message."""
    try:
        function(spec)
    except ConfigError as exc:
        return str(exc)
    return None


@pytest.fixture
def spectrum_files(tmp_path):
    files = {"good": "wavelength_nm,value\n400,0.2\n700,0.8\n", "above_1": "400,0.5\n700,1.5\n",
             "negative": "400,0.5\n700,-0.1\n", "garbled": "400,0.5x\n700,0.5\n"}
    for name, text in files.items():
        (tmp_path / f"{name}.csv").write_text(text)
    return {name: str(tmp_path / f"{name}.csv") for name in files}


@pytest.mark.parametrize("kind, specs", [
    ("illuminant", ["D65", "d65", "FL3.15", "F40/DX (Broadband FL)", "Kinoton 75P", "blackbody:3200",
                    "blackbody:499", "blackbody:x", "sunlight", "", "good", "above_1", "negative", "garbled",
                    "missing.csv"]),
    ("reflectance", [0.0, 0.18, 1, 1.5, -0.1, float("nan"), True, "dark skin", "BLACK 2 (1.5 D)", "skin",
                     "good", "above_1", "negative", "garbled", "missing.csv"]),
    ("transmission", [None, 1, 1.0, "1", "none", "", 0.5, 0, 1.2, "ir_cut:650", "ir_cut:900", "ir_cut:x",
                      "hot mirror", "good", "above_1", "negative", "garbled", "missing.csv"]),
    ("camera", ["nikon_d850", "Nikon D850", "nikon_5100_npl", "Sigma SDMerill (NPL)", "leica", ""]),
])
def test_validation_refuses_what_the_loaders_refuse_with_the_same_message(spectrum_files, kind, specs):
    """The validate_* functions (no colour-science) and the loaders must never disagree."""
    from spectral_cam import spectra

    loader = {"illuminant": spectra.illuminant, "reflectance": spectra.reflectance,
              "transmission": spectra.transmission, "camera": spectra.camera_sensitivities}[kind]
    validator = getattr(spectra, f"validate_{kind}")
    for spec in specs:
        spec = spectrum_files.get(spec, spec) if isinstance(spec, str) else spec
        expected = _outcome(loader, spec)
        assert _outcome(validator, spec) == expected, spec


@pytest.mark.parametrize("kelvin, name", [(6504.0, "D65"), (5003.0, "D50"), (7504.0, "D75")])
def test_the_daylight_series_at_a_cct_is_cies_standard_daylight(kelvin, name):
    """``daylight:<K>`` is the CIE daylight series at that correlated colour temperature: at the
    CCTs of D50, D65 and D75 it is colour-science's tabulated illuminant within 0.5 % (the tables
    are rounded), for sequences that follow daylight through a day by CCT."""
    import colour

    sd = spectra.illuminant(f"daylight:{kelvin:g}")
    table = colour.SDS_ILLUMINANTS[name]
    wavelengths = np.arange(380.0, 781.0, 5.0)
    ours = np.array([sd[w] for w in wavelengths]) / sd[560]
    theirs = np.array([table[w] for w in wavelengths]) / table[560]
    assert np.allclose(ours, theirs, atol=5e-3)
    with pytest.raises(ConfigError, match="daylight:<K>.*4000"):
        spectra.validate_illuminant("daylight:2000")
