"""Run the stress studies: the :data:`STUDIES` registry and :func:`run_studies`.

Each entry of :data:`STUDIES` is a :class:`Study` (the function that measures, the function
that draws), its ``options`` the :class:`~spectral_cam.apps.stress.settings.StressSettings`
fields it reads. Adding a study is one module in this package and one entry here.

References
----------
.. [1] docs/design.md, "Registries" and "Where to make a change" (a stress study).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from ...registry import Registry
from . import bokeh, demosaic, exposure, illuminants, lenses, olpf, optics, photon_events, rolling, shading
from .settings import StressSettings
from .summary import write_results, write_summary

__all__ = ["Study", "STUDIES", "run_studies"]


@dataclass(frozen=True)
class Study:
    """One stress study.

    Attributes
    ----------
    measure : callable
        ``measure(settings) -> {"rows": [...], "data": {...}, ...}``: the summary rows and
        the numbers for ``results.json`` (other keys, e.g. images, feed only the figures).
    plot : callable
        ``plot(result, directory) -> [file names]``: the figures of a result.
    writes_inputs : bool
        The study writes input files of its own into the output folder (``measure`` then
        takes ``directory=``).
    """

    measure: Callable[..., dict]
    plot: Callable[[dict, Path], list]
    writes_inputs: bool = False

    def __call__(self, settings: StressSettings, directory: Path | None = None) -> dict:
        if self.writes_inputs:
            return self.measure(settings, directory=directory)
        return self.measure(settings)


#: The studies in run order: name → :class:`Study`; options are the StressSettings fields read.
STUDIES = Registry("stress study")
STUDIES.add("demosaic", Study(demosaic.demosaic_study, demosaic.plot_demosaic),
            options=("square_sizes_px", "zone_plate_px", "frequency_bins"),
            description="demosaicing on checkerboards and a zone plate")
STUDIES.add("exposure", Study(exposure.exposure_study, exposure.plot_exposure),
            options=("exposure_levels", "exposure_range_e", "flat_px", "highlight_factors", "seed"),
            description="0.01 to 1e5 electrons: bias, clipping, highlights, SNR")
STUDIES.add("optics", Study(optics.optics_study, optics.plot_optics),
            options=("optics_px", "optics_spp", "seed"),
            description="f/0.95 to f/64, pinhole, near/infinity focus, 4 to 600 mm")
STUDIES.add("bokeh", Study(bokeh.bokeh_study, bokeh.plot_bokeh),
            options=("bokeh_px", "bokeh_thin_spp", "bokeh_tracer_spp", "bokeh_remedy_spp", "bokeh_reference_spp",
                     "seed"),
            description="out-of-focus point sources: Monte-Carlo noise and the remedy")
STUDIES.add("illuminants", Study(illuminants.illuminant_study, illuminants.plot_illuminants, writes_inputs=True),
            options=("patch_px", "seed"),
            description="ΔE2000 under A, FL11 and LEDs vs white balance")
STUDIES.add("lenses", Study(lenses.lens_study, lenses.plot_lenses), options=("lens_pixel_um",),
            description="thin lens vs real prescriptions: in-focus spot and cat's-eye vignetting")
STUDIES.add("olpf", Study(olpf.olpf_study, olpf.plot_olpf), options=("zone_plate_px", "frequency_bins"),
            description="false colour and sharpness vs optical low-pass filter strength, per demosaic")
STUDIES.add("rolling", Study(rolling.rolling_study, rolling.plot_rolling), options=("flicker_exposures", "skew_px"),
            description="flicker bands vs exposure time, rolling-shutter skew vs speed")
STUDIES.add("shading", Study(shading.shading_study, shading.plot_shading), options=(),
            description="lens and colour shading vs chief-ray angle; a flat-field table on another lens")
STUDIES.add("photon_events", Study(photon_events.photon_events_study, photon_events.plot_photon_events),
            options=("seed",), description="CMOS vs QIS SNR as light fades; event rate vs speed and threshold")


def run_studies(directory: Path, settings: StressSettings, *, only=None, log=None) -> dict:
    """Run the chosen studies, write their figures, the summary and ``results.json`` into
    ``directory`` (which must exist).

    Parameters
    ----------
    directory : path-like
        Output folder.
    settings : StressSettings
        Study sizes (:meth:`StressSettings.quick` or :meth:`StressSettings.full`).
    only : iterable of str, optional
        Study names (keys of :data:`STUDIES`); default all. Unknown names raise
        :class:`~spectral_cam.errors.ConfigError`.
    log : callable, optional
        Called with one progress line per study.

    Returns
    -------
    dict
        The content of ``results.json``: settings, per-study data, rows, files and timings.
    """
    from ...records import package_versions

    directory = Path(directory)
    chosen = {STUDIES.check(name) for name in only} if only else set(STUDIES)
    rows: list[dict] = []
    results: dict = {"settings": dataclasses.asdict(settings), "studies": {}, "timings_s": {}, "files": []}
    for name in (name for name in STUDIES if name in chosen):
        study = STUDIES[name].function
        started = time.perf_counter()
        result = study(settings, directory)
        files = study.plot(result, directory)
        seconds = time.perf_counter() - started
        rows += result["rows"]
        results["studies"][name] = {"data": result["data"], "rows": result["rows"]}
        results["timings_s"][name] = seconds
        results["files"] += files
        if log is not None:
            log(f"{name}: {seconds:.1f} s, {len(files)} chart{'' if len(files) == 1 else 's'}")
    results["files"] += write_summary(rows, directory)
    results["versions"] = package_versions()
    results["files"].append(write_results(results, directory))
    return results
