"""Noise-model-aware denoising of the linear Bayer mosaic.

The Poisson–Gaussian model of a linear sensor holds only on the raw mosaic, before white
balance, demosaicing and colour mixing: a normalised sample x (black 0, white 1) has
variance ``var(x) = S·x + O`` (the DNG NoiseProfile; from the sensor's gain K in DN/e⁻
and read noise σ_read in e⁻, S = K/(W − B) and O = (K²σ_read² + 1/12)/(W − B)²: x keeps
the dark signal, whose shot noise S·x already counts; docs/design.md, "RAW"). The
generalised Anscombe transform (GAT) maps such data to unit variance at every level; a
denoiser designed for additive white Gaussian noise of σ = 1 then runs on each of the
four CFA planes, and the exact unbiased inverse of Mäkitalo & Foi (2013), in its
closed-form approximation, maps the result back without the low-count bias of the
algebraic inverse.

Strength is a multiple of the stabilised noise σ (which the GAT makes exactly 1), so
``"auto"`` (strength 1) follows the noise model with no further tuning. Where a RAW
carries no noise model, σ is estimated from the data (Gaussian model, Donoho's
median-absolute-deviation estimator as in :func:`skimage.restoration.estimate_sigma`).

References
----------
.. [1] Foi, A., Trimeche, M., Katkovnik, V., & Egiazarian, K. (2008). Practical
   Poissonian-Gaussian noise modeling and fitting for single-image raw-data. IEEE Trans.
   Image Process. 17(10), 1737–1754.
.. [2] Starck, J.-L., Murtagh, F., & Bijaoui, A. (1998). Image Processing and Data
   Analysis: The Multiscale Approach. Cambridge University Press (generalised Anscombe).
.. [3] Mäkitalo, M., & Foi, A. (2013). Optimal inversion of the generalized Anscombe
   transformation for Poisson-Gaussian noise. IEEE Trans. Image Process. 22(1), 91–103.
.. [4] Buades, A., Coll, B., & Morel, J.-M. (2005). A non-local algorithm for image
   denoising. Proc. IEEE CVPR, 60–65 (OpenCV ``fastNlMeansDenoising``).
.. [5] Tomasi, C., & Manduchi, R. (1998). Bilateral filtering for gray and color images.
   Proc. ICCV, 839–846.
.. [6] Chambolle, A. (2004). An algorithm for total variation minimization and
   applications. J. Math. Imaging Vis. 20, 89–97.
.. [7] Adobe (2023). DNG Specification 1.7.1.0, NoiseProfile.
.. [8] EMVA Standard 1288, Release 4.0 (2021), the linear camera model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..cfa import cfa_period, check_cfa
from ..errors import ConfigError
from ..registry import Registry

__all__ = [
    "NoiseModel",
    "DENOISERS",
    "INVERSES",
    "generalized_anscombe",
    "inverse_generalized_anscombe",
    "estimate_noise",
    "denoise_mosaic",
]

#: The closed-form exact unbiased inverse is monotone only above this GAT value; below
#: it the inverse is 0 anyway (Mäkitalo & Foi 2013, §IV).
_D_MIN = 0.8
_SQRT_3_2 = math.sqrt(1.5)


@dataclass(frozen=True)
class NoiseModel:
    """Poisson–Gaussian noise of a normalised mosaic: ``var(x) = gain·x + offset``.

    Attributes
    ----------
    gain
        S, variance per unit signal (normalised units; DNG NoiseProfile S).
    offset
        O, signal-independent variance (normalised units²; DNG NoiseProfile O).
    source
        Where the numbers came from (``"noise_profile"``, ``"sensor"``, ``"estimated"``).

    References
    ----------
    .. [1] Foi, A., et al. (2008). IEEE TIP 17(10), 1737–1754, eq. (5).
    .. [2] Adobe (2023). DNG Specification 1.7.1.0, NoiseProfile.
    """

    gain: float
    offset: float
    source: str = "noise_profile"

    def __post_init__(self) -> None:
        if not (math.isfinite(self.gain) and self.gain >= 0 and math.isfinite(self.offset) and self.offset >= 0):
            raise ConfigError(f"noise model needs finite S >= 0 and O >= 0; got S={self.gain!r}, O={self.offset!r}")
        if self.gain == 0 and self.offset == 0:
            raise ConfigError("noise model with S = O = 0 describes a noiseless sensor; nothing to denoise")

    @classmethod
    def from_sensor(cls, *, gain_dn_per_e: float, dark_noise_e: float, black_level: float,
                    white_level: float) -> "NoiseModel":
        """The model of an EMVA 1288 linear sensor (system gain K, dark noise σ_d).

        Parameters
        ----------
        gain_dn_per_e
            System gain K, DN/e⁻.
        dark_noise_e
            Temporal dark noise σ_d, e⁻ (read noise and dark-current shot noise).
        black_level, white_level
            DN.

        References
        ----------
        .. [1] EMVA Standard 1288, Release 4.0 (2021), eq. (6): σ_y² = K²σ_d² + σ_q² + K(μ_y − μ_y.dark).
        .. [2] Adobe (2023). DNG Specification 1.7.1.0, NoiseProfile.
        """
        scale = float(white_level) - float(black_level)
        k = float(gain_dn_per_e)
        return cls(k / scale, (k * k * float(dark_noise_e) ** 2 + 1.0 / 12.0) / scale ** 2, "sensor")

    def std(self, level) -> np.ndarray:
        """Noise standard deviation at a normalised signal level: √(S·max(x, 0) + O).

        Parameters
        ----------
        level
            Normalised signal x (black 0, white 1).

        References
        ----------
        .. [1] Adobe (2023). DNG Specification 1.7.1.0, NoiseProfile.
        """
        return np.sqrt(self.gain * np.maximum(level, 0.0) + self.offset)


def _counts_domain(model: NoiseModel) -> tuple[float, float]:
    """(α, σ²) such that x/α is Poisson counts plus Gaussian noise of variance σ².

    A purely Gaussian model (S = 0) returns α = 0: the GAT is then the affine map
    x/√O (see :func:`generalized_anscombe`)."""
    if model.gain > 0:
        return model.gain, model.offset / model.gain ** 2
    return 0.0, model.offset


def generalized_anscombe(x: np.ndarray, *, noise: NoiseModel) -> np.ndarray:
    """Variance-stabilising transform of Poisson–Gaussian data to unit variance.

    With z = x/S (Poisson counts plus N(0, σ²), σ² = O/S²):
    ``f(z) = 2·sqrt(max(z + 3/8 + σ², 0))``. For a Gaussian-only model (S = 0) it is
    ``x/√O``.

    Parameters
    ----------
    x
        Normalised linear samples (black 0, white 1), any shape.
    noise
        The noise model of ``x``.

    Returns
    -------
    numpy.ndarray
        float32 values with (approximately) unit noise variance.

    References
    ----------
    .. [1] Starck, J.-L., Murtagh, F., & Bijaoui, A. (1998). Image Processing and Data
       Analysis, §2.2.3 (generalised Anscombe transformation).
    .. [2] Mäkitalo, M., & Foi, A. (2013). IEEE TIP 22(1), 91–103, eq. (2).
    """
    x = np.asarray(x, dtype=np.float32)
    alpha, sigma2 = _counts_domain(noise)
    if alpha == 0:
        return x / np.float32(math.sqrt(sigma2))
    z = x / np.float32(alpha)
    return 2.0 * np.sqrt(np.maximum(z + np.float32(0.375 + sigma2), 0.0))


def _inverse_exact_unbiased(d: np.ndarray, sigma2: float) -> np.ndarray:
    d = np.maximum(d.astype(np.float64), _D_MIN)
    z = (0.25 * d ** 2 + 0.25 * _SQRT_3_2 / d - 1.375 / d ** 2 + 0.625 * _SQRT_3_2 / d ** 3
         - 0.125 - sigma2)
    return np.maximum(z, 0.0)


def _inverse_algebraic(d: np.ndarray, sigma2: float) -> np.ndarray:
    return (np.maximum(d.astype(np.float64), 0.0) / 2.0) ** 2 - 0.375 - sigma2


#: Inverses of the GAT by name.
INVERSES = Registry("GAT inverse")
INVERSES.add("exact_unbiased", _inverse_exact_unbiased, description="Mäkitalo & Foi (2013) closed-form approximation")
INVERSES.add("algebraic", _inverse_algebraic, description="the algebraic inverse (biased at low counts)")


def inverse_generalized_anscombe(d: np.ndarray, *, noise: NoiseModel, method: str = "exact_unbiased") -> np.ndarray:
    """Map denoised GAT values back to normalised linear values.

    ``"exact_unbiased"`` uses the closed-form approximation of the exact unbiased inverse
    (Mäkitalo & Foi 2013, eq. (12)): for z = x/S,
    ``I(D) = D²/4 + √(3/2)/(4D) − 11/(8D²) + 5√(3/2)/(8D³) − 1/8 − σ²``, clipped at 0
    (its domain is non-negative counts), which removes the bias of a nonlinear forward
    transform at low counts. ``"algebraic"`` is the direct inverse
    ``(D/2)² − 3/8 − σ²``, biased by up to ~1/4 count at low signal: for denoised data
    it underestimates dark levels.

    Parameters
    ----------
    d
        Denoised GAT values.
    noise
        The noise model used by :func:`generalized_anscombe`.
    method
        ``"exact_unbiased"`` or ``"algebraic"``.

    Returns
    -------
    numpy.ndarray
        float32 normalised linear values.

    References
    ----------
    .. [1] Mäkitalo, M., & Foi, A. (2013). Optimal inversion of the generalized Anscombe
       transformation for Poisson-Gaussian noise. IEEE TIP 22(1), 91–103.
    """
    alpha, sigma2 = _counts_domain(noise)
    if alpha == 0:
        return (np.asarray(d, dtype=np.float64) * math.sqrt(sigma2)).astype(np.float32)
    return (INVERSES[method](np.asarray(d), sigma2) * alpha).astype(np.float32)


def estimate_noise(mosaic: np.ndarray, cfa: str) -> NoiseModel:
    """Estimate a Gaussian noise model from a mosaic that carries none.

    σ is the mean over the four CFA planes of Donoho's wavelet-MAD estimate
    (:func:`skimage.restoration.estimate_sigma` without PyWavelets: the finest diagonal
    Haar detail, median(|d|)/0.6745).

    Parameters
    ----------
    mosaic
        (H, W) normalised linear mosaic.
    cfa
        Bayer tile name, or ``"none"`` (monochrome).

    Returns
    -------
    NoiseModel
        S = 0, O = σ².

    References
    ----------
    .. [1] Donoho, D. L., & Johnstone, I. M. (1994). Ideal spatial adaptation by wavelet
       shrinkage. Biometrika 81(3), 425–455.
    """
    if str(cfa).lower() != "none":
        check_cfa(cfa, allow_extended=True)
    rows, cols = (2, 2) if str(cfa).lower() == "none" else cfa_period(cfa)  # one colour per sub-sampled plane
    sigmas = []
    for dy in range(rows):
        for dx in range(cols):
            plane = np.asarray(mosaic[dy::rows, dx::cols], dtype=np.float64)
            h, w = (plane.shape[0] // 2) * 2, (plane.shape[1] // 2) * 2
            p = plane[:h, :w]
            # orthonormal Haar HH sub-band
            detail = (p[0::2, 0::2] - p[0::2, 1::2] - p[1::2, 0::2] + p[1::2, 1::2]) / 2.0
            if detail.size:
                sigmas.append(np.median(np.abs(detail)) / 0.6745)
    sigma = float(np.mean(sigmas)) if sigmas else 0.0
    return NoiseModel(0.0, max(sigma, 1e-12) ** 2, "estimated")


# ----------------------------------------------------------------------------- denoisers
def _nlmeans(plane: np.ndarray, strength: float) -> np.ndarray:
    import cv2

    # OpenCV's fast NL-means takes 8- or 16-bit data; 16 bits with the L1 patch
    # distance. Scale the unit-σ plane so it fills the 16-bit range.
    low, top = float(np.min(plane)), float(np.max(plane))
    scale = 60000.0 / max(top - low, 1e-6)
    code = np.clip(np.rint((plane - np.float32(low)) * np.float32(scale)), 0, 65535).astype(np.uint16)
    h = float(_NLM_H_PER_SIGMA * strength * scale)
    out = cv2.fastNlMeansDenoising(code, h=[h], templateWindowSize=_NLM_TEMPLATE, searchWindowSize=_NLM_SEARCH,
                                   normType=cv2.NORM_L1)
    return out.astype(np.float32) / np.float32(scale) + np.float32(low)


def _bilateral(plane: np.ndarray, strength: float) -> np.ndarray:
    import cv2

    return cv2.bilateralFilter(np.ascontiguousarray(plane, np.float32), d=7,
                               sigmaColor=float(_BILATERAL_SIGMA_COLOR * strength), sigmaSpace=2.0)


def _tv(plane: np.ndarray, strength: float) -> np.ndarray:
    from skimage.restoration import denoise_tv_chambolle

    return denoise_tv_chambolle(plane.astype(np.float32), weight=float(_TV_WEIGHT * strength)).astype(np.float32)


#: Filter parameters per unit strength (unit-σ data), chosen so that strength 1 removes
#: most of the noise of a flat field without visibly smoothing ColorChecker edges.
_NLM_H_PER_SIGMA = 1.0
_NLM_TEMPLATE = 5
_NLM_SEARCH = 15
_BILATERAL_SIGMA_COLOR = 2.0
_TV_WEIGHT = 1.0

#: Denoisers for additive white Gaussian noise of σ = 1, by name.
DENOISERS = Registry("denoise method")
DENOISERS.add("nlmeans", _nlmeans, description="non-local means (Buades et al. 2005)")
DENOISERS.add("bilateral", _bilateral, description="bilateral filter (Tomasi & Manduchi 1998)")
DENOISERS.add("tv", _tv, description="total variation (Chambolle 2004)")


def denoise_mosaic(
    mosaic: np.ndarray,
    cfa: str,
    *,
    noise: NoiseModel,
    strength: float = 1.0,
    method: str = "nlmeans",
    inverse: str = "exact_unbiased",
) -> np.ndarray:
    """Denoise a normalised linear Bayer mosaic under a Poisson–Gaussian noise model.

    GAT → per-CFA-plane denoiser for unit-σ Gaussian noise → exact unbiased inverse GAT.

    Parameters
    ----------
    mosaic
        (H, W) float32 normalised mosaic (black 0, white 1), before white balance.
    cfa
        Bayer tile name (each CFA plane is denoised on its own), or ``"none"`` for a
        monochrome sensor.
    noise
        Its noise model (:class:`NoiseModel`: from the DNG NoiseProfile, the sensor's K
        and σ_d, or :func:`estimate_noise`).
    strength
        Multiple of the stabilised noise σ (= 1) that sets the filter (NL-means h,
        bilateral range σ, TV weight); 0 returns the input.
    method
        ``"nlmeans"``, ``"bilateral"`` or ``"tv"``.
    inverse
        ``"exact_unbiased"`` (default) or ``"algebraic"``.

    Returns
    -------
    numpy.ndarray
        (H, W) float32 denoised mosaic.

    Raises
    ------
    ConfigError
        For an unknown method or inverse (listing the valid ones).

    References
    ----------
    .. [1] Mäkitalo, M., & Foi, A. (2013). IEEE TIP 22(1), 91–103.
    .. [2] Buades, A., Coll, B., & Morel, J.-M. (2005). Proc. IEEE CVPR, 60–65.
    """
    DENOISERS.check(method)
    INVERSES.check(inverse)
    if not (math.isfinite(strength) and strength >= 0):
        raise ConfigError(f"denoise strength {strength!r} must be a number >= 0")
    mosaic = np.asarray(mosaic, dtype=np.float32)
    if mosaic.ndim != 2:
        raise ConfigError(f"denoising needs a 2-D mosaic; got shape {mosaic.shape}")
    monochrome = str(cfa).lower() == "none"
    if not monochrome:
        check_cfa(cfa, allow_extended=True)
    if strength == 0:
        return mosaic.copy()
    stabilised = generalized_anscombe(mosaic, noise=noise)
    out = np.empty_like(stabilised)
    rows, cols = (1, 1) if monochrome else cfa_period(cfa)  # each sub-sampled plane holds one colour
    for dy in range(rows):
        for dx in range(cols):
            plane = np.ascontiguousarray(stabilised[dy::rows, dx::cols])
            if plane.size:
                out[dy::rows, dx::cols] = DENOISERS[method](plane, strength)
    return inverse_generalized_anscombe(out, noise=noise, method=inverse)
