"""The ISP pipeline: :func:`develop` composes the stages of :mod:`spectral_cam.isp` in the
order of the design, each a pure function on float32 arrays:

    black level + normalise → denoise (Poisson–Gaussian, on the linear mosaic)
    → lens-shading correction (a flat-field table, when given) → white balance → demosaic → highlight handling → camera RGB → XYZ(D65) → linear sRGB
    → exposure → tone → sharpen

It sees only the RAW and its metadata (never spectra), so it develops any DNG: ours or a
real camera's. Encoding to files is separate (:mod:`spectral_cam.isp.encode`).

References
----------
.. [1] Ramanath, R., Snyder, W. E., Yoo, Y., & Drew, M. S. (2005). Color image processing
   pipeline. IEEE Signal Processing Magazine 22(1), 34–43.
.. [2] Adobe (2023). Digital Negative (DNG) Specification 1.7.1.0.
"""

from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field

import numpy as np

from ..cfa import LINEAR, cfa_at, cfa_period, check_cfa, is_bayer
from ..errors import ConfigError
from .colour_correction import (
    META_CAMERA_TO_XYZ,
    META_CAMERA_TO_XYZ_ROOT_POLY,
    camera_to_linear_srgb,
    colour_transform,
)
from .config import ISPConfig
from .demosaic import demosaic, method_for
from .denoise import NoiseModel, denoise_mosaic, estimate_noise
from .highlights import clipped_mask, handle_highlights
from .normalise import normalise
from .sharpen import unsharp_mask
from .tone import apply_exposure, tone_map
from .white_balance import apply_white_balance, white_balance_gains

__all__ = ["DevelopedImage", "develop", "noise_model_of", "META_CAMERA_TO_XYZ", "META_CAMERA_TO_XYZ_ROOT_POLY"]

#: RawImage.meta keys read for the sensor noise model when the RAW has no NoiseProfile.
META_GAIN_KEYS = ("K", "K_dn_per_e", "gain_dn_per_e")
META_DARK_NOISE_KEYS = ("sigma_dark_e", "sigma_d_e", "dark_noise_e")


@dataclass
class DevelopedImage:
    """The result of :func:`develop`.

    Attributes
    ----------
    image
        (H, W, 3) float32 display values in [0, 1] (sRGB-encoded unless ``tone = "linear"``):
        what a display, a PNG and a network see.
    linear
        (H, W, 3) float32 linear sRGB (D65, 1 = reference white) before the tone curve,
        after the exposure gain (BaselineExposure + ``exposure_ev``), unclipped:
        scene-referred, the image colour-accuracy metrics use.
    timings_s
        Seconds spent per stage, in pipeline order.
    meta
        What was applied: white-balance gains, colour transform source, noise model,
        demosaic method, the config.
    """

    image: np.ndarray
    linear: np.ndarray
    timings_s: dict[str, float] = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    @property
    def total_s(self) -> float:
        """Total development time, seconds."""
        return float(sum(self.timings_s.values()))


def _first(meta: dict, keys) -> float | None:
    for key in keys:
        value = meta.get(key)
        if value is not None:
            return float(value)
    return None


def noise_model_of(raw) -> NoiseModel | None:
    """The Poisson–Gaussian noise model a RAW carries, if any.

    The DNG NoiseProfile (S, O) first; else the sensor's gain K (DN/e⁻, ``meta["K_dn_per_e"]``)
    and dark noise σ_d (e⁻, ``meta["sigma_dark_e"]``), converted with
    :meth:`NoiseModel.from_sensor`; else None.

    Parameters
    ----------
    raw
        A :class:`~spectral_cam.raw.RawImage`.

    Returns
    -------
    NoiseModel or None

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, NoiseProfile.
    .. [2] EMVA Standard 1288, Release 4.0 (2021).
    """
    if raw.noise_profile is not None:
        s, o = (float(v) for v in np.asarray(raw.noise_profile, dtype=float).ravel()[:2])
        if s > 0 or o > 0:
            return NoiseModel(max(s, 0.0), max(o, 0.0), "noise_profile")
    meta = raw.meta or {}
    gain = _first(meta, META_GAIN_KEYS)
    dark = _first(meta, META_DARK_NOISE_KEYS)
    if gain is not None and gain > 0 and dark is not None:
        return NoiseModel.from_sensor(gain_dn_per_e=gain, dark_noise_e=dark,
                                      black_level=float(np.max(raw.black_level)), white_level=raw.white_level)
    return None


def _crop_slices(raw) -> tuple[slice, slice]:
    """Row and column slices of the raw's default crop (the whole mosaic without one)."""
    from ..raw.image import check_crop

    height, width = np.shape(raw.mosaic)[:2]
    top, left, rows, cols = check_crop(getattr(raw, "crop", None), (height, width)) or (0, 0, height, width)
    return slice(top, top + rows), slice(left, left + cols)


def develop(raw, config: ISPConfig | None = None, *, camera_to_xyz=None, shading_table=None) -> DevelopedImage:
    """Develop a RAW into a display sRGB image.

    Parameters
    ----------
    raw
        A :class:`~spectral_cam.raw.RawImage` (mosaic in DN, CFA, black/white levels,
        ColorMatrix1, AsShotNeutral, NoiseProfile, meta).
    config
        The ISP settings; default :class:`ISPConfig()`.
    camera_to_xyz
        Optional white-balanced camera RGB → XYZ(D65) transform for ``colour_matrix``
        ``"fitted"``/``"root_polynomial"``/``"auto"`` (a (3, 3) or (3, N) root-polynomial
        matrix, or a callable); overrides the RAW's ``meta`` entries.
    shading_table
        A :class:`~spectral_cam.isp.shading.ShadingTable` to correct lens and colour shading with
        (overrides ``config.shading``).

    Returns
    -------
    DevelopedImage
        Display image, linear sRGB, per-stage timings (s) and what was applied.

    Raises
    ------
    ConfigError
        For settings the RAW cannot support (e.g. ``"as_shot"`` white balance without
        AsShotNeutral, ``"fitted"`` without a supplied transform).

    References
    ----------
    .. [1] Ramanath, R., et al. (2005). IEEE Signal Processing Magazine 22(1), 34–43.
    .. [2] Adobe (2023). DNG Specification 1.7.1.0, ch. 5–6.

    Examples
    --------
    A flat mid-grey mosaic, developed without a colour matrix: linear 0.5 everywhere, which the
    sRGB OETF alone encodes as 0.735 and Adobe's default rendering (the default tone) as 0.908:

    >>> import numpy as np
    >>> from spectral_cam.isp import ISPConfig, develop
    >>> from spectral_cam.raw import RawImage
    >>> raw = RawImage(np.full((16, 16), 2048, np.uint16), "RGGB", black_level=0.0, white_level=4095,
    ...                as_shot_neutral=np.ones(3))
    >>> image = develop(raw, ISPConfig(colour_matrix="none", tone="srgb"))
    >>> image.image.shape, round(float(image.linear.mean()), 3), round(float(image.image.mean()), 3)
    ((16, 16, 3), 0.5, 0.735)
    >>> round(float(develop(raw, ISPConfig(colour_matrix="none")).image.mean()), 3)
    0.908
    """
    config = ISPConfig() if config is None else config
    if not isinstance(config, ISPConfig):
        raise ConfigError(f"develop() needs an ISPConfig; got {type(config).__name__}")
    timings: dict[str, float] = {}
    info: dict = {"config": config.to_dict()}

    with _timed(timings, "normalise"):
        mosaic = normalise(raw.mosaic, black_level=raw.black_level, white_level=raw.white_level)
        monochrome = str(raw.cfa).lower() == "none"
        linear_raw = raw.cfa == LINEAR  # three colours per pixel already: no mosaic to denoise or demosaic
        cfa = raw.cfa if monochrome or linear_raw else check_cfa(raw.cfa, allow_extended=True)
        # the image is the raw's default crop: the margin around it is demosaiced (so the crop's
        # edges are interpolated from real data) and then dropped; statistics come from the crop
        crop = _crop_slices(raw)
    with _timed(timings, "denoise"):
        mosaic = _denoised(raw, mosaic, cfa, config, linear_raw, info)
    with _timed(timings, "shading"):
        mosaic = _shading_corrected(mosaic, cfa, config, shading_table, linear_raw, info)
    if monochrome:
        with _timed(timings, "white_balance"):
            gains = np.ones(3)
            mask = clipped_mask(mosaic, radius_px=0)[crop]
            rgb = np.repeat(mosaic[crop][..., None], 3, axis=-1)
        timings["demosaic"] = 0.0
    else:
        with _timed(timings, "white_balance"):
            gains, balanced = _white_balanced(raw, mosaic, cfa, crop, config, linear_raw)
        with _timed(timings, "demosaic"):
            rgb, mask = _demosaiced(mosaic, balanced, cfa, crop, config, linear_raw, info)

    with _timed(timings, "highlights"):
        # gains are normalised to a smallest gain of 1, so every channel saturates at >= 1
        rgb = handle_highlights(rgb, mask, level=float(gains.min()), method=config.highlights)
    with _timed(timings, "colour"):
        transform, source = (None, "none") if monochrome else colour_transform(raw, config.colour_matrix, gains[:3],
                                                                                 camera_to_xyz)
        scene = rgb if transform is None else camera_to_linear_srgb(rgb, transform)
    with _timed(timings, "tone"):
        # the RAW's BaselineExposure (what its exposure index asks of the rendering) plus the user's
        ev = float(getattr(raw, "baseline_exposure", 0.0) or 0.0) + config.exposure_ev
        image = tone_map(scene, method=config.tone, ev=ev)
        linear = apply_exposure(scene, ev=ev) if ev != 0 else scene
    with _timed(timings, "sharpen"):
        if config.sharpen > 0:
            image = unsharp_mask(image, amount=config.sharpen, radius_px=config.sharpen_radius_px)
            np.clip(image, 0.0, 1.0, out=image)  # display values stay in [0, 1]

    info.update(_record(raw, gains, source, mask, ev, transform))
    return DevelopedImage(np.ascontiguousarray(image, dtype=np.float32),
                          np.ascontiguousarray(linear, dtype=np.float32), timings, info)


@contextlib.contextmanager
def _timed(timings: dict[str, float], stage: str):
    """Time the block as ``timings[stage]`` (s, wall clock)."""
    start = time.perf_counter()
    yield
    timings[stage] = time.perf_counter() - start


def _denoised(raw, mosaic: np.ndarray, cfa: str, config: ISPConfig, linear_raw: bool, info: dict) -> np.ndarray:
    """The denoise stage: the mosaic denoised under the RAW's noise model (or one estimated from it)."""
    strength = config.denoise_strength
    if strength > 0 and linear_raw:
        info["denoise"] = "skipped: the Poisson–Gaussian model holds on a raw mosaic, not on linear RGB"
    elif strength > 0:
        noise = noise_model_of(raw) or estimate_noise(mosaic, cfa)
        mosaic = denoise_mosaic(mosaic, cfa, noise=noise, strength=strength, method=config.denoise_method)
        info["noise_model"] = {"S": noise.gain, "O": noise.offset, "source": noise.source}
    return mosaic


def _shading_corrected(mosaic: np.ndarray, cfa: str, config: ISPConfig, shading_table, linear_raw: bool,
                       info: dict) -> np.ndarray:
    """The lens-shading stage: the mosaic times a flat-field table's gains, when one is given or configured."""
    if shading_table is None and config.shading != "off":
        from .shading import load_shading_table

        shading_table = load_shading_table(config.shading)
    if shading_table is None:
        return mosaic
    if linear_raw:
        raise ConfigError("lens-shading correction works on a raw mosaic; this RAW is linear (three colours "
                          "per pixel): set isp.shading = 'off'")
    from .shading import correct_shading

    info["shading"] = "flat-field table" if config.shading == "off" else config.shading
    return correct_shading(mosaic, cfa, shading_table)


def _white_balanced(raw, mosaic: np.ndarray, cfa: str, crop, config: ISPConfig, linear_raw: bool):
    """(gains, balanced mosaic): gains estimated on the crop's statistics (a Bayer tile has a name at
    every phase); a larger tile's crop off its tile grid: the whole mosaic's."""
    rows, cols = (1, 1) if linear_raw or is_bayer(cfa) else cfa_period(cfa)
    on_grid = crop[0].start % rows == 0 and crop[1].start % cols == 0
    stats, stats_cfa = (mosaic[crop], cfa if linear_raw else cfa_at(cfa, crop[0].start, crop[1].start)) \
        if on_grid else (mosaic, cfa)
    gains = white_balance_gains(stats, stats_cfa, method=config.white_balance, as_shot_neutral=raw.as_shot_neutral,
                                gains=config.wb_gains or None)
    return gains, apply_white_balance(mosaic, cfa, gains=gains)


def _demosaiced(mosaic: np.ndarray, balanced: np.ndarray, cfa: str, crop, config: ISPConfig, linear_raw: bool,
                info: dict):
    """(cropped camera RGB, its clipped mask): the balanced mosaic demosaiced by the method that takes
    its tile (:func:`~spectral_cam.isp.demosaic.method_for`, recorded when it differs), or a linear
    RAW's RGB as it is."""
    if linear_raw:
        return balanced[crop], clipped_mask(mosaic, radius_px=0).any(axis=-1)[crop]
    method = method_for(cfa, config.demosaic)
    if method != config.demosaic:
        info["demosaic"] = f"{method} ({config.demosaic} needs a 2×2 Bayer mosaic; this RAW is {cfa})"
    return demosaic(balanced, cfa, method=method)[crop], clipped_mask(mosaic, radius_px=2)[crop]


def _record(raw, gains: np.ndarray, source: str, mask: np.ndarray, ev: float, transform) -> dict:
    """What the develop applied, for ``DevelopedImage.meta``."""
    record = {
        "white_balance_gains": [float(g) for g in gains],
        "colour_transform": source,
        "clipped_fraction": float(mask.mean()) if mask.size else 0.0,
        "exposure_ev": ev,
        "baseline_exposure_ev": float(getattr(raw, "baseline_exposure", 0.0) or 0.0),
        "crop": None if getattr(raw, "crop", None) is None else [int(v) for v in raw.crop],
    }
    if isinstance(transform, np.ndarray):
        record["colour_transform_matrix"] = transform.tolist()
    return record
