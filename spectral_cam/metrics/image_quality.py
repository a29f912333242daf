"""Image-quality metrics: ColorChecker ΔE2000 per patch, patch means, PSNR and SSIM.

Colour error follows docs/design.md ("Ground truth"): measured on linear sRGB (tone curve off, unclipped),
converted to CIE XYZ and CIELAB under D65 (the sRGB white), compared with CIEDE2000.

References
----------
.. [1] CIE 15:2004, Colorimetry, 3rd ed., §8.2.1 (CIELAB).
.. [2] Sharma, G., Wu, W., & Dalal, E. N. (2005). The CIEDE2000 color-difference formula:
   Implementation notes, supplementary test data, and mathematical observations. Color
   Research & Application 30(1), 21–30.
.. [3] Wang, Z., Bovik, A. C., Sheikh, H. R., & Simoncelli, E. P. (2004). Image quality
   assessment: from error visibility to structural similarity. IEEE Trans. Image Process.
   13(4), 600–612.
.. [4] IEC 61966-2-1:1999, sRGB.
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "patch_means",
    "linear_srgb_to_lab",
    "delta_e2000",
    "colorchecker_delta_e",
    "psnr",
    "ssim",
]


def patch_means(image: np.ndarray, patches, *, margin: float = 0.2) -> np.ndarray:
    """Mean of an image over each patch's interior.

    Parameters
    ----------
    image
        (H, W) or (H, W, C) image (linear values: the mean of a linear image is the
        patch's linear value).
    patches
        Objects with ``.interior(margin) -> (row slice, column slice)`` (e.g.
        :class:`spectral_cam.presets.Patch`), or (row slice, column slice) tuples.
    margin
        Fraction of each patch's size left out on each side (blur and edges).

    Returns
    -------
    numpy.ndarray
        (N,) or (N, C) float64 means.

    References
    ----------
    .. [1] ISO 17321-1:2012, Graphic technology and photography — Colour characterisation
       of digital still cameras, §5 (patch averaging over uniform regions).
    """
    image = np.asarray(image, dtype=np.float64)
    out = []
    for patch in patches:
        region = patch.interior(margin) if hasattr(patch, "interior") else tuple(patch)
        values = image[region]
        if values.size == 0:
            raise ValueError(f"patch {getattr(patch, 'name', patch)!r} has an empty interior in the image")
        out.append(values.reshape(-1, *image.shape[2:]).mean(axis=0))
    return np.asarray(out)


def linear_srgb_to_lab(rgb: np.ndarray) -> np.ndarray:
    """Linear sRGB → CIE XYZ → CIELAB, white = D65 (the sRGB white, Y = 1).

    Parameters
    ----------
    rgb
        (..., 3) linear sRGB (1 = reference white), unclipped.

    Returns
    -------
    numpy.ndarray
        (..., 3) L*, a*, b*.

    References
    ----------
    .. [1] IEC 61966-2-1:1999; CIE 15:2004 §8.2.1 (colour-science ``RGB_to_XYZ``,
       ``XYZ_to_Lab``).
    """
    import colour

    space = colour.models.RGB_COLOURSPACE_sRGB
    xyz = colour.RGB_to_XYZ(np.asarray(rgb, dtype=float), space, apply_cctf_decoding=False)
    return colour.XYZ_to_Lab(xyz, space.whitepoint)


def delta_e2000(test_rgb: np.ndarray, reference_rgb: np.ndarray, *, exposure_match_index: int | None = None) -> np.ndarray:
    """CIEDE2000 colour difference between linear sRGB colours.

    Parameters
    ----------
    test_rgb, reference_rgb
        (N, 3) linear sRGB (e.g. patch means), unclipped.
    exposure_match_index
        If given, ``test_rgb`` is first scaled so that its entry at this index has the
        reference's luminance Y (exposure matching on the white patch).

    Returns
    -------
    numpy.ndarray
        (N,) ΔE00.

    References
    ----------
    .. [1] Sharma, Wu & Dalal (2005), Color Res. Appl. 30(1), 21–30 (colour-science
       ``delta_E(..., method="CIE 2000")``).
    """
    import colour

    test = np.asarray(test_rgb, dtype=float)
    reference = np.asarray(reference_rgb, dtype=float)
    if test.shape != reference.shape:
        raise ValueError(f"shapes differ: {test.shape} vs {reference.shape}")
    if exposure_match_index is not None:
        weights = np.asarray(colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ)[1]
        test = test * (reference[exposure_match_index] @ weights) / (test[exposure_match_index] @ weights)
    return np.asarray(colour.delta_E(linear_srgb_to_lab(test), linear_srgb_to_lab(reference), method="CIE 2000"))


def colorchecker_delta_e(image: np.ndarray, reference, patches, *, margin: float = 0.2,
                         white_index: int | None = None) -> dict:
    """ΔE2000 of every ColorChecker patch of a linear sRGB image, exposure-matched on white.

    Parameters
    ----------
    image
        (H, W, 3) linear sRGB (tone curve off), unclipped.
    reference
        (N, 3) reference linear sRGB per patch (e.g. :func:`spectral_cam.colour_ground_truth.patch_linear_srgb`),
        or an (H, W, 3) reference image whose patch means are taken.
    patches
        The N patches (:func:`spectral_cam.presets.colorchecker_patches`).
    margin
        Patch-interior margin (see :func:`patch_means`).
    white_index
        Index of the patch used for exposure matching; default the ColorChecker's white
        (:func:`spectral_cam.colour_ground_truth.white_patch_index` of the patch names).

    Returns
    -------
    dict
        ``delta_e`` (N,) array, ``mean``, ``max``, ``names``, ``test`` and ``reference``
        (N, 3) linear sRGB means (test after exposure matching).

    References
    ----------
    .. [1] Sharma, Wu & Dalal (2005); ISO 17321-1:2012.
    """
    import colour

    test = patch_means(image, patches, margin=margin)
    reference = np.asarray(reference, dtype=float)
    if reference.ndim == 3:
        reference = patch_means(reference, patches, margin=margin)
    if white_index is None:
        from ..colour_ground_truth import white_patch_index

        white_index = white_patch_index([p.name for p in patches])
    weights = np.asarray(colour.models.RGB_COLOURSPACE_sRGB.matrix_RGB_to_XYZ)[1]
    test = test * (reference[white_index] @ weights) / (test[white_index] @ weights)
    delta = delta_e2000(test, reference)
    return {
        "delta_e": delta,
        "mean": float(np.mean(delta)),
        "max": float(np.max(delta)),
        "names": [getattr(p, "name", str(i)) for i, p in enumerate(patches)],
        "test": test,
        "reference": reference,
    }


def psnr(image: np.ndarray, reference: np.ndarray, *, data_range: float = 1.0) -> float:
    """Peak signal-to-noise ratio, dB: 10·log10(data_range² / MSE).

    Parameters
    ----------
    image, reference
        Same-shape arrays.
    data_range
        Peak-to-peak range of the data (1 for normalised images).

    Returns
    -------
    float
        PSNR in dB (inf for identical images).

    References
    ----------
    .. [1] scikit-image ``metrics.peak_signal_noise_ratio``; Gonzalez & Woods (2018), §8.
    """
    from skimage.metrics import peak_signal_noise_ratio

    return float(peak_signal_noise_ratio(np.asarray(reference, dtype=np.float64),
                                         np.asarray(image, dtype=np.float64), data_range=data_range))


def ssim(image: np.ndarray, reference: np.ndarray, *, data_range: float = 1.0) -> float:
    """Mean structural similarity index (Gaussian-weighted, σ = 1.5, as Wang et al. 2004).

    Parameters
    ----------
    image, reference
        Same-shape (H, W) or (H, W, C) arrays (channels averaged).
    data_range
        Peak-to-peak range of the data.

    Returns
    -------
    float
        Mean SSIM in [-1, 1].

    References
    ----------
    .. [1] Wang, Z., et al. (2004). IEEE TIP 13(4), 600–612 (scikit-image
       ``metrics.structural_similarity`` with ``gaussian_weights=True``).
    """
    from skimage.metrics import structural_similarity

    image = np.asarray(image, dtype=np.float64)
    reference = np.asarray(reference, dtype=np.float64)
    channel_axis = -1 if image.ndim == 3 else None
    return float(structural_similarity(reference, image, data_range=data_range, channel_axis=channel_axis,
                                       gaussian_weights=True, sigma=1.5, use_sample_covariance=False))
