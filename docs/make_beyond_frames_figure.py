"""Beyond frames, as docs/beyond_frames.png (the README's "Single-photon and event sensors").

Top row: the bundled ColorChecker scene dimmed to 0.5 lux, captured at equal exposure (and so equal
photons) by a one-bit quanta image sensor of 256 frames — one bit plane, the sum of the frames, the
maximum-likelihood reconstruction developed by the ISP — and by the CMOS model (Nikon D850 curves and
noise, ISO 6400) developed the same way. Bottom row: an event sensor's 10 ms of a camera panning at
1 m/s past the slanted edge (events, ON blue, OFF red) and past the vegetation preset (16 renders).

    .venv/bin/python docs/make_beyond_frames_figure.py
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from spectral_cam import load_scene, render
from spectral_cam.isp import ISPConfig, develop
from spectral_cam.viz import figure, save_png

HERE = Path(__file__).parent
SIZE = {"sensor.width_px": 240, "sensor.height_px": 160}


def _qis_and_cmos():
    from spectral_cam import expose
    from spectral_cam.sensor.photon_counting import expose_photon_counting

    scene = load_scene(HERE.parent / "scenes" / "colorchecker.toml",
                       overrides={**SIZE, "illuminant.illuminance_lux": 0.5, "render.spp": 64,
                                  "exposure.time_s": 1 / 30, "exposure.iso": 6400})
    radiance = render(scene, with_margin=True, with_depth=False)
    qis = expose_photon_counting(radiance, scene.replace(**{"sensor.kind": "qis", "sensor.jot_frames": 256}))
    isp = ISPConfig(demosaic="bilinear")
    crop = radiance.frame_window
    top, left, height, width = crop

    def framed(array):
        return array[top:top + height, left:left + width]

    cmos = develop(expose(radiance, scene), isp)
    plain = develop(qis.to_raw(), isp)
    # the QIS has no ISO gain: its reconstruction is brightened to the CMOS frame's mean for display
    ev = float(np.log2(cmos.linear.mean() / plain.linear.mean()))
    qis_image = develop(qis.to_raw(), isp.replace(exposure_ev=ev)).image
    return (framed(qis.counts[0].astype(float)), framed(qis.sum()), qis_image, cmos.image,
            qis.meta["mean_detections_per_frame"] * 256, ev)


def _events(scene_file: str, overrides: dict):
    from spectral_cam.job import simulate

    scene = load_scene(HERE.parent / "scenes" / scene_file,
                       overrides={**SIZE, "sensor.kind": "event", "sensor.event_frames": 16, "exposure.time_s": 0.01,
                                  "motion.camera_velocity_mps": [1.0, 0.0, 0.0], "render.spp": 32, **overrides})
    return simulate(scene, with_depth=False).events


def main() -> None:
    bits, total, qis_image, cmos_image, photons, ev = _qis_and_cmos()
    edge = _events("slanted_edge.toml", {})
    plants = _events("vegetation.toml", {"motion.camera_velocity_mps": [0.0, 0.0, 0.0],
                                         "motion.camera_angular_velocity_dps": [20.0, 0.0, 0.0],
                                         "render.spp": 256})  # fewer spp: Monte-Carlo noise fires events
    fig = figure(13.0, 6.4)
    panels = [(bits, "QIS: one bit plane (of 256)", "gray"), (total, "QIS: sum of 256 frames", "gray"),
              (qis_image, f"QIS reconstruction ({photons:.1f} e⁻/px mean; +{ev:.1f} EV to match)", None),
              (cmos_image, "CMOS, equal photons (ISO 6400, 2.5 e⁻ read)", None),
              (edge.frame_rgb(), f"events: 1 m/s pan past an edge ({len(edge):,} in 10 ms)", None),
              (plants.frame_rgb(), f"events: 20 °/s pan over vegetation ({len(plants):,})", None)]
    for index, (image, title, cmap) in enumerate(panels):
        ax = fig.add_subplot(2, 3, index + 1)
        ax.imshow(image, cmap=cmap, interpolation="nearest")
        ax.set_title(title, fontsize=8)
        ax.axis("off")
    save_png(fig, HERE / "beyond_frames.png", dpi=90)
    print(f"QIS {photons:.2f} e-/px at the mean, display +{ev:.2f} EV; events: edge {len(edge)}, vegetation "
          f"{len(plants)}")
    print(f"wrote {HERE / 'beyond_frames.png'}")


if __name__ == "__main__":
    main()
