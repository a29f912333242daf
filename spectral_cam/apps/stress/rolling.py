"""Study (h): rolling shutter and flicker — banding against exposure time, skew against speed.

Flicker: a flat field under a light flickering at 100 Hz (50 Hz mains, sine, depth 1) and an LED
dimmed by 1 kHz PWM (duty 0.3, depth 1), through a rolling shutter (10 µs per row) at exposure
times from 0.1 to 40 ms: the bands' peak-to-peak amplitude over the mean, against the analytic
mean of the modulation over a row's window (for the sine 2·|sinc(f·T)|, zero at T = k/f — the
remedy: an exposure of whole flicker periods); and a global shutter's frame-to-frame swing.

Skew: the slanted-edge preset panned sideways at several speeds through a rolling shutter (100 µs
per row): the edge's shear over the frame against v·t_row·H·m/p.

References
----------
.. [1] IEEE Std 1789-2015 (flicker of LED lighting); Liang, Chang & Chen (2008), IEEE TIP 17(8)
   (rolling-shutter skew).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .settings import StressSettings
from .summary import summary_row

__all__ = ["rolling_study", "plot_rolling", "FLICKER_CASES", "STUDY_SPEEDS_MPS"]

#: (name, flicker settings) of the banding study.
FLICKER_CASES = (("mains 100 Hz (sine)", {"flicker_hz": 100.0, "flicker_depth": 1.0, "flicker_waveform": "sine"}),
                 ("LED PWM 1 kHz, duty 0.3", {"flicker_hz": 1000.0, "flicker_depth": 1.0, "flicker_waveform": "pwm",
                                              "flicker_duty": 0.3}))
#: Pan speeds of the skew study (m/s at 2 m).
STUDY_SPEEDS_MPS = (0.5, 1.0, 2.0, 4.0)
FLICKER_ROW_TIME_S = 10e-6
SKEW_ROW_TIME_S = 100e-6


def _row_levels(light: dict, exposure_s: float, *, shutter: str, start_s: float = 0.0, height: int = 1200):
    import spectral_cam as sc
    from spectral_cam.radiance_targets import lambertian_radiance, uniform_image

    lux = 100.0 * 2e-3 / exposure_s  # ~2400 DN at every exposure: PWM peaks (2.9×) stay unclipped
    scene = sc.scene_from_dict({
        "sensor": {"width_px": 4, "height_px": height, "model": "ideal", "cfa": "none", "shutter": shutter,
                   "row_time_s": FLICKER_ROW_TIME_S, "shot_noise": False, "read_noise_e": 0.0,
                   "dark_current_e_per_s": 0.0, "dsnu_e": 0.0, "prnu": 0.0, "vignetting": False, "bit_depth": 16,
                   "crop_margin_px": 0},
        "illuminant": {"spd": "D65", **light}, "exposure": {"time_s": exposure_s, "start_s": start_s}})
    radiance = uniform_image(lambertian_radiance("D65", [0.5], illuminance_lux=lux)[0], (height, 4))
    raw = sc.expose(radiance, scene)
    return (raw.mosaic.astype(float) - raw.black_level).mean(axis=1)


def _banding(light: dict, exposure_s: float) -> float:
    levels = _row_levels(light, exposure_s, shutter="rolling") / _row_levels({}, exposure_s, shutter="rolling")
    return float(levels.max() - levels.min())


def _analytic_banding(light: dict, exposure_s: float) -> float:
    from spectral_cam.sensor.temporal import mean_power

    period = 1.0 / light["flicker_hz"]
    starts = np.linspace(0.0, period, 2001)
    means = mean_power(starts, exposure_s, waveform=light["flicker_waveform"], frequency_hz=light["flicker_hz"],
                       depth=light["flicker_depth"], duty=light.get("flicker_duty", 0.5))
    return float(means.max() - means.min())


def _shear(speed: float, size: tuple[int, int]) -> tuple[float, float]:
    """(measured, predicted) shear over the frame (px) of the slanted edge panned at ``speed``."""
    from spectral_cam import render, scene_from_dict

    def config(v, shutter):
        return scene_from_dict({
            "scene": {"preset": "slanted_edge", "distance_m": 2.0},
            "sensor": {"width_px": size[1], "height_px": size[0], "shutter": shutter, "row_time_s": SKEW_ROW_TIME_S},
            "lens": {"model": "pinhole"}, "exposure": {"time_s": 1e-3},
            "motion": {"camera_velocity_mps": [v, 0.0, 0.0]},
            "render": {"spp": 128, "bands": "camera", "spectral_output": False, "diffraction": "off"}})

    still = render(config(0.0, "global"), with_depth=False)
    moving = render(config(speed, "rolling"), with_depth=False)
    rows = np.arange(size[0], dtype=float)
    slope = np.polyfit(rows, _edge_columns(moving.data) - _edge_columns(still.data), 1)[0]
    lens = still.lens
    predicted = speed * SKEW_ROW_TIME_S * size[0] / 2.0 * lens.image_distance_m / lens.pixel_pitch_m
    return float(abs(slope) * size[0]), float(predicted)


def _edge_columns(data) -> np.ndarray:
    luminance = data[..., :3].sum(axis=-1)
    derivative = np.abs(np.diff(luminance, axis=1))
    peak = np.argmax(derivative, axis=1)
    columns = np.arange(derivative.shape[1]) + 1.0
    weights = np.where(np.abs(columns[None, :] - 1.0 - peak[:, None]) <= 6, derivative, 0.0)
    return (weights * columns).sum(axis=1) / weights.sum(axis=1)


def rolling_study(settings: StressSettings) -> dict:
    """Flicker banding against exposure time, a global shutter's frame-to-frame swing, rolling-shutter
    skew against speed (study (h))."""
    exposures = np.geomspace(1e-4, 4e-2, settings.flicker_exposures).tolist()
    for special in (1e-2, 2e-2):  # whole periods of 100 Hz: the remedy
        if special not in exposures:
            exposures.append(special)
    exposures = sorted(exposures)
    data: dict = {"exposures_s": exposures, "flicker": {}, "skew": {}}
    rows = []
    for name, light in FLICKER_CASES:
        measured = [_banding(light, t) for t in exposures]
        analytic = [_analytic_banding(light, t) for t in exposures]
        starts = np.linspace(0.0, 1.0 / light["flicker_hz"], 9)[:-1]
        swing = [float(np.ptp([_row_levels(light, t, shutter="global", start_s=s, height=8).mean() for s in starts])
                       / _row_levels({}, t, shutter="global", height=8).mean()) for t in exposures]
        fine = np.geomspace(1e-4, 4e-2, 400)
        data["flicker"][name] = {"banding": measured, "analytic": analytic, "global_swing": swing,
                                 "fine_exposures_s": fine.tolist(),
                                 "analytic_fine": [_analytic_banding(light, t) for t in fine]}
        for t in (1e-3, 1e-2):
            i = exposures.index(min(exposures, key=lambda e: abs(e - t)))
            rows.append(summary_row("rolling", name, f"band amplitude (peak-to-peak), T = {exposures[i] * 1e3:.3g} ms",
                                    measured[i], "of the mean", f"analytic {analytic[i]:.4f}"))
        rows.append(summary_row("rolling", name, "band period",
                                1.0 / (light["flicker_hz"] * FLICKER_ROW_TIME_S), "rows", "1/(f·t_row), 10 µs per row"))
    size = (settings.skew_px, int(settings.skew_px * 1.5))
    for speed in STUDY_SPEEDS_MPS:
        measured, predicted = _shear(speed, size)
        data["skew"][str(speed)] = {"measured_px": measured, "predicted_px": predicted}
        rows.append(summary_row("rolling", f"pan {speed:g} m/s at 2 m", f"skew over {size[0]} rows", measured, "px",
                                f"v·t_row·H·m/p = {predicted:.3f}"))
    return {"rows": rows, "data": data}


def plot_rolling(result: dict, directory: Path) -> list[str]:
    """rolling_flicker.png (band amplitude and frame swing against T) and rolling_skew.png."""
    from ...viz import figure, save_png

    data = result["data"]
    fig = figure(11.0, 4.0)
    ax1, ax2 = fig.subplots(1, 2)
    t_ms = np.array(data["exposures_s"]) * 1e3
    for k, (name, entry) in enumerate(data["flicker"].items()):
        fine_ms = np.array(entry["fine_exposures_s"]) * 1e3
        ax1.plot(fine_ms, entry["analytic_fine"], "-", color=f"C{k}", alpha=0.6, label=f"{name}, analytic")
        ax1.plot(t_ms, entry["banding"], "o", color=f"C{k}", label="measured")
        ax2.plot(fine_ms, entry["analytic_fine"], "-", color=f"C{k}", alpha=0.6, label=f"{name}, analytic")
        ax2.plot(t_ms, entry["global_swing"], "s", color=f"C{k}", label="measured (8 frame phases)")
    for ax in (ax1, ax2):
        ax.set_xscale("log")
        for whole in (10, 20):
            ax.axvline(whole, color="grey", linestyle=":", linewidth=0.8)
        ax.set_xlabel("exposure time (ms)")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    ax1.set_ylabel("band amplitude, peak-to-peak / mean")
    ax1.set_title("Rolling shutter (10 µs/row): flicker bands")
    ax2.set_ylabel("frame-to-frame swing / mean")
    ax2.set_title("Global shutter: frame-to-frame flicker")
    save_png(fig, directory / "rolling_flicker.png", dpi=100)

    fig = figure(5.0, 4.0)
    ax = fig.subplots()
    speeds = [float(s) for s in data["skew"]]
    ax.plot(speeds, [v["predicted_px"] for v in data["skew"].values()], "k--", label="v·t_row·H·m/p")
    ax.plot(speeds, [v["measured_px"] for v in data["skew"].values()], "o", label="rendered")
    ax.set_xlabel("pan speed at 2 m (m/s)")
    ax.set_ylabel("edge skew over the frame (px)")
    ax.set_title("Rolling shutter (100 µs/row) skew")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    save_png(fig, directory / "rolling_skew.png", dpi=100)
    return ["rolling_flicker.png", "rolling_skew.png"]
