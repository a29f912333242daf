"""Natural-image statistics: does a developed image look like a camera's photograph?

Each statistic is measured the same way on our developed images and on real photographs (8-bit
display sRGB), and on RAWs as fractions of full scale:

- :func:`median_lightness`: median CIE 1976 L* of the pixels (sRGB decoded, Y of IEC 61966-2-1);
- :func:`clipped_share`: share of pixels with a channel at 255 (or ≥ 254.5/255);
- :func:`spectrum_slope`: slope α of the radially averaged power spectrum of luminance,
  P(f) ∝ f^α, over 1/64–1/4 cycles per pixel (natural images: α ≈ −2, van der Schaaf &
  van Hateren 1996);
- :func:`flat_share`: share of 8 × 8 blocks whose display luminance varies by less than one
  8-bit level (σ < 1/255): texture-free area, which renders of flat primitives are full of;
- :func:`colourfulness`: Hasler & Süsstrunk's M = σ_rgyb + 0.3·μ_rgyb on 8-bit RGB;
- :func:`detail_gradient_p95`: 95th percentile of the magnitude of the L* gradient (L* per pixel)
  after a Gaussian blur of σ = 1 px: how much fine structure (texture, edges) a frame holds;
- :func:`dark_channel_p25`: 25th percentile of He, Sun & Tang's dark channel (per pixel the
  darkest of R, G, B, then the darkest over 15 × 15 pixels; 0–255): outdoor photographs of the
  world are full of shadows and saturated colours, so most 15 × 15 patches hold a near-black
  channel; haze, flare or a lifted black level raise it;
- :func:`firefly_share`: share of pixels brighter than 4× the median of their 5 × 5
  neighbourhood, than the frame's median and than twice each of their 8 neighbours (isolated
  bright outliers; dark noise and the corners of bright areas excluded);
- :func:`raw_levels`: median and 99th percentile of a RAW, (DN − black)/(white − black).

Reference photographs (:func:`reference_photographs`): the colour photographs of the world that
installed packages ship offline, at their own sizes, 8-bit sRGB JPEG/PNG as published:

- scikit-image ``skimage.data``: ``astronaut`` (Eileen Collins, NASA Great Images; public domain),
  ``coffee`` (Rachel Michetti for Pikolo Espresso Bar; CC0), ``chelsea`` (a cat, Stéfan van der
  Walt; CC0; ``cat`` is the same photograph), ``rocket`` (DSCOVR launch on Falcon 9, SpaceX;
  public domain), ``stereo_motorcycle`` left view (Middlebury 2014 stereo benchmark, Scharstein
  et al. 2014, down-sampled 4×; shipped with scikit-image, the Middlebury site asks to be
  cited). Left out: ``hubble_deep_field`` (a telescope's view of space), ``retina`` (a fundus
  camera), ``immunohistochemistry`` (a microscope slide), ``colorwheel`` and ``logo`` (drawn);
- Matplotlib ``cbook.get_sample_data``: ``grace_hopper.jpg`` (Commodore Grace M. Hopper, U.S.
  Navy official photograph; public domain). Left out: ``Minduka_Present_Blue_Pack.png``
  (clip art), ``logo2.png``;
- scikit-learn ``datasets.load_sample_image``: ``china.jpg`` (a temple, Daniel Buechele, Flickr)
  and ``flower.jpg`` (Flickr user vultilion), both CC BY 2.0.

The scale-dependent ones (detail, dark channel, flat share, fireflies) are compared at one pixel
scale: :func:`resample_short_side` brings every image to the same short side first (320 px, the
bundled scenes' frames; ``image_statistics(image, short_side=320)``).

References
----------
.. [1] CIE 15:2004 §8.2.1 (L*); IEC 61966-2-1:1999 (sRGB).
.. [2] van der Schaaf, A., & van Hateren, J. H. (1996). Modelling the power spectra of natural
   images. Vision Research 36(17), 2759–2770.
.. [3] Hasler, D., & Süsstrunk, S. (2003). Measuring colourfulness in natural images. Proc. SPIE
   5007, Human Vision and Electronic Imaging VIII, 87–95.
.. [4] Buisine, J., Delepoulle, S., & Renaud, C. (2021). Firefly removal in Monte Carlo
   rendering with adaptive Median of meaNs. EGSR 2021 (fireflies as outliers of their
   neighbourhood).
.. [5] He, K., Sun, J., & Tang, X. (2009). Single image haze removal using dark channel prior.
   CVPR 2009, 1956–1963 (the dark channel: min over colour channels, then over a 15 × 15 patch).
.. [6] Scharstein, D., Hirschmüller, H., Kitajima, Y., Krathwohl, G., Nesic, N., Wang, X., &
   Westling, P. (2014). High-resolution stereo datasets with subpixel-accurate ground truth.
   GCPR 2014, LNCS 8753, 31–42 (the motorcycle photograph).
.. [7] Gonzalez, R. C., & Woods, R. E. (2018). Digital Image Processing, 4th ed., §3.6 (gradient
   magnitude) and §3.5 (Gaussian smoothing before differentiation); OpenCV ``cv2.resize``
   with ``INTER_AREA`` (pixel-area averaging when shrinking).
"""

from __future__ import annotations

import numpy as np

__all__ = ["display_luminance", "lightness", "median_lightness", "clipped_share", "spectrum_slope", "flat_share",
           "colourfulness", "detail_gradient_p95", "dark_channel", "dark_channel_p25", "firefly_share", "raw_levels",
           "resample_short_side", "image_statistics", "PHOTOGRAPHS", "reference_photographs"]


def _display(image: np.ndarray) -> np.ndarray:
    """Display sRGB in [0, 1] from a uint8/uint16 or float array."""
    x = np.asarray(image)
    if x.dtype == np.uint8:
        return x.astype(np.float64) / 255.0
    if x.dtype == np.uint16:
        return x.astype(np.float64) / 65535.0
    return np.clip(x.astype(np.float64), 0.0, 1.0)


def display_luminance(image: np.ndarray) -> np.ndarray:
    """Relative luminance Y of display sRGB (decoded, IEC 61966-2-1 eq. 4–5; BT.709 weights)."""
    v = _display(image)
    linear = np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)
    return linear @ np.array([0.2126, 0.7152, 0.0722])


def _lightness_of(y):
    """CIE 1976 L* of relative luminance Y (white Y = 1; CIE 15:2004 §8.2.1, eq. 8.3–8.5)."""
    y = np.asarray(y, dtype=np.float64)
    f = np.where(y > (6 / 29) ** 3, np.cbrt(y), y / (3 * (6 / 29) ** 2) + 4 / 29)
    return 116 * f - 16


def lightness(image: np.ndarray) -> np.ndarray:
    """CIE 1976 L* (0–100, white Y = 1) per pixel of a display sRGB image (CIE 15:2004 §8.2.1)."""
    return _lightness_of(display_luminance(image))


def median_lightness(image: np.ndarray) -> float:
    """Median CIE 1976 L* (white Y = 1) of a display sRGB image (CIE 15:2004 §8.2.1)."""
    return float(_lightness_of(np.median(display_luminance(image))))


def clipped_share(image: np.ndarray) -> float:
    """Share of pixels with any channel at display white (≥ 254.5/255)."""
    return float(np.mean(np.any(_display(image) >= 254.5 / 255, axis=-1)))


def spectrum_slope(image: np.ndarray, *, band=(1 / 64, 1 / 4)) -> float:
    """Slope α of the radially averaged power spectrum of display luminance, P ∝ f^α, fitted in
    log–log over ``band`` (cycles per pixel) on the largest centred square, Hann-windowed."""
    y = display_luminance(image)
    side = min(y.shape)
    top, left = (y.shape[0] - side) // 2, (y.shape[1] - side) // 2
    y = y[top:top + side, left:left + side]
    window = np.outer(np.hanning(side), np.hanning(side))
    power = np.abs(np.fft.fftshift(np.fft.fft2((y - y.mean()) * window))) ** 2
    f = np.fft.fftshift(np.fft.fftfreq(side))
    radius = np.hypot(*np.meshgrid(f, f, indexing="ij"))
    edges = np.geomspace(band[0], band[1], 16)
    centres, means = [], []
    for lo, hi in zip(edges[:-1], edges[1:]):
        ring = (radius >= lo) & (radius < hi)
        if ring.any():
            centres.append(np.sqrt(lo * hi))
            means.append(power[ring].mean())
    means = np.maximum(np.asarray(means), 1e-30)
    return float(np.polyfit(np.log(centres), np.log(means), 1)[0])


def flat_share(image: np.ndarray, *, block: int = 8) -> float:
    """Share of ``block`` × ``block`` tiles whose display luminance has σ < 1/255."""
    v = _display(image) @ np.array([0.2126, 0.7152, 0.0722])
    h, w = (v.shape[0] // block) * block, (v.shape[1] // block) * block
    tiles = v[:h, :w].reshape(h // block, block, w // block, block)
    return float(np.mean(tiles.std(axis=(1, 3)) < 1.0 / 255))


def colourfulness(image: np.ndarray) -> float:
    """Hasler & Süsstrunk's colourfulness M = √(σ_rg² + σ_yb²) + 0.3·√(μ_rg² + μ_yb²), rg = R − G,
    yb = ½(R + G) − B, on 8-bit display values (M ≈ 0 grey, 33 "moderately", 59 "quite",
    82 "highly", 109 "extremely colourful")."""
    rgb = _display(image) * 255.0
    rg = rgb[..., 0] - rgb[..., 1]
    yb = 0.5 * (rgb[..., 0] + rgb[..., 1]) - rgb[..., 2]
    return float(np.hypot(rg.std(), yb.std()) + 0.3 * np.hypot(rg.mean(), yb.mean()))


def detail_gradient_p95(image: np.ndarray, *, sigma: float = 1.0, percentile: float = 95.0) -> float:
    """95th percentile of the L* gradient magnitude after a Gaussian blur: how much fine detail
    (texture, edges) an image holds, in L* units per pixel.

    L* per pixel (:func:`lightness`) is blurred by a Gaussian of ``sigma`` pixels (which takes the
    8-bit quantisation and pixel noise off, and leaves a linear ramp as it is), differentiated
    by central differences (``numpy.gradient``; one-sided at the border) and the magnitude
    √(∂x² + ∂y²) taken per pixel.

    Parameters
    ----------
    image : numpy.ndarray
        (H, W, 3) display sRGB, 8-bit, 16-bit or float in [0, 1]. Compare images at one pixel
        scale (:func:`resample_short_side`): the value scales with the inverse of the size.
    sigma : float
        Gaussian σ in pixels.
    percentile : float
        Which percentile of the magnitude (95: the edges and textures, not the flat areas).

    Returns
    -------
    float
        L* per pixel (a ramp from L* 0 to 100 over 100 pixels reads 1.0).

    References
    ----------
    .. [1] CIE 15:2004 §8.2.1 (L*); IEC 61966-2-1:1999 (sRGB decoding).
    .. [2] Gonzalez, R. C., & Woods, R. E. (2018). Digital Image Processing, 4th ed., §3.5
       (Gaussian smoothing) and §3.6 (gradient magnitude).

    Examples
    --------
    >>> import numpy as np
    >>> detail_gradient_p95(np.full((40, 40, 3), 0.5))
    0.0
    """
    from scipy.ndimage import gaussian_filter

    smooth = gaussian_filter(lightness(image), sigma, mode="nearest")
    dy, dx = np.gradient(smooth)
    return float(np.percentile(np.hypot(dx, dy), percentile))


def dark_channel(image: np.ndarray, *, patch: int = 15) -> np.ndarray:
    """He, Sun & Tang's dark channel: per pixel the darkest of R, G, B, then the darkest of that
    over the ``patch`` × ``patch`` square around the pixel (cut at the frame's edge), 0–255.

    Parameters
    ----------
    image : numpy.ndarray
        (H, W, 3) display sRGB, 8-bit, 16-bit or float in [0, 1].
    patch : int
        Side of the square in pixels (odd; 15 in He et al.).

    Returns
    -------
    numpy.ndarray
        (H, W) float64, in 8-bit display levels (0–255).

    References
    ----------
    .. [1] He, K., Sun, J., & Tang, X. (2009). Single image haze removal using dark channel
       prior. CVPR 2009, 1956–1963, eq. 5.
    """
    import cv2

    darkest = (_display(image) * 255.0).min(axis=-1).astype(np.float32)
    # erode's default border is the type's largest value: the patch is cut at the edge
    return cv2.erode(darkest, np.ones((patch, patch), np.uint8)).astype(np.float64)


def dark_channel_p25(image: np.ndarray, *, patch: int = 15, percentile: float = 25.0) -> float:
    """25th percentile of the dark channel (:func:`dark_channel`), in 8-bit levels 0–255.

    In He, Sun & Tang's 5000 haze-free outdoor photographs (resized to 500 × 500 px) about 75 %
    of the dark channel's pixels were 0 and 90 % below 25 (shadows, dark and saturated colours);
    a frame whose every 15 × 15 patch holds some light in all three channels (haze, flare, a
    lifted black, fill light everywhere) reads high.

    Parameters
    ----------
    image : numpy.ndarray
        (H, W, 3) display sRGB, 8-bit, 16-bit or float in [0, 1]; compare images at one pixel
        scale (:func:`resample_short_side`): the patch is in pixels.
    patch : int
        Side of the dark channel's square in pixels.
    percentile : float
        Which percentile of the dark channel.

    Returns
    -------
    float
        Display level, 0–255.

    References
    ----------
    .. [1] He, K., Sun, J., & Tang, X. (2009). Single image haze removal using dark channel
       prior. CVPR 2009, 1956–1963.

    Examples
    --------
    >>> import numpy as np
    >>> dark_channel_p25(np.full((32, 32, 3), (200, 120, 60), np.uint8))
    60.0
    """
    return float(np.percentile(dark_channel(image, patch=patch), percentile))


def resample_short_side(image: np.ndarray, short_side: int = 320) -> np.ndarray:
    """The image scaled (aspect kept) so that its shorter side is ``short_side`` pixels:
    pixel-area averaging when shrinking (``cv2.INTER_AREA``), bilinear when enlarging
    (``cv2.INTER_LINEAR``); an image already that size is returned as it is.

    Parameters
    ----------
    image : numpy.ndarray
        (H, W) or (H, W, C) array (uint8, uint16 or float).
    short_side : int
        The shorter side after resampling, pixels.

    Returns
    -------
    numpy.ndarray
        Same channels; uint8, uint16, float32 and float64 keep their type (8-bit rounds to whole
        levels), others come back float64; the longer side rounded to whole pixels.

    References
    ----------
    .. [1] OpenCV, ``cv2.resize`` (``INTER_AREA``: resampling by pixel-area relation).

    Examples
    --------
    >>> import numpy as np
    >>> resample_short_side(np.zeros((640, 960, 3), np.uint8)).shape
    (320, 480, 3)
    """
    import cv2

    x = np.asarray(image)
    height, width = x.shape[:2]
    if min(height, width) == short_side:
        return x
    scale = short_side / min(height, width)
    if height <= width:
        size = (max(1, round(width * scale)), short_side)  # cv2 takes (width, height)
    else:
        size = (short_side, max(1, round(height * scale)))
    work = x if x.dtype in (np.uint8, np.uint16, np.float32, np.float64) else x.astype(np.float64)
    out = cv2.resize(work, size, interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
    return out[..., None] if out.ndim < work.ndim else out  # cv2 drops a single channel


def firefly_share(luminance: np.ndarray) -> float:
    """Share of pixels above 4× the median of their 5 × 5 neighbourhood, above the frame's
    median and above twice the brightest of their 8 neighbours: isolated bright outliers (a
    firefly), not the noise of dark areas nor the corner of a bright patch or lamp (whose
    5 × 5 median is dark too, but whose neighbours are as bright).

    Parameters
    ----------
    luminance : numpy.ndarray
        (H, W) linear luminance (any unit): a render's radiance summed over bands, or
        :func:`display_luminance` of a photograph.

    Examples
    --------
    >>> import numpy as np
    >>> frame = np.ones((20, 20)); frame[10, 10] = 50.0
    >>> firefly_share(frame)
    0.0025
    """
    import cv2

    lum = np.ascontiguousarray(luminance, dtype=np.float32)
    local = cv2.medianBlur(lum, 5)
    ring = np.ones((3, 3), np.uint8)
    ring[1, 1] = 0
    neighbours = cv2.dilate(lum, ring, borderType=cv2.BORDER_REFLECT)  # the brightest of the 8 around
    return float(np.mean((lum > 4 * local) & (lum > np.median(lum)) & (lum > 2 * neighbours)))


def raw_levels(mosaic: np.ndarray, black, white: float) -> tuple[float, float]:
    """Median and 99th percentile of a RAW as fractions of full scale, (DN − black)/(white − black)."""
    x = (np.asarray(mosaic, dtype=np.float64) - np.mean(black)) / (float(white) - float(np.mean(black)))
    return float(np.median(x)), float(np.percentile(x, 99))


def _skimage(name: str):
    def load():
        import skimage.data

        image = getattr(skimage.data, name)()
        return image[0] if isinstance(image, tuple) else image  # stereo_motorcycle: (left, right, disparity)
    return load


def _matplotlib(name: str):
    def load():
        from matplotlib.cbook import get_sample_data
        from PIL import Image

        with Image.open(get_sample_data(name)) as handle:
            return np.asarray(handle.convert("RGB"))
    return load


def _sklearn(name: str):
    def load():
        from sklearn.datasets import load_sample_image

        return load_sample_image(name)
    return load


#: Reference photographs: name → (loader, source, licence); see the module's notes.
PHOTOGRAPHS = {
    "skimage.data.astronaut": (_skimage("astronaut"), "Eileen Collins, NASA Great Images", "public domain"),
    "skimage.data.coffee": (_skimage("coffee"), "Rachel Michetti, Pikolo Espresso Bar", "CC0"),
    "skimage.data.chelsea": (_skimage("chelsea"), "Stéfan van der Walt", "CC0"),
    "skimage.data.rocket": (_skimage("rocket"), "SpaceX (DSCOVR launch)", "public domain"),
    "skimage.data.stereo_motorcycle (left)": (_skimage("stereo_motorcycle"),
                                              "Middlebury 2014 stereo benchmark (Scharstein et al.)",
                                              "none stated; cite Scharstein et al. 2014"),
    "matplotlib grace_hopper.jpg": (_matplotlib("grace_hopper.jpg"), "U.S. Navy official photograph",
                                    "public domain"),
    "sklearn china.jpg": (_sklearn("china.jpg"), "Daniel Buechele, Flickr", "CC BY 2.0"),
    "sklearn flower.jpg": (_sklearn("flower.jpg"), "vultilion, Flickr", "CC BY 2.0"),
}


def reference_photographs() -> dict[str, np.ndarray]:
    """The reference photographs (:data:`PHOTOGRAPHS`) the installed packages ship, as (H, W, 3)
    uint8 sRGB at their published sizes; a package that is not installed (or a file it does not
    ship) is left out, with a warning.

    References
    ----------
    .. [1] scikit-image ``skimage.data``; Matplotlib ``matplotlib.cbook.get_sample_data``;
       scikit-learn ``sklearn.datasets.load_sample_image`` (sources and licences in the module's
       notes).
    """
    import warnings

    images = {}
    for name, (load, _source, _licence) in PHOTOGRAPHS.items():
        try:
            images[name] = np.ascontiguousarray(load()[..., :3], dtype=np.uint8)
        except (ImportError, OSError, ValueError) as exc:
            warnings.warn(f"reference photograph {name} is not available ({exc}); left out", stacklevel=2)
    return images


def image_statistics(image: np.ndarray, *, short_side: int | None = None) -> dict:
    """Every display statistic of an image (8-bit or float display sRGB), after resampling to
    ``short_side`` pixels (:func:`resample_short_side`) when given.

    Returns
    -------
    dict
        ``median_L`` (L*), ``clipped`` (share), ``spectrum_slope``, ``flat`` (share),
        ``colourfulness`` (M), ``detail`` (L* per pixel, :func:`detail_gradient_p95`),
        ``dark_p25`` (0–255, :func:`dark_channel_p25`), ``fireflies`` (share).
    """
    if short_side is not None:
        image = resample_short_side(image, short_side)
    return {"median_L": median_lightness(image), "clipped": clipped_share(image),
            "spectrum_slope": spectrum_slope(image), "flat": flat_share(image),
            "colourfulness": colourfulness(image), "detail": detail_gradient_p95(image),
            "dark_p25": dark_channel_p25(image), "fireflies": firefly_share(display_luminance(image))}
