"""Every section of a scene file: the keys the scene declares itself (``[scene]``'s core,
``[illuminant]``, ``[sky]``, ``[motion]``, ``[render]``; the camera's in :mod:`.camera_sections`)
and the registries that add theirs (:data:`~.section.EXTENDERS`): presets to ``[scene]``, lens
models to ``[lens]``, sensor kinds to ``[sensor]``.

References
----------
.. [1] docs/design.md, "Scene file" (the key names are a contract).
.. [2] Hosek & Wilkie (2012), "An analytic model for full spectral sky-dome radiance" (``[sky]``).
"""

from __future__ import annotations

from pathlib import Path

from .. import spectra
from ..keys import (Key, boolean, fraction_in, is_number, non_negative_whole, number_in, one_of, triple_within,
                    whole_in)
from ..presets import PRESETS, preset_keys
from .camera_sections import EXPOSURE, LENS, SENSOR
from .section import EXTENDERS, SECTION_SPECS, SectionSpec

__all__ = ["MAX_SPP", "RENDER_SAMPLERS", "RENDER_ESTIMATORS", "RADIANCE_PRECISIONS", "DIFFRACTION_MODES",
           "BAND_MODES", "SPECTRAL_BANDS_DEFAULT"]

#: Most samples per pixel a render may ask for (``render.spp``, ``render.max_spp``).
MAX_SPP = 1 << 24
#: Mitsuba samplers for ``render.sampler`` (the first is the default; see
#: :data:`spectral_cam.render.scene_dict.SAMPLERS`, which must list the same).
RENDER_SAMPLERS = ("multijitter", "independent", "stratified", "ldsampler")
#: render.estimator: ``auto`` (the adaptive median of means where the scene can make fireflies,
#: else the mean), ``mean``, ``amon`` (:mod:`spectral_cam.render.robust`).
RENDER_ESTIMATORS = ("auto", "mean", "amon")
#: Pixel types of radiance.exr (render.radiance_precision).
RADIANCE_PRECISIONS = ("float", "half")
#: render.diffraction: "auto" applies the Airy PSF only where it costs > 0.03 MTF at Nyquist.
DIFFRACTION_MODES = ("auto", "on", "off")
#: render.bands besides "start:stop:step"; "auto" resolves to this grid or "camera".
BAND_MODES = ("auto", "camera")
SPECTRAL_BANDS_DEFAULT = spectra.SPECTRAL_BANDS_DEFAULT


# ----------------------------------------------------------------------------- [scene]
def _preset(value, scene):
    if not scene.mitsuba_xml and value not in PRESETS:
        return f"unknown preset; valid: {', '.join(PRESETS)} (or set scene.mitsuba_xml)"
    return None


def _xml_file(value, scene):
    return "file does not exist" if value and not Path(value).is_file() else None


def _camera_moved(scene):
    moved = any(scene.camera_offset_m) or any(scene.camera_rotation_deg)
    if moved and not scene.mitsuba_xml:
        return ("scene.camera_offset_m/camera_rotation_deg", [list(scene.camera_offset_m),
                list(scene.camera_rotation_deg)], "move an XML scene's camera (scene.mitsuba_xml); a preset is laid "
                "out around our camera")
    return None


SCENE = SectionSpec("scene", "SceneSection", owner="the scene", doc="""What is in front of the camera: a preset (``preset``, whose keys
    each preset declares: :data:`spectral_cam.presets.PRESETS`) or a user's Mitsuba XML scene
    (``mitsuba_xml``, its camera moved by ``camera_offset_m`` and ``camera_rotation_deg``).""", keys=(
    Key("preset", "colorchecker", "str", "the scene preset (`spectral-cam keys scene` lists each one's keys)",
        (_preset,)),
    Key("mitsuba_xml", "", "str", "a Mitsuba 3 XML scene: its shapes, emitters and camera pose; our lens, film "
        "and integrator", (_xml_file,)),
    Key("camera_offset_m", (0.0, 0.0, 0.0), "tuple[float, ...]", "moves an XML scene's camera in its own frame "
        "(x image-left, y up, z along the view)", (triple_within(1e6),)),
    Key("camera_rotation_deg", (0.0, 0.0, 0.0), "tuple[float, ...]", "turns an XML scene's camera: yaw (> 0 "
        "left), pitch (> 0 up), roll (about the view)", (triple_within(180.0),)),
), checks=(_camera_moved,))


def _preset_checks(scene) -> tuple:
    # the named preset's checks even beside an XML scene, as before the keys were declared
    return PRESETS[scene.preset].checks if scene.preset in PRESETS else ()


# ----------------------------------------------------------------------------- [illuminant]
def _illuminant(value, light):
    if value != "auto":
        spectra.validate_illuminant(value)


ILLUMINANT = SectionSpec("illuminant", "IlluminantSection", owner="the light", doc="""The light: a named SPD, ``blackbody:<K>``,
    ``daylight:<CCT>`` or a CSV path, at ``illuminance_lux`` on a surface facing the camera; ``"auto"``: the
    scene's own light (D65 for a preset, an XML scene's emitters, ``render/lights.py``); ``flicker_*``
    modulate its power in time (:mod:`spectral_cam.sensor.temporal`).""", keys=(
    Key("spd", "auto", "str", "auto (the scene's own light), a colour-science illuminant or light source (D65, A, "
        "FL11, LED-B1, …), blackbody:3200, daylight:5500 or a CSV", (_illuminant,)),
    Key("illuminance_lux", 1000.0, "float", "illuminance on a surface facing the camera (presets)",
        range=(1e-6, 1e7, "lx")),
    Key("emitter", "", "str", "an XML scene's emitter to take the light from (default: the one sending the "
        "camera most light)"),
    Key("flicker_hz", 0.0, "float", "flicker frequency (0: steady; 100/120 for a lamp on 50/60 Hz mains)",
        (number_in(0.0, 1e6, rule="the light's flicker frequency in 0..1e6 Hz (0: steady; 100 or 120 for a lamp on 50 "
                  "or 60 Hz mains, an LED's PWM frequency)"),)),
    Key("flicker_depth", 1.0, "float", "modulation depth (1: the light goes dark)",
        (number_in(0.0, 1.0, rule="the modulation depth in 0..1 (1: the light goes dark)"),)),
    Key("flicker_waveform", "sine", "str", "sine (mains) or pwm (a dimmed LED)",
        (lambda v, s: None if v in ("sine", "pwm") else "valid: 'sine' (mains), 'pwm' (a dimmed LED)",)),
    Key("flicker_duty", 0.5, "float", "a PWM light's duty cycle",
        (number_in(0.0, 1.0, rule="the PWM duty cycle in (0, 1]", open_low=True),)),
))


# ----------------------------------------------------------------------------- [sky]
def _date(value, sky):
    from ..solar import parse_date

    parse_date(value)


def _sky_number(low: float, high: float, what: str):
    return fraction_in(low, high, f"must be a number in [{low:g}, {high:g}]: {what}")


SKY = SectionSpec("sky", "SkySection", owner="the outdoor presets' sun and sky", doc="""Mitsuba's ``sunsky`` (Hosek–Wilkie sky and sun) for the outdoor
    presets: the sun where it stands at local clock ``hour`` on ``date`` at the place (NOAA's solar position,
    :mod:`spectral_cam.solar`), ``turbidity`` the haze, ``heading_deg`` the camera's compass heading,
    ``cloud_cover`` the share of the sky a layer of cumulus hides (:mod:`spectral_cam.presets.clouds`),
    ``aerial_perspective`` the air's veil over far ground (:mod:`spectral_cam.render.aerial`).""", keys=(
    Key("date", "2026-06-21", "str", "the day (YYYY-MM-DD)", (_date,)),
    Key("hour", 14.0, "float", "local clock time", (_sky_number(0.0, 24.0, "a local clock time in hours"),)),
    Key("utc_offset_h", 2.0, "float", "the clock's offset from UTC",
        (_sky_number(-14.0, 14.0, "the clock's offset from UTC in hours"),)),
    Key("latitude_deg", 47.3769, "float", "degrees north", (_sky_number(-90.0, 90.0, "degrees north"),)),
    Key("longitude_deg", 8.5417, "float", "degrees east", (_sky_number(-180.0, 180.0, "degrees east"),)),
    Key("turbidity", 3.0, "float", "haze: 2 arctic-clear, 3 clear, 6 warm and moist, 10 hazy",
        (_sky_number(1.0, 10.0, "Mitsuba's sunsky turbidity"),)),
    Key("heading_deg", 0.0, "float", "the compass direction the camera looks in (0: north)",
        (lambda v, s: None if isinstance(v, float) and is_number(v) else "must be a compass heading in degrees",)),
    Key("cloud_cover", 0.0, "float", "the share of the sky a layer of cumulus hides (0: clear)",
        (_sky_number(0.0, 1.0, "the share of the sky under cloud (0: clear)"),)),
    Key("aerial_perspective", "auto", "str", "the air's veil over far ground: auto (where it dims the farthest "
        "ground by 0.5 % or more), on or off",
        (one_of(("auto", "on", "off"), "must be auto, on or off: the air's veil over far ground"),)),
))


# ----------------------------------------------------------------------------- [motion]
def _velocity(value, motion):
    return "give three numbers within ±1e5" if triple_within(1e5)(value, motion) else None


MOTION = SectionSpec("motion", "MotionSection", owner="the motion", doc="""Motion during the exposure, in the camera's own frame (x
    image-left, y up, z the view): the camera's velocity and angular velocity, and the velocity of the shape
    named ``object`` (or, with none, of the whole scene). Rendered as ``subframes`` time-stratified sub-frames;
    needs a fixed ``exposure.time_s`` and ``render.spp``.""", keys=(
    Key("camera_velocity_mps", (0.0, 0.0, 0.0), "tuple[float, ...]", "the camera's velocity",
        (_velocity,)),
    Key("camera_angular_velocity_dps", (0.0, 0.0, 0.0), "tuple[float, ...]", "[yaw, pitch, roll] rates",
        (_velocity,)),
    Key("object_velocity_mps", (0.0, 0.0, 0.0), "tuple[float, ...]", "the velocity of the shape `object` "
        "(without one, of the whole scene)", (_velocity,)),
    Key("object", "", "str", "the moving shape: an XML id or a preset's object_3 (its parts move with it)"),
    Key("subframes", "auto", "int | str", "auto (one per half pixel of the largest motion) or a count",
        (lambda v, s: None if v == "auto" else whole_in(1, 4096, "give 'auto' or a whole number in 1..4096")(v, s),)),
), properties={"moving": property(lambda self: any(self.camera_velocity_mps) or any(self.camera_angular_velocity_dps)
                                  or any(self.object_velocity_mps))})


# ----------------------------------------------------------------------------- [render]
def _spp(value, render):
    if value != "auto" and not (isinstance(value, int) and 1 <= value <= MAX_SPP):
        return f"must be a whole number in 1..{MAX_SPP} or 'auto'"
    return None


def _bands(value, render):
    if value not in BAND_MODES:
        spectra.parse_bands(value)
    if value == "camera" and render.spectral_output:
        return ("a camera film has no spectrum to write: set render.spectral_output = false, or use 'auto' or a "
                "band grid")
    return None


def _variant(value, render):
    if value != "auto" and "spectral" not in value:
        return ("must be 'auto' or a spectral Mitsuba variant such as 'llvm_ad_spectral', 'scalar_spectral' or "
                "'cuda_ad_spectral'")
    return None


def _max_depth(value, render):
    if not (isinstance(value, int) and value >= 1):
        return "must be a whole number >= 1"
    # Mitsuba's integrators hold it as a 32-bit int: a larger one would fail only when the render starts
    return None if value < 2 ** 31 else "must be a whole number >= 1 and < 2**31 (Mitsuba's path length is an int32)"


RENDER = SectionSpec("render", "RenderSection", owner="the renderer", doc="""Monte-Carlo rendering: samples per pixel, spectral bands,
    Mitsuba variant, seed, the estimator that turns passes into a pixel (docs/design.md, "Rendering").""", keys=(
    Key("spp", 64, "int | str", "samples per pixel, or auto (rounds until the Monte-Carlo noise is <= 0.3 of "
        "the sensor's)", (_spp,)),
    Key("bands", "auto", "str", "auto, camera, or start:stop:step band centres (400:700:10: 31 bands of ±5 nm)",
        (_bands,)),
    Key("variant", "auto", "str", "auto or a spectral Mitsuba variant", (_variant,)),
    Key("seed", 0, "int", "the render's seed", (non_negative_whole(),)),
    Key("max_depth", 8, "int", "path length", (_max_depth,)),
    Key("diffraction", "auto", "str", "auto, on or off (the Airy PSF per band)", (one_of(DIFFRACTION_MODES),)),
    Key("spectral_output", True, "bool", "write radiance.exr"),
    Key("radiance_precision", "float", "str", "radiance.exr's pixel type: float or half",
        (one_of(RADIANCE_PRECISIONS, "radiance.exr's pixel type: 'half' halves the file, 0.049 % rounding from "
                "6.1e-5 to 65504 W·m⁻²·sr⁻¹·nm⁻¹"),)),
    Key("max_spp", 1024, "int", "the most samples spp = auto renders",
        (whole_in(1, MAX_SPP, f"must be a whole number in 1..{MAX_SPP}"),)),
    Key("sampler", "multijitter", "str", "Mitsuba's sampler",
        (one_of(RENDER_SAMPLERS, "Mitsuba's orthogonal sampler rounds its sample count to a prime square, so it "
                "cannot hold the spp asked for"),)),
    Key("estimator", "auto", "str", "auto, mean or amon (the adaptive median of means: no fireflies)",
        (one_of(RENDER_ESTIMATORS, "auto: the adaptive median of means where the scene can make fireflies, else "
                "the mean"),)),
    Key("deterministic", False, "bool", "true: one renderer thread, the same bytes under any load whatever the "
        "scene holds", (boolean(),)),
), properties={"spectral_bands": property(
    lambda self: self.bands if self.bands not in BAND_MODES else SPECTRAL_BANDS_DEFAULT,
    doc="The band grid of the render's spectrum: ``bands``, or the default grid for auto and camera.")})


# ----------------------------------------------------------------------------- registries that add keys
def _lens_keys() -> list:
    from ..render.lens_models import LENS_MODELS  # a floor up: the entries build Mitsuba cameras

    return LENS_MODELS.declared_keys()


def _lens_checks(lens) -> tuple:
    from ..render.lens_models import LENS_MODELS

    return tuple(check for entry in LENS_MODELS.values() for check in entry.checks)


def _sensor_checks(sensor) -> tuple:
    """The chosen kind's own combination checks (an unknown kind is the ``kind`` key's to refuse)."""
    from ..sensor.kinds import SENSOR_KINDS

    return SENSOR_KINDS[sensor.kind].checks if sensor.kind in SENSOR_KINDS else ()


def _sensor_keys() -> list:
    from ..sensor.kinds import SENSOR_KINDS

    return SENSOR_KINDS.declared_keys()


SECTION_SPECS.update({spec.name: spec for spec in (SCENE, ILLUMINANT, SKY, LENS, SENSOR, EXPOSURE, MOTION, RENDER)})
EXTENDERS.update({"scene": (preset_keys, _preset_checks), "lens": (_lens_keys, _lens_checks),
                  "sensor": (_sensor_keys, _sensor_checks)})
