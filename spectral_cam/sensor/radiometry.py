"""The camera equation and quantum efficiency: band radiance → irradiance on the sensor →
photo-electrons per band and channel.

1. the camera equation (:func:`camera_equation_irradiance`):
   ``E_b = π·L_b·T(λ_b) / (1 + 4·N_w²) · cos⁴θ`` (W·m⁻²), from band integrals of radiance
   ``L_b`` (W·m⁻²·sr⁻¹);
2. photons and electrons (:func:`band_weights`, :func:`electron_rates`):
   ``μ_e,c = Σ_b E_b·A_pix·t·(λ_b·10⁻⁹ / (h·c))·η_c(λ_b)`` — no extra Δλ, ``L_b`` is
   already a band integral — with the quantum efficiency ``η_c ∝ S_c(λ)/λ`` of the
   measured per-energy curves (:func:`quantum_efficiency`); :func:`signal_model` gathers the
   per-band, per-channel weights of a radiance image.

The weights are applied to the radiance cube, through the CFA, in
:mod:`spectral_cam.sensor.pixel_rates` (:func:`electron_rates`, imported here).

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
from ..errors import ConfigError, SensorError
# the weights applied to the radiance cube live in pixel_rates.py; the sensor's stages and
# other programs have imported them from here
from .pixel_rates import electron_rates, max_channel_rates, validate_radiance  # noqa: F401

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
