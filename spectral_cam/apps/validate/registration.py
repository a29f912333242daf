"""Registering a tool's image on the frame: where it lies, and whether it shows the chart where
the RAW has it.

A raw developer may trim the frame (RawTherapee removes 4 px a side for demosaicing) or keep
the DNG's border outside its default crop. :func:`register` puts its image back on the frame's
pixel grid: by a declared ``crop = [top, bottom, left, right]``, or under ``"auto"`` at the offset
:func:`find_crop` finds against the RAW's own luminance (:func:`raw_template`).
:func:`check_registration` then refuses an image that does not correlate with the RAW (shifted,
flipped, rotated, or another crop than declared).

References
----------
.. [1] Adobe DNG Specification 1.7.1.0, DefaultCropOrigin, DefaultCropSize.
.. [2] Pearson's correlation coefficient (the registration's score).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ...errors import ConfigError

__all__ = ["raw_template", "find_crop", "MIN_REGISTRATION_CORRELATION", "check_registration", "register",
           "check_crop"]


def raw_template(raw) -> np.ndarray:
    """The frame as the RAW saw it: the mosaic above black, averaged over 3 × 3 (centred; every CFA
    colour in it), on the frame's pixels (inside the DNG's default crop) — what a tool's image is
    registered against (:func:`find_crop`)."""
    from scipy.ndimage import uniform_filter

    mosaic = np.asarray(raw.mosaic, dtype=np.float64)
    mosaic = mosaic.mean(axis=-1) if mosaic.ndim == 3 else mosaic
    level = uniform_filter(mosaic - np.mean(raw.black_level), size=3, mode="nearest")  # centred, CFA averaged
    if raw.crop is not None:
        top, left, height, width = raw.crop
        level = level[top:top + height, left:left + width]
    return level


def find_crop(image: np.ndarray, template: np.ndarray, *, search_px: int = 16) -> tuple[int, int, int, int]:
    """Where a tool's image lies on the frame: the offset (within ± ``search_px``) at which its
    luminance correlates best with ``template`` (the frame's own luminance, :func:`raw_template`),
    weighted by the share of the image that lands on the frame (a chart repeats, and a shift by
    one patch period correlates almost as well but leaves part of the image off the frame);
    returned as ``(top, bottom, left, right)``, the pixels the tool removed from each side."""
    height, width = template.shape
    luminance = np.nan_to_num(np.asarray(image, dtype=np.float64)[..., :3].mean(axis=-1))
    best, where = -np.inf, (0, 0)
    for top in range(-search_px, search_px + 1):
        for left in range(-search_px, search_px + 1):
            # the image's pixel (r, c) lies at the frame's (r + top, c + left)
            r0, c0 = max(top, 0), max(left, 0)
            r1, c1 = min(height, top + luminance.shape[0]), min(width, left + luminance.shape[1])
            if r1 - r0 < height // 2 or c1 - c0 < width // 2:
                continue
            a = template[r0:r1, c0:c1].ravel()
            b = luminance[r0 - top:r1 - top, c0 - left:c1 - left].ravel()
            if a.std() == 0 or b.std() == 0:
                continue
            score = float(np.corrcoef(a, b)[0, 1]) * a.size / luminance.size
            if score > best + 1e-9:
                best, where = score, (top, left)
    if best == -np.inf:
        raise ConfigError(f"cannot register the tool's {luminance.shape[1]} × {luminance.shape[0]} px image on the "
                          f"{width} × {height} frame: no offset within ±{search_px} px lays half of it on the frame "
                          "with any contrast; declare crop = [top, bottom, left, right] (pixels the tool removed)")
    top, left = where
    return top, height - top - luminance.shape[0], left, width - left - luminance.shape[1]


#: A tool's image whose luminance correlates with the RAW's own less than this is misregistered:
#: the example plan's tools, registered, measure r = 0.92–0.94; the same images flipped 0.33–0.54.
MIN_REGISTRATION_CORRELATION = 0.75


def check_registration(image: np.ndarray, template: np.ndarray, *, name: str) -> None:
    """Refuse a tool's image (on the frame's grid) that does not show the chart where the RAW
    has it: Pearson's r between its luminance and :func:`raw_template` over the pixels it
    covers below :data:`MIN_REGISTRATION_CORRELATION` (shifted, flipped, rotated, or another
    crop than declared). The message says what was measured.

    Raises
    ------
    ConfigError
        With the correlation and the share of the frame the image covers.
    """
    luminance = np.asarray(image, dtype=np.float64)[..., :3].mean(axis=-1)
    covered = np.isfinite(luminance)
    if covered.sum() < 2 or np.ptp(template[covered]) == 0 or np.ptp(luminance[covered]) == 0:
        r = float("nan")
    else:
        r = float(np.corrcoef(luminance[covered], template[covered])[0, 1])
    if not r >= MIN_REGISTRATION_CORRELATION:
        raise ConfigError(f"pipeline {name!r}: its image is misregistered on the frame: its luminance correlates with "
                          f"the RAW's at r = {r:.2f} (registered images measure 0.92–0.94) over the "
                          f"{100 * covered.mean():.0f} % of the frame it covers — shifted, flipped, rotated or cropped "
                          "other than declared; check crop = [top, bottom, left, right] (pixels the tool removed)")


def register(image: np.ndarray, frame: tuple[int, int], crop, template: np.ndarray | None = None) -> np.ndarray:
    """A tool's image on the frame's pixel grid.

    ``crop = [top, bottom, left, right]``: the pixels the tool removed from each side of the
    frame (negative: added). ``"auto"``: found against ``template`` where it is given
    (:func:`find_crop`: any offset within 16 px), else the difference split evenly (RawTherapee
    trims 4 px a side for demosaicing; a tool that keeps the DNG's border outside its default
    crop adds even margins). Pixels the tool removed come back as NaN (no patch interior lies
    there).

    Raises
    ------
    ConfigError
        For an uneven difference under ``"auto"`` without a template, or a declared crop that
        does not add up.
    """
    height, width = frame
    dy, dx = height - image.shape[0], width - image.shape[1]
    if crop == "auto" and template is not None:
        top, bottom, left, right = find_crop(image, template)
    elif crop == "auto":
        if dy % 2 or dx % 2:
            raise ConfigError(f"the image is {image.shape[1]} × {image.shape[0]} px, the frame {width} × {height}: "
                              "not an even margin; declare crop = [top, bottom, left, right] (pixels the tool removed)")
        top, bottom, left, right = dy // 2, dy // 2, dx // 2, dx // 2
    else:
        top, bottom, left, right = (int(v) for v in crop)
        if top + bottom != dy or left + right != dx:
            raise ConfigError(f"crop = {list(crop)} does not turn {image.shape[1]} × {image.shape[0]} px into the "
                              f"frame's {width} × {height}")
    canvas = np.full((height, width, image.shape[2]), np.nan)
    source = image[max(-top, 0):image.shape[0] - max(-bottom, 0), max(-left, 0):image.shape[1] - max(-right, 0)]
    canvas[max(top, 0):height - max(bottom, 0), max(left, 0):width - max(right, 0)] = source
    return canvas



def check_crop(name: str, crop: Any):
    """A command's ``crop`` checked: ``"auto"`` (also when absent) or four whole numbers of pixels."""
    if crop == "auto" or crop is None:
        return "auto"
    if (isinstance(crop, (list, tuple)) and len(crop) == 4
            and all(isinstance(v, int) and not isinstance(v, bool) for v in crop)):
        return [int(v) for v in crop]
    raise ConfigError(f"pipeline {name!r}: crop = {crop!r}; give 'auto' or [top, bottom, left, right] in pixels the "
                      "tool removed (negative: added)")
