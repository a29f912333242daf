"""Issue 39 #23 and #31: impossible white-balance gains, zero or singular colour matrices and
non-finite values on their way to the tone curve.

Each case used to run on silently or die deep inside (``IndexError: index -2147483648`` in the
tone stage; a singular ColorMatrix developed as camera RGB without a word; ``write_dcp`` copying an
all-zero ForwardMatrix; "no ForwardMatrix" when the ColorMatrix was the corrupt tag). The expected
behaviour is the DNG specification's (ch. 6: ColorMatrix is inverted, ForwardMatrix maps camera
white onto D50, so neither may be singular) and the tone curves' own ends (0 and 1)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import tifffile

from spectral_cam.errors import ConfigError, RawFormatError, SceneWarning
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.raw import RawImage, read_raw, write_dcp, write_dng

pytestmark = pytest.mark.timeout(240)


def _profile_raw(**changes) -> RawImage:
    """A 32 × 32 grey RAW with the D850's full dual-illuminant profile (as expose writes it)."""
    from spectral_cam.sensor.dng_colour import _colour_matrix, _forward_matrix, _hue_sat_map

    tags = {f"{name}{suffix}": fit(*args) for suffix, args in (("", ("nikon_d850", ())), ("_2", ("nikon_d850", (), "A")))
            for name, fit in (("color_matrix", _colour_matrix), ("forward_matrix", _forward_matrix),
                              ("hue_sat_map", _hue_sat_map))}
    tags.update(changes)
    return RawImage(np.full((32, 32), 900, np.uint16), "RGGB", 64.0, 4095, as_shot_neutral=np.ones(3), **tags)


def _dng_with_zeroed(tmp_path, *names) -> "Path":  # noqa: F821
    """Our DNG with the named SRATIONAL 3 × 3 tags overwritten by zeros (0/1), as a corrupt file has them."""
    path = write_dng(_profile_raw(), tmp_path / f"zeroed_{'_'.join(names)}.dng")
    with tifffile.TiffFile(path, mode="r+b") as tif:
        for name in names:
            tif.pages[0].tags[name].overwrite(tuple([0, 1] * 9))
    return path


# ----------------------------------------------------------------------------- #23 white-balance gains
def test_impossible_manual_gains_are_refused_at_load_with_the_valid_range():
    """[1e300, 1, 1] overflowed float32 to inf and NaN; it is refused when the [isp] table loads, saying
    what is valid. The bound (2¹⁴) admits the most extreme light any bundled camera meets: low-pressure
    sodium's white, whose channel ratio colour-science's spectral integration puts at ≤ 139."""
    import colour

    from spectral_cam.scene import scene_from_dict
    from spectral_cam.spectra import camera_names, camera_sensitivities, illuminant

    with pytest.raises(ConfigError, match=r"isp.wb_gains.*at most 16384"):
        ISPConfig(white_balance="manual", wb_gains=(1e300, 1.0, 1.0))
    with pytest.raises(ConfigError, match=r"wb_gains.*at most 16384"):
        scene_from_dict({"isp": {"white_balance": "manual", "wb_gains": [1e300, 1, 1]}})
    shape = colour.SpectralShape(380, 780, 1)
    sodium = illuminant("LPS")
    sodium = sodium.to_colour() if hasattr(sodium, "to_colour") else sodium
    power = sodium.copy().align(shape, extrapolator_kwargs={"method": "Constant", "left": 0, "right": 0}).values
    for camera in camera_names():
        curves = camera_sensitivities(camera).to_colour().copy().align(
            shape, extrapolator_kwargs={"method": "Constant", "left": 0, "right": 0}).values
        white = power @ curves
        gains = white.max() / white  # what balances the sodium white
        assert ISPConfig(white_balance="manual", wb_gains=tuple(gains)).wb_gains == pytest.approx(tuple(gains))


def test_impossible_gains_given_to_develop_are_refused_before_any_output():
    from spectral_cam.isp.white_balance import white_balance_gains

    with pytest.raises(ConfigError, match="at most 16384"):
        white_balance_gains(np.ones((4, 4), np.float32), "RGGB", method="manual", gains=(1e300, 1.0, 1.0))
    with pytest.raises(ConfigError, match="at most 16384"):  # a hostile AsShotNeutral asks the same gains
        white_balance_gains(np.ones((4, 4), np.float32), "RGGB", method="as_shot",
                            as_shot_neutral=(1e-300, 1.0, 1.0))


# ----------------------------------------------------------------------------- #23 the tone stage
@pytest.mark.parametrize("method", ["adobe", "srgb", "filmic", "linear"])
def test_the_tone_stage_puts_non_finite_values_at_the_curves_ends_with_a_warning(method):
    """NaN, +inf and −inf never index the curve's table: a neutral +inf pixel shows white (1), a NaN or
    −inf pixel black (0) — every curve maps 0 to 0 and clips white to 1 (IEC 61966-2-1's encoding of
    0 and 1) — with a SceneWarning counting them; finite pixels are untouched."""
    from spectral_cam.isp.tone import tone_map

    linear = np.full((2, 2, 3), 0.18, np.float32)
    linear[0, 0] = np.nan
    linear[0, 1] = np.inf
    linear[1, 0] = -np.inf
    with pytest.warns(SceneWarning, match="3 pixel"):
        shown = tone_map(linear, method=method)
    reference = tone_map(np.full((1, 1, 3), 0.18, np.float32), method=method)
    assert np.all(np.isfinite(shown)) and shown.min() >= 0 and shown.max() <= 1
    np.testing.assert_array_equal(shown[0, 0], 0.0)
    np.testing.assert_allclose(shown[0, 1], 1.0, atol=2e-4)  # float32 ProPhoto round trip (adobe)
    np.testing.assert_array_equal(shown[1, 0], 0.0)
    np.testing.assert_array_equal(shown[1, 1], reference[0, 0])


# ----------------------------------------------------------------------------- #23 / #31 forward matrices
def test_a_dng_whose_forward_matrices_are_zero_is_refused_by_dng_profile_naming_the_tags(tmp_path):
    """ForwardMatrix1/2 all zero: scaling them onto D50 divided 0 by 0 and the tone stage indexed with
    NaN. The reader drops them and says which; dng_profile refuses with that, and the 'dng' path (which
    needs no forward matrix) develops unwarned."""
    raw = read_raw(_dng_with_zeroed(tmp_path, "ForwardMatrix1", "ForwardMatrix2"))
    assert raw.forward_matrix is None and raw.forward_matrix_2 is None
    with pytest.raises(ConfigError, match=r"ForwardMatrix1 \(CalibrationIlluminant1 = 17\) is singular"):
        develop(raw, ISPConfig(colour_matrix="dng_profile"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", SceneWarning)
        out = develop(raw, ISPConfig(colour_matrix="dng"))
    assert np.all(np.isfinite(out.image))


def test_a_zero_forward_matrix_given_directly_is_refused_with_what_is_valid():
    with pytest.raises(ConfigError, match=r"forward_matrix .*singular \(rank 0\).*rank-3"):
        develop(_profile_raw(forward_matrix=np.zeros((3, 3)), forward_matrix_2=np.zeros((3, 3))),
                ISPConfig(colour_matrix="dng_profile"))


def test_dng_profile_names_the_colour_matrix_when_it_is_the_corrupt_tag(tmp_path):
    """Issue 39 #31: the D65 ColorMatrix (slot 2) zeroed: dng_profile used to say the RAW had "no
    ForwardMatrix" (both ForwardMatrix tags are intact); it names ColorMatrix2."""
    raw = read_raw(_dng_with_zeroed(tmp_path, "ColorMatrix2"))
    with pytest.raises(ConfigError, match=r"ColorMatrix2 \(CalibrationIlluminant2 = 21\) is singular"):
        develop(raw, ISPConfig(colour_matrix="dng_profile"))
    with pytest.raises(ConfigError, match=r"'dng' needs the RAW's ColorMatrix.*ColorMatrix2 .*singular"):
        develop(raw, ISPConfig(colour_matrix="dng"))


def test_a_singular_colour_matrix_does_not_develop_silently_without_colour_correction(tmp_path):
    """Issue 39 #31: with its D65 ColorMatrix singular, 'auto' fell back to camera RGB without a word; it
    warns naming the tag. With the Standard A one singular, the develop goes on with D65's and says so."""
    raw = read_raw(_dng_with_zeroed(tmp_path, "ColorMatrix2"))
    with pytest.warns(SceneWarning, match=r"without colour correction.*ColorMatrix2"):
        out = develop(raw, ISPConfig())
    assert out.meta["colour_transform"] == "none"
    raw = read_raw(_dng_with_zeroed(tmp_path, "ColorMatrix1"))
    assert raw.color_matrix is not None and raw.color_matrix_2 is None
    with pytest.warns(SceneWarning, match=r"usable colour tags only.*ColorMatrix1"):
        develop(raw, ISPConfig(colour_matrix="dng"))


def test_writers_refuse_singular_colour_and_forward_matrices(tmp_path):
    """Issue 39 #31: write_dcp copied an all-zero ForwardMatrix into the profile (and write_dng into the
    DNG); both refuse a singular matrix, naming the tag, and leave no file behind."""
    for changes, tag in (({"forward_matrix": np.zeros((3, 3))}, "ForwardMatrix2"),
                         ({"color_matrix_2": np.ones((3, 3))}, "ColorMatrix1")):
        raw = _profile_raw(**changes)
        for write, name in ((write_dcp, "profile.dcp"), (write_dng, "raw.dng")):
            with pytest.raises(RawFormatError, match=rf"{tag} is singular \(rank [01]\)"):
                write(raw, tmp_path / name)
            assert not (tmp_path / name).exists()
    assert list(tmp_path.iterdir()) == []
