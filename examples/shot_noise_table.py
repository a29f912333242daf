"""Shot noise: photons arrive as a Poisson process, so a pixel that collects n photo-electrons on
average scatters by √n — the signal-to-noise ratio grows only as √n.

A uniform grey field exposed through the sensor (mono, no read noise, dark current, fixed
pattern or vignetting) for times that give 10, 100, 1000 and 10 000 photo-electrons per pixel;
the table prints the measured mean, standard deviation and SNR against √n, and the expected
spread √(n + q²) with q = 1/(K√12) the ADC's quantisation noise (K in DN per electron), which
only the dimmest level notices.

    python examples/shot_noise_table.py [--pixels 256]
"""

from __future__ import annotations

import argparse
import math

import numpy as np


def table(pixels: int = 256) -> list[dict]:
    from spectral_cam import expose, scene_from_dict
    from spectral_cam.radiance_targets import uniform_image
    from spectral_cam.sensor import expected_electrons

    config = scene_from_dict({"sensor": {"model": "ideal", "cfa": "none", "width_px": pixels, "height_px": pixels,
                                         "read_noise_e": 0.0, "dark_current_e_per_s": 0.0, "dsnu_e": 0.0,
                                         "prnu": 0.0, "full_well_e": 200000.0, "bit_depth": 16,
                                         "black_level_dn": 0, "crop_margin_px": 0, "vignetting": False},
                              "exposure": {"time_s": 1.0}, "lens": {"model": "pinhole"}})
    image = uniform_image(np.full(31, 0.01), (pixels, pixels))
    rate = float(expected_electrons(image, config, exposure_s=1.0)[0].mean())  # e⁻ per second
    rows = []
    for n in (10, 100, 1000, 10000):
        raw = expose(image, config.replace(**{"exposure.time_s": n / rate}), frame_seed=n)
        electrons = (raw.mosaic.astype(np.float64) - raw.black_level) / raw.meta["K_dn_per_e"]
        mean, std = float(electrons.mean()), float(electrons.std())
        quantisation = 1.0 / (raw.meta["K_dn_per_e"] * math.sqrt(12.0))
        rows.append({"photons": n, "mean_e": mean, "std_e": std, "sqrt_n": math.sqrt(n), "snr": mean / std,
                     "expected_std_e": math.sqrt(mean + quantisation ** 2)})
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--pixels", type=int, default=256)
    args = parser.parse_args(argv)
    rows = table(args.pixels)
    print(f"{'photons':>8} {'mean e-':>9} {'std e-':>8} {'sqrt(n)':>8} {'expected':>9} {'SNR':>7}")
    for r in rows:
        print(f"{r['photons']:>8} {r['mean_e']:>9.1f} {r['std_e']:>8.2f} {r['sqrt_n']:>8.2f} "
              f"{r['expected_std_e']:>9.2f} {r['snr']:>7.1f}")
    worst = max(abs(r["std_e"] / r["expected_std_e"] - 1.0) for r in rows)
    print(f"measured spread within {100 * worst:.1f} % of sqrt(n + q^2) at every level: shot noise is Poisson")
    return 0 if worst < 0.03 else 1


if __name__ == "__main__":
    raise SystemExit(main())
