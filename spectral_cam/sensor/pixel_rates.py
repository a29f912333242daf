"""Each pixel's photo-electron rate: a radiance cube through the signal model's weights and the CFA.

The cube is read once, in row chunks on threads (:mod:`spectral_cam.sensor.parallel`), and checked
while it is read (NaN, ±Inf, negative values, float32 overflow are refused with the pixel named):

- :func:`validate_radiance`: the cube's shape against the sensor (cheap, before any reading);
- :func:`electron_rates`: ``rate = cos⁴θ · Σ_b L_b · w_b,c(pixel)`` through the CFA, one dot
  product per pixel on a Bayer tile; every channel's plane, filtered by the optical low-pass filter
  and the pixels' acceptance, then sampled, otherwise;
- :func:`max_channel_rates`: the largest channel's rate at chosen pixels, for the meter.

The weights ``w_b,c`` and the falloff come from :func:`spectral_cam.sensor.radiometry.signal_model`.

References
----------
.. [1] EMVA Standard 1288, Release 4.0 Linear (2021), §2.1 (μ_e = η·μ_p).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..cfa import is_bayer, tile_layout
from ..errors import SensorError
from .parallel import row_chunks, run_chunks, workers_for

if TYPE_CHECKING:  # pragma: no cover
    from ..image import SpectralImage
    from ..scene import SensorSection

__all__ = ["validate_radiance", "electron_rates", "max_channel_rates"]


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
