"""The capture plan: every modelling decision of a job, made once, before rendering.

:func:`make_plan` turns a validated :class:`~spectral_cam.scene.SceneConfig` into a frozen
:class:`CapturePlan`. In order, it resolves the focus (``lens.focus_object``), builds the lens
(the frame's, and the capture lens that adds the sensor's crop margin), chooses the Mitsuba
variant, resolves the light (an XML scene's own emitter), judges the field of view, picks
the estimator, renders the one depth probe the decisions need, decides the lens model, the
diffraction and the film (spectral bands or camera channels), the layered model's margin and
the tiles, and checks memory and disk against a budget.

The plan holds the resolved config (what ``scene.toml`` writes: no ``"auto"`` left where a choice
was made before rendering), each decision with its reason, the optics, and the budget. Decisions
that need the rendered image (``render.spp = "auto"``, ``exposure.time_s = "auto"``, the ISP's
colour matrix) stay policies in the config; their outcomes are recorded once, in ``meta.json``.
:func:`spectral_cam.render.render` executes a plan; ``spectral-cam render --dry-run`` prints
one (:meth:`CapturePlan.summary`). A plan holds no Mitsuba object: it pickles to a Dask worker,
which checks the variant on its own machine.

References
----------
.. [1] docs/design.md, "The capture plan".
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass, field
from typing import Iterable

import numpy as np

from ..budget import estimate_result_bytes, measured_budget
from ..optics import ThinLens
from ..scene import SceneConfig
from .lens_models import LENS_MODELS

__all__ = ["CapturePlan", "make_plan", "layered_margin", "clamp_margin", "warn_wide_view", "xml_field_of_view_record",
           "WIDEST_RECTILINEAR_DEG"]

@dataclass(frozen=True)
class CapturePlan:
    """Everything decided about a capture before it is rendered.

    Attributes
    ----------
    config : SceneConfig
        The resolved config: focus distance, light, lens model, bands, variant and estimator as
        chosen; ``scene.toml`` writes it, and rendering it again decides the same.
    requested : SceneConfig
        The config as given.
    lens : ThinLens
        The frame's lens (``meta.optics`` describes it).
    capture_lens : ThinLens
        The lens of the rendered area: the frame and the sensor's crop margin.
    lens_model : str
        ``pinhole``, ``thin``, ``layered``, ``spectral_thin`` or ``prescription``.
    variant : str
        The Mitsuba variant.
    decisions : dict
        Name → record (``choice``, ``reason``, inputs), in the order made.
    camera_film : bool
        The film integrates the camera's curves (6 channels) rather than spectral bands.
    diffraction : bool
        The per-band Airy PSF applies.
    estimator_passes : int
        K groups of passes for the adaptive median of means (1: the mean).
    subframes : int
        Time-stratified motion sub-frames (1 without motion).
    layered_margin_px : int
        Pixels the layered model renders around the capture area (0 for other models).
    tiles : int
        Mitsuba calls per pass (frames above the tile size render in tiles).
    budget : dict
        ``memory_bytes`` (estimated peak), ``memory_available_bytes``, ``time_s`` (estimated
        wall time; None unless measured), ``outputs_bytes`` (per result file, uncompressed),
        ``probe`` (the measured cost, when measured).
    depth_m : numpy.ndarray or None
        The depth probe over the capture area (m), when one was rendered; the depth output of a
        pinhole or thin-lens job.
    aerial : bool
        The air veils far ground (:mod:`spectral_cam.render.aerial`).
    """

    config: SceneConfig
    requested: SceneConfig
    lens: ThinLens
    capture_lens: ThinLens
    lens_model: str
    variant: str
    decisions: dict
    camera_film: bool
    diffraction: bool
    estimator_passes: int
    subframes: int
    layered_margin_px: int
    tiles: int
    budget: dict
    depth_m: np.ndarray | None = field(default=None, repr=False, compare=False)
    depth_s: float = 0.0
    aerial: bool = False

    @property
    def channels(self) -> int:
        """Values per pixel of the film: 6 camera channels or the spectral bands."""
        from ..spectra import parse_bands

        return 6 if self.camera_film else len(parse_bands(self.config.render.spectral_bands))

    @property
    def crop_margin_px(self) -> int:
        """Real pixels rendered around the frame for the RAW's crop (0 for a plain render)."""
        return (self.capture_lens.width_px - self.lens.width_px) // 2

    def record(self) -> dict:
        """The plan as plain JSON-ready data (``meta.json → plan``): decisions, optics, frame,
        budget (without the machine's free memory, which changes from run to run); no arrays."""
        from .trace import frame_optics

        return {"lens_model": self.lens_model, "variant": self.variant,
                "film": {"kind": "camera" if self.camera_film else "bands",
                         "bands": None if self.camera_film else self.config.render.spectral_bands, "channels": self.channels,
                         "diffraction": self.diffraction},
                "optics": frame_optics(self.capture_lens),
                "frame": {"width_px": self.lens.width_px, "height_px": self.lens.height_px,
                          "crop_margin_px": self.crop_margin_px,
                          "layered_margin_px": self.layered_margin_px, "tiles": self.tiles,
                          "estimator_passes": self.estimator_passes, "seed": self.config.render.seed},
                "budget": {k: v for k, v in self.budget.items() if k != "memory_available_bytes"},
                "decisions": self.decisions}

    def summary(self) -> str:
        """What ``--dry-run`` prints: one line per decision, then the optics and the budget."""
        lines = [f"{name}: {record.get('choice')} — {record.get('reason', '')}".rstrip(" —")
                 for name, record in self.decisions.items()]
        lens = self.lens
        lines.append(f"optics: {lens.focal_length_m * 1e3:.4g} mm f/{lens.f_number:.3g} focused at "
                     f"{lens.focus_distance_m:.4g} m, {lens.fov_x_deg:.3g}° × {lens.fov_y_deg:.3g}° on "
                     f"{lens.sensor_width_m * 1e3:.3g} × {lens.sensor_height_m * 1e3:.3g} mm "
                     f"({lens.width_px} × {lens.height_px} px, +{self.crop_margin_px} px crop margin"
                     + (f", +{self.layered_margin_px} px defocus margin" if self.layered_margin_px else "") + ")")
        lines += self._view_lines()
        budget = self.budget
        spp = self.config.render.spp
        lines.append(f"render: {spp} spp ({'up to ' + str(self.config.render.max_spp) if spp == 'auto' else 'fixed'}), "
                     f"{self.channels} channels, {self.tiles} tile(s), seed {self.config.render.seed}")
        when = f"about {budget['time_s']:.3g} s" if budget["time_s"] is not None else "time not measured"
        lines.append(f"budget: {when}, peak memory about {budget['memory_bytes'] / 1e9:.2g} GB "
                     f"of {budget['memory_available_bytes'] / 1e9:.3g} GB available")
        if budget.get("outputs_bytes"):
            lines.append("outputs: " + ", ".join(f"{name} {size / 1e6:.3g} MB"
                                                 for name, size in budget["outputs_bytes"].items()))
        return "\n".join(lines)


    def _view_lines(self) -> list[str]:
        """The dry run's view and defocus (issue 39 #10: a 128 × 96 frame at the camera's pitch was
        a 5.5° view with |CoC| ≤ 1.7 px, unsaid): the circle of confusion, in pixels, over the depth
        probe's nearest and farthest finite depths, and the part of a named camera's sensor the
        frame covers."""
        lens, sensor, lines = self.lens, self.config.sensor, []
        depth = None if self.depth_m is None else np.asarray(self.depth_m, dtype=float)
        depth = None if depth is None else depth[np.isfinite(depth) & (depth > 0)]
        if depth is not None and depth.size:
            coc = np.asarray(lens.coc_diameter_px(depth), dtype=float)
            lines.append(f"view: {lens.fov_x_deg:.3g}° × {lens.fov_y_deg:.3g}°; circle of confusion "
                         f"{coc.min():.3g}–{coc.max():.3g} px over the depths {depth.min():.3g}–{depth.max():.3g} m "
                         f"(focus {lens.focus_distance_m:.4g} m, f/{lens.f_number:.3g})")
        else:
            lines.append(f"view: {lens.fov_x_deg:.3g}° × {lens.fov_y_deg:.3g}° (no depth probe: no defocus)")
        if "pixel_pitch_um" in sensor.model_figures:  # the camera's own pixels: a frame smaller than its sensor
            from ..spectra import camera_figures

            figures = camera_figures(sensor.model)
            width_mm, height_mm = figures["sensor_width_mm"].value, figures["sensor_height_mm"].value
            frame_w, frame_h = lens.sensor_width_m * 1e3, lens.sensor_height_m * 1e3
            if frame_w < 0.99 * width_mm and frame_h < 0.99 * height_mm:
                lines.append(f"sensor: a {frame_w:.3g} × {frame_h:.3g} mm crop of the {sensor.model}'s "
                             f"{width_mm:g} × {height_mm:g} mm sensor (sensor.keep_field_of_view = true spreads "
                             "the pixels over all of it)")
        return lines


#: The widest diagonal field a rectilinear lens covers well: a 12 mm lens on a 36 × 24 mm
#: sensor (122°). A few lenses go further (Laowa 9 mm f/5.6 FF: 135°), at corners a
#: photographer avoids.
WIDEST_RECTILINEAR_DEG = 122.0


def warn_wide_view(lens: ThinLens) -> None:
    """A SceneWarning when the frame's diagonal field passes :data:`WIDEST_RECTILINEAR_DEG`:
    ``sensor.width_px`` × ``pixel_pitch_um`` sets the sensor's size, so a big frame behind the
    default 8 mm lens is an extreme wide angle (8000 × 6000 px at 6 µm: 143° across), whose
    corners get cos⁴θ of the centre's light and a 1/cos²θ stretch (issue 25 #8: the meter read
    a dark corner and clipped a quarter of the centre)."""
    diagonal = lens.fov_diagonal_deg
    if diagonal <= WIDEST_RECTILINEAR_DEG:
        return
    import warnings

    from ..errors import SceneWarning

    corner = math.radians(diagonal / 2)
    widest_f = math.hypot(lens.sensor_width_m, lens.sensor_height_m) / 2 / math.tan(math.radians(WIDEST_RECTILINEAR_DEG / 2))
    warnings.warn(f"a {lens.sensor_width_m * 1e3:.3g} × {lens.sensor_height_m * 1e3:.3g} mm sensor (sensor.width_px × "
                  f"pixel_pitch_um) behind a {lens.focal_length_m * 1e3:.3g} mm lens sees {lens.fov_x_deg:.0f}° across "
                  f"and {diagonal:.0f}° diagonally, wider than rectilinear lenses reach ({WIDEST_RECTILINEAR_DEG:.0f}°, "
                  f"a 12 mm lens on full frame): its corners get {100 * math.cos(corner) ** 4:.2g} % of the centre's "
                  f"light, stretched {1 / math.cos(corner) ** 2:.2g}×. Set lens.focal_length_mm ≥ {widest_f * 1e3:.3g}, "
                  "or a smaller sensor.pixel_pitch_um or frame, for a usual view", SceneWarning, stacklevel=3)


def xml_field_of_view_record(config: SceneConfig, lens: ThinLens) -> dict:
    """Whether the render keeps an XML camera's horizontal field of view (meta.json)."""
    from ..xml_scene import xml_field_of_view

    ours = lens.layout_lens.fov_x_deg
    xml = xml_field_of_view(config.scene.mitsuba_xml)
    if xml is None:
        return {"choice": "ours", "fov_x_deg": ours, "reason": "the XML has no perspective or thin-lens camera "
                "whose field of view could be read; lens.focal_length_mm sets it"}
    kept = abs(ours / xml.fov_x_deg - 1) <= 0.01
    if not kept:
        import warnings

        from ..errors import SceneWarning

        warnings.warn(f"lens.focal_length_mm = {config.lens.focal_length_mm:g} gives a {ours:.3g}° field of view on "
                      f"this {lens.layout_lens.sensor_width_m * 1e3:.3g} mm-wide sensor, replacing the XML camera's "
                      f"{xml.fov_x_deg:.3g}° field of view ({xml.source}); leave lens.focal_length_mm unset to keep "
                      "it", SceneWarning, stacklevel=3)
    return {"choice": "kept" if kept else "replaced", "fov_x_deg": ours, "xml_fov_x_deg": xml.fov_x_deg,
            "focal_length_mm": config.lens.focal_length_mm, "xml_camera": xml.source,
            "reason": "lens.focal_length_mm derived from the XML camera" if kept else
            "lens.focal_length_mm set in the scene file replaces the XML camera's field of view"}


def _xml_focal_length_mm(config: SceneConfig) -> float | None:
    """The focal length (mm) that gives an XML scene's camera its field of view on this sensor at
    ``lens.focus_distance_m``; None without an XML camera whose field of view can be read."""
    from ..xml_scene import focal_length_for_fov, xml_field_of_view

    fov = xml_field_of_view(config.scene.mitsuba_xml) if config.scene.mitsuba_xml else None
    if fov is None:
        return None
    return focal_length_for_fov(fov.fov_x_deg, config.sensor.width_m, config.lens.focus_distance_m)


def _focused(config: SceneConfig, frame: ThinLens) -> tuple[SceneConfig, dict | None, ThinLens]:
    """``lens.focus_object`` resolved (:func:`spectral_cam.render.focus.resolve_focus`): the config,
    the focus decision (None without a focus object) and the frame's lens, refocused.

    A focal length derived from an XML camera (left unset by the user) is derived again where the
    focus moves, to keep that camera's field of view (issue 26: a warning blamed a focal length
    the user never set)."""
    from .focus import resolve_focus

    derived_mm = _xml_focal_length_mm(config)
    keeps_xml_view = derived_mm is not None and abs(config.lens.focal_length_mm / derived_mm - 1.0) <= 1e-9
    config, focus_record, frame = resolve_focus(config, frame)
    if focus_record is not None and keeps_xml_view:
        focal_mm = _xml_focal_length_mm(config)
        config = config.replace(**{"lens.focal_length_mm": focal_mm})
        frame = dataclasses.replace(frame, focal_length_m=focal_mm * 1e-3)
    return config, focus_record, frame


def _choices(config: SceneConfig, decisions: dict, *, lens_model: str, variant: str, camera_film: bool,
             diffract: bool, subframes: int) -> dict:
    """The config keys the plan resolved (no ``"auto"`` left where it chose before rendering), for
    :meth:`SceneConfig.replace`: what ``scene.toml`` writes."""
    choices = {"lens.model": lens_model, "render.variant": variant,
               "render.bands": "camera" if camera_film else decisions["bands"]["choice"],
               "render.estimator": decisions["estimator"]["choice"]}
    choices["render.diffraction"] = "on" if diffract else "off"
    if config.motion.moving:
        choices["motion.subframes"] = subframes
    if not config.scene.mitsuba_xml and config.scene.light == "auto":
        from ..presets.common import reads_light
        from ..presets.outdoor import light_kind

        choices["scene.light"] = light_kind(config) if reads_light(config.scene.preset) else "illuminant"
    return choices


def _lens_model_decision(config: SceneConfig, capture: ThinLens, depth: np.ndarray | None) -> tuple[str, dict]:
    from .decisions import decide_lens_model

    requested = config.lens.model
    if requested != "auto":
        return requested, {"choice": requested, "reason": f"lens.model = {requested!r}"}
    return decide_lens_model(capture, depth, config)


def layered_margin(lens: ThinLens, depth: np.ndarray) -> int:
    """Pixels the layered model renders around ``lens``'s area so that light from just outside
    blurs in: half the largest CoC in view (the CoC at infinity where a pixel saw nothing) + 1."""
    finite = depth[np.isfinite(depth)]
    reach = [float(lens.coc_diameter_px(z)) for z in (finite.min(), finite.max())] if finite.size else []
    if not np.all(np.isfinite(depth)):
        reach.append(float(lens.coc_diameter_px(math.inf)))
    return clamp_margin(lens, int(math.ceil(max(reach, default=0.0) / 2.0)) + 1)


def clamp_margin(lens: ThinLens, margin: int) -> int:
    """A layered margin the widened film can hold: at most the frame's longer side, and the film
    at most 20000 px wide."""
    longest = max(lens.width_px, lens.height_px)
    return min(margin, longest, (20000 - longest) // 2)


#: Frame width (px) and samples per pixel of the radiance probe that measures a scene's cost.
PROBE_WIDTH_PX, PROBE_SPP = 96, 16


def _resident_bytes() -> float:
    """This process's resident memory now (Linux ``/proc/self/statm``), or NaN where unknown."""
    import os

    try:
        with open("/proc/self/statm") as handle:
            return float(handle.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return math.nan


def measure_cost(config: SceneConfig, traced: ThinLens, lens_model: str, variant: str, camera_film: bool) -> dict:
    """The scene's own cost on this machine, from radiance probes of the traced area (same view,
    coarser pixels) at :data:`PROBE_WIDTH_PX` and 4× that width (at most the frame's), at
    :data:`PROBE_SPP` spp, each rendered three times through the job's geometry on one loaded
    scene. Mitsuba compiles a kernel per film size and spp (measured: 0.6 s for the
    ColorChecker, 2.2 s for the tabletop), so a first render's extra time is the compile. The
    repeats (the quicker of two: timing jitter) of the two sizes differ by the samples alone,
    which gives the cost per sample; what is left of a repeat is the cost of a render call
    (3.6 s on dead_leaves, whatever its size: the larger probe lets the samples outweigh its
    jitter). The resident memory after the first size holds the process, Mitsuba and the
    scene as the job will.

    Returns
    -------
    dict
        ``scene_load_s``, ``compile_s``, ``call_s``, ``s_per_msample`` (seconds per million
        pixel-samples), ``resident_bytes``.
    """
    import mitsuba as mi

    from .films import render_film
    from .scene_dict import build_scene, configured_camera, exact_pass_spp

    spp = exact_pass_spp(config.render.sampler, PROBE_SPP)
    loaded, runs, resident = None, [], None
    widths = (min(PROBE_WIDTH_PX, traced.width_px), min(4 * PROBE_WIDTH_PX, traced.width_px))
    for width in dict.fromkeys(widths):  # one size where the frame is no wider than the first
        height = max(1, round(width * traced.height_px / traced.width_px))
        probe = dataclasses.replace(traced, width_px=width, height_px=height, frame_lens=traced.layout_lens)
        camera = configured_camera(mi, config, probe, lens_model, render_film(config, camera_film, width, height),
                                   spp)  # the layered model's camera is the pinhole it renders through
        started = time.perf_counter()
        scene, sensor, integrator = build_scene(mi, config, probe, camera,
                                                {"type": "path", "max_depth": config.render.max_depth})
        loaded = time.perf_counter() - started if loaded is None else loaded
        seconds = []
        for seed in range(3):  # the compile, then the quicker of two repeats (timing jitter)
            t0 = time.perf_counter()
            np.asarray(mi.render(scene, sensor=sensor, integrator=integrator, seed=seed, spp=spp))
            seconds.append(time.perf_counter() - t0)
        runs.append((width * height * spp, [seconds[0], min(seconds[1:])]))
        # as the job holds it: the depth probe's scene and one traced scene (not the second probe's)
        resident = _resident_bytes() if resident is None else resident
    (small, (first, repeat)), (large, (_, repeat_large)) = runs[0], runs[-1]
    per_sample = max(repeat_large - repeat, 0.0) / (large - small) if large > small else repeat / small
    return {"scene_load_s": loaded, "compile_s": max(first - repeat, 0.0),
            "call_s": max(repeat - per_sample * small, 0.0), "s_per_msample": per_sample * 1e6,
            "resident_bytes": resident}


def make_plan(config: SceneConfig, *, with_margin: bool = True, with_depth: bool = True,
              outputs: Iterable[str] = (), lens: ThinLens | None = None, measure: bool = False) -> CapturePlan:
    """Every decision of a capture, made once and in order (see the module docstring).

    Parameters
    ----------
    config
        The validated scene.
    with_margin
        Render the sensor's crop margin (``sensor.crop_margin_px``) around the frame, as a
        render job does for its DNG.
    with_depth
        The job wants the depth map (rendered as the plan's probe).
    outputs
        Result files (:data:`spectral_cam.job.RESULT_FILES`) whose sizes the budget counts.
    lens
        A lens already built for this config (the frame's); default: built here, once.
    measure
        Measure the scene's cost with small radiance probes (:func:`measure_cost`) for the
        budget's time and peak memory, as ``--dry-run`` does; otherwise the budget holds the
        memory model's conservative bound (the one the refusal uses) and no time.

    Returns
    -------
    CapturePlan

    Raises
    ------
    ConfigError
        For a focus object not in the scene, a light that cannot be resolved, a frame beyond the
        memory, or tiling that ``spp = "auto"`` cannot use; before any radiance is rendered.
    """
    import mitsuba as mi

    from ..spectra import parse_bands
    from .aerial import decide_aerial
    from .decisions import decide_bands, decide_diffraction, decide_estimator
    from .depth import render_depth
    from .lights import resolve_light
    from .memory import (available_bytes, check_render_memory, estimate_render_bytes, lens_bytes_per_pixel,
                         sensor_bytes_per_pixel)
    from .scene_dict import frame_tiles
    from .trace import check_tiling
    from .variants import choose_variant_record

    requested = config
    decisions: dict[str, dict] = {}
    variant, decisions["variant"] = choose_variant_record(config.render.variant)
    mi.set_variant(variant)
    frame = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens.layout_lens
    config, focus_record, frame = _focused(config, frame)
    if focus_record is not None:
        decisions["focus"] = focus_record
    capture = frame.widened(config.sensor.crop_margin_px) if with_margin else frame
    warn_wide_view(frame)
    config, decisions["illuminant"] = resolve_light(config, lens=frame, variant=variant)
    aerial, decisions["aerial_perspective"] = decide_aerial(config, frame)
    if config.scene.mitsuba_xml:
        decisions["field_of_view"] = xml_field_of_view_record(config, frame)
    groups, decisions["estimator"] = decide_estimator(config, config.render.spp, lens=frame)  # may probe (few passes)

    # memory before anything renders, at the most the decisions to come can need (31 bands unless
    # the camera film is asked; the layered model only where asked: auto's choice is checked again)
    bands = parse_bands(config.render.spectral_bands)
    most = 6 if config.render.bands == "camera" else len(bands)
    check_render_memory(capture.width_px, capture.height_px, channels=most, lens_model=config.lens.model,
                        robust_passes=groups, config=config)  # with a QIS's count frames, an event sensor's events
    depth, depth_s = None, 0.0
    if with_depth or config.lens.model == "auto" or LENS_MODELS[config.lens.model].needs_depth:
        t0 = time.perf_counter()
        depth = render_depth(mi, config, capture)
        depth_s = time.perf_counter() - t0
    lens_model, decisions["lens_model"] = _lens_model_decision(config, capture, depth)
    margin = LENS_MODELS[lens_model].margin(capture, depth)  # the layered model's defocus margin
    traced = capture.widened(margin)

    diffract, decisions["diffraction"] = decide_diffraction(capture, bands, config.render.diffraction)
    camera_film, decisions["bands"] = decide_bands(config, diffract)
    channels = 6 if camera_film else len(bands)
    subframes = 1
    if config.motion.moving:
        from .motion import plan_subframes

        spp = config.render.max_spp if config.render.spp == "auto" else int(config.render.spp)
        subframes, decisions["motion"] = plan_subframes(config, capture, depth, spp)

    sensor_bytes = sensor_bytes_per_pixel(config)
    memory = estimate_render_bytes(traced.width_px, traced.height_px, channels, lens_model=lens_model,
                                   robust_passes=groups, sensor_bytes=sensor_bytes)
    if config.lens.model == "auto" and lens_bytes_per_pixel(lens_model, channels):  # the choice, before its render
        check_render_memory(traced.width_px, traced.height_px, channels=channels, lens_model=lens_model,
                            robust_passes=groups, config=config,
                            what=f"this frame with the {lens_model} lens model that lens.model = \"auto\" chose")
    check_tiling(config, traced)  # after the margin, which can push the frame into tiles; before any radiance

    resolved = config.replace(**_choices(config, decisions, lens_model=lens_model, variant=variant,
                                         camera_film=camera_film, diffract=diffract, subframes=subframes))
    spp = resolved.render.max_spp if resolved.render.spp == "auto" else int(resolved.render.spp)
    pixels = float(traced.width_px) * traced.height_px
    budget = {"memory_bytes": memory, "memory_available_bytes": available_bytes(), "time_s": None,
              "outputs_bytes": estimate_result_bytes(resolved, [o for o in outputs if o != "scene"])}
    if measure:
        cost = measure_cost(resolved, traced, lens_model, variant, camera_film)
        calls = len(frame_tiles(traced.width_px, traced.height_px)) * max(groups, 1) * subframes
        budget.update(measured_budget(cost, pixels, spp, channels, depth_s, robust_passes=groups, calls=calls,
                                      sensor_bytes=sensor_bytes))
        budget["probe"] = cost
    return CapturePlan(config=resolved, requested=requested, lens=frame, capture_lens=capture, lens_model=lens_model,
                       variant=variant, decisions=decisions, camera_film=camera_film, diffraction=diffract,
                       estimator_passes=groups, subframes=subframes, layered_margin_px=margin,
                       tiles=len(frame_tiles(traced.width_px, traced.height_px)), budget=budget, depth_m=depth,
                       depth_s=depth_s, aerial=aerial)

