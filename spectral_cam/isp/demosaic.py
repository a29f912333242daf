"""Demosaicing: a registry of interpolators with one call, :func:`demosaic`.

Each :data:`DEMOSAIC` entry (a :class:`DemosaicEntry`) declares the CFA tiles it takes: a Bayer
tile of any phase (:data:`BAYER`) and/or larger tiles (X-Trans, Quad Bayer, RGBW;
:data:`spectral_cam.cfa.EXTENDED_PATTERNS`), and which larger tile's default it is. The larger tiles'
own methods, ``colour_difference`` (any CFA), ``quad_binning``, ``quad_remosaic`` and ``rgbw_fusion``,
live in :mod:`spectral_cam.isp.tile_demosaic`; :data:`CFA_METHODS` and :func:`bayer_methods` read the
entries, and :func:`method_for` asks them when a Bayer method is asked of another tile.

Every method takes the (white-balanced) float32 linear mosaic and returns (H, W, 3)
float32 linear RGB, unclipped, for any of the four Bayer phases and any image size
(odd included).

``bilinear``, ``malvar2004`` (:mod:`spectral_cam.isp.linear_demosaic`) and ``menon2007`` are written
on the four CFA planes (R, G in red rows, G in blue rows, B), so each value is computed only at the
sites that keep it, and run by :func:`spectral_cam.isp.plane_bands.by_planes` on cache-sized row bands
on threads, whose per-site colours ``cv2.merge``
interleaves straight into the output. Mirror padding about the edge pixel (BORDER_REFLECT_101)
keeps the CFA phase, so borders are exact too.

- ``bilinear``: the mean of the nearest 2 or 4 samples of each missing colour (normalised
  masked convolution, to float32 rounding).
- ``malvar2004``: gradient-corrected linear interpolation, the four 5×5 kernels of Malvar,
  He & Cutler, each evaluated at the sites that use it.
- ``menon2007``: directional filtering with a posteriori decision, colour-demosaicing's
  algorithm in float32 (:mod:`spectral_cam.isp.menon2007`).
- ``rcd`` (the default, issue 37 #7): ratio-corrected demosaicing and one 3 × 3 median of the
  colour differences (:mod:`spectral_cam.isp.rcd`): no dark magenta rims at sharp, off-grid edges
  of high contrast, where menon2007's Laplacian-corrected green undershoots.
- ``vng`` and ``ea``: OpenCV's variable number of gradients and edge-aware demosaicing.
  OpenCV's VNG accepts 8-bit input only (EA 8- or 16-bit). To keep the linear data's
  precision, the mosaic is split in two layers: a coarse layer, scaled to the image
  maximum and quantised (square-root encoded to 8 bits for VNG, linear 16 bits for EA),
  which OpenCV demosaics; and the residual the quantisation left, which is small and is
  interpolated bilinearly and added back. Measured samples are therefore kept exactly,
  and the result differs from a hypothetical float VNG only in how the sub-quantum
  residual is interpolated.

References
----------
.. [1] Malvar, H. S., He, L., & Cutler, R. (2004). High-quality linear interpolation for
   demosaicing of Bayer-patterned color images. Proc. IEEE ICASSP, vol. 3, 485–488.
.. [2] Menon, D., Andriani, S., & Calvagno, G. (2007). Demosaicing with directional
   filtering and a posteriori decision. IEEE Trans. Image Process. 16(1), 132–141.
.. [3] Chang, E., Cheung, S., & Pan, D. Y. (1999). Color filter array recovery using a
   threshold-based variable number of gradients. Proc. SPIE 3650, 36–43 (VNG).
.. [4] OpenCV documentation, imgproc "Color conversions", Bayer → RGB (bilinear, VNG, EA).
.. [5] Mansencal, T., et al. colour-demosaicing, https://github.com/colour-science/colour-demosaicing
.. [6] Sanz Rodríguez, L. (2017). RCD: Ratio Corrected Demosaicing, v2.3.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields
from typing import Callable, Iterator

import numpy as np

from ..cfa import EXTENDED_PATTERNS, check_cfa, is_bayer, opencv_bayer_code
from ..errors import ConfigError
from ..registry import Entry, Registry
from .linear_demosaic import _bilinear_sites, _malvar_sites, bilinear, malvar2004  # noqa: F401 (tests read the sites)
from .menon2007 import MENON_BAND_ROWS, menon2007  # noqa: F401 (MENON_BAND_ROWS: its old home)
from .plane_bands import BAND_ROWS, by_planes, check_bayer_mosaic  # noqa: F401 (their old home)
from .scratch import Scratch as _Scratch  # noqa: F401 (its old name here)
from .tile_demosaic import colour_difference, quad_binning, quad_remosaic, rgbw_fusion

__all__ = ["DEMOSAIC", "DemosaicEntry", "DemosaicRegistry", "BAYER", "demosaic", "bilinear", "malvar2004",
           "menon2007", "rcd", "vng", "ea", "colour_difference", "quad_binning", "quad_remosaic", "rgbw_fusion",
           "method_for", "CFA_METHODS", "bayer_methods"]

_F32 = np.float32


def rcd(mosaic: np.ndarray, cfa: str = "RGGB", *, median: bool = True) -> np.ndarray:
    """Ratio-corrected demosaicing (Sanz Rodríguez 2017) and one 3 × 3 median of R − G and B − G.

    Green at red and blue sites from the four neighbouring greens, each scaled by a ratio of
    low-passes and weighted by inverse gradients, the two axes blended by a soft decision; red
    and blue from colour differences along the diagonals and axes; then dcraw's false-colour
    median (:mod:`spectral_cam.isp.rcd`). The default: on the sharp, off-grid edges of the
    bundled renders (no optical low-pass filter) it leaves 0.66× menon2007's chroma error
    (vegetation, noise-free, mean ΔC*ab on edge pixels 5.97 → 3.93) and no dark magenta rims; on
    pixel-aligned grey checkers 0.08× its false colour.

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name read from the top-left pixel.
    median
        Finish with the colour-difference median (as the registered method does).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB, unclipped; without the median, measured samples are kept
        (the median moves red and blue by their colour difference's 3 × 3 median).

    References
    ----------
    .. [1] Sanz Rodríguez, L. (2017). RCD: Ratio Corrected Demosaicing, v2.3.
    .. [2] Coffin, D. dcraw.c, ``median_filter`` (``-m``).
    """
    from .rcd import rcd as _rcd

    mosaic, cfa = check_bayer_mosaic(mosaic, cfa)
    return _rcd(mosaic, cfa, median=median)


#: Mirror padding (pixels, even) around the mosaic for OpenCV's Bayer conversions.
_OPENCV_PAD = 4


def _opencv_layers(mosaic: np.ndarray, cfa: str, method: str, bits: int, sqrt_encode: bool) -> np.ndarray:
    """OpenCV demosaicing of a quantised coarse layer plus bilinear interpolation of the
    quantisation residual (see the module docstring)."""
    import cv2

    top = float(np.max(mosaic))
    if not np.isfinite(top) or top <= 0:
        return bilinear(mosaic, cfa)
    levels = float(2 ** bits - 1)
    unit = np.clip(mosaic / _F32(top), 0.0, 1.0)
    encoded = np.sqrt(unit) if sqrt_encode else unit
    code = np.rint(encoded * levels).astype(np.uint8 if bits == 8 else np.uint16)

    def decode(values):
        v = values.astype(_F32) / _F32(levels)
        return (v * v if sqrt_encode else v) * _F32(top)

    # OpenCV fills its outermost rows and columns by copying; pad by an even width with
    # mirror padding (which keeps the CFA phase) so every output pixel is interpolated
    pad = _OPENCV_PAD
    padded = cv2.copyMakeBorder(code, pad, pad, pad, pad, cv2.BORDER_REFLECT_101)
    coarse = decode(cv2.cvtColor(padded, opencv_bayer_code(cfa, method))[pad:-pad, pad:-pad])
    residual = mosaic - decode(code)
    return (coarse + bilinear(residual, cfa)).astype(_F32, copy=False)


def vng(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """OpenCV's variable-number-of-gradients demosaicing (8-bit core, see module notes).

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name read from the top-left pixel (OpenCV's name is derived with
        :func:`~spectral_cam.cfa.opencv_bayer_name`).

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB.

    References
    ----------
    .. [1] Chang, E., Cheung, S., & Pan, D. Y. (1999). Proc. SPIE 3650, 36–43.
    .. [2] OpenCV documentation, COLOR_Bayer**2RGB_VNG (8-bit only).
    """
    mosaic, cfa = check_bayer_mosaic(mosaic, cfa)
    return _opencv_layers(mosaic, cfa, "VNG", 8, True)


def ea(mosaic: np.ndarray, cfa: str = "RGGB") -> np.ndarray:
    """OpenCV's edge-aware demosaicing, run on 16 bits (see module notes).

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic.
    cfa
        Bayer tile name read from the top-left pixel.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB.

    References
    ----------
    .. [1] OpenCV documentation, COLOR_Bayer**2RGB_EA.
    """
    mosaic, cfa = check_bayer_mosaic(mosaic, cfa)
    return _opencv_layers(mosaic, cfa, "EA", 16, False)


# ----------------------------------------------------------------------------- the registry
#: The tile name a :class:`DemosaicEntry` gives for a 2 × 2 Bayer mosaic of any phase (RGGB, BGGR, GRBG, GBRG).
BAYER = "BAYER"


@dataclass(frozen=True)
class DemosaicEntry(Entry):
    """A demosaicer and the CFA tiles it takes.

    Attributes
    ----------
    tiles : tuple of str
        :data:`BAYER` (any 2 × 2 Bayer phase) and/or names of :data:`spectral_cam.cfa.EXTENDED_PATTERNS`.
    default_for : tuple of str
        The larger tiles whose default it is: :func:`method_for` gives it when a method that does not
        take the tile is asked of it.
    """

    tiles: tuple[str, ...] = (BAYER,)
    default_for: tuple[str, ...] = ()


class DemosaicRegistry(Registry):
    """The :data:`DEMOSAIC` registry: as :class:`~spectral_cam.registry.Registry`, but every entry says
    which CFA tiles it takes (default: Bayer only), so the tile knowledge has one place."""

    def register(self, name: str, *, tiles: tuple[str, ...] = (BAYER,), default_for: tuple[str, ...] = (),
                 options: tuple[str, ...] = (), description: str = ""):
        """Decorator: register the decorated demosaicer under ``name`` with the tiles it takes."""

        def decorate(function: Callable) -> Callable:
            self.add(name, function, tiles=tiles, default_for=default_for, options=options, description=description)
            return function

        return decorate

    def add(self, name: str, function: Callable, *, tiles: tuple[str, ...] = (BAYER,),
            default_for: tuple[str, ...] = (), options: tuple[str, ...] = (), description: str = "") -> DemosaicEntry:
        """Register ``function(mosaic, cfa) → (H, W, 3) float32`` under ``name``.

        Raises
        ------
        ValueError
            For a tile that is neither :data:`BAYER` nor a larger tile's name, a ``default_for`` tile the
            entry does not take, or a tile that already has a default.
        """
        tiles, default_for = tuple(tiles), tuple(default_for)
        unknown = [t for t in tiles if t != BAYER and t not in EXTENDED_PATTERNS]
        if unknown or not tiles or not set(default_for) <= set(tiles) - {BAYER}:
            raise ValueError(f"demosaic method {name!r}: tiles {tiles} must name {BAYER!r} or larger tiles "
                             f"({', '.join(EXTENDED_PATTERNS)}), and default_for {default_for} only larger tiles "
                             "among them")
        taken = [t for t in default_for if self.default_of(t) is not None]
        if taken:
            raise ValueError(f"demosaic method {name!r}: {', '.join(taken)} already has a default method")
        entry = super().add(name, function, options=options, description=description)  # refuses a name twice
        base = {f.name: getattr(entry, f.name) for f in fields(entry)}
        self._entries[name] = DemosaicEntry(**base, tiles=tiles, default_for=default_for)
        return self._entries[name]

    def takes(self, name: str, tile: str) -> bool:
        """Whether the entry ``name`` takes ``tile`` (:data:`BAYER` or a larger tile's name)."""
        return tile in getattr(self[name], "tiles", (BAYER,))

    def default_of(self, tile: str) -> str | None:
        """The method a larger ``tile`` falls back to (None: no entry is its default)."""
        return next((n for n, e in self._entries.items() if tile in getattr(e, "default_for", ())), None)

    def methods_for(self, tile: str) -> tuple[str, ...]:
        """The methods that take ``tile``: its default first, the others in registration order."""
        names = [n for n in self._entries if self.takes(n, tile)]
        default = self.default_of(tile)
        return tuple(sorted(names, key=lambda n: n != default))


class _TileMethods(Mapping):
    """:data:`CFA_METHODS`: each larger tile → the methods that take it, default first, read from the
    :data:`DEMOSAIC` entries when asked (a method registered later is listed)."""

    def __getitem__(self, tile: str) -> tuple[str, ...]:
        methods = DEMOSAIC.methods_for(tile) if tile != BAYER else ()
        if not methods:
            raise KeyError(tile)
        return methods

    def __iter__(self) -> Iterator[str]:
        seen = dict.fromkeys(t for e in DEMOSAIC.values() for t in getattr(e, "tiles", ()) if t != BAYER)
        return iter(seen)

    def __len__(self) -> int:
        return sum(1 for _ in self)


#: The methods that take each larger tile, the first its default (:func:`method_for`); read from the entries.
CFA_METHODS = _TileMethods()


def bayer_methods() -> list[str]:
    """The registered methods that take a 2×2 Bayer mosaic."""
    return [name for name in DEMOSAIC if DEMOSAIC.takes(name, BAYER)]


def method_for(cfa: str, asked: str) -> str:
    """``asked`` where it takes ``cfa``, else the tile's default: a Bayer method on an X-Trans or Quad
    Bayer mosaic becomes ``colour_difference`` or ``quad_remosaic`` (the develop records it).

    Raises
    ------
    ConfigError
        For a method asked of a Bayer mosaic that takes only larger tiles, or a larger tile no
        method takes.
    """
    name = check_cfa(cfa, allow_extended=True)
    tile = BAYER if is_bayer(name) else name
    if asked in DEMOSAIC and DEMOSAIC.takes(asked, tile):
        return asked
    if tile == BAYER:
        if asked in DEMOSAIC:
            raise ConfigError(f"demosaic {asked!r} needs a {' or '.join(DEMOSAIC[asked].tiles)} mosaic; "
                              f"this one is {name}")
        return asked
    default = DEMOSAIC.default_of(tile) or next(iter(DEMOSAIC.methods_for(tile)), None)
    if default is None:
        raise ConfigError(f"no demosaic method takes a {name} mosaic; valid tiles: {', '.join(CFA_METHODS)}")
    return default


#: Demosaicing methods by name (``isp.demosaic``); a new method is one entry here, with the tiles it takes.
DEMOSAIC = DemosaicRegistry("demosaic method")
DEMOSAIC.add("bilinear", bilinear, description="normalised masked convolution")
DEMOSAIC.add("malvar2004", malvar2004, description="gradient-corrected linear (Malvar, He & Cutler 2004)")
DEMOSAIC.add("menon2007", menon2007, description="directional filtering, a posteriori decision (Menon et al. 2007)")
DEMOSAIC.add("rcd", rcd, description="ratio-corrected demosaicing (Sanz Rodríguez 2017) + colour-difference median")
DEMOSAIC.add("vng", vng, description="OpenCV variable number of gradients")
DEMOSAIC.add("ea", ea, description="OpenCV edge-aware")
DEMOSAIC.add("colour_difference", colour_difference, tiles=(BAYER, "XTRANS", "QUAD_RGGB"), default_for=("XTRANS",),
             description="any CFA (X-Trans, Quad Bayer, Bayer): green, then colour differences, masked convolution")
DEMOSAIC.add("quad_remosaic", quad_remosaic, tiles=("QUAD_RGGB",), default_for=("QUAD_RGGB",),
             description="Quad Bayer remosaiced to RGGB, then menon2007")
DEMOSAIC.add("quad_binning", quad_binning, tiles=("QUAD_RGGB",),
             description="Quad Bayer 2×2 cells binned, menon2007, upsampled")
DEMOSAIC.add("rgbw_fusion", rgbw_fusion, tiles=("RGBW",), default_for=("RGBW",),
             description="RGBW: white pixels for luminance, colour differences")


def demosaic(mosaic: np.ndarray, cfa: str = "RGGB", *, method: str = "malvar2004") -> np.ndarray:
    """Demosaic a Bayer mosaic with the named method.

    Parameters
    ----------
    mosaic
        (H, W) float32 linear mosaic (usually white-balanced).
    cfa
        Bayer tile name read from the top-left pixel: ``"RGGB"``, ``"BGGR"``, ``"GRBG"``
        or ``"GBRG"``.
    method
        One of :data:`DEMOSAIC`: ``"bilinear"``, ``"malvar2004"``, ``"menon2007"``, ``"rcd"``,
        ``"vng"``, ``"ea"``.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 linear RGB.

    Raises
    ------
    ConfigError
        For an unknown method or CFA (listing the valid ones).

    References
    ----------
    .. [1] Malvar, H. S., He, L., & Cutler, R. (2004). Proc. IEEE ICASSP, 485–488.
    .. [2] Menon, D., Andriani, S., & Calvagno, G. (2007). IEEE TIP 16(1), 132–141.
    """
    return DEMOSAIC[method](mosaic, cfa)
