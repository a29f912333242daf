"""``spectral-cam stress``: where each method of the chain stops being trustworthy.

Ten studies, one module each; a study function returns its numbers (``rows`` for the
summary table, ``data`` for ``results.json``) and a plot function draws them (matplotlib
Figure objects through :mod:`spectral_cam.viz`). :func:`run_studies` runs the studies of
the :data:`STUDIES` registry into one output folder:

(a) :mod:`.demosaic` — every registered demosaicing method on checkerboards and a zone
    plate: error against feature size and frequency, false colour, the lossless size.
(b) :mod:`.exposure` — flat fields from 0.01 to 10⁵ electrons per pixel: bias at low
    counts with and without ADC dither, clipping, highlight colour casts, SNR against EMVA 1288.
(c) :mod:`.optics` — f/0.95 to f/64 and a pinhole, 1:2 macro to 10⁶-m focus, 4 to 600 mm:
    circle-of-confusion and diffraction regimes, checked by tiny renders of a point source.
(d) :mod:`.bokeh` — Monte-Carlo noise of a small bright source far out of focus for the
    thin-lens path tracer and the light tracer, against the depth-layered lens model
    (``lens.model = "layered"``, :func:`spectral_cam.render.render_layered`).
(e) :mod:`.illuminants` — ΔE2000 of the colour pipeline on a synthetic ColorChecker under
    illuminants far from the D65 calibration, per colour matrix and white balance.
(f) :mod:`.lenses` — where the thin lens stops describing the bundled prescriptions: the
    in-focus spot against f-number and field angle, and cat's-eye vignetting.
(g) :mod:`.olpf` — false colour and sharpness of every demosaic against the optical low-pass
    filter's spot separation, on a neutral zone plate.
(h) :mod:`.rolling` — flicker bands of a rolling shutter and a global shutter's frame-to-frame
    swing against exposure time (mains and LED PWM); rolling-shutter skew against pan speed.
(i) :mod:`.shading` — lens and colour shading against the chief-ray angle, and the residual of a
    flat-field table calibrated on another lens.
(j) :mod:`.photon_events` — SNR of CMOS and a quanta image sensor against photons per pixel (where
    counting wins); an event sensor's rate against edge speed and threshold.

:mod:`.settings` holds the sizes (:class:`StressSettings`), :mod:`.summary` the summary
table and ``results.json``, :mod:`.run` the registry; the command line is
:mod:`spectral_cam.cli.stress`.

References
----------
.. [1] docs/design.md, "Where to make a change" (a stress study) and "Pitfalls measured so far".
"""

from __future__ import annotations

from .bokeh import BOKEH_CASE, bokeh_study, disc_mask, plot_bokeh
from .demosaic import LOSSLESS_TOLERANCE, checkerboard, demosaic_errors, demosaic_study, plot_demosaic, zone_plate
from .exposure import EXPOSURE_SENSORS, exposure_study, mono_config, neutral_chroma, plot_exposure
from .illuminants import (NARROW_LED_FWHM_NM, NARROW_LED_PEAKS_NM, STUDY_COLOUR_MATRICES, STUDY_ILLUMINANTS,
                          STUDY_WHITE_BALANCE, illuminant_study, plot_illuminants, write_narrow_band_led)
from .lenses import LENS_F_NUMBERS, LENS_FIELDS_DEG, lens_study, plot_lenses
from .olpf import STUDY_SEPARATIONS, olpf_study, plot_olpf
from .photon_events import STUDY_PHOTONS, STUDY_THRESHOLDS, photon_events_study, plot_photon_events
from .optics import (OPTICS_RENDERS, band_sum, bokeh_scene, chart_lens, diffraction_limit_f_number, optics_study,
                     plot_optics)
from .rolling import FLICKER_CASES, STUDY_SPEEDS_MPS, plot_rolling, rolling_study
from .run import STUDIES, Study, run_studies
from .shading import STUDY_CORNER_DEG, STUDY_HALVES_DEG, plot_shading, shading_study
from .settings import STUDY_CAMERA, StressSettings
from .summary import SUMMARY_FIELDS, summary_row, write_results, write_summary

__all__ = [
    "StressSettings", "STUDY_CAMERA", "STUDIES", "Study", "run_studies",
    "SUMMARY_FIELDS", "summary_row", "write_summary", "write_results",
    "LOSSLESS_TOLERANCE", "checkerboard", "zone_plate", "demosaic_errors", "demosaic_study", "plot_demosaic",
    "EXPOSURE_SENSORS", "mono_config", "neutral_chroma", "exposure_study", "plot_exposure",
    "OPTICS_RENDERS", "chart_lens", "diffraction_limit_f_number", "bokeh_scene", "band_sum", "optics_study",
    "plot_optics",
    "BOKEH_CASE", "disc_mask", "bokeh_study", "plot_bokeh",
    "STUDY_ILLUMINANTS", "NARROW_LED_PEAKS_NM", "NARROW_LED_FWHM_NM", "STUDY_WHITE_BALANCE",
    "STUDY_COLOUR_MATRICES", "write_narrow_band_led", "illuminant_study", "plot_illuminants",
    "LENS_F_NUMBERS", "LENS_FIELDS_DEG", "lens_study", "plot_lenses",
    "STUDY_SEPARATIONS", "olpf_study", "plot_olpf",
    "FLICKER_CASES", "STUDY_SPEEDS_MPS", "rolling_study", "plot_rolling",
    "STUDY_CORNER_DEG", "STUDY_HALVES_DEG", "shading_study", "plot_shading",
    "STUDY_PHOTONS", "STUDY_THRESHOLDS", "photon_events_study", "plot_photon_events",
]
