"""Exposing a plan's charts: every reflectance set × illuminant × camera × exposure, once per seed.

The chart is a synthetic one (:func:`spectral_cam.radiance_targets.synthetic_chart`) or the
ColorChecker preset rendered with Mitsuba (:func:`rendered_chart`, shared by the cells its render
does not depend on); it is exposed on the camera's curves so that the brightest patch — the
white reference, or a fluorescent sample brighter than white — reaches the exposure's
``auto_fraction`` of saturation under ``time_s = "auto"``. Temporal noise is seeded by
``[render] seed`` (+ the seed's index) and the fixed patterns by ``[sensor] seed``, as in a
render, so every pipeline of a cell develops the same RAWs (common random numbers make pipelines
directly comparable).

References
----------
.. [1] docs/design.md, "Ground truth and metrics" (validation statistics).
.. [2] Jakob, W., et al. (2022). Mitsuba 3 renderer (spectral variants, ``specfilm``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from ...colour_ground_truth import white_patch_index
from ...errors import ConfigError
from ...radiance_targets import Chart, ReflectanceSet, synthetic_chart
from .plan import ExposureSpec, Plan
from .scoring import PATCH_MARGIN

__all__ = ["rendered_chart", "Exposed", "exposed_charts"]


def rendered_chart(config) -> Chart:
    """The ``colorchecker`` scene preset rendered with Mitsuba under ``config``.

    Parameters
    ----------
    config : SceneConfig
        A scene with ``scene.preset = "colorchecker"`` (its illuminant, lens, sensor size
        and render settings are used as they are).

    Returns
    -------
    Chart
        The render (tiny negative round-off set to 0) with the preset's patches.

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3 renderer (spectral variants, ``specfilm``).
    """
    from ... import spectra
    from ...presets import colorchecker_patches
    from ...render import render

    if config.scene.preset != "colorchecker" or config.scene.mitsuba_xml:
        raise ConfigError("validate.chart = 'render' renders the 'colorchecker' scene preset; "
                          "set [scene] preset = 'colorchecker' (and no mitsuba_xml)")
    image = render(config, with_depth=False)
    image.data = np.maximum(image.data, 0.0)
    patches = colorchecker_patches(config)
    names = [p.name for p in patches]
    sds = list(spectra.colorchecker_reflectances().values())
    return Chart(image, patches, len(patches), white_patch_index(names), sds, "render")


@dataclass
class Exposed:
    """One exposed chart: what every pipeline of a cell develops."""

    refset: ReflectanceSet
    illuminant: str
    camera: str
    exposure: ExposureSpec
    chart: Chart
    reference: np.ndarray
    raw: object
    dng_name: str
    seed: int = 0


def _slug(text: str) -> str:
    text = Path(text).stem if str(text).lower().endswith(".csv") else str(text)
    return re.sub(r"[^A-Za-z0-9.+-]+", "_", text).strip("_") or "x"


def _exposure_mask(chart: Chart, camera: str, illuminant: str, config) -> np.ndarray:
    """Interior of the patch with the largest camera response (normally the white)."""
    from ...sensor import colour_calibration

    responses = colour_calibration.camera_responses(camera, illuminant, chart.sds,
                                             transmission=(config.lens.transmission, config.sensor.ir_cut))
    brightest = int(np.argmax(responses.max(axis=1)))
    if responses.max(axis=1)[brightest] <= responses.max(axis=1)[chart.white_index] * (1 + 1e-9):
        brightest = chart.white_index
    height, width = chart.radiance.data.shape[:2]
    mask = np.zeros((height, width), dtype=bool)
    mask[chart.patches[brightest].interior(PATCH_MARGIN)] = True
    return mask


def _render_key(config, illuminant: str, camera: str, exposure: ExposureSpec) -> tuple:
    """Renders are shared by cameras and exposures unless the film holds the camera's own
    curves, or ``spp = "auto"`` sizes the render by the sensor's noise at the exposure."""
    render = config.render
    bands = getattr(render, "bands", "400:700:10")
    camera_film = bands == "camera" or (bands == "auto" and not getattr(render, "spectral_output", True))
    auto_spp = render.spp == "auto"
    return (illuminant, camera if camera_film or auto_spp else None, exposure.name if auto_spp else None)


def exposed_charts(plan: Plan) -> Iterator[list[Exposed]]:
    """Every chart of the plan, exposed once per seed, in report order (set, illuminant, camera,
    exposure)."""
    from ... import colour_ground_truth

    render_cache: dict = {}
    for s, refset in enumerate(plan.reflectance_sets):
        for i, illuminant in enumerate(plan.illuminants):
            synthetic = None
            if plan.chart == "synthetic":
                synthetic = synthetic_chart(refset, illuminant, illuminance_lux=plan.illuminance_lux,
                                            bands=plan.bands, patch_px=plan.patch_px, gap_px=plan.gap_px)
                reference = colour_ground_truth.patch_linear_srgb(illuminant, synthetic.sds)
            for camera in plan.cameras:
                for e, exposure in enumerate(plan.exposures):
                    chart = synthetic
                    if chart is None:
                        config = plan.scene_config(illuminant, camera, exposure)
                        key = _render_key(config, illuminant, camera, exposure)
                        if key not in render_cache:
                            render_cache[key] = rendered_chart(config)
                        chart = render_cache[key]
                        reference = colour_ground_truth.patch_linear_srgb(illuminant, chart.sds)
                    # positions keep names unique (two CSVs may share a file name)
                    stem = (f"{s:02d}-{_slug(refset.name)}__{i:02d}-{_slug(illuminant)}__"
                            f"{_slug(camera)}__{e:02d}-{_slug(exposure.name)}")
                    yield _expose_seeds(plan, chart, reference, refset=refset, illuminant=illuminant, camera=camera,
                                        exposure=exposure, stem=stem)


def _expose_seeds(plan: Plan, chart: Chart, reference: np.ndarray, *, refset: ReflectanceSet, illuminant: str,
                  camera: str, exposure: ExposureSpec, stem: str) -> list[Exposed]:
    """One chart exposed once per seed (the temporal noise's seed ``render.seed + k``), its DNGs
    named ``stem`` (+ ``__seed<k>`` with more than one seed)."""
    from ...sensor import expose

    config = plan.scene_config(illuminant, camera, exposure, chart)
    mask = _exposure_mask(chart, camera, illuminant, config)
    seeded = []
    for k in range(plan.seeds):  # noise realisations: the temporal noise's seed
        raw = expose(chart.radiance, config, white_mask=mask, frame_seed=config.render.seed + k)
        dng_name = stem + (f"__seed{k}" if plan.seeds > 1 else "") + ".dng"
        seeded.append(Exposed(refset, illuminant, camera, exposure, chart, reference, raw, dng_name, k))
    return seeded
