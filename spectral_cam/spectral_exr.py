"""Multichannel spectral OpenEXR files (radiance per nm, one float32 channel per band).

The layout is that of Fichet, Pacanowski & Wilkie (2021): emissive channels named
``S0.<λ>nm`` with the wavelength written with a decimal comma (``S0.550,000000nm``, since a
period separates EXR layers), a ``spectralLayoutVersion`` attribute and ``emissiveUnits``.
pbrt-v4 and ART read it. The band edges (which the layout does not carry) are stored in an
extra ``spectral_cam_band_edges_nm`` attribute so the file round-trips exactly.

References
----------
.. [1] Fichet, A., Pacanowski, R., & Wilkie, A. (2021). An OpenEXR Layout for Spectral
   Images. Journal of Computer Graphics Techniques 10(3), 1–18.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from .errors import RawFormatError
from .image import SpectralImage
from .exr import HALF_MAX, HALF_MIN_NORMAL, resolve_compression, write_exr, write_exr_channels
from .errors import ConfigError

__all__ = ["write_spectral_exr", "read_spectral_exr", "write_depth_exr", "read_depth_exr", "channel_name", "read_exr"]

_CHANNEL = re.compile(r"^S0\.(\d+(?:,\d+)?)nm$")
EMISSIVE_UNITS = "W.m^-2.sr^-1"


def channel_name(wavelength_nm: float) -> str:
    """``S0.<λ>nm`` with a decimal comma, e.g. ``S0.550,000000nm``."""
    return "S0." + f"{wavelength_nm:.6f}".replace(".", ",") + "nm"


def write_spectral_exr(image: SpectralImage, path: str | Path, *, precision: str = "float") -> Path:
    """Write spectral radiance **per nm** (band integral / band width), W·m⁻²·sr⁻¹·nm⁻¹.

    The file appears only once complete (written to a temporary name, then renamed).

    Parameters
    ----------
    image
        Band integrals of radiance.
    path
        Output file.
    precision : {"float", "half"}
        Pixel type: FLOAT (binary32) or HALF (binary16: half the bytes, a relative error
        ≤ 2⁻¹¹ = 0.049 % for values from 6.1e-5 to 65504 W·m⁻²·sr⁻¹·nm⁻¹, coarser below;
        docs/design.md measures it against the sensor's noise).

    Raises
    ------
    ConfigError
        For ``precision="half"`` when a value passes the largest half (65504), which would be
        written as infinity; nothing is written.

    Examples
    --------
    >>> import pathlib, tempfile
    >>> import numpy as np
    >>> from spectral_cam.radiance_targets import narrow_band_flat
    >>> from spectral_cam.spectral_exr import read_spectral_exr, write_spectral_exr
    >>> image = narrow_band_flat((4, 4), 0.05)            # 31 bands of 10 nm, 400–700 nm
    >>> path = write_spectral_exr(image, pathlib.Path(tempfile.mkdtemp()) / "radiance.exr")
    >>> back = read_spectral_exr(path)
    >>> bool(np.allclose(back.data, image.data)), back.wavelengths_nm[:3].tolist()
    (True, [400.0, 410.0, 420.0])
    """
    # streamed 16 rows at a time from the cube (per nm on the way): no copy of the cube,
    # which is 5.6 GB for a 45 MP frame of 31 bands
    cube = image.data
    names = [channel_name(w) for w in image.wavelengths_nm]
    order = sorted(range(len(names)), key=lambda i: names[i].encode())  # OpenEXR's channel order
    widths = np.asarray(image.band_widths_nm, dtype=np.float32)[order]

    def rows(first: int, end: int) -> np.ndarray:
        block = np.asarray(cube[first:end], dtype=np.float32)[..., order]  # (rows, W, B) in name order
        return np.divide(block, widths, dtype=np.float32).transpose(0, 2, 1)  # per nm

    attributes = {
        "spectralLayoutVersion": "1.0",
        "emissiveUnits": EMISSIVE_UNITS,
        "spectral_cam_band_edges_nm": json.dumps([float(e) for e in image.band_edges_nm]),
    }
    height, width = cube.shape[:2]
    if precision == "half":
        _check_half_range(cube, image.band_widths_nm)
    codec = resolve_compression("auto", rows, height, precision)
    return write_exr(path, [names[i] for i in order], width, height, rows, attributes=attributes, compression=codec,
                     pixel_type=precision)


#: Warn when more than this fraction of a half file's positive values fall below the normal
#: range, where the rounding passes 0.049 %.
SUBNORMAL_WARN_FRACTION = 0.01


def _check_half_range(cube: np.ndarray, band_widths_nm) -> None:
    """Whether the per-nm radiance fits a half, in one pass over the cube in blocks of 64 rows
    (bounded memory on a 45 MP cube): a ConfigError where a value passes the largest half
    (written as infinity), a SceneWarning when a dim scene puts many values below half's normal
    range (a 1000-lux ColorChecker: 15 % of them; a 1-lux one: all of them, docs/design.md)."""
    widths = np.asarray(band_widths_nm, dtype=np.float32)
    peak, below, positive = 0.0, 0, 0
    for first in range(0, cube.shape[0], 64):
        block = np.asarray(cube[first:first + 64], dtype=np.float32) / widths
        if block.size:
            peak = max(peak, float(block.max()))
        lit = block > 0
        positive += int(np.count_nonzero(lit))
        below += int(np.count_nonzero(lit & (block < HALF_MIN_NORMAL)))
    if peak > HALF_MAX:
        raise ConfigError(f"render.radiance_precision = 'half' cannot hold this radiance: it reaches {peak:.4g} "
                          f"W·m⁻²·sr⁻¹·nm⁻¹, beyond the largest half ({HALF_MAX:g}); use 'float'")
    if positive and below / positive > SUBNORMAL_WARN_FRACTION:
        import warnings

        from .errors import SceneWarning

        warnings.warn(f"render.radiance_precision = 'half': {100 * below / positive:.3g} % of radiance.exr's values lie "
                      f"below {HALF_MIN_NORMAL:.3g} W·m⁻²·sr⁻¹·nm⁻¹, where a half keeps fewer digits than its 0.049 % "
                      "(a dim scene); use 'float' to keep them", SceneWarning, stacklevel=4)


def read_exr(path: str | Path) -> tuple[dict, dict]:
    """(header, {name: (H, W) pixels}) of an EXR file, R, G, B (and A) split out of the group the
    OpenEXR bindings make of them, or a RawFormatError saying why not (also for channels that
    are not float images)."""
    import OpenEXR

    path = Path(path)
    if not path.is_file():
        raise RawFormatError(f"{path} does not exist")
    try:
        exr = OpenEXR.File(str(path))
        header = dict(exr.header())
        channels = {}
        for name, channel in exr.channels().items():
            pixels = np.asarray(channel.pixels)
            if pixels.ndim == 3:  # "RGB" / "RGBA": one entry of three or four channels
                channels.update({letter: pixels[..., i] for i, letter in enumerate(name)})
            else:
                channels[name] = pixels
    except Exception as exc:  # OpenEXR raises bare Exception/ValueError on corrupt files
        raise RawFormatError(f"{path} is not a readable OpenEXR file: {exc}") from None
    if any(pixels.ndim != 2 or pixels.dtype.kind != "f" for pixels in channels.values()):
        raise RawFormatError(f"{path} is not a readable OpenEXR file: channels are not float images")
    return header, channels


def _band_edges(path: Path, attribute, bands: int) -> np.ndarray:
    """The ``spectral_cam_band_edges_nm`` attribute: B + 1 finite, increasing edges, or a
    RawFormatError (a wrong-length or NaN list was broadcast into the data)."""
    try:
        edges = np.asarray(json.loads(attribute), dtype=float)
    except (TypeError, ValueError):
        raise RawFormatError(f"{path}: attribute spectral_cam_band_edges_nm is not a JSON list of numbers") from None
    if edges.shape != (bands + 1,) or not np.all(np.isfinite(edges)) or not np.all(np.diff(edges) > 0):
        raise RawFormatError(f"{path}: spectral_cam_band_edges_nm must hold {bands + 1} finite, increasing band "
                             f"edges (nm) for its {bands} spectral channels; it holds {np.ravel(edges)[:8].tolist()}")
    return edges


def read_spectral_exr(path: str | Path) -> SpectralImage:
    """Read a spectral EXR (ours or any file in the Fichet et al. layout) into a
    :class:`SpectralImage` of band integrals."""
    path = Path(path)
    header, parts = read_exr(path)
    found = []
    for name, pixels in parts.items():
        match = _CHANNEL.match(name)
        if match:
            found.append((float(match.group(1).replace(",", ".")), pixels))
    if not found:
        raise RawFormatError(
            f"{path} has no emissive spectral channels named S0.<wavelength>nm; "
            f"it holds {', '.join(sorted(parts)) or 'no channels'}"
        )
    found.sort(key=lambda item: item[0])
    wavelengths = np.array([w for w, _ in found])
    per_nm = np.stack([np.asarray(p, dtype=np.float32) for _, p in found], axis=-1)
    if "spectral_cam_band_edges_nm" in header:
        edges = _band_edges(path, header["spectral_cam_band_edges_nm"], len(wavelengths))
    else:  # contiguous bands around the sampled wavelengths
        mids = (wavelengths[1:] + wavelengths[:-1]) / 2
        first = wavelengths[0] - (mids[0] - wavelengths[0]) if len(mids) else wavelengths[0] - 0.5
        last = wavelengths[-1] + (wavelengths[-1] - mids[-1]) if len(mids) else wavelengths[0] + 0.5
        edges = np.concatenate([[first], mids, [last]])
    data = per_nm * np.diff(edges).astype(np.float32)
    return SpectralImage(data, wavelengths, edges, None, {"source": str(path)})


def write_depth_exr(depth_m: np.ndarray, path: str | Path) -> Path:
    """Write camera-space depth (m) as a single float32 channel ``Z``."""
    return write_exr_channels({"Z": depth_m}, path)


def read_depth_exr(path: str | Path) -> np.ndarray:
    """Read the ``Z`` channel of a depth EXR (m)."""
    path = Path(path)
    _, channels = read_exr(path)
    if "Z" not in channels:
        raise RawFormatError(f"{path} has no 'Z' channel; it holds {', '.join(sorted(channels))}")
    return channels["Z"].astype(np.float32)
