"""Real lenses: optical glasses and their dispersion (:mod:`.glass`), prescriptions
(:mod:`.prescription`), distortion (:mod:`.distortion`) and bladed openings (:mod:`.aperture`). The Mitsuba camera that
renders through a dispersive thin lens is :mod:`spectral_cam.render.spectral_lens` (Mitsuba
stays inside ``render/``).

References
----------
.. [1] Hecht, E. (2017). Optics, 5th ed., ch. 6 (aberrations).
"""

from .glass import GLASS_NAMES, LINES_NM, Glass, glass, thin_lens_focal_length

__all__ = ["GLASS_NAMES", "LINES_NM", "Glass", "glass", "thin_lens_focal_length"]
