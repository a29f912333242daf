"""Spectral rendering with Mitsuba 3: the capture plan, passes, seeds, depth.

The only package that imports Mitsuba. :func:`render` turns a
:class:`~spectral_cam.scene.SceneConfig` into a :class:`~spectral_cam.image.SpectralImage`
of band radiances (W·m⁻²·sr⁻¹ per band: each value the integral of L(λ) over its band, as
Mitsuba's ``specfilm`` returns it) and a depth map: ``plan`` makes every decision once (with
the rules of ``decisions``), :func:`execute` renders the plan. ``variants`` picks the Mitsuba
variant, ``films`` what a pixel integrates, ``scene_dict`` builds the Mitsuba scene, ``trace``
the passes, ``depth`` the depth pass and ``defocus`` the depth-layered lens model.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer, https://mitsuba-renderer.org
   (plugins ``thinlens``, ``perspective``, ``specfilm``, ``aov``).
.. [2] Pharr, M., Jakob, W., & Humphreys, G. (2023). Physically Based Rendering, 4th ed.,
   §5.2.3 (thin lens), §4.6 (spectral sampling).
"""

from __future__ import annotations

from typing import Callable

from ..image import SpectralImage
from ..optics import ThinLens
from ..scene import SceneConfig
from ..presets import white_reference_mask
from .depth import ALBEDO_SPP
from .layered import render_layered
from .lens_models import LENS_MODELS
from .trace import LANES_PER_PASS, SCALAR_LANES_PER_PASS, trace
from .variants import choose_variant

__all__ = ["render", "execute", "render_layered", "render_shape_map", "render_coverage_map", "render_normal_map", "render_shape_layer_map", "choose_variant", "SpectralImage", "LANES_PER_PASS",
           "SCALAR_LANES_PER_PASS"]


def render_shape_map(config: SceneConfig, *, lens: ThinLens | None = None, with_materials: bool = False) -> tuple:
    """Which shape each pixel sees (:func:`.depth.render_shape_index`): (H, W) int32 indices,
    −1 for none, and the shapes' names (with ``with_materials``, records of name and material:
    :func:`.depth.render_shapes`). The lens is the frame's (default: built from the config).

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3, plugin ``aov``.
    """
    import mitsuba as mi

    from .depth import render_shape_index, render_shapes

    mi.set_variant(choose_variant(config.render.variant))
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    return (render_shapes if with_materials else render_shape_index)(mi, config, lens)


def render_coverage_map(config: SceneConfig, *, lens: ThinLens | None = None, model: str = "thin",
                        passes: int = 64) -> tuple:
    """The soft segmentation under defocus (:func:`.depth.render_shape_coverage`): ranked
    (ids, coverage) per pixel through the frame's camera ``model`` and the shapes' records."""
    import mitsuba as mi

    from .depth import render_shape_coverage

    mi.set_variant(choose_variant(config.render.variant))
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    return render_shape_coverage(mi, config, lens, model=model, passes=passes)


def render_albedo_map(config: SceneConfig, *, lens: ThinLens | None = None, spp: int = ALBEDO_SPP):
    """(H, W, B) band integrals of the diffuse reflectance each pixel sees
    (:func:`.depth.render_albedo`) and the band grid; the lens is the frame's."""
    import mitsuba as mi

    from .. import spectra
    from .depth import ALBEDO_BANDS, render_albedo

    mi.set_variant(choose_variant(config.render.variant))
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    return render_albedo(mi, config, lens, spp=spp), spectra.parse_bands(ALBEDO_BANDS)


def render_shape_layer_map(config: SceneConfig, *, lens: ThinLens | None = None):
    """The shapes each pixel's pinhole ray passes through (:func:`.depth.render_shape_layers`:
    (H, W, AMODAL_LAYERS) indices into :func:`render_shape_map`'s shapes, nearest first, −1 for
    none, on the segmentation's rays), or None in Mitsuba's scalar variants; the lens is the frame's."""
    import mitsuba as mi

    from .depth import render_shape_layers

    mi.set_variant(choose_variant(config.render.variant))
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    return render_shape_layers(mi, config, lens)


def render_normal_map(config: SceneConfig, *, lens: ThinLens | None = None) -> tuple:
    """(H, W, 3) unit surface normals in OpenCV camera axes, facing the camera, and the z (m) of
    the same hits, through the frame's pinhole on the depth label's rays
    (:func:`.depth.render_normals`); the lens is the frame's."""
    import mitsuba as mi

    from .depth import render_normals

    mi.set_variant(choose_variant(config.render.variant))
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    return render_normals(mi, config, lens)


def render(
    config,
    *,
    progress: Callable[[int, int, float], None] | None = None,
    with_depth: bool = True,
    lens: ThinLens | None = None,
    with_margin: bool = False,
) -> SpectralImage:
    """Render the scene's spectral radiance through the configured lens: plan the capture
    (:func:`spectral_cam.render.plan.make_plan`: every decision, once), then execute the plan.

    Parameters
    ----------
    config
        The validated scene, or a :class:`~spectral_cam.render.plan.CapturePlan` made already (the
        other options then come from the plan).
    progress
        Called after each pass with (spp done, spp total, seconds so far).
    with_depth
        Also render the camera-space depth map (a second, cheap render).
    lens
        The frame's lens, built once (default: ``ThinLens.from_config(config.lens,
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
        Band integrals of radiance, W·m⁻²·sr⁻¹, shape (height_px, width_px, bands); its
        ``meta["plan"]`` is the plan's record.

    Examples
    --------
    >>> import spectral_cam as sc
    >>> scene = sc.scene_from_dict({"sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 4}})
    >>> radiance = sc.render(scene)
    >>> radiance.data.shape, radiance.meta["bands"], radiance.meta["lens_model"]
    ((16, 24, 31), '400:700:10', 'pinhole')
    """
    from .plan import CapturePlan, make_plan
    from .variants import deterministic_threads

    scene = config.config if isinstance(config, CapturePlan) else config
    with deterministic_threads(scene.render.deterministic):
        plan = config if isinstance(config, CapturePlan) else \
            make_plan(config, with_margin=with_margin, with_depth=with_depth, lens=lens)
        return execute(plan, progress=progress)


def execute(plan, *, progress: Callable[[int, int, float], None] | None = None) -> SpectralImage:
    """Render what a :class:`~spectral_cam.render.plan.CapturePlan` decided; nothing is decided here
    but ``spp = "auto"``'s stop.

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer (``mi.render``).
    """
    import mitsuba as mi

    if plan.variant not in mi.variants():  # a plan made on another machine (a Dask worker's)
        from ..errors import RenderError

        raise RenderError(f"the capture plan renders with {plan.variant!r}, which this machine's Mitsuba lacks "
                          f"(it has {', '.join(v for v in mi.variants() if 'spectral' in v)}); plan it here")
    mi.set_variant(plan.variant)
    config = plan.config
    model = LENS_MODELS[plan.lens_model]
    if model.render is not None:  # a model with a render of its own (the layered model's)
        image = model.render(config, plan, progress)
    else:
        image = trace(config, plan.capture_lens, plan.lens_model, variant=plan.variant, camera_film=plan.camera_film,
                      diffraction=plan.diffraction, groups=plan.estimator_passes, subframes=plan.subframes,
                      depth=plan.depth_m, depth_s=plan.depth_s, decisions=dict(plan.decisions), progress=progress,
                      aerial=plan.aerial)
    model.post_render(image, plan)  # what the model records (a prescription's traced optics)
    image.meta["lens_shading"] = model.shading(config)  # what the sensor's shading reads of the render
    image.white_reference = white_reference_mask(config, plan.capture_lens)
    image.meta["illuminant_spd"] = config.illuminant.spd  # what white balance and the truth assume
    image.meta["illuminant_emitter"] = config.illuminant.emitter
    image.meta["plan"] = plan.record()
    image.meta["threads"] = _render_threads()  # meta.json: what the sums' order depended on
    return image


def _render_threads() -> int:
    """The renderer's worker threads (Dr.Jit's pool, 1 under ``render.deterministic``), which
    meta.json records: the order of a multi-threaded sum follows them (docs/design.md)."""
    import drjit

    return int(drjit.thread_count())
