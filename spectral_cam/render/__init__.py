"""Spectral rendering with Mitsuba 3: passes, seeds, model decisions, depth.

The only package that imports Mitsuba. :func:`render` turns a
:class:`~spectral_cam.scene.SceneConfig` into a :class:`~spectral_cam.image.SpectralImage`
of band radiances (W·m⁻²·sr⁻¹ per band: each value the integral of L(λ) over its band, as
Mitsuba's ``specfilm`` returns it) and a depth map. ``variants`` picks the Mitsuba variant,
``films`` what a pixel integrates, ``scene_dict`` builds the Mitsuba scene, ``decisions``
the model choices, ``depth`` the depth pass and ``defocus`` the depth-layered lens model.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer, https://mitsuba-renderer.org
   (plugins ``thinlens``, ``perspective``, ``specfilm``, ``aov``).
.. [2] Pharr, M., Jakob, W., & Humphreys, G. (2023). Physically Based Rendering, 4th ed.,
   §5.2.3 (thin lens), §4.6 (spectral sampling).
"""

from __future__ import annotations

import time
from typing import Callable

from ..image import SpectralImage
from ..optics import ThinLens
from ..scene import SceneConfig
from ..presets import white_reference_mask
from .decisions import decide_estimator, decide_lens_model
from .defocus import render_layered
from .depth import render_depth
from .focus import resolve_focus
from .lights import resolve_light
from .memory import check_render_memory
from .trace import LANES_PER_PASS, SCALAR_LANES_PER_PASS, check_tiling, trace
from .variants import choose_variant, choose_variant_record

__all__ = ["render", "render_layered", "render_shape_map", "choose_variant", "SpectralImage", "LANES_PER_PASS",
           "SCALAR_LANES_PER_PASS"]


def render_shape_map(config: SceneConfig, *, lens: ThinLens | None = None) -> tuple:
    """Which shape each pixel sees (:func:`.depth.render_shape_index`): (H, W) int32 indices,
    −1 for none, and the shapes' names. The lens is the frame's (default: built from the config).

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3, plugin ``aov``.
    """
    import mitsuba as mi

    from .depth import render_shape_index

    mi.set_variant(choose_variant(config.render.variant))
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    return render_shape_index(mi, config, lens)


def _most_channels(config: SceneConfig) -> int:
    """Values per pixel the render may hold: 6 camera-film channels, else the spectral bands
    (``"auto"`` counted as spectral: the choice is made later, and may need the spectrum)."""
    from ..spectra import parse_bands
    from ..scene import BAND_MODES, SPECTRAL_BANDS_DEFAULT

    if config.render.bands == "camera":
        return 6
    return len(parse_bands(config.render.bands if config.render.bands not in BAND_MODES else SPECTRAL_BANDS_DEFAULT))


def render(
    config: SceneConfig,
    *,
    progress: Callable[[int, int, float], None] | None = None,
    with_depth: bool = True,
    lens: ThinLens | None = None,
    with_margin: bool = False,
) -> SpectralImage:
    """Render the scene's spectral radiance through the configured lens.

    Parameters
    ----------
    config
        The validated scene.
    progress
        Called after each pass with (spp done, spp total, seconds so far).
    with_depth
        Also render the camera-space depth map (a second, cheap render).
    lens
        The job's lens, built once (default: ``ThinLens.from_config(config.lens,
        config.sensor)``). It travels on the result as ``.lens``, so the sensor's camera
        equation uses the optics the render used.
    with_margin
        Also render the sensor's crop margin, ``sensor.crop_margin_px`` real pixels around
        the frame (the lens :meth:`~spectral_cam.optics.ThinLens.widened`; the scene still
        laid out for the frame). The result then holds the frame and its margin:
        ``frame_window`` locates the frame, ``framed()`` crops it, and
        :func:`~spectral_cam.expose` makes a RAW whose default crop is the frame, so every
        developer interpolates the frame's edges from real data.

    Returns
    -------
    SpectralImage
        Band integrals of radiance, W·m⁻²·sr⁻¹, shape (height_px, width_px, bands).

    Examples
    --------
    >>> import spectral_cam as sc
    >>> scene = sc.scene_from_dict({"sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 4}})
    >>> radiance = sc.render(scene)
    >>> radiance.data.shape, radiance.meta["bands"], radiance.meta["lens_model"]
    ((16, 24, 31), '400:700:10', 'pinhole')
    """
    import mitsuba as mi

    config, focus_record = resolve_focus(config)  # before the lens: it sets the focus distance
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    if with_margin:
        lens = lens.layout_lens.widened(config.sensor.crop_margin_px)
    channels = _most_channels(config)
    check_render_memory(lens.width_px, lens.height_px, channels=channels, layered=config.lens.model == "layered",
                        robust_passes=decide_estimator(config, config.render.spp)[0])
    check_tiling(config, lens)
    warn_wide_view(lens.layout_lens)
    variant, variant_record = choose_variant_record(config.render.variant)
    mi.set_variant(variant)
    decisions: dict[str, dict] = {"variant": variant_record}
    config, decisions["illuminant"] = resolve_light(config)  # an XML scene's own light
    if focus_record is not None:
        decisions["focus"] = focus_record
    if config.scene.mitsuba_xml:
        decisions["field_of_view"] = _xml_field_of_view_record(config, lens)

    depth, depth_s = None, 0.0
    lens_model = config.lens.model
    if with_depth or lens_model == "auto":
        t0 = time.perf_counter()
        depth = render_depth(mi, config, lens)
        depth_s = time.perf_counter() - t0
    if lens_model == "auto":
        lens_model, decisions["lens_model"] = decide_lens_model(lens, depth, config)
        if lens_model == "layered":  # the choice made, before its render starts
            check_render_memory(lens.width_px, lens.height_px, channels=channels, layered=True,
                                what="this frame with the layered lens model that lens.model = \"auto\" chose")

    if config.lens.model == "layered" or lens_model == "layered":
        image = render_layered(config, lens=lens, progress=progress, variant=variant)
        if decisions:
            image.meta["model_decisions"] = {**decisions, **image.meta["model_decisions"]}
    else:
        image = trace(config, lens, lens_model, variant=variant, depth=depth, depth_s=depth_s,
                      decisions=decisions, progress=progress)
    if lens_model == "prescription":  # what the trace says the lens is (focal length, f-number, field)
        from ..lenses.prescription import load_prescription

        image.meta["prescription"] = load_prescription(config.lens.prescription).describe(
            lens.focus_distance_m, lens.layout_lens.sensor_width_m)
    image.white_reference = white_reference_mask(config, lens)
    image.meta["illuminant_spd"] = config.illuminant.spd  # what white balance and the truth assume
    image.meta["illuminant_emitter"] = config.illuminant.emitter
    return image


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
    import math
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


def _xml_field_of_view_record(config: SceneConfig, lens: ThinLens) -> dict:
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
