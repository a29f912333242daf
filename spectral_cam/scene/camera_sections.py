"""The camera's own keys: ``[lens]`` (those every lens model reads), ``[sensor]`` (those every sensor
kind reads: the EMVA 1288 linear model, the mosaic, the frame) and ``[exposure]``.

A lens model's own keys (``glass``, ``blades``, ``prescription`` …) are declared by its entry in
:data:`spectral_cam.render.lens_models.LENS_MODELS`, a sensor kind's (``jot_frames``,
``event_threshold`` …) by its entry in :data:`spectral_cam.sensor.kinds.SENSOR_KINDS`.

References
----------
.. [1] EMVA Standard 1288, Release 4.0 (2021), the linear camera model.
.. [2] ISO 12232:2019, the exposure index (``iso_definition``).
"""

from __future__ import annotations

from ..cfa import CFA_PATTERNS
from ..keys import Key, boolean, non_negative_whole, number_in, one_of, whole_in
from .section import SectionSpec

__all__ = ["LENS", "SENSOR", "EXPOSURE"]


# ----------------------------------------------------------------------------- [lens]
def _models():
    from ..render.lens_models import LENS_MODELS  # a floor up: the entries build Mitsuba cameras

    return ("auto", *LENS_MODELS)


def _focus_beyond_focal_length(lens):
    if lens.focus_distance_m * 1000.0 <= lens.focal_length_mm:
        return ("lens.focus_distance_m", lens.focus_distance_m, f"a thin lens focuses only beyond its focal length "
                f"({lens.focal_length_mm / 1000:g} m); give a larger focus distance")
    return None


def _transmission(value, lens):
    from .. import spectra

    spectra.validate_transmission(value)


LENS = SectionSpec("lens", "LensSection", owner="every lens model", doc="""A thin lens (or a pinhole with the same field of view). ``model = "auto"``
    renders through a pinhole when defocus costs <= 0.03 of MTF at Nyquist over the scene's depths, and with
    the depth-layered model where that is exact and thin-lens path tracing would be noisy
    (:func:`spectral_cam.render.decisions.decide_lens_model`).""", keys=(
    Key("focal_length_mm", 8.0, "float", "focal length (unset for an XML scene: keeps its camera's horizontal "
        "field of view; a prescription's is its EFL)", range=(0.1, 1e4, "mm")),
    Key("f_number", 2.8, "float", "f-number (a prescription's: its traced N unless set slower)",
        range=(0.5, 1000.0, "")),
    Key("focus_distance_m", 2.0, "float", "distance in focus", range=(1e-4, 1e9, "m")),
    Key("model", "auto", "str", "the lens model: auto (chosen per scene, docs/design.md \"Model decisions\") or a "
        "registered one", (one_of(_models),)),
    Key("transmission", 1.0, "float | str", "the lens's spectral transmission: a number or a CSV",
        (_transmission,)),
    Key("focus_object", "", "str", "a shape to focus on (an XML id, a preset's object_3 or plant_2); replaces "
        "focus_distance_m when the render starts"),
), checks=(_focus_beyond_focal_length,))


# ----------------------------------------------------------------------------- [sensor]
def _figure_keys(value, sensor):
    from .. import spectra

    if not set(value) <= set(spectra.SENSOR_FIGURE_KEYS.values()):
        return ("the keys the named model set (written by spectral_cam), among "
                + ", ".join(spectra.SENSOR_FIGURE_KEYS.values()))
    return None


def _camera_model(value, sensor):
    from .. import spectra

    if value != "ideal":
        spectra.validate_camera(value)


def _cfa(value, sensor):
    if value not in CFA_PATTERNS:
        return f"valid: {', '.join(CFA_PATTERNS)}"
    if value != "none" and min(sensor.width_px, sensor.height_px) < 2:
        return ("sensor.width_px" if sensor.width_px < 2 else "sensor.height_px",
                min(sensor.width_px, sensor.height_px), f"a {value} Bayer sensor needs at least 2×2 pixels")
    if value == "none" and sensor.model != "ideal":
        return "a monochrome sensor needs sensor.model = 'ideal'"
    return None


def _black_level(value, sensor):
    if isinstance(value, int) and 0 <= value < 2 ** sensor.bit_depth - 1:
        return None
    return f"must be a whole number in 0..{2 ** sensor.bit_depth - 2}"


def _ir_cut(value, sensor):
    from .. import spectra

    spectra.validate_transmission(value)


def _olpf(value, sensor):
    from ..sensor.olpf import check_olpf_margin

    # parses it; its light from beyond the frame must be rendered
    check_olpf_margin(value, model=sensor.model, pixel_pitch_um=sensor.pixel_pitch_um,
                      crop_margin_px=sensor.crop_margin_px, cfa=sensor.cfa)


def _angular_response(value, sensor):
    from ..sensor.shading import parse_angular_response

    parse_angular_response(value)


def _kind(value, sensor):
    from ..sensor.kinds import validate_sensor_keys

    problem = validate_sensor_keys(sensor)
    return problem if problem and problem[0] == "sensor.kind" else None


def _kind_keys_set(sensor):
    """A key set for a kind it does not belong to: checked after every kind's own keys, so a value out of
    its own range (a dead time of 2 s on a CMOS) is refused for its range first."""
    from ..sensor.kinds import validate_sensor_keys

    return validate_sensor_keys(sensor)


_PIXELS = whole_in(1, 20000, "must be a whole number of pixels in 1..20000")

SENSOR = SectionSpec("sensor", "SensorSection", owner="every sensor kind", doc="""The image sensor (EMVA 1288 linear model). Zero switches a
    noise term off. A scene that names ``model`` gets that camera's published full well, read noise, bit
    depth, pitch and base ISO for the keys it leaves unset (:func:`spectral_cam.spectra.with_camera_figures`);
    ``keep_field_of_view`` spreads ``width_px`` × ``height_px`` over the camera's sensor size.""", keys=(
    Key("model", "nikon_d850", "str", "the camera whose filter curves (and figures) the sensor takes "
        "(`spectral-cam cameras`), or ideal", (_camera_model,)),
    Key("width_px", 480, "int", "frame width", (_PIXELS,)),
    Key("height_px", 320, "int", "frame height", (_PIXELS,)),
    Key("pixel_pitch_um", 6.0, "float", "pixel pitch: with the lens it sets the field of view",
        range=(0.1, 1000.0, "µm")),
    Key("keep_field_of_view", False, "bool", "true spreads width_px × height_px over the named camera's "
        "whole sensor, so a small frame keeps its view", (boolean(),)),
    Key("model_figures", (), "tuple[str, ...]", "the keys the named model set (written by spectral_cam)",
        (_figure_keys,)),
    Key("crop_margin_px", 8, "int", "real pixels rendered around the frame (the DNG's crop margin)",
        (whole_in(0, 256, "must be an even whole number of pixels in 0..256 (even keeps the CFA phase at "
                  "the crop)"), lambda v, s: None if v % 2 == 0 else "must be an even whole number of pixels "
                  "in 0..256 (even keeps the CFA phase at the crop)")),
    Key("cfa", "RGGB", "str", "the colour filter array: RGGB, BGGR, GRBG, GBRG; XTRANS; QUAD_RGGB; RGBW; none",
        (_cfa,)),
    Key("peak_qe", 0.6, "float", "peak quantum efficiency",
        (number_in(0.0, 1.0, rule="must lie in (0, 1]", open_low=True),)),
    Key("full_well_e", 20000.0, "float", "full-well capacity", range=(1.0, 1e9, "e⁻")),
    Key("read_noise_e", 2.5, "float", "read noise", range=(0.0, 1e6, "e⁻")),
    Key("dark_current_e_per_s", 1.0, "float", "dark current (a QIS's or SPAD's dark count rate)",
        range=(0.0, 1e9, "e⁻/s")),
    Key("dsnu_e", 0.5, "float", "dark signal non-uniformity", range=(0.0, 1e6, "e⁻")),
    Key("prnu", 0.005, "float", "photo-response non-uniformity", range=(0.0, 1.0, "")),
    Key("bit_depth", 12, "int", "ADC bits", (whole_in(8, 16),)),
    Key("black_level_dn", 256, "int", "black level", (_black_level,)),
    Key("base_iso", 100.0, "float", "the ISO at unity analogue gain", range=(1.0, 1e7, "")),
    Key("ir_cut", 1.0, "float | str", "IR-cut filter: a number, a CSV or ir_cut:650", (_ir_cut,)),
    Key("seed", 0, "int", "noise seed", (non_negative_whole(),)),
    Key("shot_noise", True, "bool", "photon shot noise"),
    Key("vignetting", True, "bool", "cos⁴ falloff of a thin lens"),
    Key("olpf", "off", "float | str", "optical low-pass filter: off, camera (where its maker says it has one), "
        "a spot separation in pixel pitches or \"3.5 um\"", (_olpf,)),
    Key("angular_response_deg", "off", "float | str | tuple", "the pixels' acceptance: half response at θ½ "
        "degrees of chief-ray angle, one or per channel (lens and colour shading); off", (_angular_response,)),
    Key("shutter", "global", "str", "global (every row at once) or rolling (row by row, row_time_s apart)",
        (lambda v, s: None if v in ("global", "rolling") else "valid: 'global' (every row at once), 'rolling' (row by "
         "row, row_time_s apart)",)),
    Key("row_time_s", 10e-6, "float", "a rolling shutter's readout time of one row",
        (number_in(0.0, 0.01, rule="must be the readout time of one row in (0, 0.01] s (a full-frame sensor "
                   "reads a row in ~5-20 µs)", open_low=True),)),
    Key("kind", "cmos", "str", "the sensor kind: cmos (integrating) or another registered kind (their keys below)",
        (_kind,)),
), checks=(_kind_keys_set,), properties={"width_m": property(lambda self: self.width_px * self.pixel_pitch_um * 1e-6),
               "height_m": property(lambda self: self.height_px * self.pixel_pitch_um * 1e-6)})


# ----------------------------------------------------------------------------- [exposure]
def _metering(value, exposure):
    from ..metering import METERING

    return None if value in METERING.names() else f"unknown mode; valid: {', '.join(METERING.names())}"


def _iso_definition(value, exposure):
    from ..metering import ISO_DEFINITIONS

    return None if value in ISO_DEFINITIONS else f"valid: {', '.join(ISO_DEFINITIONS)}"


def _time(value, exposure):
    return None if value == "auto" else number_in(1e-9, 1e4, "s")(value, exposure)  # a word other than auto


EXPOSURE = SectionSpec("exposure", "ExposureSection", owner="the exposure", doc="""Exposure time (s, or ``"auto"``: metered as a camera
    does, ``metering``), ISO (a scene file that leaves it unset gets the sensor's ``base_iso``), the exposure
    index's definition, ``compensation_ev`` and ``auto_fraction``.""", keys=(
    Key("time_s", "auto", "float | str", "auto (metered) or seconds", (_time,), range=(1e-9, 1e4, "s")),
    Key("iso", 100.0, "float", "unset: the sensor's base_iso (a named camera's own)", range=(1.0, 1e7, "")),
    Key("auto_fraction", 0.8, "float", "where highlight and etr metering put the brightest 1 %",
        (number_in(0.0, 1.0, rule="must lie in (0, 1]", open_low=True),)),
    Key("metering", "average", "str", "average, centre_weighted, spot, highlight, etr", (_metering,)),
    Key("compensation_ev", 0.0, "float", "exposure compensation in stops",
        (number_in(-10.0, 10.0, rule="must be a number of stops in [-10, 10]"),)),
    Key("iso_definition", "sos", "str", "sos (a metered grey at 118/255) or saturation", (_iso_definition,)),
    Key("start_s", 0.0, "float", "the frame's start time (the phase of a flickering light)",
        (number_in(-1e6, 1e6, rule="the frame's start time in seconds (for a flickering light's phase), a number "
                   "within ±1e6"),)),
))
