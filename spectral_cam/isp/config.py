"""The ISP's settings: a frozen, validated, TOML/JSON-serialisable :class:`ISPConfig`.

The scene file reader uses :class:`ISPConfig` as its ``[isp]`` section. Valid method names
are the stage registries' (``WHITE_BALANCE``, ``DEMOSAIC``, ``DENOISERS``, ``HIGHLIGHTS``,
``COLOUR_MATRIX``, ``TONE``, ``ENCODERS`` in the sibling modules): a new method is one
registry entry, nothing here. The stage modules import only NumPy at load time (OpenCV,
colour-science and scikit-image load on first use).

Every field takes a TOML-friendly type (``str``, ``float``, ``int``, ``bool`` or a tuple
of ``str``/``float``) and its annotation is kept as a string, the form
:func:`spectral_cam.scene._coerce` reads.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

from ..errors import ConfigError
from .colour_correction import COLOUR_MATRIX
from .demosaic import DEMOSAIC
from .denoise import DENOISERS
from .encode import ENCODERS
from .highlights import HIGHLIGHTS
from .tone import TONE
from .white_balance import WHITE_BALANCE, gains_problem

__all__ = [
    "ISPConfig",
    "WHITE_BALANCE_METHODS",
    "DEMOSAIC_METHODS",
    "DENOISE_METHODS",
    "HIGHLIGHT_METHODS",
    "COLOUR_MATRIX_METHODS",
    "TONE_METHODS",
    "OUTPUT_FORMATS",
]

#: The registry behind each public ``*_METHODS`` name: the names are read from it when asked
#: (:func:`__getattr__`), never copied at import, so an entry a user's module registers later is
#: listed and accepted (one place per extension point).
_REGISTRY_OF = {
    "WHITE_BALANCE_METHODS": WHITE_BALANCE,
    "DEMOSAIC_METHODS": DEMOSAIC,
    "DENOISE_METHODS": DENOISERS,
    "HIGHLIGHT_METHODS": HIGHLIGHTS,
    "COLOUR_MATRIX_METHODS": COLOUR_MATRIX,
    "TONE_METHODS": TONE,
    "OUTPUT_FORMATS": ENCODERS,
}


def __getattr__(name: str) -> tuple[str, ...]:
    """``WHITE_BALANCE_METHODS``, ``DEMOSAIC_METHODS``, …, ``OUTPUT_FORMATS``: the registered names
    now, in registration order (PEP 562 module attributes)."""
    if name in _REGISTRY_OF:
        return _REGISTRY_OF[name].names()
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def _fail(key: str, value: Any, rule: str) -> None:
    raise ConfigError(f"isp.{key} = {value!r}: {rule}")


def _choice(key: str, value: Any, valid: tuple[str, ...]) -> None:
    if value not in valid:
        _fail(key, value, f"unknown name; valid: {', '.join(valid)}")


def _number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class ISPConfig:
    """Image-processing choices of :func:`spectral_cam.isp.develop`.

    Attributes
    ----------
    white_balance
        ``"as_shot"`` (the RAW's AsShotNeutral), ``"grey_world"``, ``"white_patch"`` or
        ``"manual"`` (then ``wb_gains`` gives the R, G, B gains).
    wb_gains
        Three gains for ``white_balance = "manual"`` (normalised so the smallest is 1); the largest at
        most :data:`~spectral_cam.isp.white_balance.MAX_GAIN_RATIO` (2¹⁴) times the smallest.
    demosaic
        ``"rcd"`` (the default since issue 37 #7: ratio-corrected demosaicing and a 3 × 3
        colour-difference median; on the sharp, off-grid leaf and shadow edges of the bundled
        renders 0.66× menon2007's chroma error and none of its dark magenta rims, 0.08× its
        false colour on 16-px grey checkers), ``"menon2007"`` (the default before: 0.44×
        malvar2004's false colour on 16-px checkers, +1.8 dB PSNR over it), ``"malvar2004"``,
        ``"bilinear"``, ``"vng"`` (OpenCV, 8-bit core) or ``"ea"`` (OpenCV edge-aware, 16-bit).
    denoise
        ``"off"``, ``"auto"`` (strength 1 in units of the stabilised noise σ) or a
        strength > 0 (a multiple of that σ).
    denoise_method
        ``"nlmeans"`` (OpenCV fast non-local means), ``"bilateral"`` (OpenCV) or ``"tv"``
        (scikit-image total-variation, Chambolle).
    highlights
        ``"clip"`` (clipped pixels become neutral at the saturation level),
        ``"desaturate"`` (blend clipped areas to neutral) or ``"none"``.
    colour_matrix
        ``"auto"``, ``"dng"`` (inv(ColorMatrix1)·diag(AsShotNeutral) + Bradford CAT to
        D65), ``"fitted"`` / ``"root_polynomial"`` (supplied in ``RawImage.meta``) or
        ``"none"`` (camera RGB passed through, for diagnostics).
    exposure_ev
        Exposure in stops on top of the RAW's BaselineExposure, applied before the tone curve.
    tone
        ``"adobe"`` (default: Adobe's default rendering, the DNG SDK's exposure ramp and ACR3
        curve; a camera's look with a highlight roll-off), ``"srgb"`` (the sRGB OETF only,
        hard clip: the look before issue 23), ``"filmic"`` or ``"linear"`` (no curve).
    sharpen
        Unsharp-mask amount (0 = off).
    sharpen_radius_px
        Standard deviation of the unsharp mask's Gaussian, pixels.
    outputs
        Files to write: ``"png"`` (8-bit), ``"png16"``, ``"jpeg"``, ``"tiff"`` (16-bit),
        ``"exr"`` (linear sRGB, float32).
    jpeg_quality
        JPEG quality 1..100.
    shading
        ``"off"`` or the path of a lens-shading table (:func:`spectral_cam.isp.shading.
        calibrate_flat_field`, saved as JSON): each pixel times its channel's gain before white
        balance.

    References
    ----------
    .. [1] Ramanath, R., Snyder, W. E., Yoo, Y., & Drew, M. S. (2005). Color image
       processing pipeline. IEEE Signal Processing Magazine 22(1), 34–43 (stage order).
    """

    white_balance: str = "as_shot"
    wb_gains: tuple[float, ...] = ()
    demosaic: str = "rcd"
    denoise: float | str = "off"
    denoise_method: str = "nlmeans"
    highlights: str = "clip"
    colour_matrix: str = "auto"
    exposure_ev: float = 0.0
    tone: str = "adobe"
    sharpen: float = 0.0
    sharpen_radius_px: float = 1.0
    outputs: tuple[str, ...] = ("png",)
    jpeg_quality: int = 95
    shading: str = "off"

    def __post_init__(self) -> None:
        # the registries' names now, not tuples taken at import: an entry registered later counts
        _choice("white_balance", self.white_balance, WHITE_BALANCE.names())
        gains = tuple(self.wb_gains)
        if self.white_balance == "manual":
            if len(gains) != 3 or not all(_number(g) and g > 0 for g in gains):
                _fail("wb_gains", self.wb_gains,
                      "white_balance = 'manual' needs three positive gains, e.g. [2.0, 1.0, 1.5]")
        elif gains and (len(gains) != 3 or not all(_number(g) and g > 0 for g in gains)):
            _fail("wb_gains", self.wb_gains, "give three positive gains (R, G, B) or none")
        if gains and gains_problem(gains):  # refused at load, not as NaN in the tone stage (issue 39 #23)
            _fail("wb_gains", self.wb_gains, gains_problem(gains))
        object.__setattr__(self, "wb_gains", tuple(float(g) for g in gains))
        _choice("demosaic", self.demosaic, DEMOSAIC.names())
        if isinstance(self.denoise, str):
            if self.denoise not in ("off", "auto"):
                _fail("denoise", self.denoise, "valid: 'off', 'auto' or a strength > 0 (e.g. 1.0)")
        elif not (_number(self.denoise) and self.denoise >= 0):
            _fail("denoise", self.denoise, "valid: 'off', 'auto' or a strength > 0 (e.g. 1.0)")
        _choice("denoise_method", self.denoise_method, DENOISERS.names())
        _choice("highlights", self.highlights, HIGHLIGHTS.names())
        _choice("colour_matrix", self.colour_matrix, COLOUR_MATRIX.names())
        if not (_number(self.exposure_ev) and abs(self.exposure_ev) <= 20):
            _fail("exposure_ev", self.exposure_ev, "must be a number of stops in [-20, 20]")
        _choice("tone", self.tone, TONE.names())
        if not (_number(self.sharpen) and 0 <= self.sharpen <= 10):
            _fail("sharpen", self.sharpen, "must be an unsharp-mask amount in [0, 10] (0 = off)")
        if not (_number(self.sharpen_radius_px) and 0 < self.sharpen_radius_px <= 50):
            _fail("sharpen_radius_px", self.sharpen_radius_px, "must be a radius in (0, 50] pixels")
        if isinstance(self.outputs, str):
            object.__setattr__(self, "outputs", (self.outputs,))
        for name in self.outputs:
            _choice("outputs", name, ENCODERS.names())
        object.__setattr__(self, "outputs", tuple(self.outputs))
        if not isinstance(self.shading, str) or not self.shading:
            _fail("shading", self.shading, "'off' or the path of a lens-shading table (JSON)")
        if (not isinstance(self.jpeg_quality, int) or isinstance(self.jpeg_quality, bool)
                or not 1 <= self.jpeg_quality <= 100):
            _fail("jpeg_quality", self.jpeg_quality, "must be a whole number in 1..100")

    @property
    def denoise_strength(self) -> float:
        """The denoiser's strength in units of the stabilised noise σ (0 = off)."""
        if self.denoise == "off":
            return 0.0
        if self.denoise == "auto":
            return 1.0
        return float(self.denoise)

    def to_dict(self) -> dict[str, Any]:
        """Plain, JSON/TOML-serialisable dict (tuples become lists)."""
        return {k: list(v) if isinstance(v, tuple) else v for k, v in dataclasses.asdict(self).items()}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "ISPConfig":
        """Build from :meth:`to_dict` output (lists become tuples).

        Raises
        ------
        ConfigError
            For an unknown key (listing the valid ones) or an invalid value.
        """
        known = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(data) - set(known))
        if unknown:
            raise ConfigError(f"unknown key(s) {', '.join('isp.' + k for k in unknown)}; valid keys "
                              f"of [isp]: {', '.join(known)}")
        kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
        return cls(**kwargs)

    def replace(self, **changes: Any) -> "ISPConfig":
        """A validated copy with some fields changed."""
        return dataclasses.replace(self, **changes)
