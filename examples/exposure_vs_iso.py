"""Half the exposure, twice the ISO: the image is as bright, but not as clean.

ISO is a gain applied after the photons are counted. Halving the exposure halves the
photo-electrons, so the shot-noise SNR falls by √2; doubling the gain restores the brightness in
DN but amplifies the shot noise and the read noise (which the sensor adds before the gain) alike,
so the SNR stays √2 lower — and lower still where read noise matters (dim pixels).

A grey flat field on a colour-less sensor with 3 e⁻ of read noise, at three signal levels:
exposure t at ISO 100 against t/2 at ISO 200; the table prints mean DN and SNR of each.

    python examples/exposure_vs_iso.py [--pixels 128]
"""

from __future__ import annotations

import argparse
import math

import numpy as np


def table(pixels: int = 128) -> list[dict]:
    from spectral_cam import expose, scene_from_dict
    from spectral_cam.radiance_targets import uniform_image
    from spectral_cam.sensor import expected_electrons

    config = scene_from_dict({"sensor": {"model": "ideal", "cfa": "none", "width_px": pixels, "height_px": pixels,
                                         "read_noise_e": 3.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0,
                                         "prnu": 0.0, "full_well_e": 100000.0, "bit_depth": 16,
                                         "black_level_dn": 0, "crop_margin_px": 0, "vignetting": False},
                              "exposure": {"time_s": 1.0, "iso": 100.0}, "lens": {"model": "pinhole"}})
    image = uniform_image(np.full(31, 0.01), (pixels, pixels))
    rate = float(expected_electrons(image, config, exposure_s=1.0)[0].mean())
    rows = []
    for electrons in (20, 200, 2000):
        for time_factor, iso in ((1.0, 100.0), (0.5, 200.0)):
            shot = config.replace(**{"exposure.time_s": electrons / rate * time_factor, "exposure.iso": iso})
            raw = expose(image, shot, frame_seed=int(electrons * iso))
            dn = raw.mosaic.astype(np.float64) - raw.black_level
            rows.append({"electrons_at_iso100": electrons, "iso": iso, "mean_dn": float(dn.mean()),
                         "snr": float(dn.mean() / dn.std()),
                         "expected_snr": electrons * time_factor / math.sqrt(electrons * time_factor + 9.0)})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pixels", type=int, default=128)
    args = parser.parse_args(argv)
    rows = table(args.pixels)
    print(f"{'e- @ISO100':>10} {'ISO':>5} {'mean DN':>9} {'SNR':>6} {'expected':>9}")
    for r in rows:
        print(f"{r['electrons_at_iso100']:>10} {r['iso']:>5.0f} {r['mean_dn']:>9.1f} {r['snr']:>6.2f} "
              f"{r['expected_snr']:>9.2f}")
    pairs = list(zip(rows[::2], rows[1::2]))
    bright = all(abs(b["mean_dn"] / a["mean_dn"] - 1.0) < 0.02 for a, b in pairs)
    noisier = all(b["snr"] < a["snr"] for a, b in pairs)
    model = all(abs(r["snr"] / r["expected_snr"] - 1.0) < 0.05 for r in rows)
    print("brightness restored by the gain:", bright, "| SNR lost (n/2 electrons, read noise before the gain):",
          noisier, "| SNR = s/sqrt(s + 3^2):", model)
    return 0 if bright and noisier and model else 1


if __name__ == "__main__":
    raise SystemExit(main())
