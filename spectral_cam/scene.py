"""Scene files: TOML -> validated, frozen :class:`SceneConfig`.

A scene file says only what differs from the defaults below; any key can be overridden
with ``section.key=value`` strings (the CLI's ``--set``) or an ``overrides`` mapping.
Every section is a frozen dataclass; :meth:`SceneConfig.to_dict` round-trips through
:func:`scene_from_dict`, so each output's ``meta.json`` can reproduce its render.

The geometry of the presets lives in :mod:`spectral_cam.presets`.

References
----------
.. [1] TOML v1.0.0, https://toml.io/en/v1.0.0 (read with the standard library's tomllib).
.. [2] docs/design.md, "Scene file" (the key names are a contract).
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, Mapping

from . import spectra
from .cfa import CFA_PATTERNS
from .presets import PRESETS
from .presets.assets import AssetSpec, asset_from_table
from .presets.scatter import ScatterSpec, scatter_from_table
from .errors import ConfigError
from .isp.config import ISPConfig as ISPSection

__all__ = [
    "SceneConfig",
    "SceneSection",
    "IlluminantSection",
    "LensSection",
    "SensorSection",
    "ExposureSection",
    "RenderSection",
    "ISPSection",
    "SkySection",
    "MotionSection",
    "SCENE_LIGHTS",
    "OBJECT_MATERIALS",
    "load_scene",
    "scene_from_dict",
    "parse_override",
    "read_toml",
    "PRESETS",
    "CFA_PATTERNS",
]

#: Bayer tiles, read row by row from the top-left pixel; "none" = monochrome.
#: render.diffraction: "auto" applies the Airy PSF only where it costs > 0.03 MTF at Nyquist.
DIFFRACTION_MODES = ("auto", "on", "off")
#: render.bands besides "start:stop:step"; "auto" resolves to this grid or "camera".
BAND_MODES = ("auto", "camera")
SPECTRAL_BANDS_DEFAULT = spectra.SPECTRAL_BANDS_DEFAULT
#: scene.light: "auto" is each preset's own light ("sunsky" for the outdoor presets, else
#: "illuminant"); "sunsky" is Mitsuba's sun and sky per [sky] (presets that declare "light").
SCENE_LIGHTS = ("auto", "sunsky", "illuminant", "overcast")
#: scene.object_materials of ``tabletop``: Lambert, rough plastic, rough measured metal, glass.
OBJECT_MATERIALS = ("diffuse", "plastic", "conductor", "glass")
#: scene.ground of the outdoor presets.
GROUND_KINDS = ("textured", "checker", "flat", "table")


def _fail(key: str, value: Any, rule: str) -> None:
    raise ConfigError(f"{key} = {value!r}: {rule}")


#: The valid range of every physical key, (low, high, unit): a camera or scene outside it is
#: not one this simulator models (and its arithmetic would overflow or underflow), so it is
#: refused before anything runs. The same table is in docs/design.md ("Scene file").
PHYSICAL_RANGES = {
    "scene.distance_m": (1e-4, 1e6, "m"),
    "scene.depths_m": (1e-4, 1e6, "m"),
    "scene.source_radius_m": (1e-7, 1e3, "m"),
    "scene.checker_px": (1.0, 1e5, "px"),
    "scene.leaf_radius_px": (0.5, 1e5, "px"),
    "illuminant.illuminance_lux": (1e-6, 1e7, "lx"),
    "lens.focal_length_mm": (0.1, 1e4, "mm"),
    "lens.f_number": (0.5, 1000.0, ""),
    "lens.focus_distance_m": (1e-4, 1e9, "m"),
    "sensor.pixel_pitch_um": (0.1, 1000.0, "µm"),
    "sensor.full_well_e": (1.0, 1e9, "e⁻"),
    "sensor.read_noise_e": (0.0, 1e6, "e⁻"),
    "sensor.dark_current_e_per_s": (0.0, 1e9, "e⁻/s"),
    "sensor.dsnu_e": (0.0, 1e6, "e⁻"),
    "sensor.prnu": (0.0, 1.0, ""),
    "sensor.base_iso": (1.0, 1e7, ""),
    "exposure.time_s": (1e-9, 1e4, "s"),
    "exposure.iso": (1.0, 1e7, ""),
}
#: Most samples per pixel a render may ask for (``render.spp``, ``render.max_spp``).
MAX_SPP = 1 << 24


def _within(key: str, value: Any) -> None:
    """Refuse a value outside :data:`PHYSICAL_RANGES` with the range and its unit."""
    low, high, unit = PHYSICAL_RANGES[key]
    if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
            and low <= value <= high):
        unit = f" {unit}" if unit else ""
        _fail(key, value, f"must be a number in [{low:g}, {high:g}]{unit}")


@dataclass(frozen=True)
class SceneSection:
    """What is in front of the camera.

    ``distance_m`` is the subject distance of ``colorchecker``, ``flat_field`` and
    ``slanted_edge``; ``depths_m`` the plane depths of ``dof_targets`` and the source depths
    of ``point_sources``; ``checker_px`` the in-focus checker square size of ``dof_targets``
    (pixels). ``fill`` is the fraction of the frame width the chart covers and
    ``gap`` the fraction of each patch pitch left as dark border; ``surround`` the reflectance of
    the card the chart lies on (an 18 % grey by default, as charts are photographed; 0: nothing
    behind the chart). ``reflectance`` is the
    flat-field target (a number in [0, 1], a ColorChecker patch name or a CSV path).
    ``leaf_*`` shape ``dead_leaves``: disc radii on the sensor (pixels, power law between the
    two), the expected fraction of the view covered, the reflectance set the discs draw from
    and the layout's seed; its discs lie at depths spread over ``depths_m``.
    ``camera_offset_m`` and ``camera_rotation_deg`` move an XML scene's camera from its pose in
    the file, in the camera's own frame: an offset (x image-left, y up, z along the view) and
    yaw (> 0 turns left), pitch (> 0 tilts up), roll (about the view axis, right-handed).
    ``light`` lights the outdoor presets (``tabletop``, ``vegetation``) by Mitsuba's sun and
    sky at ``[sky]``'s date, time and place (``"sunsky"``, their ``"auto"``) or by
    ``[illuminant]`` (``"illuminant"``). ``object_*`` shape ``tabletop``: how many objects, the
    size range (fractions of the view's width at the look point), the materials drawn from and the reflectance set their colours come from;
    ``layout_seed`` draws the layout of ``tabletop`` and ``vegetation``; ``view_pitch_deg``
    tilts their camera (< 0 looks down) at the ground point ``distance_m`` away.
    ``vegetation`` reads ``object_count`` and ``object_size`` for its plants, whose leaves take
    ``plant_reflectances``: ``"prospect"`` (PROSPECT-D reflectance and transmittance, each plant's
    biochemistry drawn by health: ``dry_fraction`` dry, ``stressed_fraction`` stressed, the rest
    healthy) or a reflectance set (its ``dry_*`` samples for ``dry_fraction`` of the plants), on a
    soil of ``soil_reflectances``.
    ``assets`` (``[[scene.assets]]``) places users' PLY/OBJ/glTF meshes and ``scatter``
    (``[[scene.scatter]]``) instanced stones, clods, straw and grass blades on the ground of
    an outdoor preset (:mod:`spectral_cam.presets.assets`, :mod:`spectral_cam.presets.scatter`).
    """

    preset: str = "colorchecker"
    mitsuba_xml: str = ""
    distance_m: float = 2.0
    depths_m: tuple[float, ...] = (1.0, 2.0, 4.0)
    fill: float = 0.8
    gap: float = 0.15
    reflectance: float | str = 0.18
    surround: float | str = 0.18
    edge_angle_deg: float = 5.0
    source_radius_m: float = 0.002
    checker_px: float = 16.0
    leaf_radius_px: tuple[float, ...] = (3.0, 120.0)
    leaf_coverage: float = 0.99
    leaf_reflectances: str = "cie2017"
    leaf_seed: int = 0
    camera_offset_m: tuple[float, ...] = (0.0, 0.0, 0.0)
    camera_rotation_deg: tuple[float, ...] = (0.0, 0.0, 0.0)
    light: str = "auto"
    object_count: int = 8
    object_size: tuple[float, ...] = (0.08, 0.2)
    object_materials: tuple[str, ...] = OBJECT_MATERIALS
    object_reflectances: str = "cie2017"
    layout_seed: int = 0
    view_pitch_deg: float = -25.0
    plant_reflectances: str = "prospect"
    ground: str = "textured"
    layout: str = "scatter"
    chart: bool = False
    soil_reflectances: str = "usgs_soils"
    dry_fraction: float = 0.1
    stressed_fraction: float = 0.2
    assets: tuple[AssetSpec, ...] = ()
    scatter: tuple[ScatterSpec, ...] = ()

    def __post_init__(self) -> None:
        if not self.mitsuba_xml and self.preset not in PRESETS:
            _fail("scene.preset", self.preset, f"unknown preset; valid: {', '.join(PRESETS)} "
                  "(or set scene.mitsuba_xml)")
        if self.mitsuba_xml and not Path(self.mitsuba_xml).is_file():
            _fail("scene.mitsuba_xml", self.mitsuba_xml, "file does not exist")
        _within("scene.distance_m", self.distance_m)
        if not self.depths_m:
            _fail("scene.depths_m", self.depths_m, "give at least one depth in metres")
        for depth in self.depths_m:
            _within("scene.depths_m", depth)
        if self.preset == "dof_targets" and len(self.depths_m) < 3:
            _fail("scene.depths_m", self.depths_m, "dof_targets needs three or more depths")
        if not 0 < self.fill <= 1:
            _fail("scene.fill", self.fill, "must lie in (0, 1]")
        if not 0 <= self.gap < 1:
            _fail("scene.gap", self.gap, "must lie in [0, 1)")
        if not 0 <= self.edge_angle_deg < 45:
            _fail("scene.edge_angle_deg", self.edge_angle_deg, "must lie in [0, 45)")
        _within("scene.source_radius_m", self.source_radius_m)
        _within("scene.checker_px", self.checker_px)
        if len(self.leaf_radius_px) != 2 or not self.leaf_radius_px[0] < self.leaf_radius_px[1]:
            _fail("scene.leaf_radius_px", list(self.leaf_radius_px), "give [smallest, largest] disc radius in "
                  "pixels, smallest < largest")
        for radius in self.leaf_radius_px:
            _within("scene.leaf_radius_px", radius)
        if not 0 < self.leaf_coverage <= 0.9999:
            _fail("scene.leaf_coverage", self.leaf_coverage, "must lie in (0, 0.9999]: the expected fraction "
                  "of the view the discs cover")
        for key, bound in (("camera_offset_m", 1e6), ("camera_rotation_deg", 180.0)):
            values = getattr(self, key)
            if len(values) != 3 or not all(math.isfinite(v) and abs(v) <= bound for v in values):
                _fail(f"scene.{key}", list(values), f"give three numbers within ±{bound:g}")
        moved = any(self.camera_offset_m) or any(self.camera_rotation_deg)
        if moved and not self.mitsuba_xml:
            _fail("scene.camera_offset_m/camera_rotation_deg", [list(self.camera_offset_m), list(self.camera_rotation_deg)],
                  "move an XML scene's camera (scene.mitsuba_xml); a preset is laid out around our camera")
        for key in ("leaf_seed", "layout_seed"):
            value = getattr(self, key)
            if not isinstance(value, int) or isinstance(value, bool) or value < 0:
                _fail(f"scene.{key}", value, "must be a whole number >= 0")
        for key in ("leaf_reflectances", "object_reflectances", "plant_reflectances", "soil_reflectances"):
            value = getattr(self, key)
            if key == "plant_reflectances" and value == "prospect":
                continue
            if value not in spectra.REFLECTANCE_SET_NAMES and not str(value).lower().endswith(".csv"):
                _fail(f"scene.{key}", value, f"valid: {', '.join(spectra.REFLECTANCE_SET_NAMES)} or a CSV "
                      "(wavelength_nm, one column per sample)")
        if not isinstance(self.chart, bool):
            _fail("scene.chart", self.chart, "true places a ColorChecker in the tabletop, false none")
        if self.layout not in ("scatter", "rows"):
            _fail("scene.layout", self.layout, "valid: scatter (plants drawn over the view), rows (a crop field: "
                  "rows 0.75 m apart, a plant every 0.3 m, weeds between)")
        if self.ground not in GROUND_KINDS:
            _fail("scene.ground", self.ground, f"valid: {', '.join(GROUND_KINDS)} (textured: measured soils and litter "
                  "mixed in fractal patches with relief; checker: the tabletop's 10 %/40 % checkerboard; flat: one "
                  "soil sample; table: a wooden table top before a stone wall)")
        self._check_outdoor_keys()
        self._check_assets()
        spectra.validate_reflectance(self.reflectance)
        spectra.validate_reflectance(self.surround)

    def _check_assets(self) -> None:
        if not (self.assets or self.scatter):
            return
        # the presets on the ground of outdoor.GroundView (their heading is [sky]'s), those under the sky
        outdoor = [name for name in PRESETS if "light" in PRESETS[name].options]
        if self.mitsuba_xml or self.preset not in outdoor:
            _fail("scene.assets/scatter", self.mitsuba_xml or self.preset,
                  f"assets and scatter stand on the ground of an outdoor preset ({', '.join(outdoor)})")
        names = [a.name for a in self.assets] + [s.name for s in self.scatter]
        repeated = sorted({n for n in names if names.count(n) > 1})
        if repeated:
            _fail("scene.assets/scatter name", repeated, "each entry needs a name of its own (the segmentation's)")

    def _check_outdoor_keys(self) -> None:
        if self.light not in SCENE_LIGHTS:
            _fail("scene.light", self.light, f"valid: {', '.join(SCENE_LIGHTS)}")
        if self.light in ("sunsky", "overcast") and (self.mitsuba_xml or "light" not in PRESETS[self.preset].options):
            outdoor = [name for name in PRESETS if "light" in PRESETS[name].options]
            _fail("scene.light", self.light, f"the sun and sky light the outdoor presets ({', '.join(outdoor)}); "
                  f"{self.mitsuba_xml or self.preset!r} brings its own light")
        if not isinstance(self.object_count, int) or isinstance(self.object_count, bool) or not 0 <= self.object_count <= 200:
            _fail("scene.object_count", self.object_count, "must be a whole number in 0..200")
        if (len(self.object_size) != 2 or not 0.005 <= self.object_size[0] <= self.object_size[1] <= 0.5):
            _fail("scene.object_size", list(self.object_size), "give [smallest, largest] object size as fractions "
                  "of the view's width at the look point, within [0.005, 0.5]")
        if not self.object_materials or any(m not in OBJECT_MATERIALS for m in self.object_materials):
            _fail("scene.object_materials", list(self.object_materials), f"give one or more of {', '.join(OBJECT_MATERIALS)}")
        if not (isinstance(self.dry_fraction, float) and 0.0 <= self.dry_fraction <= 1.0):
            _fail("scene.dry_fraction", self.dry_fraction, "must lie in [0, 1]: the fraction of plants with dry leaves")
        if not (isinstance(self.stressed_fraction, float) and 0.0 <= self.stressed_fraction <= 1.0
                and self.dry_fraction + self.stressed_fraction <= 1.0):
            _fail("scene.stressed_fraction", self.stressed_fraction, "must lie in [0, 1 − dry_fraction]: the fraction "
                  "of plants with stressed (chlorotic) leaves")
        if not (isinstance(self.view_pitch_deg, float) and -89.0 <= self.view_pitch_deg <= -1.0):
            _fail("scene.view_pitch_deg", self.view_pitch_deg, "must lie in [-89, -1] degrees (the camera looks "
                  "down at the ground point distance_m away)")


@dataclass(frozen=True)
class SkySection:
    """Mitsuba's ``sunsky`` (Hosek–Wilkie sky and sun) for the outdoor presets: the sun stands
    where it stands at local clock ``hour`` on ``date`` at ``latitude_deg``/``longitude_deg``
    (north/east positive) with the clock ``utc_offset_h`` hours from UTC (NOAA's solar
    position, :mod:`spectral_cam.solar`); ``turbidity`` (1–10: 2 arctic-clear, 3 clear, 6 warm
    and moist, 10 hazy) sets the haze; ``heading_deg`` is the compass direction the camera
    looks in (clockwise from north); ``cloud_cover`` (0–1) is the share of the sky a layer of
    cumulus hides (:mod:`spectral_cam.presets.clouds`; 0: the clear sky). Its light is in
    absolute units (about 100 klx of sun at a high elevation), so ``exposure.time_s = "auto"``
    is the natural choice."""

    date: str = "2026-06-21"
    hour: float = 14.0
    utc_offset_h: float = 2.0
    latitude_deg: float = 47.3769
    longitude_deg: float = 8.5417
    turbidity: float = 3.0
    heading_deg: float = 0.0
    cloud_cover: float = 0.0

    def __post_init__(self) -> None:
        from .solar import parse_date

        parse_date(self.date)
        for key, low, high, what in (("hour", 0.0, 24.0, "a local clock time in hours"),
                                     ("utc_offset_h", -14.0, 14.0, "the clock's offset from UTC in hours"),
                                     ("latitude_deg", -90.0, 90.0, "degrees north"),
                                     ("longitude_deg", -180.0, 180.0, "degrees east"),
                                     ("turbidity", 1.0, 10.0, "Mitsuba's sunsky turbidity"),
                                     ("cloud_cover", 0.0, 1.0, "the share of the sky under cloud (0: clear)")):
            value = getattr(self, key)
            if not (isinstance(value, float) and low <= value <= high):
                _fail(f"sky.{key}", value, f"must be a number in [{low:g}, {high:g}]: {what}")
        if not (isinstance(self.heading_deg, float) and math.isfinite(self.heading_deg)):
            _fail("sky.heading_deg", self.heading_deg, "must be a compass heading in degrees")


@dataclass(frozen=True)
class IlluminantSection:
    """The light: a named SPD, ``blackbody:<K>``, ``daylight:<CCT>`` or a CSV path, at ``illuminance_lux`` on a
    surface facing the camera. ``spd = "auto"``: the scene's own light, D65 for a preset and
    its emitters' spectrum for an XML scene (``emitter`` names the one to use when it has
    several; otherwise the one sending the camera most light: ``render/lights.py``). ``flicker_hz``,
    ``flicker_depth``, ``flicker_waveform`` and ``flicker_duty`` modulate its power in time
    (:mod:`spectral_cam.sensor.temporal`)."""

    spd: str = "auto"
    illuminance_lux: float = 1000.0
    emitter: str = ""
    flicker_hz: float = 0.0
    flicker_depth: float = 1.0
    flicker_waveform: str = "sine"
    flicker_duty: float = 0.5

    def __post_init__(self) -> None:
        _within("illuminant.illuminance_lux", self.illuminance_lux)
        _flicker_check(self)
        if self.spd != "auto":
            spectra.validate_illuminant(self.spd)


def _check_photon_counting(sensor) -> None:
    """``sensor.kind`` and every kind's own keys, as the kind's registry entry declares them
    (:data:`spectral_cam.sensor.kinds.SENSOR_KINDS`)."""
    from .sensor.kinds import validate_sensor_keys

    problem = validate_sensor_keys(sensor)
    if problem:
        _fail(*problem)


def _flicker_check(light) -> None:
    """The light's modulation in time (:mod:`spectral_cam.sensor.temporal`)."""
    def number(value):
        return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)

    if not (number(light.flicker_hz) and 0 <= light.flicker_hz <= 1e6):
        _fail("illuminant.flicker_hz", light.flicker_hz, "the light's flicker frequency in 0..1e6 Hz (0: steady; "
              "100 or 120 for a lamp on 50 or 60 Hz mains, an LED's PWM frequency)")
    if not (number(light.flicker_depth) and 0 <= light.flicker_depth <= 1):
        _fail("illuminant.flicker_depth", light.flicker_depth, "the modulation depth in 0..1 (1: the light goes dark)")
    if light.flicker_waveform not in ("sine", "pwm"):
        _fail("illuminant.flicker_waveform", light.flicker_waveform, "valid: 'sine' (mains), 'pwm' (a dimmed LED)")
    if not (number(light.flicker_duty) and 0 < light.flicker_duty <= 1):
        _fail("illuminant.flicker_duty", light.flicker_duty, "the PWM duty cycle in (0, 1]")


def lens_models():
    """The lens models ``lens.model`` may name besides ``"auto"``: the registry
    :data:`spectral_cam.render.lens_models.LENS_MODELS` (a model registered by a user's module
    included). Read when a lens section is checked, not at import: the registry's entries build
    Mitsuba cameras, a floor above this one."""
    from .render.lens_models import LENS_MODELS as registry

    return registry


@dataclass(frozen=True)
class LensSection:
    """A thin lens (or a pinhole with the same field of view). ``model = "auto"`` renders
    through a pinhole when defocus costs ≤ 0.03 of MTF at Nyquist over the scene's depths,
    and with the depth-layered model (``"layered"``: a pinhole render defocused per depth
    layer, :mod:`spectral_cam.render.layered`) where that is exact and thin-lens path tracing
    would be noisy (docs/design.md, "Model decisions"). ``focus_object`` names a shape of the
    scene (an XML ``id``, a preset's ``object_3`` or ``plant_2``) to focus on: it replaces
    ``focus_distance_m`` with that object's depth when the render starts
    (:mod:`spectral_cam.render.focus`). ``model = "spectral_thin"`` is a thin lens of ``glass``
    (``"ideal"``, the default: no dispersion; a catalogue glass: a singlet, or
    ``"crown+flint"``: a cemented achromat) whose focal
    length follows the glass's dispersion, ``focal_length_mm`` at the d line
    (:mod:`spectral_cam.optics.glass`; ``glass = "ideal"``: none), with ``blades`` straight aperture
    blades (0: round; a vertex ``blade_rotation_deg`` from up towards image-left; rounded by
    ``blade_rounding`` from 0, straight, to 1, a circle) and
    Brown–Conrady ``distortion`` [k1, k2, p1, p2, k3] (OpenCV's convention). ``model = "prescription"`` traces the real surfaces of
    ``prescription`` (a bundled lens or a CSV, :mod:`spectral_cam.optics.prescription`); its
    focal length and f-number are then the prescription's (paraxial), set when the scene is
    read."""

    focal_length_mm: float = 8.0
    f_number: float = 2.8
    focus_distance_m: float = 2.0
    model: str = "auto"
    transmission: float | str = 1.0
    focus_object: str = ""
    glass: str = "ideal"
    prescription: str = "dgauss_50mm"
    blades: int = 0
    blade_rotation_deg: float = 0.0
    blade_rounding: float = 0.0
    distortion: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        _within("lens.focal_length_mm", self.focal_length_mm)
        _within("lens.f_number", self.f_number)
        _within("lens.focus_distance_m", self.focus_distance_m)
        if self.focus_distance_m * 1000.0 <= self.focal_length_mm:
            _fail("lens.focus_distance_m", self.focus_distance_m,
                  f"a thin lens focuses only beyond its focal length "
                  f"({self.focal_length_mm / 1000:g} m); give a larger focus distance")
        models = lens_models()
        if self.model != "auto" and self.model not in models:
            _fail("lens.model", self.model, f"valid: auto, {', '.join(models)}")
        from .optics.glass import GLASS_NAMES

        glasses = [part.strip() for part in str(self.glass).split("+")]
        if self.glass != "ideal" and (len(glasses) > 2 or any(g not in GLASS_NAMES for g in glasses)):
            _fail("lens.glass", self.glass, f"give \"ideal\" (no dispersion), a glass (a singlet) or crown+flint (an "
                  f"achromat) from: {', '.join(GLASS_NAMES)}")
        if not (isinstance(self.blades, int) and not isinstance(self.blades, bool)
                and (self.blades == 0 or 3 <= self.blades <= 32)):
            _fail("lens.blades", self.blades, "give 0 (a circular opening) or 3..32 straight blades")
        if not (isinstance(self.blade_rounding, float) and 0.0 <= self.blade_rounding <= 1.0):
            _fail("lens.blade_rounding", self.blade_rounding, "must lie in [0, 1]: 0 straight blades, 1 a circle")
        if not (isinstance(self.blade_rotation_deg, float) and math.isfinite(self.blade_rotation_deg)):
            _fail("lens.blade_rotation_deg", self.blade_rotation_deg, "must be an angle in degrees")
        if len(self.distortion) != 5 or not all(math.isfinite(v) and abs(v) <= 1.0 for v in self.distortion):
            _fail("lens.distortion", list(self.distortion), "give Brown–Conrady [k1, k2, p1, p2, k3] (OpenCV's "
                  "order), each within ±1")
        if self.blades and self.model != "auto" and not models[self.model].blades:
            _fail("lens.model", self.model, "aperture blades are rendered by the \"spectral_thin\" lens (lens.model = "
                  "\"auto\" picks it) or a \"prescription\"'s stop; set lens.model accordingly")
        if any(self.distortion) and self.model != "auto" and not models[self.model].distortion:
            _fail("lens.model", self.model, "Brown–Conrady distortion is rendered by the \"spectral_thin\" lens "
                  "(lens.model = \"auto\" picks it; a prescription has its own); set lens.model = \"spectral_thin\"")
        spectra.validate_transmission(self.transmission)


@dataclass(frozen=True)
class SensorSection:
    """The image sensor (EMVA 1288 linear model). Zero switches a noise term off. A scene that
    names ``model`` gets that camera's published full well, read noise, bit depth, pitch and
    base ISO for the keys it leaves unset (:func:`spectral_cam.spectra.with_camera_figures`);
    ``keep_field_of_view`` spreads ``width_px`` × ``height_px`` over the camera's sensor size."""

    model: str = "nikon_d850"
    width_px: int = 480
    height_px: int = 320
    pixel_pitch_um: float = 6.0
    keep_field_of_view: bool = False
    model_figures: tuple[str, ...] = ()
    cfa: str = "RGGB"
    peak_qe: float = 0.6
    full_well_e: float = 20000.0
    read_noise_e: float = 2.5
    dark_current_e_per_s: float = 1.0
    dsnu_e: float = 0.5
    prnu: float = 0.005
    bit_depth: int = 12
    black_level_dn: int = 256
    base_iso: float = 100.0
    ir_cut: float | str = 1.0
    seed: int = 0
    shot_noise: bool = True
    vignetting: bool = True
    crop_margin_px: int = 8
    olpf: float | str = "off"
    angular_response_deg: float | str | tuple = "off"
    shutter: str = "global"
    row_time_s: float = 10e-6
    kind: str = "cmos"
    jot_frames: int = 256
    jot_bits: int = 1
    dead_time_s: float = 0.0
    afterpulsing: float = 0.0
    event_threshold: float = 0.2
    event_threshold_sigma: float = 0.03
    event_refractory_s: float = 1e-4
    event_leak_hz: float = 0.1
    event_shot_noise_hz: float = 0.0
    event_frames: int = 16

    def __post_init__(self) -> None:
        for key in ("width_px", "height_px"):
            value = getattr(self, key)
            if not isinstance(value, int) or value < 1 or value > 20000:
                _fail(f"sensor.{key}", value, "must be a whole number of pixels in 1..20000")
        margin = self.crop_margin_px
        if not (isinstance(margin, int) and not isinstance(margin, bool) and 0 <= margin <= 256 and margin % 2 == 0):
            _fail("sensor.crop_margin_px", margin,
                  "must be an even whole number of pixels in 0..256 (even keeps the CFA phase at the crop)")
        _within("sensor.pixel_pitch_um", self.pixel_pitch_um)
        if not isinstance(self.keep_field_of_view, bool):
            _fail("sensor.keep_field_of_view", self.keep_field_of_view, "must be true or false")
        if isinstance(self.model_figures, list):
            object.__setattr__(self, "model_figures", tuple(self.model_figures))
        if not set(self.model_figures) <= set(spectra.SENSOR_FIGURE_KEYS.values()):
            _fail("sensor.model_figures", list(self.model_figures), "the keys the named model set (written by "
                  f"spectral_cam), among {', '.join(spectra.SENSOR_FIGURE_KEYS.values())}")
        if self.model != "ideal":
            spectra.validate_camera(self.model)
        if self.cfa not in CFA_PATTERNS:
            _fail("sensor.cfa", self.cfa, f"valid: {', '.join(CFA_PATTERNS)}")
        if self.cfa != "none" and min(self.width_px, self.height_px) < 2:
            _fail("sensor.width_px" if self.width_px < 2 else "sensor.height_px",
                  min(self.width_px, self.height_px), f"a {self.cfa} Bayer sensor needs at least 2×2 pixels")
        if self.cfa == "none" and self.model != "ideal":
            _fail("sensor.cfa", self.cfa, "a monochrome sensor needs sensor.model = 'ideal'")
        if not (isinstance(self.peak_qe, (int, float)) and 0 < self.peak_qe <= 1):
            _fail("sensor.peak_qe", self.peak_qe, "must lie in (0, 1]")
        for key in ("full_well_e", "read_noise_e", "dark_current_e_per_s", "dsnu_e", "prnu"):
            _within(f"sensor.{key}", getattr(self, key))
        if not isinstance(self.bit_depth, int) or not 8 <= self.bit_depth <= 16:
            _fail("sensor.bit_depth", self.bit_depth, "must be a whole number in 8..16")
        if not isinstance(self.black_level_dn, int) or not 0 <= self.black_level_dn < 2 ** self.bit_depth - 1:
            _fail("sensor.black_level_dn", self.black_level_dn,
                  f"must be a whole number in 0..{2 ** self.bit_depth - 2}")
        _within("sensor.base_iso", self.base_iso)
        if not isinstance(self.seed, int) or isinstance(self.seed, bool) or self.seed < 0:
            _fail("sensor.seed", self.seed, "must be a whole number >= 0")
        spectra.validate_transmission(self.ir_cut)
        from .sensor.olpf import check_olpf_margin
        from .sensor.shading import parse_angular_response

        check_olpf_margin(self.olpf, model=self.model, pixel_pitch_um=self.pixel_pitch_um, crop_margin_px=margin,
                          cfa=self.cfa)  # parses it; its light from beyond the frame must be rendered
        if isinstance(self.angular_response_deg, list):
            object.__setattr__(self, "angular_response_deg", tuple(self.angular_response_deg))
        parse_angular_response(self.angular_response_deg)
        if self.shutter not in ("global", "rolling"):
            _fail("sensor.shutter", self.shutter, "valid: 'global' (every row at once), 'rolling' (row by row, "
                  "row_time_s apart)")
        _check_photon_counting(self)
        if isinstance(self.row_time_s, bool) or not isinstance(self.row_time_s, (int, float)) \
                or not 0 < self.row_time_s <= 0.01:
            _fail("sensor.row_time_s", self.row_time_s, "must be the readout time of one row in (0, 0.01] s "
                  "(a full-frame sensor reads a row in ~5-20 µs)")

    @property
    def width_m(self) -> float:
        return self.width_px * self.pixel_pitch_um * 1e-6

    @property
    def height_m(self) -> float:
        return self.height_px * self.pixel_pitch_um * 1e-6


@dataclass(frozen=True)
class ExposureSection:
    """Exposure time (s, or ``"auto"``: metered as a camera does, ``metering``), ISO (a scene file
    that leaves it unset gets the sensor's ``base_iso``: a named camera's own), the
    exposure index's definition (``iso_definition``: ``sos`` renders a metered grey at 118/255,
    ``saturation`` leaves the rendering alone), ``compensation_ev``, and ``auto_fraction``
    (where ``highlight`` and ``etr`` metering put the brightest 1 %)."""

    time_s: float | str = "auto"
    iso: float = 100.0
    auto_fraction: float = 0.8
    metering: str = "average"
    compensation_ev: float = 0.0
    iso_definition: str = "sos"
    start_s: float = 0.0

    def __post_init__(self) -> None:
        from .metering import ISO_DEFINITIONS, METERING

        if isinstance(self.start_s, bool) or not isinstance(self.start_s, (int, float)) \
                or not (math.isfinite(self.start_s) and abs(self.start_s) <= 1e6):
            _fail("exposure.start_s", self.start_s, "the frame's start time in seconds (for a flickering light's "
                  "phase), a number within ±1e6")
        if self.time_s != "auto":
            _within("exposure.time_s", self.time_s)
        _within("exposure.iso", self.iso)
        if not 0 < self.auto_fraction <= 1:
            _fail("exposure.auto_fraction", self.auto_fraction, "must lie in (0, 1]")
        if self.metering not in METERING.names():
            _fail("exposure.metering", self.metering, f"unknown mode; valid: {', '.join(METERING.names())}")
        if not (isinstance(self.compensation_ev, (int, float)) and not isinstance(self.compensation_ev, bool)
                and -10 <= self.compensation_ev <= 10):
            _fail("exposure.compensation_ev", self.compensation_ev, "must be a number of stops in [-10, 10]")
        if self.iso_definition not in ISO_DEFINITIONS:
            _fail("exposure.iso_definition", self.iso_definition, f"valid: {', '.join(ISO_DEFINITIONS)}")


#: Mitsuba samplers for ``render.sampler`` (the first is the default; see
#: :data:`spectral_cam.render.scene_dict.SAMPLERS`, which must list the same).
RENDER_SAMPLERS = ("multijitter", "independent", "stratified", "ldsampler")
#: render.estimator: ``auto`` (the adaptive median of means where the scene can make fireflies,
#: else the mean), ``mean``, ``amon`` (:mod:`spectral_cam.render.robust`).
RENDER_ESTIMATORS = ("auto", "mean", "amon")
#: Pixel types of radiance.exr (render.radiance_precision).
RADIANCE_PRECISIONS = ("float", "half")


@dataclass(frozen=True)
class RenderSection:
    """Monte-Carlo rendering: samples per pixel, spectral bands, Mitsuba variant, seed.

    ``spp = "auto"`` renders rounds of four equal passes, 4× larger each round, until the
    Monte-Carlo noise is ≤ 0.3 of the sensor's own noise (at most ``max_spp``). ``sampler``
    is Mitsuba's: ``multijitter`` by default (7× less noise than ``independent`` at 256 spp on
    the bundled ColorChecker, docs/bench/samplers.csv). ``bands = "auto"`` is the 31-band grid
    ``400:700:10`` when a spectral output is wanted (``spectral_output``) or diffraction
    applies, else ``"camera"``: a 6-channel film of the photon-weighted camera curves and
    the CIE 1931 CMFs. ``radiance_precision`` is radiance.exr's pixel type: ``float``
    (binary32, the default) or ``half`` (half the bytes; its 0.049 % rounding is 10× below
    the shot noise of a 40 000 e⁻ full well, but a scene dimmer than 6.1e-5 W·m⁻²·sr⁻¹·nm⁻¹ loses
    digits, docs/design.md). ``estimator`` turns the passes into a pixel's radiance: ``mean``, or
    ``amon`` (the adaptive median of 8 pass means: no fireflies, :mod:`spectral_cam.render.robust`);
    ``auto`` takes ``amon`` where the scene can make fireflies (glossy, metal or glass
    materials, a user's XML scene) and ``spp`` is fixed. The same scene.toml gives the same
    bytes under load on the renderer's threads for the bundled presets (measured:
    :func:`spectral_cam.render.variants.deterministic_threads`); ``deterministic = true``
    renders on one thread, for anything else that may follow the threads' timing (a user's
    Python plugin), at the cost of the other cores.
    """

    spp: int | str = 64
    bands: str = "auto"
    variant: str = "auto"
    seed: int = 0
    max_depth: int = 8
    diffraction: str = "auto"
    spectral_output: bool = True
    radiance_precision: str = "float"
    max_spp: int = 1024
    sampler: str = "multijitter"
    estimator: str = "auto"
    deterministic: bool = False

    @property
    def spectral_bands(self) -> str:
        """The band grid of the render's spectrum: ``bands`` itself, or the default grid for
        ``"auto"`` and ``"camera"`` (a camera film's diffraction PSF is per band too)."""
        return self.bands if self.bands not in BAND_MODES else SPECTRAL_BANDS_DEFAULT

    def __post_init__(self) -> None:
        if self.estimator not in RENDER_ESTIMATORS:
            _fail("render.estimator", self.estimator, f"valid: {', '.join(RENDER_ESTIMATORS)} (auto: the adaptive median "
                  "of means where the scene can make fireflies, else the mean)")
        if self.sampler not in RENDER_SAMPLERS:
            _fail("render.sampler", self.sampler, f"valid: {', '.join(RENDER_SAMPLERS)} (Mitsuba's orthogonal "
                  "sampler rounds its sample count to a prime square, so it cannot hold the spp asked for)")
        if self.diffraction not in DIFFRACTION_MODES:
            _fail("render.diffraction", self.diffraction, f"valid: {', '.join(DIFFRACTION_MODES)}")
        if self.spp != "auto" and (not isinstance(self.spp, int) or not 1 <= self.spp <= MAX_SPP):
            _fail("render.spp", self.spp, f"must be a whole number in 1..{MAX_SPP} or 'auto'")
        if not isinstance(self.max_spp, int) or not 1 <= self.max_spp <= MAX_SPP:
            _fail("render.max_spp", self.max_spp, f"must be a whole number in 1..{MAX_SPP}")
        if self.bands not in BAND_MODES:
            spectra.parse_bands(self.bands)
        if self.radiance_precision not in RADIANCE_PRECISIONS:
            _fail("render.radiance_precision", self.radiance_precision,
                  f"valid: {', '.join(RADIANCE_PRECISIONS)} (radiance.exr's pixel type: 'half' halves the file, "
                  "0.049 % rounding from 6.1e-5 to 65504 W·m⁻²·sr⁻¹·nm⁻¹)")
        if self.bands == "camera" and self.spectral_output:
            _fail("render.bands", self.bands, "a camera film has no spectrum to write: set "
                  "render.spectral_output = false, or use 'auto' or a band grid")
        if self.variant != "auto" and "spectral" not in self.variant:
            _fail("render.variant", self.variant,
                  "must be 'auto' or a spectral Mitsuba variant such as 'llvm_ad_spectral', "
                  "'scalar_spectral' or 'cuda_ad_spectral'")
        if not isinstance(self.seed, int) or self.seed < 0:
            _fail("render.seed", self.seed, "must be a whole number >= 0")
        if not isinstance(self.max_depth, int) or self.max_depth < 1:
            _fail("render.max_depth", self.max_depth, "must be a whole number >= 1")


@dataclass(frozen=True)
class MotionSection:
    """Motion during the exposure: the camera's velocity (m/s) and angular velocity (°/s) in its
    own frame (x image-left, y up, z the view; yaw > 0 turns left, pitch > 0 tilts up, roll
    about the view), and ``object_velocity_mps`` (same axes): the velocity of the shape named
    ``object`` (an XML id or a preset's ``object_3``; its parts ``object_3_*`` move with it), or,
    with no ``object``, of the whole scene moving rigidly (the camera moving the other way). Rendered as ``subframes``
    time-stratified sub-frames (``"auto"``: one per half pixel of the largest motion), each
    with an equal share of the samples, averaged before the sensor; the exposure's middle is
    the pose of the depth label. Needs a fixed ``exposure.time_s`` and ``render.spp``."""

    camera_velocity_mps: tuple[float, ...] = (0.0, 0.0, 0.0)
    camera_angular_velocity_dps: tuple[float, ...] = (0.0, 0.0, 0.0)
    object_velocity_mps: tuple[float, ...] = (0.0, 0.0, 0.0)
    object: str = ""
    subframes: int | str = "auto"

    def __post_init__(self) -> None:
        for key in ("camera_velocity_mps", "camera_angular_velocity_dps", "object_velocity_mps"):
            values = getattr(self, key)
            if len(values) != 3 or not all(math.isfinite(v) and abs(v) <= 1e5 for v in values):
                _fail(f"motion.{key}", list(values), "give three numbers within ±1e5")
        if self.subframes != "auto" and not (isinstance(self.subframes, int) and not isinstance(self.subframes, bool)
                                            and 1 <= self.subframes <= 4096):
            _fail("motion.subframes", self.subframes, "give 'auto' or a whole number in 1..4096")

    @property
    def moving(self) -> bool:
        return any(self.camera_velocity_mps) or any(self.camera_angular_velocity_dps) or any(self.object_velocity_mps)


_SECTIONS = {
    "scene": SceneSection,
    "illuminant": IlluminantSection,
    "sky": SkySection,
    "lens": LensSection,
    "sensor": SensorSection,
    "exposure": ExposureSection,
    "motion": MotionSection,
    "render": RenderSection,
    "isp": ISPSection,
}


@dataclass(frozen=True)
class SceneConfig:
    """A whole, validated scene: one frozen section per TOML table."""

    scene: SceneSection = field(default_factory=SceneSection)
    illuminant: IlluminantSection = field(default_factory=IlluminantSection)
    sky: SkySection = field(default_factory=SkySection)
    lens: LensSection = field(default_factory=LensSection)
    sensor: SensorSection = field(default_factory=SensorSection)
    exposure: ExposureSection = field(default_factory=ExposureSection)
    motion: MotionSection = field(default_factory=MotionSection)
    render: RenderSection = field(default_factory=RenderSection)
    isp: ISPSection = field(default_factory=ISPSection)

    def to_dict(self) -> dict[str, dict[str, Any]]:
        """Plain, JSON/TOML-serialisable dict (tuples become lists)."""
        out = {}
        for name in _SECTIONS:
            section = dataclasses.asdict(getattr(self, name))
            out[name] = {k: list(v) if isinstance(v, tuple) else v for k, v in section.items()}
        out["scene"]["assets"] = [spec.to_table() for spec in self.scene.assets]
        out["scene"]["scatter"] = [spec.to_table() for spec in self.scene.scatter]
        return out

    def to_toml(self) -> str:
        """The whole resolved scene as a TOML scene file (``load_scene`` reads it back equal)."""
        lines = ["# spectral_cam scene, every key resolved"]
        for name, table in self.to_dict().items():
            lines.append(f"\n[{name}]")
            lines += [f"{key} = {_toml_value(value)}" for key, value in table.items()]
        return "\n".join(lines) + "\n"

    def replace(self, **overrides: Any) -> "SceneConfig":
        """A copy with ``"section.key": value`` overrides applied and validated."""
        # its instance budget was reckoned when it was read: copies that move only the focus, the
        # light or the lens (the capture plan's) are not reckoned again, each with a lens of its own
        return scene_from_dict(_CheckedDict(self.to_dict()), overrides=overrides)


def _budget_reckoned(data: Mapping[str, Any], overrides: Mapping[str, Any] | None) -> bool:
    """Whether ``scene_from_dict`` must reckon the scatter's instance budget: always for a scene
    read from a file or a dict, and for a copy whose overrides change what the count depends on
    (the copies, the ground in view: :data:`_BUDGET_KEYS`, any ``[sensor]`` key)."""
    if not isinstance(data, _CheckedDict):
        return True
    return any(str(key) in _BUDGET_KEYS or str(key).startswith("sensor.") for key in (overrides or {}))


#: The keys besides ``[sensor]`` that change how many copies a scene holds.
_BUDGET_KEYS = frozenset({"scene.scatter", "scene.assets", "scene.preset", "scene.distance_m", "scene.view_pitch_deg",
                          "scene.layout_seed", "lens.focal_length_mm"})


class _CheckedDict(dict):
    """A config's own dict, whose instance budget was reckoned when it was read."""


def _toml_value(value: Any) -> str:
    """A TOML literal for the value types scene sections hold."""
    import json

    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)  # a JSON string is a valid TOML basic string
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_toml_value(item) for item in value) + "]"
    if isinstance(value, Mapping):  # an inline table ([[scene.assets]] entries, distributions)
        return "{" + ", ".join(f"{key} = {_toml_value(item)}" for key, item in value.items()) + "}"
    raise ConfigError(f"cannot write {value!r} ({type(value).__name__}) to TOML")


# ----------------------------------------------------------------------------- coercion
def _coerce(key: str, value: Any, default: Any, annotation: str) -> Any:
    """Check a TOML value against a field's type and convert int->float, list->tuple."""
    kinds = annotation.replace(" ", "").split("|")
    if isinstance(value, bool):
        if "bool" in kinds:
            return value
    elif isinstance(value, int) and "int" in kinds:
        return value
    elif isinstance(value, (int, float)) and "float" in kinds:
        return float(value)
    elif isinstance(value, float) and "int" in kinds and value.is_integer():
        return int(value)
    elif isinstance(value, str) and "str" in kinds:
        return value
    elif isinstance(value, (list, tuple)) and any(k.startswith("tuple") for k in kinds):
        inner = "float" if "float" in annotation else "str"
        items = []
        for item in value:
            if inner == "float" and isinstance(item, (int, float)) and not isinstance(item, bool):
                items.append(float(item))
            elif inner == "str" and isinstance(item, str):
                items.append(item)
            else:
                _fail(key, value, f"must be a list of {inner} values")
        return tuple(items)
    expected = " or ".join("a list" if k.startswith("tuple") else k for k in kinds)
    _fail(key, value, f"has the wrong type; expected {expected} (default {default!r})")


def _resolve_path(value: Any, base_dir: Path) -> Any:
    """Make a relative file path (CSV, XML) relative to the scene file's folder."""
    if isinstance(value, str) and (value.lower().endswith((".csv", ".xml"))):
        path = Path(value).expanduser()
        if not path.is_absolute():
            path = base_dir / path
        return str(path.resolve())
    return value


def _shading_table_path(value: str, base_dir: Path) -> str:
    """``isp.shading``: ``"off"``, or a table's path resolved against the scene file's folder and
    read now, so a missing or broken table is refused at load, not after the render (issue 39 #24)."""
    if value == "off" or not value:
        return value  # ISPSection names what is valid for an empty one
    from .isp.shading import load_shading_table

    path = Path(value).expanduser()
    path = (path if path.is_absolute() else base_dir / path).resolve()
    load_shading_table(path)
    return str(path)


def parse_override(text: str) -> tuple[str, Any]:
    """Split ``"section.key=value"``; the value is read as a TOML value, else a string."""
    if "=" not in text:
        raise ConfigError(f"override {text!r}: use section.key=value, e.g. lens.f_number=2.8")
    key, raw = (part.strip() for part in text.split("=", 1))
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw
    return key, value


def scene_from_dict(
    data: Mapping[str, Any],
    *,
    overrides: Mapping[str, Any] | None = None,
    base_dir: str | Path = ".",
) -> SceneConfig:
    """Build and validate a :class:`SceneConfig` from nested dicts (as read from TOML).

    Parameters
    ----------
    data
        ``{"section": {"key": value}}``; missing keys take their defaults.
    overrides
        ``{"section.key": value}`` applied on top (values as Python objects or strings).
    base_dir
        Folder that relative CSV/XML paths are resolved against.

    Raises
    ------
    ConfigError
        For an unknown section or key (listing the valid ones) or an invalid value.
    """
    base_dir = Path(base_dir)
    merged: dict[str, dict[str, Any]] = {}
    for section, table in data.items():
        if section not in _SECTIONS:
            raise ConfigError(f"unknown section [{section}]; valid: {', '.join(_SECTIONS)}")
        if not isinstance(table, Mapping):
            raise ConfigError(f"[{section}] must be a table of key = value pairs")
        merged[section] = dict(table)
    for dotted, value in (overrides or {}).items():
        section, _, key = str(dotted).partition(".")
        if section not in _SECTIONS or not key:
            raise ConfigError(
                f"override {dotted!r}: use section.key with a section among {', '.join(_SECTIONS)}"
            )
        merged.setdefault(section, {})[key] = value
    merged["sensor"] = _sensor_table(merged.get("sensor", {}), data, overrides)
    sections = {name: section_from_table(name, merged.get(name, {}), base_dir) for name in _SECTIONS
                if name not in ("lens", "exposure")}
    # an ISO left unset is the sensor's base ISO (a named camera's own: 64 for a D850), as a camera
    # leaves it until the light asks for more; the generic sensor's base is 100, as before
    exposure = dict(merged.get("exposure", {}))
    exposure.setdefault("iso", sections["sensor"].base_iso)
    sections["exposure"] = section_from_table("exposure", exposure, base_dir)
    # the prescription first: it sees what the user gave, not a default filled in for an XML camera
    lens_table = _lens_for_prescription(dict(merged.get("lens", {})), base_dir)
    lens_table = _lens_for_xml_camera(lens_table, sections["scene"], sections["sensor"])
    sections["lens"] = section_from_table("lens", lens_table, base_dir)
    copies = sections["scene"].scatter or any(a.count > 1 for a in sections["scene"].assets)
    if copies and _budget_reckoned(data, overrides):
        from .optics import ThinLens
        from .presets.scatter import check_instance_budget

        check_instance_budget(SceneConfig(**sections), ThinLens.from_config(sections["lens"], sections["sensor"]))
    if sections["motion"].moving:
        if sections["exposure"].time_s == "auto":
            _fail("exposure.time_s", "auto", "motion blur needs a fixed exposure time (the blur is velocity × time); "
                  "give exposure.time_s in seconds")
        if sections["render"].spp == "auto":
            _fail("render.spp", "auto", "motion blur splits the samples between sub-frames; give render.spp")
    return SceneConfig(**sections)


def _sensor_table(table: Mapping[str, Any], data: Mapping[str, Any], overrides: Mapping[str, Any] | None) -> dict:
    """The ``[sensor]`` table with a named camera's figures for the keys left unset (issue 39 #9:
    a D850 and an α7 III got the same full well). A copy (:meth:`SceneConfig.replace`) holds the
    figures its first model filled in, and the pitch its frame derived: a new model or frame size
    fills and derives them again, unless the overrides set them."""
    given = {str(key).partition(".")[2] for key in (overrides or {}) if str(key).startswith("sensor.")}
    table = dict(table)
    if isinstance(data, _CheckedDict):
        from_model = set(table.get("model_figures", ())) - given
        if table.get("model") != data.get("sensor", {}).get("model"):
            if not from_model:  # the first named no camera: its generic figures give way too
                from_model = {key for key in spectra.SENSOR_FIGURE_KEYS.values()
                              if key not in given and table.get(key) == getattr(SensorSection, key)}
            for key in from_model:  # the first camera's figures: the new camera's take their place
                table.pop(key, None)
            from_model = set()
        table["model_figures"] = [key for key in table.get("model_figures", ()) if key in from_model]
        if table.get("keep_field_of_view") is True and "pixel_pitch_um" not in given:
            table.pop("pixel_pitch_um", None)
    return spectra.with_camera_figures(table, default_size_px=(SensorSection.width_px, SensorSection.height_px))


def _lens_for_prescription(lens: dict[str, Any], base_dir: Path) -> dict[str, Any]:
    """For ``model = "prescription"``: the focal length is the prescription's (paraxial EFL), the
    f-number the one asked (the stop is closed to it when rendered), or unset the design's own
    (traced: the focal length over the widest axial bundle that passes every aperture); one
    faster than the design's is refused. A relative CSV path is resolved against the scene
    file's folder here, once, before it is read (issue 39 #12: it was read from the working
    directory, then resolved again)."""
    if "prescription" in lens:
        lens = dict(lens, prescription=_resolve_path(lens["prescription"], base_dir))
    if lens.get("model") != "prescription":
        return lens
    from .optics.prescription import focal_length_and_f_number

    name = str(lens.get("prescription", "dgauss_50mm"))
    focal_m, own_f_number = focal_length_and_f_number(name)
    asked = lens.get("f_number")
    if not (isinstance(asked, (int, float)) and not isinstance(asked, bool)):
        asked = own_f_number if asked is None else asked  # a wrong type: LensSection says so
    elif asked < own_f_number * (1 - 1e-4):
        _fail("lens.f_number", asked, f"lens.prescription {name!r} opens to f/{own_f_number:.4g} at most: valid "
              f"f-numbers are >= {own_f_number:.4g} (the stop is closed to a slower one), or leave it unset")
    given = lens.get("focal_length_mm")
    number = isinstance(given, (int, float)) and not isinstance(given, bool)
    if number and abs(given - focal_m * 1e3) > 1e-6 * focal_m * 1e3:
        import warnings  # a prescription is a real lens: said, not done silently (issue 25 #15)

        from .errors import SceneWarning

        warnings.warn(f"lens.prescription {name!r} replaces lens.focal_length_mm = {given!r} by its "
                      f"{focal_m * 1e3:.4g} (a prescription's focal length is its own); leave it unset",
                      SceneWarning, stacklevel=4)
    return dict(lens, focal_length_mm=focal_m * 1e3, f_number=asked)


def _lens_for_xml_camera(lens: dict[str, Any], scene: SceneSection, sensor: SensorSection) -> dict[str, Any]:
    """The lens table with ``focal_length_mm`` resolved: for a user's XML scene left unset (or
    ``"auto"``) it keeps the XML camera's horizontal field of view on this sensor
    (:func:`spectral_cam.xml_scene.focal_length_for_fov`); a value given is kept (the render
    records, and warns, when it replaces the XML camera's field of view). Without an XML camera
    (or for a preset) ``"auto"`` is the default 8 mm."""
    from .xml_scene import focal_length_for_fov, xml_field_of_view

    given = lens.get("focal_length_mm", "auto")
    if given != "auto":
        return lens
    fov = xml_field_of_view(scene.mitsuba_xml) if scene.mitsuba_xml else None
    focus = lens.get("focus_distance_m", LensSection.focus_distance_m)
    if fov is None or not isinstance(focus, (int, float)) or isinstance(focus, bool) or focus <= 0:
        lens["focal_length_mm"] = LensSection.focal_length_mm  # LensSection reports a bad focus
        return lens
    width_m = sensor.width_px * sensor.pixel_pitch_um * 1e-6
    lens["focal_length_mm"] = focal_length_for_fov(fov.fov_x_deg, width_m, float(focus))
    return lens


def section_from_table(name: str, table: Mapping[str, Any], base_dir: str | Path = ".") -> Any:
    """One validated section (``[isp]``, ``[lens]``, …) from a table of its keys, defaults for
    the rest: what :func:`scene_from_dict` does per section, for callers that need only one
    (``spectral-cam develop`` builds its ``[isp]`` without validating a whole scene).

    Raises
    ------
    ConfigError
        For an unknown section or key (listing the valid ones) or an invalid value.

    Examples
    --------
    >>> section_from_table("isp", {"demosaic": "bilinear", "denoise": 1}).denoise
    1.0
    """
    if name not in _SECTIONS:
        raise ConfigError(f"unknown section [{name}]; valid: {', '.join(_SECTIONS)}")
    cls = _SECTIONS[name]
    known = {f.name: f for f in fields(cls)}
    unknown = sorted(set(table) - set(known))
    if unknown:
        raise ConfigError(
            f"unknown key(s) {', '.join(f'{name}.{k}' for k in unknown)}; valid keys of "
            f"[{name}]: {', '.join(known)}"
        )
    kwargs = {key: _coerce(f"{name}.{key}", _resolve_path(value, Path(base_dir)), known[key].default,
                           str(known[key].type)) for key, value in table.items() if key not in _ENTRY_LISTS.get(name, {})}
    for key, parse in _ENTRY_LISTS.get(name, {}).items():
        if key in table:
            kwargs[key] = _entry_list(f"{name}.{key}", table[key], parse, Path(base_dir))
    if name == "isp" and isinstance(kwargs.get("shading"), str):
        kwargs["shading"] = _shading_table_path(kwargs["shading"], Path(base_dir))
    try:
        return cls(**kwargs)
    except ConfigError:
        raise
    except (TypeError, ValueError) as exc:  # e.g. a comparison with a wrong type
        raise ConfigError(f"[{name}]: {exc}") from None


#: Keys whose value is an array of tables ([[scene.assets]]), each validated by its own parser.
_ENTRY_LISTS = {"scene": {"assets": lambda table, k, base: asset_from_table(table, k, base),
                          "scatter": lambda table, k, base: scatter_from_table(table, k)}}


def _entry_list(key: str, value: Any, parse, base_dir: Path) -> tuple:
    if isinstance(value, Mapping):  # a single table given with --set
        value = [value]
    if not isinstance(value, (list, tuple)):
        _fail(key, value, f"give an array of tables ([[{key}]] in the scene file)")
    return tuple(parse(table, k, base_dir) for k, table in enumerate(value))


def read_toml(path: str | Path, what: str) -> dict:
    """Read a TOML file (a scene file, validation plan, dataset spec, ...) into a dict.

    Raises
    ------
    ConfigError
        Naming ``what`` when the file is missing, unreadable (or its path holds a NUL byte),
        not UTF-8, or not valid TOML.
    """
    try:
        path = Path(path)
        if not path.is_file():
            raise ConfigError(f"{what} {str(path)!r} does not exist or is not a file")
        text = path.read_text(encoding="utf-8")
    except (OSError, ValueError) as exc:  # unreadable, not UTF-8, or a path with a NUL byte
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError(f"cannot read {what} {str(path)!r}: {exc}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{path} is not a valid TOML {what}: {exc}") from None


def load_scene(path: str | Path, overrides: Mapping[str, Any] | list[str] | None = None) -> SceneConfig:
    """Read a scene file, apply overrides and validate.

    Parameters
    ----------
    path
        The ``.toml`` scene file, or a Mitsuba 3 ``.xml`` scene: it is then the scene as
        ``[scene] mitsuba_xml = path`` with every other key at its default (its camera's pose and
        field of view kept, :func:`_lens_for_xml_camera`); overrides set the rest.
    overrides
        ``{"lens.f_number": 2.8}`` or a list of ``"section.key=value"`` strings.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> folder = pathlib.Path(tempfile.mkdtemp())
    >>> _ = (folder / "scene.toml").write_text("lens = { f_number = 4.0 }")
    >>> scene = load_scene(folder / "scene.toml", overrides={"sensor.width_px": 64})
    >>> scene.lens.f_number, scene.sensor.width_px, scene.scene.preset
    (4.0, 64, 'colorchecker')
    """
    path = Path(path)
    if path.suffix.lower() == ".xml":  # a user's Mitsuba scene needs no wrapper TOML (issue 39 #18)
        if not path.is_file():
            raise ConfigError(f"scene file {str(path)!r} does not exist; give a .toml scene file or a "
                              "Mitsuba 3 .xml scene")
        data: dict[str, Any] = {"scene": {"mitsuba_xml": str(path.resolve())}}
    else:
        data = read_toml(path, "scene file")
    if isinstance(overrides, (list, tuple)):
        overrides = dict(parse_override(item) for item in overrides)
    return scene_from_dict(data, overrides=overrides, base_dir=path.parent)
