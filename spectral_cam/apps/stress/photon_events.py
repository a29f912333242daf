"""Study (j): beyond frames — CMOS against a quanta image sensor as light fades, and event rates.

SNR against photons per pixel: a noise-free-optics flat field (one 550-nm band, ideal QE) captured by
the CMOS model (read noise 2.5 e⁻ and 0.5 e⁻, dark current off) and by one-bit QIS captures of 64 and
1 024 frames over the same exposure (no read noise: a jot counts photons), reconstructed by maximum
likelihood. The SNR is the frame's mean over its standard deviation across pixels; the analytic curves
are μ/√(μ + σ_r²) for CMOS and √F·H/√(e^H − 1) (H = μ/F) for the QIS. The crossover is where
counting single photons beats integrating them.

Event rate against speed and threshold: an edge of log contrast 1.15 sweeping a 64-row sensor at
several speeds, with thresholds 0.1 … 0.4: events per second against the analytic
rows · v · floor(1.15/C).

References
----------
.. [1] Fossum, E. R., Ma, J., Masoodian, S., Anzagira, L., & Zizza, R. (2016). The quanta image sensor:
   every photon counts. Sensors 16(8), 1260 (SNR of single-bit counting against read noise).
.. [2] Gallego et al. (2022), IEEE TPAMI 44(1) (event generation).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .settings import StressSettings
from .summary import summary_row

__all__ = ["photon_events_study", "plot_photon_events", "STUDY_PHOTONS", "STUDY_THRESHOLDS"]

STUDY_PHOTONS = tuple(float(v) for v in np.geomspace(0.05, 2000.0, 16))
STUDY_THRESHOLDS = (0.1, 0.2, 0.3, 0.4)
STUDY_EDGE_SPEEDS = (500.0, 1000.0, 2000.0, 4000.0)
_SIZE = (48, 48)


def _scene(kind: str, *, read_noise: float = 2.5, frames: int = 64):
    import spectral_cam as sc

    h, w = _SIZE
    return sc.scene_from_dict({"sensor": {"width_px": w, "height_px": h, "model": "ideal", "cfa": "none",
                                          "kind": kind, "jot_frames": frames, "vignetting": False,
                                          "crop_margin_px": 0, "pixel_pitch_um": 1.1, "dark_current_e_per_s": 0.0,
                                          "read_noise_e": read_noise, "dsnu_e": 0.0, "prnu": 0.0,
                                          "bit_depth": 16, "full_well_e": 20000.0},
                               "lens": {"f_number": 2.0, "focal_length_mm": 50.0, "focus_distance_m": 1e6},
                               "exposure": {"time_s": 1e-3}})


def _radiance(photons: float, scene):
    """A flat field giving ``photons`` photo-electrons a pixel over the exposure (its band radiance from
    the sensor's own per-radiance response, so both sensors see the same light)."""
    from spectral_cam.image import SpectralImage
    from spectral_cam.sensor.radiometry import electrons_per_band_radiance

    per_radiance = electrons_per_band_radiance(scene, 550.0) * float(scene.exposure.time_s)
    data = np.full((*_SIZE, 1), photons / per_radiance, np.float32)
    return SpectralImage(data, (550.0,), (545.0, 555.0))


def _snr(values: np.ndarray) -> float:
    return float(values.mean() / values.std()) if values.std() > 0 else float("inf")


def _cmos_snr(photons: float, read_noise: float, seed: int) -> float:
    import spectral_cam as sc

    scene = _scene("cmos", read_noise=read_noise)
    raw = sc.expose(_radiance(photons, scene), scene, frame_seed=seed)
    return _snr((raw.mosaic.astype(float) - raw.black_level) / raw.meta["K_dn_per_e"])


def _qis_snr(photons: float, frames: int, seed: int) -> float:
    from spectral_cam.sensor.photon_counting import expose_photon_counting

    scene = _scene("qis", frames=frames)
    capture = expose_photon_counting(_radiance(photons, scene), scene, frame_seed=seed)
    if np.mean(capture.sum() >= frames) > 0.01:  # jots whose every frame fired: the estimate is a cap, not a measurement
        return float("nan")
    return _snr(capture.reconstruct() * frames)


def _event_rate(speed: float, threshold: float) -> float:
    import spectral_cam as sc
    from spectral_cam.sensor.events import simulate_events

    config = sc.scene_from_dict({"sensor": {"kind": "event", "width_px": 64, "height_px": 64,
                                            "event_threshold": threshold, "event_threshold_sigma": 0.0,
                                            "event_refractory_s": 0.0, "event_leak_hz": 0.0}})
    columns = np.arange(64) + 0.5
    duration = 48.0 / speed  # the edge crosses 48 columns
    times = np.linspace(0.0, duration, 97)
    logs = [np.broadcast_to(1.15 * np.clip(speed * t - columns + 8.5, 0.0, 1.0), (64, 64)) for t in times]
    return len(simulate_events(logs, times, config)) / duration


def photon_events_study(settings: StressSettings) -> dict:
    """SNR of CMOS and QIS against photons per pixel; event rate against speed and threshold (study (j))."""
    data: dict = {"photons": list(STUDY_PHOTONS), "cmos": {}, "qis": {}, "events": {}}
    rows = []
    for noise in (2.5, 0.5):
        measured = [_cmos_snr(p, noise, settings.seed_for(10, i)) for i, p in enumerate(STUDY_PHOTONS)]
        analytic = [p / math.sqrt(p + noise ** 2) for p in STUDY_PHOTONS]
        data["cmos"][f"{noise:g} e⁻ read noise"] = {"measured": measured, "analytic": analytic}
    for frames in (64, 1024):
        measured = [_qis_snr(p, frames, settings.seed_for(11, i)) for i, p in enumerate(STUDY_PHOTONS)]
        analytic = [math.sqrt(frames) * (p / frames) / math.sqrt(math.expm1(p / frames)) for p in STUDY_PHOTONS]
        data["qis"][f"{frames} one-bit frames"] = {"measured": measured, "analytic": analytic}
    cmos, qis = data["cmos"]["2.5 e⁻ read noise"]["analytic"], data["qis"]["1024 one-bit frames"]["analytic"]
    crossing = next((p for p, a, b in zip(STUDY_PHOTONS, cmos, qis) if a >= b), None)
    rows.append(summary_row("photon_events", "QIS 1024 frames vs CMOS 2.5 e⁻", "QIS better below", crossing,
                            "photons/pixel", "analytic, first sampled level where CMOS catches up"))
    for p_index in (0, 5, 10):
        photons = STUDY_PHOTONS[p_index]
        rows.append(summary_row("photon_events", f"{photons:.3g} photons/pixel", "SNR CMOS 2.5 e⁻ / QIS 1024",
                                data["cmos"]["2.5 e⁻ read noise"]["measured"][p_index]
                                / data["qis"]["1024 one-bit frames"]["measured"][p_index], "ratio"))
    for threshold in STUDY_THRESHOLDS:
        rates = [_event_rate(v, threshold) for v in STUDY_EDGE_SPEEDS]
        analytic = [64 * v * math.floor(1.15 / threshold) for v in STUDY_EDGE_SPEEDS]
        data["events"][f"C = {threshold:g}"] = {"speeds_px_s": list(STUDY_EDGE_SPEEDS), "rate": rates,
                                               "analytic": analytic}
        rows.append(summary_row("photon_events", f"edge at 2000 px/s, C = {threshold:g}", "event rate",
                                rates[2], "events/s", f"rows·v·floor(1.15/C) = {analytic[2]:.4g}"))
    return {"rows": rows, "data": data}


def plot_photon_events(result: dict, directory: Path) -> list[str]:
    """photon_snr.png (SNR against photons per pixel) and event_rates.png."""
    from ...viz import figure, save_png

    data = result["data"]
    photons = data["photons"]
    fig = figure(6.4, 4.2)
    ax = fig.subplots()
    for k, (group, marker) in enumerate((("cmos", "o"), ("qis", "s"))):
        for j, (name, entry) in enumerate(data[group].items()):
            colour = f"C{2 * k + j}"
            ax.loglog(photons, entry["analytic"], "-", color=colour, alpha=0.6)
            ax.loglog(photons, entry["measured"], marker, color=colour,
                      label=f"{'CMOS' if group == 'cmos' else 'QIS'}, {name}")
    ax.loglog(photons, np.sqrt(photons), "k:", label="photon shot noise √μ")
    ax.set_xlabel("photo-electrons per pixel over the exposure")
    ax.set_ylabel("SNR (mean / σ across a flat)")
    ax.set_ylim(3e-3, 100)
    ax.set_title("Integrating vs counting photons (lines: analytic)", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    save_png(fig, directory / "photon_snr.png", dpi=100)

    fig = figure(6.0, 4.0)
    ax = fig.subplots()
    for k, (name, entry) in enumerate(data["events"].items()):
        ax.loglog(entry["speeds_px_s"], entry["analytic"], "-", color=f"C{k}", alpha=0.6)
        ax.loglog(entry["speeds_px_s"], entry["rate"], "o", color=f"C{k}", label=name)
    ax.set_xlabel("edge speed (px/s)")
    ax.set_ylabel("events per second (64 rows)")
    ax.set_title("Event rate of a moving edge (lines: rows·v·floor(Δ/C))")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    save_png(fig, directory / "event_rates.png", dpi=100)
    return ["photon_snr.png", "event_rates.png"]
