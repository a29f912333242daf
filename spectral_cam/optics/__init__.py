"""Optics: everything between the scene's radiance and the sensor's irradiance that is not
Mitsuba.

- :mod:`.thin_lens` — the thin lens (:class:`ThinLens`): aperture, image distance, field of
  view, circle of confusion, diffraction and defocus MTFs, vignetting;
- :mod:`.glass` — optical glasses and their dispersion (Sellmeier), thin-lens focal length
  per wavelength;
- :mod:`.prescription` — real lens prescriptions (surfaces, glasses, stop), paraxial focal
  length and f-number, sag of spheres and aspheres;
- :mod:`.distortion` — Brown–Conrady radial distortion and its undistortion map;
- :mod:`.aperture` — bladed (polygonal, rounded) aperture outlines;
- :mod:`.layered_defocus` — the depth-layered lens model's defocus (disc PSF per depth
  layer, composited back to front).

The Mitsuba cameras that trace through these lenses live beside the rest of rendering:
:mod:`spectral_cam.render.spectral_lens` (dispersive thin lens) and
:mod:`spectral_cam.render.prescription_lens` (a prescription, surface by surface); the
layered model's render is :mod:`spectral_cam.render.layered`.

References
----------
.. [1] Hecht, E. (2017). Optics, 5th ed., ch. 5–6 (thin lenses, aberrations).
"""

from .glass import GLASS_NAMES, LINES_NM, Glass, glass, thin_lens_focal_length
from .thin_lens import (MTF_TOLERANCE, ThinLens, airy_kernel, defocus_mtf, defocus_otf, diffraction_mtf,
                        pixel_mtf)

__all__ = ["GLASS_NAMES", "LINES_NM", "MTF_TOLERANCE", "Glass", "ThinLens", "airy_kernel", "defocus_mtf",
           "defocus_otf", "diffraction_mtf", "glass", "pixel_mtf", "thin_lens_focal_length"]
