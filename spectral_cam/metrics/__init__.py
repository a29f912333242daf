"""Measurements on images and RAW frames: colour error, detail, blur, EMVA 1288 analysis.

- :mod:`.image_quality`: ΔE2000 per ColorChecker patch, patch means, PSNR, SSIM.
- :mod:`.sharpness`: slanted-edge MTF (ISO 12233).
- :mod:`.blur`: blur-disc diameter by second moments or by fitting a disc OTF.
- :mod:`.emva1288`: the photon-transfer analysis of flat-field frame pairs.
"""

from .blur import disc_diameter_from_moments, measure_blur, second_moment
from .emva1288 import PhotonTransferResult, photon_transfer, plot_photon_transfer
from .image_quality import colorchecker_delta_e, delta_e2000, linear_srgb_to_lab, patch_means, psnr, ssim
from .sharpness import slanted_edge_mtf

__all__ = ["photon_transfer", "PhotonTransferResult", "plot_photon_transfer", "patch_means", "linear_srgb_to_lab",
           "delta_e2000", "colorchecker_delta_e", "psnr", "ssim", "slanted_edge_mtf", "second_moment",
           "disc_diameter_from_moments", "measure_blur"]
