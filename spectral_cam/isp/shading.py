"""Lens-shading correction from a flat-field calibration, as phone ISPs do it.

Calibration: a RAW of a uniform field (an integrating sphere, a diffuser over the lens) gives, per
CFA channel, the level at every pixel of that channel; a smooth surface — a polynomial of degree 8 in
the normalised coordinates fitted by least squares to the logarithm of the levels (45 terms, so the
noise of a single frame averages out) — stands for the channel's shading, and the gain at a pixel
is the channel's level at the frame's centre over the surface there. The degree is what the flat
supports: a surface of T terms needs at least 2T pixels of its sparsest channel and d + 1 distinct
rows and columns, and its standard error at every pixel of the frame (the flat's residual noise
times the root of the fit's leverage there, largest at the corners, where a polynomial
extrapolates) must stay within 0.2 % or half a flat pixel's own noise. A degree-8 surface through
the four red pixels of a 4 × 4 flat (an underdetermined fit) made gains of 0.94–1.64 of a uniform
field; ``degree = "auto"`` takes the largest degree up to 8 the flat supports (0 there: gains of 1),
and a degree asked beyond it is refused with the one that fits. The fit runs in the Legendre basis
(well conditioned to degree 12, accumulated in blocks of rows so a 45 MP flat needs no 45 MP design
matrix) and is stored as the monomials' coefficients. The corrected flat field is
flat in every channel: luminance shading (cos⁴ and the pixels' angular response) and colour shading
(the channels' different responses) alike. A coarse grid of cell means, bilinearly interpolated (the
Android map's form), left 8 % where the shading is steep (a 27° corner at 0.3 of the centre), so the
surface is stored instead. Applied to the black-subtracted mosaic, each pixel times its channel's
gain, before white balance. The table is the camera's, independent of the scene: calibrate once per
lens setting (focal length, aperture), as a phone stores one table per module.

References
----------
.. [1] Android camera2 API, CaptureResult.STATISTICS_LENS_SHADING_CORRECTION_MAP (per-channel gain
   maps over the frame); Adobe (2023), DNG Specification 1.7.1.0, ch. 7, opcodes GainMap and
   FixVignetteRadial (a polynomial gain surface).
.. [2] EMVA Standard 1288, Release 4.0 (2021), §8 (flat-field non-uniformity).
.. [3] Hoaglin, D. C., & Welsch, R. E. (1978). The hat matrix in regression and ANOVA. The American
   Statistician 32(1), 17–22 (leverage: the variance of a fitted value over the noise's).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.polynomial import legendre, polynomial

from ..errors import ConfigError

__all__ = ["ShadingTable", "calibrate_flat_field", "correct_shading", "load_shading_table"]

#: Degree of the fitted shading surface (all terms x^i·y^j with i + j <= degree) where the flat supports it.
DEFAULT_DEGREE = 8
#: The highest degree a table may hold (91 terms: well conditioned in the Legendre basis).
MAX_DEGREE = 12
#: A surface's standard error may reach this relative gain error (0.2 %) ...
GAIN_NOISE_LIMIT = 0.002
#: ... or this fraction of a flat pixel's own noise, whichever is larger.
NOISE_FRACTION_LIMIT = 0.5
#: Gains a table may give anywhere in its frame: a corner at 1 % of the centre's level, or 100× it.
GAIN_RANGE = (0.01, 100.0)
#: Rows of the design matrix built at once (2^18 × 91 terms: 190 MB at most).
_ROWS_PER_BLOCK = 1 << 18


@dataclass(frozen=True)
class ShadingTable:
    """Per-channel shading surfaces of a flat-field calibration.

    Attributes
    ----------
    coefficients : numpy.ndarray
        (channels, terms) of log(level) as a polynomial in x, y ∈ [−1, 1] (the frame's edges), terms
        x^i·y^(t−i) for t = 0..degree, i = 0..t.
    degree : int
        The polynomial's degree (0..12).
    shape : tuple
        (H, W) of the mosaic it was calibrated on.
    cfa : str
        The mosaic's CFA (``"none"``: one channel).

    Raises
    ------
    ConfigError
        For a degree outside 0..12, a CFA that is not one, coefficients that are not (the CFA's
        channels, terms) finite numbers, or gains outside 0.01..100 anywhere in the frame.
    """

    coefficients: np.ndarray
    degree: int
    shape: tuple[int, int]
    cfa: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "coefficients", _check_table(self.coefficients, self.degree, self.shape, self.cfa))
        object.__setattr__(self, "shape", tuple(int(v) for v in self.shape))

    def gains(self) -> np.ndarray:
        """(H, W, channels) gains: the centre's level over each pixel's."""
        height, width = self.shape
        return self._gains_at(_pixel_coords(height), _pixel_coords(width))

    def _gains_at(self, y: np.ndarray, x: np.ndarray) -> np.ndarray:
        """Gains on the grid of rows at ``y`` and columns at ``x`` (normalised coordinates), evaluated
        as a sum over rows and columns, never as a (pixels × terms) matrix."""
        planes = []
        for row in np.asarray(self.coefficients, dtype=np.float64):
            grid = _monomial_grid(row, self.degree)  # grid[i, j]: x^i·y^j
            with np.errstate(over="ignore", invalid="ignore"):
                planes.append(np.exp(grid[0, 0] - polynomial.polygrid2d(y, x, grid.T)))
        return np.stack(planes, axis=-1)

    def to_dict(self) -> dict:
        return {"coefficients": np.asarray(self.coefficients).tolist(), "degree": self.degree,
                "shape": list(self.shape), "cfa": self.cfa, "kind": "spectral_cam lens shading table"}

    def save(self, path) -> Path:
        from ..io import atomic_path

        path = Path(path)
        with atomic_path(path) as tmp:
            tmp.write_text(json.dumps(self.to_dict()), encoding="utf-8")
        return path


def _check_table(coefficients, degree, shape, cfa) -> np.ndarray:
    """The coefficients as a float array, after checking every field (see :class:`ShadingTable`)."""
    from ..cfa import CFA_PATTERNS

    if isinstance(degree, bool) or not isinstance(degree, (int, np.integer)) or not 0 <= degree <= MAX_DEGREE:
        raise ConfigError(f"shading table degree {degree!r}: a whole number in 0..{MAX_DEGREE}")
    if not (isinstance(shape, (tuple, list)) and len(shape) == 2 and all(
            isinstance(v, (int, np.integer)) and not isinstance(v, bool) and 1 <= v <= 1 << 16 for v in shape)):
        raise ConfigError(f"shading table shape {shape!r}: (height, width) of the calibrated mosaic, whole "
                          "numbers of pixels")
    if cfa not in CFA_PATTERNS:
        raise ConfigError(f"shading table cfa {cfa!r}: valid: {', '.join(CFA_PATTERNS)}")
    channels = _channel_count(cfa)
    terms = _term_count(degree)
    try:
        array = np.asarray(coefficients, dtype=np.float64)
    except (TypeError, ValueError):
        array = np.empty(0)
    if array.shape != (channels, terms) or not np.all(np.isfinite(array)):
        raise ConfigError(f"shading table coefficients: a {cfa} table of degree {degree} holds {channels} channel(s) "
                          f"× {terms} finite numbers; this one is {'×'.join(map(str, array.shape)) or 'empty'}"
                          + ("" if np.all(np.isfinite(array)) else ", not all finite"))
    probe = ShadingTable._gains_at(_Coefficients(array, degree), _probe_coords(shape[0]), _probe_coords(shape[1]))
    low, high = GAIN_RANGE
    if not (np.all(np.isfinite(probe)) and probe.min() >= low and probe.max() <= high):
        raise ConfigError(f"shading table gains reach {np.nanmin(probe):.3g}..{np.nanmax(probe):.3g} across the "
                          f"frame; a lens-shading table's gains lie in {low:g}..{high:g} (corners at 1 % of the "
                          "centre's level or more)")
    return array


@dataclass(frozen=True)
class _Coefficients:
    """What :meth:`ShadingTable._gains_at` reads, for a table being checked."""

    coefficients: np.ndarray
    degree: int


def load_shading_table(path) -> ShadingTable:
    """A table written by :meth:`ShadingTable.save`.

    Raises
    ------
    ConfigError
        For a missing file, one that is not a shading table, or a table that
        :class:`ShadingTable` refuses; the message names the file.
    """
    path = Path(path)
    hint = "make one with spectral_cam.isp.shading.calibrate_flat_field(raw).save(path)"
    if not path.is_file():
        raise ConfigError(f"isp.shading = {str(path)!r}: no such file; give the path of a lens shading table (JSON), "
                          f"or 'off'; {hint}")
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
        fields = (data["coefficients"], data["degree"], data["shape"], data["cfa"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ConfigError(f"isp.shading = {str(path)!r}: not a lens shading table ({exc}); {hint}") from None
    coefficients, degree, shape, cfa = fields
    try:
        return ShadingTable(coefficients, degree, tuple(shape) if isinstance(shape, list) else shape, cfa)
    except ConfigError as exc:
        raise ConfigError(f"isp.shading = {str(path)!r}: {exc}") from None


def _term_count(degree: int) -> int:
    return (degree + 1) * (degree + 2) // 2


def _pairs(degree: int) -> list[tuple[int, int]]:
    """(power of x, power of y) of each term, in the stored order (by total degree)."""
    return [(i, total - i) for total in range(degree + 1) for i in range(total + 1)]


def _pixel_coords(size: int, index=None) -> np.ndarray:
    """Normalised coordinates of pixel centres: −1 and 1 are the frame's edges."""
    index = np.arange(size) if index is None else np.asarray(index)
    return (index + 0.5) / size * 2.0 - 1.0


def _probe_coords(size: int, count: int = 17) -> np.ndarray:
    """``count`` coordinates from the first pixel centre to the last: where the checks look."""
    return _pixel_coords(size, np.linspace(0, size - 1, min(count, size)))


def _monomial_grid(row: np.ndarray, degree: int) -> np.ndarray:
    """A stored coefficient row as a (degree + 1)² grid, grid[i, j] of x^i·y^j."""
    grid = np.zeros((degree + 1, degree + 1))
    for value, (i, j) in zip(row, _pairs(degree)):
        grid[i, j] = value
    return grid


def _legendre_rows(x: np.ndarray, y: np.ndarray, degree: int) -> np.ndarray:
    """P_i(x)·P_j(y) for the stored terms' (i, j): the design in a basis orthogonal on [−1, 1]."""
    vx, vy = legendre.legvander(x, degree), legendre.legvander(y, degree)
    return np.stack([vx[:, i] * vy[:, j] for i, j in _pairs(degree)], axis=1)


def _legendre_to_monomials(coefficients: np.ndarray, degree: int) -> np.ndarray:
    """Stored (monomial) coefficients of a surface given by its Legendre coefficients."""
    to_power = np.zeros((degree + 1, degree + 1))  # to_power[k, a]: the x^a coefficient of P_k
    for k in range(degree + 1):
        to_power[k, :k + 1] = legendre.leg2poly(np.eye(degree + 1)[k])[:k + 1]
    grid = np.zeros((degree + 1, degree + 1))
    for value, (i, j) in zip(coefficients, _pairs(degree)):
        grid[i, j] = value
    powers = to_power.T @ grid @ to_power
    return np.array([powers[i, j] for i, j in _pairs(degree)])


def _channel_count(cfa: str) -> int:
    from ..cfa import channel_count

    return 1 if str(cfa).lower() == "none" else channel_count(cfa)


def _channels(cfa: str, shape) -> tuple[np.ndarray, int]:
    from ..cfa import channel_index

    if str(cfa).lower() == "none":
        return np.zeros(shape, dtype=np.intp), 1
    return channel_index(shape, cfa).astype(np.intp), _channel_count(cfa)


@dataclass(frozen=True)
class _ChannelFit:
    """One channel's normal equations in the Legendre basis at the highest degree tried."""

    gram: np.ndarray
    moment: np.ndarray
    sum_squares: float
    mean: float
    count: int
    distinct: int  # the fewer of its distinct rows and columns

    @classmethod
    def of(cls, logs: np.ndarray, rows: np.ndarray, cols: np.ndarray, shape, degree: int) -> "_ChannelFit":
        mean = float(logs.mean())
        terms = _term_count(degree)
        gram, moment, squares = np.zeros((terms, terms)), np.zeros(terms), 0.0
        for start in range(0, logs.size, _ROWS_PER_BLOCK):  # in blocks: no (pixels × terms) matrix
            block = slice(start, start + _ROWS_PER_BLOCK)
            design = _legendre_rows(_pixel_coords(shape[1], cols[block]), _pixel_coords(shape[0], rows[block]), degree)
            values = logs[block] - mean  # centred: the residual sum of squares keeps its digits
            gram += design.T @ design
            moment += design.T @ values
            squares += float(values @ values)
        return cls(gram, moment, squares, mean, int(logs.size), min(np.unique(rows).size, np.unique(cols).size))

    def solve(self, degree: int, probe: np.ndarray) -> tuple[np.ndarray, float, float] | None:
        """(Legendre coefficients, residual noise σ, largest standard error over ``probe`` in units of σ)
        of the degree-``degree`` fit; None where the flat cannot determine it."""
        terms = _term_count(degree)
        if self.count < 2 * terms or self.distinct < degree + 1:
            return None
        try:
            factor = np.linalg.cholesky(self.gram[:terms, :terms])
        except np.linalg.LinAlgError:
            return None
        coefficients = np.linalg.solve(factor.T, np.linalg.solve(factor, self.moment[:terms]))
        residual = max(self.sum_squares - float(coefficients @ self.moment[:terms]), 0.0)
        sigma = float(np.sqrt(residual / (self.count - terms)))
        whitened = np.linalg.solve(factor, probe[:, :terms].T)  # leverage h = |L⁻¹ t|²
        leverage = float(np.max(np.sum(whitened ** 2, axis=0)))
        coefficients[0] += self.mean
        return coefficients, sigma, float(np.sqrt(leverage))


def _supported(solution) -> bool:
    """The surface's standard error everywhere within 0.2 % or half the flat's pixel noise."""
    if solution is None:
        return False
    _, sigma, spread = solution
    return sigma * spread <= max(GAIN_NOISE_LIMIT, NOISE_FRACTION_LIMIT * sigma)


def calibrate_flat_field(raw, *, degree: int | str = "auto") -> ShadingTable:
    """A shading table from a RAW of a uniform field.

    Parameters
    ----------
    raw : RawImage
        A flat-field capture, unclipped and above the black level everywhere.
    degree : int or "auto"
        Degree of the per-channel surface (0..12), or ``"auto"``: the largest up to 8 that the flat
        supports (a surface's standard error within 0.2 % or half a flat pixel's noise at every
        pixel, at least two pixels of each channel per term).

    Returns
    -------
    ShadingTable

    Raises
    ------
    ConfigError
        For a clipped or black flat, a linear RAW, a degree outside 0..12, or one the flat does not
        support (the message names the largest that it does).

    References
    ----------
    .. [1] EMVA 1288 Release 4.0, §8; Adobe DNG 1.7.1.0 ch. 7 (GainMap, FixVignetteRadial).
    .. [2] Hoaglin & Welsch (1978), The American Statistician 32(1), 17–22 (leverage).
    """
    from .normalise import normalise

    if degree != "auto" and (isinstance(degree, bool) or not isinstance(degree, int) or not 0 <= degree <= MAX_DEGREE):
        raise ConfigError(f"shading surface degree {degree!r}: give a whole number in 0..{MAX_DEGREE}, or 'auto'")
    mosaic = normalise(raw.mosaic, black_level=raw.black_level, white_level=raw.white_level)
    if mosaic.ndim != 2:
        raise ConfigError("lens-shading calibration needs a raw mosaic; this RAW is linear (three colours per pixel)")
    if np.any(mosaic >= 0.999):
        raise ConfigError("the flat field is clipped: calibrate on an exposure below saturation")
    if np.any(mosaic <= 0):
        raise ConfigError("the flat field reaches the black level somewhere: expose it brighter")
    index, channels = _channels(raw.cfa, mosaic.shape)
    top = DEFAULT_DEGREE if degree == "auto" else degree
    grid_x, grid_y = np.meshgrid(_probe_coords(mosaic.shape[1]), _probe_coords(mosaic.shape[0]))
    probe = _legendre_rows(grid_x.ravel(), grid_y.ravel(), top)  # the frame's extremes: where leverage peaks
    fits = []
    for c in range(channels):
        rows, cols = np.nonzero(index == c)
        fits.append(_ChannelFit.of(np.log(mosaic[rows, cols].astype(np.float64)), rows, cols, mosaic.shape, top))
    chosen = _choose_degree(fits, probe, top, asked=degree, shape=mosaic.shape)
    coefficients = [_legendre_to_monomials(fit.solve(chosen, probe)[0], chosen) for fit in fits]
    return ShadingTable(np.array(coefficients), chosen, tuple(mosaic.shape), str(raw.cfa))


def _choose_degree(fits, probe, top: int, *, asked, shape) -> int:
    """The degree asked if every channel supports it, else the largest they do ("auto") or a refusal."""
    def supported(d):
        return all(_supported(fit.solve(d, probe)) for fit in fits)

    if asked != "auto" and supported(asked):
        return asked
    best = next((d for d in range(top, -1, -1) if supported(d)), None)
    if asked == "auto" and best is not None:
        return best
    sparsest = min(fit.count for fit in fits)
    size = f"this {shape[1]} × {shape[0]} flat (its sparsest channel has {sparsest} pixels)"
    if best is None:
        raise ConfigError(f"{size} is too small or too noisy for any shading surface: even a constant (degree 0) "
                          "needs two pixels of each channel and a standard error within 0.2 % or half a pixel's noise; "
                          "calibrate on a larger flat field")
    raise ConfigError(f"a degree-{asked} shading surface ({_term_count(asked)} terms) is more than {size} supports: "
                      f"it needs two pixels of each channel per term and a standard error within 0.2 % or half a "
                      f"pixel's noise at every pixel (a polynomial extrapolates at the corners); the largest degree "
                      f"it supports is {best}: give degree <= {best}, degree = 'auto', or a larger flat field")


def correct_shading(mosaic: np.ndarray, cfa: str, table: ShadingTable) -> np.ndarray:
    """The black-subtracted, normalised mosaic with each pixel times its channel's gain.

    Raises
    ------
    ConfigError
        If the table was calibrated on a mosaic of another size or CFA.
    """
    if tuple(mosaic.shape[:2]) != tuple(table.shape) or str(cfa) != table.cfa:
        raise ConfigError(f"the shading table was calibrated on a {table.shape[1]} × {table.shape[0]} {table.cfa} "
                          f"mosaic; this RAW is {mosaic.shape[1]} × {mosaic.shape[0]} {cfa}: calibrate on a flat field "
                          "of this camera")
    index, channels = _channels(cfa, mosaic.shape[:2])
    gains = table.gains()
    per_pixel = np.take_along_axis(gains, index[..., None], axis=2)[..., 0] if channels > 1 else gains[..., 0]
    return (mosaic * per_pixel).astype(mosaic.dtype, copy=False)
