"""Image sensor: band radiance → irradiance → photons → electrons → noise → ADC → RAW.

:func:`expose` composes the stages, each a plain function in its own module so tests and
other programs can use them alone: ``radiometry`` (camera equation, quantum efficiency,
electron rates through the CFA), ``exposure`` (auto exposure), ``noise`` (the EMVA 1288
chain), ``calibration`` (colour matrices fitted from the measured curves) and ``colour``
(the colour metadata of a RAW). The result is a :class:`~spectral_cam.raw.RawImage` with
the metadata a DNG and an ISP need (ColorMatrix1/2, AsShotNeutral, NoiseProfile, K, ...).

Every noise term can be switched off (``sensor.shot_noise = false``, or a zero
``read_noise_e`` / ``dark_current_e_per_s`` / ``dsnu_e`` / ``prnu``).

References
----------
.. [1] EMVA Standard 1288, Release 4.0 Linear (2021), §2–3.
.. [2] Adobe (2023). DNG Specification 1.7.1.0 (ColorMatrix1, AsShotNeutral, NoiseProfile).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np

from ..errors import SensorError
from ..isp.tone import TONE, profile_tone_curve
from ..raw.image import RawImage
from ..spectra import figure_record
from .dng_colour import (
    _colour_matrix,
    _fitted_corrections,
    _forward_matrix,
    _hue_sat_map,
    _third_calibration,
)
from .metered_exposure import (
    auto_exposure_time,
    expected_electrons,
    exposure_index,
    resolve_exposure,
)
from .noise import (
    HYBRID_POISSON_BELOW_E,
    SHOT_NOISE_METHODS,
    _check_sensor,
    dark_noise_electrons,
    fixed_patterns,
    noise_profile,
    saturation_electrons,
    simulate_frame,
    system_gain,
)
from .radiometry import (
    CAMERA_CHANNELS,
    FILM_REFERENCE_NM,
    SignalModel,
    band_weights,
    camera_equation_irradiance,
    electron_rates,
    electrons_per_band_radiance,
    film_curves,
    max_channel_rates,
    photons_per_joule,
    quantum_efficiency,
    signal_model,
    validate_radiance,
    white_response,
)
from .temporal import row_exposure_factors

__all__ = [
    "expose", "quantum_efficiency", "camera_equation_irradiance", "photons_per_joule", "band_weights",
    "electron_rates", "max_channel_rates", "electrons_per_band_radiance", "system_gain", "saturation_electrons",
    "dark_noise_electrons", "noise_profile", "fixed_patterns", "auto_exposure_time", "simulate_frame",
    "validate_radiance", "signal_model", "SignalModel", "film_curves", "expected_electrons", "CAMERA_CHANNELS",
    "FILM_REFERENCE_NM", "SHOT_NOISE_METHODS", "HYBRID_POISSON_BELOW_E", "resolve_exposure", "exposure_index",
    "white_response",
]

if TYPE_CHECKING:  # pragma: no cover
    from ..image import SpectralImage
    from ..scene import SceneConfig


# ----------------------------------------------------------------------------- expose
def _with_scene_light(config: "SceneConfig", radiance: "SpectralImage") -> "SceneConfig":
    """``config`` with ``illuminant.spd = "auto"`` replaced by the light the render resolved
    (an XML scene's emitter or a preset's sun and sky, recorded in
    ``radiance.meta["illuminant_spd"]``); a preset's "auto" is otherwise D65. A scene whose
    emitters light it and whose light is unknown is refused rather than exposed as D65."""
    from ..presets.outdoor import lit_by_sky

    if config.illuminant.spd != "auto":
        return config
    resolved = (radiance.meta or {}).get("illuminant_spd")
    if resolved is None:
        if config.scene.mitsuba_xml or lit_by_sky(config):
            raise SensorError("illuminant.spd = 'auto' on a scene its own emitters light (an XML scene, or the sun "
                              "and sky): expose a radiance from "
                              "spectral_cam.render (it reads the scene's emitters), or set illuminant.spd")
        resolved = "D65"
    return config.replace(**{"illuminant.spd": resolved})


def expose(
    radiance: "SpectralImage",
    config: "SceneConfig",
    *,
    frame_seed: int | None = None,
    white_mask: np.ndarray | None = None,
    shot_noise_method: str = "hybrid",
    workers: int | None = None,
) -> RawImage:
    """Simulate the sensor's exposure to a spectral radiance image.

    Parameters
    ----------
    radiance : SpectralImage
        (H, W, B) band integrals of radiance (W·m⁻²·sr⁻¹) matching the sensor's size; any
        SpectralImage works, a synthetic uniform one included.
    config : SceneConfig
        Uses ``sensor``, ``lens`` (working f-number, transmission, vignetting geometry),
        ``exposure`` (time or ``"auto"`` metered by ``metering``, ISO, ``iso_definition``),
        ``isp.tone`` (the BaselineExposure and ProfileToneCurve the RAW carries: the rendering
        a metered grey needs to show at 118/255), ``illuminant.spd`` (for AsShotNeutral and
        the meter's white balance) and ``render.seed`` (the default frame seed).
    frame_seed : int, optional
        Seed of the temporal noise (default ``config.render.seed``).
    white_mask : numpy.ndarray, optional
        Boolean (H, W) white reference for ``exposure.metering = "etr"``; default the
        rendered scene's own (``radiance.white_reference``: the ColorChecker's white patch),
        so the API and ``spectral-cam render`` expose alike; without one the 99th percentile
        of the max-channel electron rate is used.
    shot_noise_method : {"hybrid", "poisson"}
        See :data:`SHOT_NOISE_METHODS`.
    workers : int, optional
        Threads for the chunked stages.

    Returns
    -------
    RawImage
        uint16 mosaic, CFA, black/white levels, ColorMatrix1 (XYZ(D65) → camera; None for
        an ``"ideal"`` sensor's identical channels), AsShotNeutral (the simulated sensor's
        own response to the illuminant's white, max 1), NoiseProfile and ``meta`` with K
        (DN/e⁻), exposure, ISO, saturation, σ_d, QE, seeds and per-stage timings.

    Raises
    ------
    SensorError
        For radiance of the wrong shape or with NaN, infinite or negative values, or an
        invalid sensor.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2–3.
    .. [2] Adobe (2023). DNG Specification 1.7.1.0 (ColorMatrix1, AsShotNeutral, NoiseProfile).

    Examples
    --------
    A flat field of 550-nm light (0.05 W·m⁻²·sr⁻¹ in its 10-nm band) for 10 ms:

    >>> import spectral_cam as sc
    >>> from spectral_cam.radiance_targets import narrow_band_flat
    >>> scene = sc.scene_from_dict({"sensor": {"width_px": 32, "height_px": 32}, "exposure": {"time_s": 0.01}})
    >>> raw = sc.expose(narrow_band_flat((32, 32), 0.05), scene)
    >>> raw.mosaic.shape, raw.mosaic.dtype, raw.cfa, raw.white_level
    ((32, 32), dtype('uint16'), 'RGGB', 4095)
    """
    started = time.perf_counter()
    timings: dict[str, float] = {}
    config = _with_scene_light(config, radiance)
    sensor, exposure = config.sensor, config.exposure
    frame_seed = config.render.seed if frame_seed is None else frame_seed
    if getattr(sensor, "kind", "cmos") != "cmos":
        from .kind_registry import SENSOR_KINDS

        entry = SENSOR_KINDS[sensor.kind]
        raise SensorError(f"sensor.kind = {sensor.kind!r} ({entry.description}) is not an integrating sensor: "
                          f"{entry.direct_use or 'capture it with spectral_cam.sensor.kinds.capture'}; expose() is the "
                          "integrating CMOS sensor (sensor.kind = 'cmos')")
    _check_expose_arguments(radiance, sensor, frame_seed, shot_noise_method)
    model = signal_model(radiance, config)
    timings["setup"] = time.perf_counter() - started

    t0 = time.perf_counter()
    rate = electron_rates(radiance.data, model.weights, cfa=sensor.cfa, cos4=model.cos4, workers=workers,
                          olpf_px=model.olpf_px, channel_gain=model.channel_gain)
    timings["electron_rates"] = time.perf_counter() - t0

    gain = system_gain(sensor, exposure.iso)
    t0 = time.perf_counter()
    exposure_s, reference_rate = resolve_exposure(radiance, config, model, white_mask=white_mask)
    timings["auto_exposure"] = time.perf_counter() - t0

    rows = row_exposure_factors(config, rate.shape[0], exposure_s)  # a flickering light, row by row
    if rows is not None:
        rate = rate * rows
    t0 = time.perf_counter()
    mosaic, chain_cpu = simulate_frame(rate, sensor, exposure_s=exposure_s, gain=gain, frame_seed=int(frame_seed),
                                       shot_noise_method=shot_noise_method, workers=workers)
    timings["noise_chain"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    index = exposure_index(config)
    colour = _colour_metadata(radiance, config, model)
    timings["colour"] = time.perf_counter() - t0
    timings["total"] = time.perf_counter() - started

    meta = _exposure_record(config, model, radiance, gain=gain, exposure_s=exposure_s, reference_rate=reference_rate,
                            index=index, frame_seed=int(frame_seed), shot_noise_method=shot_noise_method)
    meta.update({"timings_s": timings, "noise_chain_cpu_s": chain_cpu})
    if colour["matrix"] is not None:
        meta.update(_fitted_corrections(sensor.model, config.illuminant.spd, model.transmission_specs))
    black, white = sensor.black_level_dn, 2 ** sensor.bit_depth - 1
    return RawImage(
        mosaic=mosaic,
        cfa=sensor.cfa,
        black_level=float(black),
        white_level=int(white),
        color_matrix=colour["matrix"],
        as_shot_neutral=colour["neutral"],
        noise_profile=noise_profile(gain, sensor.read_noise_e, black, white),
        camera_model=f"spectral_cam {sensor.model}",
        meta=meta,
        color_matrix_2=colour["matrix_a"],
        forward_matrix=colour["forward"],
        forward_matrix_2=colour["forward_a"],
        hue_sat_map=colour["hue_sat"],
        hue_sat_map_2=colour["hue_sat_a"],
        calibration_3=colour.get("third"),
        crop=radiance.frame_window if hasattr(radiance, "frame_window") else None,
        baseline_exposure=index["baseline_exposure_ev"],
        profile_tone_curve=profile_tone_curve(config.isp.tone),
    )


def _check_expose_arguments(radiance, sensor, frame_seed, shot_noise_method: str) -> None:
    """Refuse an invalid sensor, radiance, frame seed or shot-noise method before any work."""
    _check_sensor(sensor)
    validate_radiance(radiance, sensor)
    if not (isinstance(frame_seed, (int, np.integer)) and not isinstance(frame_seed, bool) and frame_seed >= 0):
        raise SensorError(f"frame_seed {frame_seed!r} must be a whole number >= 0")
    if shot_noise_method not in SHOT_NOISE_METHODS:
        raise SensorError(f"shot_noise_method {shot_noise_method!r}; valid: {', '.join(SHOT_NOISE_METHODS)}")


def _colour_metadata(radiance, config, model) -> dict:
    """The colour tags of the RAW: AsShotNeutral (the sensor's own response to the light's
    white, max 1), ColorMatrix1/2 (XYZ → camera under D65 and A), ForwardMatrix1/2 and their
    ProfileHueSatMaps; all None for a monochrome sensor, the matrices None for an ``"ideal"`` one."""
    sensor, specs = config.sensor, model.transmission_specs
    colour = dict.fromkeys(("neutral", "matrix", "matrix_a", "forward", "forward_a", "hue_sat", "hue_sat_a"))
    if sensor.cfa == "none":
        return colour
    response = white_response(radiance, config, model)
    colour["neutral"] = response / response.max() if response.max() > 0 else None
    if sensor.model != "ideal":
        colour.update(matrix=_colour_matrix(sensor.model, specs), matrix_a=_colour_matrix(sensor.model, specs, "A"),
                      forward=_forward_matrix(sensor.model, specs), forward_a=_forward_matrix(sensor.model, specs, "A"),
                      hue_sat=_hue_sat_map(sensor.model, specs), hue_sat_a=_hue_sat_map(sensor.model, specs, "A"),
                      third=_third_calibration(sensor.model, specs, config.illuminant.spd)
                      if sensor.cfa != "RGBW" else None)  # DNG 1.6: a light off the D65–A locus
    if sensor.cfa == "RGBW":  # four colour planes: W = R + G + B (radiometry.white_quantum_efficiency)
        for key in ("matrix", "matrix_a"):  # XYZ → camera: W's row the sum of the others
            if colour[key] is not None:
                colour[key] = np.vstack([colour[key], colour[key].sum(axis=0)])
        for key in ("forward", "forward_a"):  # white-balanced camera → XYZ(D50): from R, G, B alone
            if colour[key] is not None:
                colour[key] = np.hstack([colour[key], np.zeros((3, 1))])
    return colour


def _exposure_record(config, model, radiance, *, gain: float, exposure_s: float, reference_rate, index: dict,
                     frame_seed: int, shot_noise_method: str) -> dict:
    """``RawImage.meta``: what the sensor was and did (gain, exposure, noise parameters, seeds)."""
    sensor, exposure = config.sensor, config.exposure
    auto = exposure.time_s == "auto"
    return {
        "K_dn_per_e": gain,
        "exposure_s": exposure_s,
        "exposure_auto": auto,
        "auto_reference_e_per_s": reference_rate,
        "auto_fraction": exposure.auto_fraction if auto and exposure.metering in ("highlight", "etr") else None,
        "exposure_index": index,
        "tone_black_render": TONE[config.isp.tone].sets_black,  # the curve's entry says (DefaultBlackRender)
        "iso": exposure.iso,
        "base_iso": sensor.base_iso,
        "saturation_e": saturation_electrons(sensor, gain),
        "full_well_e": sensor.full_well_e,
        "sigma_dark_e": dark_noise_electrons(sensor, exposure_s),
        "read_noise_e": sensor.read_noise_e,
        "dark_current_e_per_s": sensor.dark_current_e_per_s,
        "dsnu_e": sensor.dsnu_e,
        "prnu": sensor.prnu,
        "peak_qe": sensor.peak_qe,
        "peak_qe_per_channel": [float(v) for v in model.qe.max(axis=0)],
        "input": "camera channels (photon-weighted film)" if model.camera_channels else
                 f"{len(radiance.wavelengths_nm)} spectral bands",
        "bit_depth": sensor.bit_depth,
        "sensor_figures": figure_record(sensor),  # which came from the named camera's table (issue 39 #9)
        "working_f_number": model.working_f_number,
        "pixel_area_m2": model.pixel_area_m2,
        "vignetting": bool(sensor.vignetting),
        "olpf": {"separation_px": model.olpf_px, "separation_um": model.olpf_px * sensor.pixel_pitch_um,
                 "why": model.olpf_note},
        "angular_response_deg": sensor.angular_response_deg,
        "shutter": sensor.shutter,
        "row_time_s": sensor.row_time_s if sensor.shutter == "rolling" else None,
        "exposure_start_s": exposure.start_s,
        "flicker": None if not config.illuminant.flicker_hz else {
            "frequency_hz": config.illuminant.flicker_hz, "depth": config.illuminant.flicker_depth,
            "waveform": config.illuminant.flicker_waveform, "duty": config.illuminant.flicker_duty},
        "shot_noise": bool(sensor.shot_noise),
        "shot_noise_method": shot_noise_method,
        "seeds": {"sensor": int(sensor.seed), "frame": frame_seed},
        "model": sensor.model,
        "f_number": config.lens.f_number,
        "focal_length_mm": config.lens.focal_length_mm,
    }
