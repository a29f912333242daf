"""Radiometry: band radiance → irradiance on the sensor → photo-electron rates per pixel.

1. the camera equation (:func:`camera_equation_irradiance`):
   ``E_b = π·L_b·T(λ_b) / (1 + 4·N_w²) · cos⁴θ`` (W·m⁻²), from band integrals of radiance
   ``L_b`` (W·m⁻²·sr⁻¹);
2. photons and electrons (:func:`band_weights`, :func:`electron_rates`):
   ``μ_e,c = Σ_b E_b·A_pix·t·(λ_b·10⁻⁹ / (h·c))·η_c(λ_b)`` — no extra Δλ, ``L_b`` is
   already a band integral — with the quantum efficiency ``η_c ∝ S_c(λ)/λ`` of the
   measured per-energy curves (:func:`quantum_efficiency`), sampled through the CFA.

The working f-number and the pixel angles come from the
:class:`~spectral_cam.optics.ThinLens` the render used (docs/design.md, "Sensor").

References
----------
.. [1] EMVA Standard 1288, Release 4.0 Linear (2021), §2.1.
.. [2] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 17 (image illuminance,
   E = π·L·T / (4·N_w²) in the paraxial limit, and the exact 1/(1 + 4·N_w²) form; cos⁴ law).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .. import spectra
from ..cfa import is_bayer, tile_layout
from ..errors import ConfigError, SensorError
from .parallel import row_chunks, run_chunks, workers_for

if TYPE_CHECKING:  # pragma: no cover
    from ..image import SpectralImage
    from ..optics import ThinLens
    from ..scene import SceneConfig, SensorSection


#: Planck's constant (J·s) and the speed of light (m/s), exact in the SI since 2019 (written out:
#: ``scipy.constants`` costs 70 ms of every run's start).
PLANCK_J_S, SPEED_OF_LIGHT_M_S = 6.62607015e-34, 299792458.0


def photons_per_joule(wavelength_nm) -> np.ndarray:
    """Photons per joule at a wavelength, λ / (h·c) (J⁻¹).

    Parameters
    ----------
    wavelength_nm : array_like
        Vacuum wavelength (nm).

    References
    ----------
    .. [1] BIPM (2019). The International System of Units, 9th ed.: h and c are exact
       (tests/sensor/test_expose.py checks them against scipy.constants' CODATA 2018).
    """
    return np.asarray(wavelength_nm, dtype=float) * 1e-9 / (PLANCK_J_S * SPEED_OF_LIGHT_M_S)


def camera_equation_irradiance(band_radiance, *, working_f_number: float, transmission=1.0,
                               cos4=1.0) -> np.ndarray:
    """Band irradiance on the sensor from band radiance in object space.

    ``E_b = π·L_b·T(λ_b) / (1 + 4·N_w²) · cos⁴θ``.

    Parameters
    ----------
    band_radiance : array_like
        Band integrals of radiance L_b (W·m⁻²·sr⁻¹).
    working_f_number : float
        N_w = N·(1 + m) (dimensionless).
    transmission : array_like
        Lens (and filter) transmission T(λ_b) in [0, 1], broadcast against the bands.
    cos4 : array_like
        Natural vignetting factor cos⁴θ of each pixel (1 on axis), broadcast.

    Returns
    -------
    numpy.ndarray
        Band irradiance E_b (W·m⁻²).

    References
    ----------
    .. [1] Ray (2002), Applied Photographic Optics, ch. 17 (image illuminance).
    .. [2] EMVA 1288 Release 4.0, §3.1 (irradiance on the sensor from the f-number).
    """
    if not (math.isfinite(working_f_number) and working_f_number > 0):
        raise SensorError(f"working f-number {working_f_number!r} must be a finite number > 0")
    return (np.pi * np.asarray(band_radiance, dtype=float) * np.asarray(transmission, dtype=float)
            / (1.0 + 4.0 * working_f_number ** 2) * np.asarray(cos4, dtype=float))


def quantum_efficiency(model: str, wavelengths_nm, *, peak_qe: float, monochrome: bool = False
                       ) -> np.ndarray:
    """Quantum efficiency of each channel at band centres.

    Measured curves are per-energy responsivities S_c(λ), so η_c(λ) ∝ S_c(λ)/λ, scaled so
    that the maximum over all channels and tabulated wavelengths is ``peak_qe``; zero
    outside the table. ``model = "ideal"`` is flat: η = peak_qe everywhere.

    Parameters
    ----------
    model : str
        ``"ideal"`` or a measured camera name (:func:`spectral_cam.spectra.camera_names`).
    wavelengths_nm : array_like
        Band centres (nm), shape (B,).
    peak_qe : float
        Largest quantum efficiency, in (0, 1] (electrons per photon).
    monochrome : bool
        One channel (only with ``model = "ideal"``).

    Returns
    -------
    numpy.ndarray
        (B, 3) — or (B, 1) when monochrome — electrons per photon.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 (η, the total quantum efficiency).
    .. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §5.4.2 (per-energy camera curves).
    """
    if not (isinstance(peak_qe, (int, float)) and not isinstance(peak_qe, bool)
            and 0 < peak_qe <= 1):
        raise SensorError(f"peak quantum efficiency {peak_qe!r} must lie in (0, 1]")
    wl = np.asarray(wavelengths_nm, dtype=float)
    if model == "ideal":
        return np.full((wl.size, 1 if monochrome else 3), float(peak_qe))
    if monochrome:
        raise SensorError(f"a monochrome sensor needs model 'ideal', not {model!r}")
    try:
        msds = spectra.camera_sensitivities(model)
    except ConfigError as exc:
        raise SensorError(str(exc)) from None
    table_wl = np.asarray(msds.wavelengths, dtype=float)
    eta = np.asarray(msds.values, dtype=float) / table_wl[:, None]
    eta *= peak_qe / eta.max()
    return np.stack([np.interp(wl, table_wl, eta[:, c], left=0.0, right=0.0)
                     for c in range(eta.shape[1])], axis=-1)


def white_quantum_efficiency(qe: np.ndarray) -> np.ndarray:
    """The QE of an RGBW sensor's white (unfiltered) pixels from its colour channels': their sum, at most 1.

    A colour pixel's QE is the bare photodiode's times its filter's transmission, and the three
    filters between them pass each visible wavelength about once, so the bare photodiode's response is
    taken as their sum (the camera data hold no unfiltered curve; a stated approximation).

    Parameters
    ----------
    qe : numpy.ndarray
        (B, 3) R, G, B quantum efficiencies.

    Returns
    -------
    numpy.ndarray
        (B,) electrons per photon.

    References
    ----------
    .. [1] Compton & Hamilton (2007), US 8,139,130 (panchromatic pixels collect what the filters share).
    """
    return np.minimum(np.asarray(qe, dtype=float)[:, :3].sum(axis=1), 1.0)


def band_weights(wavelengths_nm, qe, *, working_f_number: float, pixel_area_m2: float,
                 transmission=1.0) -> np.ndarray:
    """Electrons per second per unit band radiance, per band and channel, on axis.

    ``w_b,c = π·T_b / (1 + 4·N_w²) · A_pix · λ_b·10⁻⁹/(h·c) · η_c(λ_b)``, so that
    ``μ_e,c = t · cos⁴θ · Σ_b L_b·w_b,c``.

    Parameters
    ----------
    wavelengths_nm : array_like
        Band centres (nm), (B,).
    qe : array_like
        (B, C) quantum efficiency.
    working_f_number : float
        N_w.
    pixel_area_m2 : float
        Pixel area A_pix (m²).
    transmission : array_like
        (B,) or scalar lens × filter transmission.

    Returns
    -------
    numpy.ndarray
        (B, C) in e⁻·s⁻¹ per W·m⁻²·sr⁻¹.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 eq. (1)–(2) (photons μ_p = A·E·t·λ/(h·c)).
    """
    if not (math.isfinite(pixel_area_m2) and pixel_area_m2 > 0):
        raise SensorError(f"pixel area {pixel_area_m2!r} m² must be > 0")
    wl = np.asarray(wavelengths_nm, dtype=float)
    trans = np.broadcast_to(np.asarray(transmission, dtype=float), wl.shape)
    irradiance_per_radiance = camera_equation_irradiance(np.ones_like(wl), working_f_number=working_f_number,
                                                         transmission=trans)
    photons = irradiance_per_radiance * pixel_area_m2 * photons_per_joule(wl)
    return photons[:, None] * np.asarray(qe, dtype=float)


# ----------------------------------------------------------------------------- validation
def validate_radiance(radiance: "SpectralImage", sensor: "SensorSection") -> None:  # noqa: C901
    """Check a SpectralImage's shape against the sensor (cheap; values are checked while
    they are integrated).

    Raises
    ------
    SensorError
        For a wrong shape, a band count that does not match the wavelengths, or
        wavelengths that are not finite and positive.

    References
    ----------
    .. [1] The SpectralImage contract of :mod:`spectral_cam.render`.
    """
    data = getattr(radiance, "data", None)
    if not isinstance(data, np.ndarray) or data.ndim != 3:
        shape = getattr(data, "shape", None)
        raise SensorError(
            f"radiance.data must be an (H, W, B) array of band radiances (W·m⁻²·sr⁻¹); got shape {shape}")
    if not np.issubdtype(data.dtype, np.floating):
        raise SensorError(f"radiance.data must be float32 or float64, not {data.dtype}")
    height, width, bands = data.shape
    window = radiance.frame_window if hasattr(radiance, "frame_window") else None
    if window is not None:  # the frame and a crop margin of real pixels around it
        height, width = window[2:]
    if (height, width) != (sensor.height_px, sensor.width_px):
        raise SensorError(
            f"radiance is {width}×{height} pixels but the sensor is {sensor.width_px}×{sensor.height_px}; "
            "set sensor.width_px / sensor.height_px to the radiance's size")
    channels = getattr(radiance, "channels", None)
    if channels:
        if len(channels) != bands:
            raise SensorError(f"radiance has {bands} channels but names {len(channels)}: {tuple(channels)}")
        return
    wl = np.asarray(radiance.wavelengths_nm, dtype=float)
    if wl.shape != (bands,):
        raise SensorError(f"radiance has {bands} bands but {wl.size} wavelengths; they must match")
    if not (np.all(np.isfinite(wl)) and np.all(wl > 0)):
        raise SensorError("radiance.wavelengths_nm must be finite, positive band centres in nm")
    edges = np.asarray(radiance.band_edges_nm, dtype=float)
    if edges.shape != (bands + 1,) or not np.all(np.diff(edges) > 0):
        raise SensorError(f"radiance.band_edges_nm must hold {bands + 1} increasing band edges in nm; "
                          f"got shape {edges.shape}")
    if bands == 0:
        raise SensorError("radiance has no bands")


def _bad_value_message(block: np.ndarray, row0: int) -> str:
    finite = np.isfinite(block)
    if not finite.all():
        y, x, b = np.argwhere(~finite)[0]
        return (f"radiance has a non-finite value ({block[y, x, b]}) at pixel (row {row0 + y}, "
                f"column {x}), band {b}; band radiances must be finite numbers >= 0 W·m⁻²·sr⁻¹")
    negative = np.argwhere(block < 0)
    if len(negative):
        y, x, b = negative[0]
        return (f"radiance is negative ({block[y, x, b]:g}) at pixel (row {row0 + y}, column {x}), band {b}; "
                "band radiances must be finite numbers >= 0 W·m⁻²·sr⁻¹")
    # every value is finite and >= 0, yet the electron rate overflowed float32
    y, x, b = np.unravel_index(np.argmax(block), block.shape)
    return (f"radiance {block[y, x, b]:g} W·m⁻²·sr⁻¹ at pixel (row {row0 + y}, column {x}), band {b} is so "
            "large that the electron rate overflows float32; physical scenes stay many orders of magnitude "
            "below this")


def electron_rates(data: np.ndarray, weights: np.ndarray, *, cfa: str, cos4: np.ndarray | None = None,
                   workers: int | None = None, olpf_px: float = 0.0,
                   channel_gain: np.ndarray | None = None) -> np.ndarray:
    """Mean photo-electron rate of every pixel through its CFA filter (e⁻/s).

    ``rate = cos⁴θ · Σ_b L_b · w_b,c(pixel)``, computed for each pixel's own channel only
    (one dot product per pixel); checks the radiance for NaN, ±Inf and negative values
    while reading it (one pass over the cube, chunked and threaded).

    Parameters
    ----------
    data : numpy.ndarray
        (H, W, B) band radiances (W·m⁻²·sr⁻¹).
    weights : numpy.ndarray
        (B, C) from :func:`band_weights`.
    cfa : str
        CFA pattern or ``"none"`` (then C must be 1).
    cos4 : numpy.ndarray, optional
        (H, W) natural vignetting; None for none.
    workers : int, optional
        Threads (default: the CPUs this process may use, at most 8).
    olpf_px : float
        Spot separation of an optical low-pass filter in pixels (0: none): then every channel's
        full-resolution plane is formed, filtered (:func:`spectral_cam.sensor.olpf.apply_olpf`)
        and sampled through the CFA.
    channel_gain : numpy.ndarray, optional
        (H, W, C) pixel acceptance per channel (:mod:`spectral_cam.sensor.shading`): a property of
        each pixel, so it acts on what reaches the pixel, after the low-pass filter in front of it.

    Returns
    -------
    numpy.ndarray
        float32 (H, W) rate through each pixel's filter.

    Raises
    ------
    SensorError
        If the radiance holds a NaN, an infinity or a negative value.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 (μ_e = η·μ_p).
    """
    height, width, bands = data.shape
    weights = np.asarray(weights, dtype=np.float32)
    if weights.ndim != 2 or weights.shape[0] != bands:
        raise SensorError(f"weights must be (bands={bands}, channels); got {weights.shape}")
    if cfa == "none" and weights.shape[1] != 1:
        raise SensorError("a monochrome sensor (cfa = 'none') needs one QE channel")
    if olpf_px or (cfa != "none" and not is_bayer(cfa)):  # a larger tile: every channel's plane, then sampled
        return _filtered_rates(data, weights, cfa, cos4, olpf_px, workers, channel_gain)
    layout = tile_layout(cfa)
    vectors = [np.ascontiguousarray(weights[:, c]) for c in range(weights.shape[1])]
    rate = np.empty((height, width), dtype=np.float32)

    def work(span):
        r0, r1 = span
        block = _checked_block(data, r0, r1)
        with np.errstate(over="ignore", invalid="ignore"):  # overflow becomes inf: refused just below
            if layout is None:
                np.matmul(block, vectors[0], out=rate[r0:r1])
            else:
                for a in (0, 1):
                    for b in (0, 1):
                        np.matmul(block[a::2, b::2], vectors[layout[a][b]], out=rate[r0 + a:r1:2, b::2])
        _check_finite(rate[r0:r1], block, r0)
        if cos4 is not None:
            rate[r0:r1] *= cos4[r0:r1]

    run_chunks(work, row_chunks(height, width), workers_for(workers))
    if channel_gain is not None:
        rate *= _sampled(channel_gain, cfa)
    return rate


def _checked_block(data: np.ndarray, r0: int, r1: int) -> np.ndarray:
    """Rows r0..r1 of the radiance as float32, refused if they hold a negative value or NaN."""
    block = data[r0:r1].astype(np.float32, copy=False)
    if not block.min() >= 0:  # also catches NaN
        raise SensorError(_bad_value_message(block, r0))
    return block


def _check_finite(rates: np.ndarray, block: np.ndarray, r0: int) -> None:
    """Refuse rates made infinite by the radiance (Inf·w = Inf, Inf·0 = NaN, float32 overflow)."""
    if not np.isfinite(rates).all():
        raise SensorError(_bad_value_message(block, r0))


def _sampled(planes: np.ndarray, cfa: str) -> np.ndarray:
    """Each pixel's own channel of (H, W, C) planes, through the CFA."""
    from ..cfa import channel_index

    if cfa == "none":
        return np.ascontiguousarray(planes[..., 0])
    index = channel_index(planes.shape[:2], cfa).astype(np.intp)
    return np.take_along_axis(planes, index[..., None], axis=2)[..., 0]


def _filtered_rates(data, weights, cfa: str, cos4, olpf_px: float, workers, channel_gain=None) -> np.ndarray:
    """:func:`electron_rates` behind an optical low-pass filter or through a larger CFA tile: all
    channels' planes, filtered (linear in the bands, so equal to filtering each band's irradiance),
    then the CFA's samples."""
    from .olpf import apply_olpf

    height, width, _ = data.shape
    planes = np.empty((height, width, weights.shape[1]), dtype=np.float32)

    def work(span):
        r0, r1 = span
        block = _checked_block(data, r0, r1)
        with np.errstate(over="ignore", invalid="ignore"):  # overflow becomes inf: refused just below
            np.matmul(block, weights, out=planes[r0:r1])
        _check_finite(planes[r0:r1], block, r0)
        if cos4 is not None:
            planes[r0:r1] *= cos4[r0:r1, :, None]

    run_chunks(work, row_chunks(height, width), workers_for(workers))
    if olpf_px:
        planes = apply_olpf(planes, olpf_px)
    if channel_gain is not None:
        planes *= channel_gain
    return _sampled(planes, cfa)


def _row_dot(x: np.ndarray, vector: np.ndarray) -> np.ndarray:
    """``x @ vector`` for a tall (n, B) float32 array, as a stack of small products (one
    huge BLAS gemv wakes OpenBLAS's thread pool, which on small machines costs ~10×)."""
    n, bands = x.shape
    out = np.empty(n, dtype=np.float32)
    step = 1024
    full = n // step * step
    if full:
        np.matmul(x[:full].reshape(-1, step, bands), vector, out=out[:full].reshape(-1, step))
    if n > full:
        np.matmul(x[full:], vector, out=out[full:])
    return out


def max_channel_rates(data: np.ndarray, weights: np.ndarray, *, cos4: np.ndarray | None = None,
                      mask: np.ndarray | None = None, step: int = 1) -> np.ndarray:
    """Largest channel's photo-electron rate (e⁻/s) at the pixels of a mask or a grid.

    Parameters
    ----------
    data : numpy.ndarray
        (H, W, B) band radiances (W·m⁻²·sr⁻¹), already validated.
    weights : numpy.ndarray
        (B, C) from :func:`band_weights`.
    cos4 : numpy.ndarray, optional
        (H, W) natural vignetting.
    mask : numpy.ndarray, optional
        Boolean (H, W): use these pixels; otherwise every pixel of every ``step``-th row.
    step : int
        Row step without a mask (1 = every pixel).

    Returns
    -------
    numpy.ndarray
        float32 1-D ``max_c cos⁴θ·Σ_b L_b·w_b,c`` of the selected pixels.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1.
    """
    weights = np.asarray(weights, dtype=np.float32)
    vectors = [np.ascontiguousarray(weights[:, c]) for c in range(weights.shape[1])]
    if mask is not None:
        selected = data[mask].astype(np.float32, copy=False)
        best = _row_dot(selected, vectors[0])
        for vector in vectors[1:]:
            np.maximum(best, _row_dot(selected, vector), out=best)
        if cos4 is not None:
            best *= cos4[mask]
        return best
    # Whole rows (contiguous in memory), each row's channels while it sits in cache.
    rows = range(0, data.shape[0], step)
    best = np.empty((len(rows), data.shape[1]), dtype=np.float32)
    for i, row in enumerate(rows):
        line = data[row]
        if line.dtype != np.float32:
            line = line.astype(np.float32)
        np.matmul(line, vectors[0], out=best[i])
        for vector in vectors[1:]:
            np.maximum(best[i], np.matmul(line, vector), out=best[i])
    if cos4 is not None:
        best *= cos4[::step]
    return best.ravel()


# ----------------------------------------------------------------------------- caches
@functools.lru_cache(maxsize=4)
def _cos4(lens: "ThinLens") -> np.ndarray:
    cos4 = (lens.pixel_angles_cos() ** 4).astype(np.float32)
    cos4.setflags(write=False)
    return cos4


@functools.lru_cache(maxsize=32)
def _transmission_at(specs: tuple, wavelengths: tuple) -> np.ndarray:
    wl = np.asarray(wavelengths)
    curve = np.ones_like(wl)
    for spec in specs:
        sd = spectra.transmission(spec)
        if sd is not None:
            curve = curve * spectra.sample(sd, wl)
    return curve


@functools.lru_cache(maxsize=32)
def _illuminant_bands(spd: str, edges: tuple) -> np.ndarray:
    wl, irradiance = spectra.absolute_irradiance(spd, 1.0)
    centres = 0.5 * (np.asarray(edges[:-1]) + np.asarray(edges[1:]))
    return spectra.band_integrals(irradiance, wl, spectra.BandGrid(tuple(centres), edges))


# ----------------------------------------------------------------------------- signal model
#: Reference wavelength of the photon-weighted camera film: a film value times
#: λ_ref/(h·c) is photo-electrons per (s·m²·sr) before the camera equation's geometry.
FILM_REFERENCE_NM = 555.0


#: Channel names of a camera-channel SpectralImage (render.bands = "camera").
CAMERA_CHANNELS = ("camera_r", "camera_g", "camera_b", "X", "Y", "Z")


@dataclass(frozen=True)
class SignalModel:
    """How a radiance image becomes photo-electron rates on this sensor.

    Attributes
    ----------
    weights
        (B, C) e⁻·s⁻¹ per unit input value on axis (band radiance W·m⁻²·sr⁻¹, or camera
        film value).
    cos4
        (H, W) natural vignetting, or None.
    qe
        (B, C) quantum efficiency at the band centres (ones for camera channels, whose
        film already holds η).
    camera_channels
        True when the input holds the photon-weighted camera film channels.
    """

    weights: np.ndarray
    cos4: np.ndarray | None
    qe: np.ndarray
    working_f_number: float
    pixel_area_m2: float
    transmission_specs: tuple
    camera_channels: bool
    olpf_px: float = 0.0
    olpf_note: str = "no optical low-pass filter"
    channel_gain: np.ndarray | None = None


def film_curves(config: "SceneConfig", wavelengths_nm) -> np.ndarray:
    """Photon-weighted camera curves for a ``specfilm``: η_c(λ)·T(λ)·λ/λ_ref.

    Integrating radiance against them gives, times λ_ref·10⁻⁹/(h·c), the photon-weighted
    channel signal, so a 3-channel render integrates the camera's response exactly (no
    band discretisation); lens transmission and IR cut are inside.

    Parameters
    ----------
    config : SceneConfig
        Uses sensor.model, sensor.peak_qe, lens.transmission, sensor.ir_cut.
    wavelengths_nm : array_like
        Where to tabulate (nm).

    Returns
    -------
    numpy.ndarray
        (n, 3) dimensionless curves.

    References
    ----------
    .. [1] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §5.4.2 (sensor response
       integrated against measured curves).
    """
    wl = np.asarray(wavelengths_nm, dtype=float)
    qe = quantum_efficiency(config.sensor.model, wl, peak_qe=config.sensor.peak_qe)
    transmission = _transmission_at((config.lens.transmission, config.sensor.ir_cut), tuple(wl.tolist()))
    return qe * (transmission * wl / FILM_REFERENCE_NM)[:, None]


def white_response(radiance: "SpectralImage", config: "SceneConfig", model: "SignalModel",
                   spd: str | None = None) -> np.ndarray:
    """Each channel's response (relative) to the white of the light ``spd`` (default
    ``illuminant.spd``): through the photon-weighted film for camera-channel radiance, else the
    light's band integrals through the signal model's weights. AsShotNeutral is it over its
    largest; the meter balances for it.

    References
    ----------
    .. [1] Adobe (2023). DNG Specification 1.7.1.0, AsShotNeutral.
    """
    spd = config.illuminant.spd if spd is None else spd
    if model.camera_channels:
        wl, irradiance = spectra.absolute_irradiance(spd, 1.0)
        return irradiance @ film_curves(config, wl)
    return _illuminant_bands(spd, tuple(np.asarray(radiance.band_edges_nm, float).tolist())) @ model.weights


def lens_of(radiance: "SpectralImage | None", config: "SceneConfig") -> "ThinLens":
    """The lens a radiance image was rendered through (``radiance.lens``), so the camera
    equation uses the optics the render used; the configured thin lens for an image that
    carries none (a synthetic chart).

    References
    ----------
    .. [1] docs/design.md, "Optics" (one lens per job).
    """
    from ..optics import ThinLens

    lens = getattr(radiance, "lens", None)
    return lens if lens is not None else ThinLens.from_config(config.lens, config.sensor)


def lens_shading(radiance: "SpectralImage | None", config: "SceneConfig") -> dict:
    """How the render's lens model shades the image (``meta["lens_shading"]``, its entry's
    ``shading`` in :data:`spectral_cam.render.lens_models.LENS_MODELS`): ``traced_vignetting``
    (the render holds the falloff already) and ``chief_ray_prescription`` (whose real chief rays
    set the pixels' angle; None: the thin lens's). An image without it (a synthetic chart, an
    older render): the configured model's, a prescription's traced, any other's the thin lens's."""
    recorded = getattr(radiance, "meta", {}).get("lens_shading") if radiance is not None else None
    if recorded is not None:
        return recorded
    traced = config.lens.model == "prescription"
    return {"traced_vignetting": traced, "chief_ray_prescription": config.lens.prescription if traced else None}


def signal_model(radiance: "SpectralImage", config: "SceneConfig") -> SignalModel:
    """The :class:`SignalModel` of a radiance image (spectral bands or camera channels).

    The working f-number and the cos⁴ falloff come from :func:`lens_of` (the render's lens).

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 (photons from irradiance, area and time).
    """
    sensor, lens_cfg = config.sensor, config.lens
    lens = lens_of(radiance, config)
    n_w = lens.working_f_number
    area = (sensor.pixel_pitch_um * 1e-6) ** 2
    trans_specs = (lens_cfg.transmission, sensor.ir_cut)
    shading = lens_shading(radiance, config)
    # a prescription's render already holds its vignetting (natural and mechanical): traced
    cos4 = _cos4(lens) if sensor.vignetting and not shading["traced_vignetting"] else None
    channels = getattr(radiance, "channels", None)
    if channels:
        if tuple(channels) != CAMERA_CHANNELS:
            raise SensorError(f"radiance channels {tuple(channels)} are not the camera film's {CAMERA_CHANNELS}")
        if sensor.cfa == "none":
            raise SensorError("camera-channel radiance needs a colour sensor (sensor.cfa != 'none')")
        if sensor.cfa == "RGBW":
            raise SensorError("an RGBW sensor's white pixels need spectral bands: render.bands = 'auto' or a grid, "
                              "not 'camera' (the camera film holds R, G and B only)")
        geometry = float(camera_equation_irradiance(1.0, working_f_number=n_w)) * area
        weights = np.zeros((len(CAMERA_CHANNELS), 3))
        weights[:3, :3] = np.eye(3) * geometry * float(photons_per_joule(FILM_REFERENCE_NM))
        qe = np.zeros_like(weights)
        qe[:3, :3] = np.eye(3)
        return SignalModel(weights, cos4, qe, n_w, area, trans_specs, True, *_olpf(sensor),
                           _channel_gain(lens, config, 3, shading["chief_ray_prescription"]))
    wavelengths = np.asarray(radiance.wavelengths_nm, dtype=float)
    transmission = _transmission_at(trans_specs, tuple(wavelengths.tolist()))
    qe = quantum_efficiency(sensor.model, wavelengths, peak_qe=sensor.peak_qe, monochrome=sensor.cfa == "none")
    if sensor.cfa == "RGBW":
        qe = np.column_stack([qe, white_quantum_efficiency(qe)])
    weights = band_weights(wavelengths, qe, working_f_number=n_w, pixel_area_m2=area, transmission=transmission)
    return SignalModel(weights, cos4, qe, n_w, area, trans_specs, False, *_olpf(sensor),
                       _channel_gain(lens, config, weights.shape[1], shading["chief_ray_prescription"]))


@functools.lru_cache(maxsize=4)
def _channel_gain_cached(lens: "ThinLens", prescription: str | None, halves: tuple) -> np.ndarray:
    from .shading import channel_gains

    gains = channel_gains(lens, halves, prescription=prescription)
    gains.setflags(write=False)
    return gains


def _channel_gain(lens: "ThinLens", config: "SceneConfig", channels: int,
                  prescription: str | None) -> np.ndarray | None:
    """The pixels' acceptance per channel (:mod:`spectral_cam.sensor.shading`), None when off."""
    from .shading import parse_angular_response

    halves = parse_angular_response(config.sensor.angular_response_deg, channels)
    if halves is None:
        return None
    return _channel_gain_cached(lens, prescription, halves)


def _olpf(sensor: "SensorSection") -> tuple[float, str]:
    from .olpf import olpf_separation_px

    if sensor.cfa == "none" and sensor.olpf == "camera":
        return 0.0, "a monochrome sensor: no optical low-pass filter"
    return olpf_separation_px(sensor.olpf, model=sensor.model, pixel_pitch_um=sensor.pixel_pitch_um)


def electrons_per_band_radiance(config: "SceneConfig", wavelength_nm: float) -> float:
    """Photo-electrons per second of one on-axis pixel per unit band radiance (W·m⁻²·sr⁻¹)
    in the band of the default 400:700:10 grid nearest ``wavelength_nm``, for a monochrome
    (``cfa = "none"``) sensor: ``π·T/(1 + 4·N_w²)·A_pix·λ/(h·c)·η`` (:func:`band_weights`).

    Parameters
    ----------
    config : SceneConfig
        Scene with a monochrome sensor.
    wavelength_nm : float
        A band centre, nm.

    Returns
    -------
    float
        e⁻·s⁻¹ per W·m⁻²·sr⁻¹.

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §2.1 eqs. (1)–(2).
    """
    wl = np.asarray(spectra.parse_bands(spectra.SPECTRAL_BANDS_DEFAULT).centres_nm, float)
    qe = quantum_efficiency(config.sensor.model, wl, peak_qe=config.sensor.peak_qe, monochrome=True)
    lens = lens_of(None, config)
    weights = band_weights(wl, qe, working_f_number=lens.working_f_number,
                           pixel_area_m2=(config.sensor.pixel_pitch_um * 1e-6) ** 2)
    return float(weights[int(np.argmin(np.abs(wl - wavelength_nm))), 0])
