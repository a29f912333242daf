"""Measurements on images and RAW frames: colour error, detail, EMVA 1288 sensor analysis.

- :mod:`.image_quality`: ΔE2000 per ColorChecker patch, patch means, PSNR, SSIM.
- :mod:`.emva1288`: the photon-transfer analysis of flat-field frame pairs.
"""

from .emva1288 import PhotonTransferResult, photon_transfer, plot_photon_transfer
from .image_quality import colorchecker_delta_e, delta_e2000, linear_srgb_to_lab, patch_means, psnr, ssim

__all__ = ["photon_transfer", "PhotonTransferResult", "plot_photon_transfer","patch_means", "linear_srgb_to_lab", "delta_e2000", "colorchecker_delta_e", "psnr", "ssim"]

from .sharpness import slanted_edge_mtf  # noqa: E402

__all__ += ["slanted_edge_mtf"]
