"""A raw's colour metadata: the XYZ(D65) → camera matrix recovered from what LibRaw derived, and the
DNG's own colour tags read from the file: ColorMatrix/ForwardMatrix per calibration slot (daylight,
Standard A), the ProfileHueSatMaps, a DNG 1.6 third calibration, and what is wrong with each tag a
reader then drops (malformed, singular: :func:`colour_tag_problems`).

References
----------
.. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (ColorMatrix, ForwardMatrix, ProfileHueSatMap,
   CalibrationIlluminant3, IlluminantData3).
.. [2] LibRaw 0.21 (libraw_internal ``cam_xyz_coeff``: rgb_cam = (diag(1/pre_mul)·cam_xyz·xyz_rgb)⁻¹
   with rows of cam_xyz·xyz_rgb normalised to sum 1).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError
from .dng import ILLUMINANT_A
from .hue_sat_map import HueSatMap

__all__ = ["colour_tag_problems"]

#: sRGB (D65) → XYZ as LibRaw hard-codes it (``xyz_rgb``), needed to undo its derivation.
_LIBRAW_XYZ_RGB = np.array([[0.412453, 0.357580, 0.180423],
                            [0.212671, 0.715160, 0.072169],
                            [0.019334, 0.119193, 0.950227]])


def _xyz_to_camera_from_libraw(rgb_cam: np.ndarray, daylight: np.ndarray) -> np.ndarray | None:
    """Undo LibRaw's cam_xyz → rgb_cam derivation; normalise D65 white → max 1."""
    rgb_cam = np.asarray(rgb_cam, dtype=float)[:3, :3]
    pre_mul = np.asarray(daylight, dtype=float)[:3]
    if not (np.all(np.isfinite(rgb_cam)) and np.all(pre_mul > 0)) or abs(np.linalg.det(rgb_cam)) < 1e-12:
        return None
    cam_xyz = np.diag(1.0 / pre_mul) @ np.linalg.inv(rgb_cam) @ np.linalg.inv(_LIBRAW_XYZ_RGB)
    neutral = cam_xyz @ _LIBRAW_XYZ_RGB.sum(axis=1)
    if not neutral.max() > 0:
        return None
    return cam_xyz / neutral.max()


def _xyz_to_camera_from_table(cam_xyz: np.ndarray) -> np.ndarray | None:
    """LibRaw's own XYZ(D65) → camera matrix for the camera (``rgb_xyz_matrix``: Adobe's
    ColorMatrix for that model, from LibRaw's table), D65 white → max 1; None if absent.
    For a proprietary raw LibRaw derives rgb_cam only while processing, so this is the matrix."""
    cam_xyz = np.asarray(cam_xyz, dtype=float)[:3, :3]
    if not np.all(np.isfinite(cam_xyz)) or abs(np.linalg.det(cam_xyz)) < 1e-12:
        return None
    neutral = cam_xyz @ _LIBRAW_XYZ_RGB.sum(axis=1)
    return cam_xyz / neutral.max() if neutral.max() > 0 else None


#: EXIF LightSource codes treated as Standard Illuminant A (≈ 2856 K) for interpolation.
_TUNGSTEN_CODES = (ILLUMINANT_A, 3)


def _rational_matrix(value, shape: tuple[int, int] | None = None) -> np.ndarray | None:
    """A matrix from a TIFF (S)RATIONAL tag as tifffile returns it (values or num/den pairs): 3×3, or
    ``shape`` (a four-plane RGBW DNG's 4×3 ColorMatrix, 3×4 ForwardMatrix)."""
    shape = (3, 3) if shape is None else shape
    count = shape[0] * shape[1]
    try:
        flat = np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):  # a corrupt tag type
        return None
    if flat.size == 2 * count:
        den = flat[1::2]
        if np.any(den == 0):
            return None
        flat = flat[0::2] / den
    return flat.reshape(shape) if flat.size == count and np.all(np.isfinite(flat)) else None


def _tungsten_slot(extras: dict) -> int | None:
    """The calibration slot (1 or 2) calibrated under Standard Illuminant A, if any."""
    for number in (1, 2):
        try:
            codes = np.asarray(extras.get(f"CalibrationIlluminant{number}", []), dtype=float).reshape(-1)
        except (TypeError, ValueError):  # a corrupt tag type (e.g. ASCII) is no tag
            continue
        if codes.size and codes[0] in _TUNGSTEN_CODES:  # a tag of count 0 (a corrupt file) is no tag
            return number
    return None


def _tungsten_matrix(extras: dict, planes: int = 3) -> np.ndarray | None:
    """The DNG colour matrix calibrated under Standard Illuminant A, from either slot (None when singular)."""
    slot = _tungsten_slot(extras)
    if slot and f"ColorMatrix{slot}" in colour_tag_problems(extras, planes):
        return None
    value = extras.get(f"ColorMatrix{slot}") if slot else None
    return None if value is None else _rational_matrix(value, (planes, 3))


def _daylight_matrix(extras: dict, planes: int) -> np.ndarray | None:
    """The colour matrix of the slot not calibrated under Standard A (a four-plane DNG's, which LibRaw's
    three-colour conversion cannot give)."""
    tungsten = _tungsten_slot(extras)
    slot = next((n for n in (1, 2) if n != tungsten and f"ColorMatrix{n}" in extras), None)
    return None if slot is None else _rational_matrix(extras[f"ColorMatrix{slot}"], (planes, 3))


def colour_tag_problems(extras: dict, planes: int = 3) -> dict[str, str]:
    """What is wrong with each ColorMatrixN / ForwardMatrixN tag present, by tag name: malformed (not
    ``planes``·3 finite numbers) or singular (rank under 3: an all-zero matrix maps every colour to
    black). A reader that drops such a tag says which one it dropped (issue 39 #31).

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, ch. 6 (ColorMatrix is inverted; ForwardMatrix
       maps camera white onto D50).
    """
    problems = {}
    for number in (1, 2):
        code = np.ravel(np.asarray(extras.get(f"CalibrationIlluminant{number}", []), dtype=object))
        light = f"CalibrationIlluminant{number} = {code[0]}" if code.size else f"no CalibrationIlluminant{number}"
        for kind, shape in (("ColorMatrix", (planes, 3)), ("ForwardMatrix", (3, planes))):
            name = f"{kind}{number}"
            if name not in extras:
                continue
            matrix = _rational_matrix(extras[name], shape)
            if matrix is None:
                problems[name] = f"{name} ({light}) is malformed: not {shape[0] * shape[1]} finite numbers"
            elif np.linalg.matrix_rank(matrix) < 3:
                problems[name] = (f"{name} ({light}) is singular (rank {np.linalg.matrix_rank(matrix)}): it maps no "
                                  "camera colour to XYZ")
    return problems


def _profile(extras: dict, planes: int = 3) -> dict:
    """ForwardMatrix and ProfileHueSatMap per calibration: ``forward_matrix``/``hue_sat_map`` of the
    daylight slot (the one that is not Standard A), ``..._2`` of the Standard A slot; None where a
    tag is absent or malformed (a corrupt profile is no profile, as Adobe's reader treats it)."""
    tungsten = _tungsten_slot(extras)
    daylight = next((n for n in (1, 2) if n != tungsten and f"ColorMatrix{n}" in extras), None)
    out = dict.fromkeys(("forward_matrix", "forward_matrix_2", "hue_sat_map", "hue_sat_map_2"))
    for slot, suffix in ((daylight, ""), (tungsten, "_2")):
        if slot is None:
            continue
        value = extras.get(f"ForwardMatrix{slot}")
        if f"ForwardMatrix{slot}" not in colour_tag_problems(extras, planes):  # a singular one is no matrix
            out[f"forward_matrix{suffix}"] = None if value is None else _rational_matrix(value, (3, planes))
        dims, data = extras.get("ProfileHueSatMapDims"), extras.get(f"ProfileHueSatMapData{slot}")
        if dims is not None and data is not None:
            try:
                out[f"hue_sat_map{suffix}"] = HueSatMap.from_dng(np.ravel(dims), data)
            except (ConfigError, TypeError, ValueError):
                pass  # a malformed map (wrong count, non-finite, negative scale) is no map, as for Adobe's reader
    if out["hue_sat_map"] is None or (tungsten and out["hue_sat_map_2"] is None):
        out["hue_sat_map"] = out["hue_sat_map_2"] = None  # half a dual-illuminant profile is none
    if tungsten and daylight and (out["forward_matrix"] is None) != (out["forward_matrix_2"] is None):
        out["forward_matrix"] = out["forward_matrix_2"] = None  # both or neither (DNG ch. 6, ForwardMatrix2)
    return out


#: CIE 1931 xy of the EXIF LightSource codes a third calibration may name (CIE 15:2004 Table T.3; the
#: DNG SDK's dng_illuminant_data uses the same): D50, D55, D65, D75, Standard A.
_LIGHT_XY = {23: (0.34567, 0.35850), 20: (0.33242, 0.34743), 21: (0.31272, 0.32903), 22: (0.29902, 0.31485),
             17: (0.44757, 0.40745)}


def _illuminant_data_xy(value) -> tuple[float, float] | None:
    """The white xy an IlluminantData tag holds: type 0 (x, y RATIONALs) or type 1 (a spectrum:
    count, first wavelength, spacing, samples; its CIE 1931 xy by colour-science); None when malformed.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, IlluminantData1/2/3.
    """
    import struct

    data = bytes(value) if isinstance(value, (bytes, bytearray)) else bytes(np.asarray(value, np.uint8))
    try:
        kind = struct.unpack_from("<H", data)[0]
        if kind == 0:
            xn, xd, yn, yd = struct.unpack_from("<4I", data, 2)
            xy = (xn / xd, yn / yd)
        elif kind == 1:
            import colour

            count = struct.unpack_from("<I", data, 2)[0]
            if not 2 <= count <= 1000:
                return None
            fields = np.array(struct.unpack_from(f"<{4 + 2 * count}I", data, 6), dtype=float)
            if np.any(fields[1::2] == 0) or fields[2] == 0:  # a zero denominator or spacing: corrupt
                return None
            start, step = fields[0] / fields[1], fields[2] / fields[3]
            power = fields[4::2] / fields[5::2]
            if not (200 <= start <= 1000 and step <= 100 and power.max() > 0):
                return None
            sd = colour.SpectralDistribution(power, start + step * np.arange(count))
            xy = tuple(colour.XYZ_to_xy(colour.sd_to_XYZ(sd.align(colour.SpectralShape(360, 830, 1)))))
        else:
            return None
    except (struct.error, ZeroDivisionError, ValueError, TypeError):
        return None
    return xy if all(np.isfinite(xy)) and all(0 < v < 1 for v in xy) and sum(xy) < 1 else None


def _third_calibration(extras: dict, planes: int, profile: dict):
    """The DNG 1.6 third calibration (:class:`~spectral_cam.raw.image.Calibration`) when the file has
    one that can be used: CalibrationIlluminant3 (a named light or 255 with IlluminantData3), a
    ColorMatrix3 of rank 3, and ForwardMatrix3 / ProfileHueSatMapData3 exactly where the other two
    calibrations have theirs; else None."""
    from .image import Calibration

    if planes != 3 or "ColorMatrix3" not in extras or "CalibrationIlluminant3" not in extras:
        return None
    code = int(np.ravel(extras["CalibrationIlluminant3"])[0]) if np.size(extras["CalibrationIlluminant3"]) else None
    xy = _illuminant_data_xy(extras.get("IlluminantData3", b"")) if code == 255 else _LIGHT_XY.get(code)
    matrix = _rational_matrix(extras["ColorMatrix3"], (3, 3))
    if xy is None or matrix is None or np.linalg.matrix_rank(matrix) < 3:
        return None
    forward = _rational_matrix(extras["ForwardMatrix3"], (3, 3)) if "ForwardMatrix3" in extras else None
    if forward is not None and np.linalg.matrix_rank(forward) < 3:
        forward = None
    hue_sat = None
    dims, data = extras.get("ProfileHueSatMapDims"), extras.get("ProfileHueSatMapData3")
    if dims is not None and data is not None:
        try:
            hue_sat = HueSatMap.from_dng(np.ravel(dims), data)
        except (ConfigError, TypeError, ValueError):
            hue_sat = None
    if (forward is None) != (profile.get("forward_matrix") is None) or \
            (hue_sat is None) != (profile.get("hue_sat_map") is None):
        return None  # DNG 1.6: forward matrices and maps for all three calibrations or none
    return Calibration(illuminant=f"CalibrationIlluminant3 = {code}", white_xy=(float(xy[0]), float(xy[1])),
                       color_matrix=matrix, forward_matrix=forward, hue_sat_map=hue_sat)
