"""(f) Where the ideal thin lens stops describing a real one: for each bundled prescription, the
in-focus spot a point leaves on the best-focus plane (which the thin lens renders as a point)
against f-number and field angle, and the mechanical (cat's-eye) vignetting the thin lens's cos⁴
law does not have — from NumPy's real-ray trace (:mod:`spectral_cam.optics.prescription`).

A case is within the thin-lens model while the spot's RMS diameter stays below one pixel
(``StressSettings.lens_pixel_um``, 6 µm) and the pupil keeps ≥ 95 % of its axial area.

References
----------
.. [1] Smith, W. J. (2005). Modern Lens Design, 2nd ed. (the prescriptions).
.. [2] Kolb, C., Mitchell, D., & Hanrahan, P. (1995). A realistic camera model for computer
   graphics. SIGGRAPH '95.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...optics.prescription import PRESCRIPTION_NAMES, load_prescription
from ...viz import figure, save_png
from .summary import summary_row

__all__ = ["lens_study", "plot_lenses", "LENS_F_NUMBERS", "LENS_FIELDS_DEG", "PUPIL_HOLDS"]

LENS_F_NUMBERS = (2.0, 2.8, 4.0, 5.6, 8.0, 11.0, 16.0)
LENS_FIELDS_DEG = (0.0, 5.0, 10.0, 15.0, 20.0)
#: Pupil area (relative to the axis) above which the thin lens's missing cat's-eye vignetting is
#: within the study's tolerance.
PUPIL_HOLDS = 0.95
_MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")


def lens_study(settings) -> dict:
    """Spot RMS diameter (px of ``settings.lens_pixel_um``) and pupil area (relative to the axis)
    per prescription, f-number (from the lens's own, stopped down) and field angle (within the
    half field of a 36 × 24 mm frame)."""
    pixel = settings.lens_pixel_um * 1e-6
    rows, data = [], {}
    for name in PRESCRIPTION_NAMES:
        lens = load_prescription(name)
        own = lens.traced_f_number()
        half_field = np.degrees(np.arctan(0.5 * 0.0432 / lens.focal_length_m()))  # a 36 × 24 mm frame's diagonal
        fields = [f for f in LENS_FIELDS_DEG if f < half_field - 0.5] + [round(float(half_field), 1)]
        table = {"f_numbers": [], "fields_deg": fields, "spot_px": [], "pupil": []}
        for f_number in [own] + [n for n in LENS_F_NUMBERS if n > own * 1.02]:
            stopped = lens.stopped_down(f_number) if f_number > own else lens
            spots, pupils = [], []
            axial = stopped.spot_rms_m(0.0)[1]
            for field in fields:
                rms, passing = stopped.spot_rms_m(field)
                spots.append(2 * rms / pixel)
                pupils.append(passing / axial if axial else float("nan"))
            table["f_numbers"].append(f_number)
            table["spot_px"].append(spots)
            table["pupil"].append(pupils)
        data[name] = table
        spots = np.asarray(table["spot_px"])
        sharp = [n for n, row in zip(table["f_numbers"], spots) if row.max() < 1.0]
        rows.append(summary_row("lenses", name, "in-focus spot at full aperture, axis", spots[0, 0], "px",
                                f"f/{own:.2f}, RMS diameter at best focus, {settings.lens_pixel_um:g} µm pixels"))
        rows.append(summary_row("lenses", name, "in-focus spot at full aperture, edge", spots[0, -1], "px",
                                f"{fields[-1]:g}° field (a 36 × 24 mm frame's corner)"))
        note = "stopped down from full aperture" if sharp else f"none up to f/{max(table['f_numbers']):g}"
        rows.append(summary_row("lenses", name, "fastest f-number at which the thin lens holds (spot < 1 px at every "
                                "field)", min(sharp) if sharp else None, "", note))
        rows.append(summary_row("lenses", name, "pupil area at the edge, full aperture", table["pupil"][0][-1], "",
                                f"relative to the axis (cat's-eye vignetting, beyond cos⁴), {fields[-1]:g}°"))
    return {"rows": rows, "data": data}


def plot_lenses(result: dict, directory: Path) -> list[str]:
    """Spot diameter against f-number per field angle, and pupil area against field angle."""
    from matplotlib.ticker import FormatStrFormatter, NullFormatter

    data = result["data"]
    fig = figure(12, 4.0 * len(data))
    axes = fig.subplots(len(data), 2, squeeze=False)
    for (name, table), (left, right) in zip(data.items(), axes):
        spots, pupils = np.asarray(table["spot_px"]), np.asarray(table["pupil"])
        for j, field in enumerate(table["fields_deg"]):
            left.semilogy(table["f_numbers"], spots[:, j], marker=_MARKERS[j % len(_MARKERS)], label=f"{field:g}°")
        left.yaxis.set_major_formatter(FormatStrFormatter("%g"))  # plain numbers, not "4×10⁰"
        left.yaxis.set_minor_formatter(FormatStrFormatter("%g") if spots.max() / spots.min() < 30 else NullFormatter())
        left.axhline(1.0, color="k", ls=":", lw=0.8, label="1 px (thin lens holds below)")
        left.set_xlabel("f-number")
        left.set_ylabel("in-focus spot RMS diameter (px)")
        left.set_title(f"{name}: what the thin lens misses")
        left.legend(fontsize=7)
        for i, f_number in enumerate(table["f_numbers"]):  # markers tell apart the curves that coincide at 1
            right.plot(table["fields_deg"], pupils[i], marker=_MARKERS[i % len(_MARKERS)], label=f"f/{f_number:.3g}")
        fields = np.asarray(table["fields_deg"])
        right.plot(fields, np.ones_like(fields), "k:", lw=0.8, label="thin lens (no mechanical vignetting)")
        right.axhline(PUPIL_HOLDS, color="grey", ls="--", lw=0.8, label=f"{PUPIL_HOLDS:.0%}: the thin lens holds above")
        # one scale from 0 for every lens: auto-scaling blew a 0.3 % change up to the panel's height
        right.set_ylim(0.0, max(1.05, float(np.nanmax(pupils)) + 0.03))
        right.set_xlabel("field angle (°)")
        right.set_ylabel("pupil area / axial")
        right.set_title(f"{name}: cat's-eye vignetting")
        right.legend(fontsize=7, loc="lower left")
    from ...records import write_csv
    from .summary import SUMMARY_FIELDS

    # the study's rows on their own (README: docs/stress/lenses.csv; issue 25 #19 found it unwritten)
    write_csv(result["rows"], Path(directory) / "lenses.csv", SUMMARY_FIELDS)
    return [save_png(fig, Path(directory) / "lenses_thin_vs_prescription.png").name, "lenses.csv"]
