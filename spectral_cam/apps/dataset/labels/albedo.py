"""The ``albedo`` label: reflectance as camera RGB and linear sRGB, and the shading that multiplies it.

References
----------
.. [1] Barrow, H. G., & Tenenbaum, J. M. (1978). Recovering intrinsic scene characteristics from images.
.. [2] Lindbloom, B. Chromatic adaptation (Bradford).
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from ....exr import write_exr_channels
from .files import camera_rgb, exr_channels, stack
from .item import Item
from .physics import clean_camera_rgb
from .registry import LABELS


def _read_albedo(path: Path) -> dict[str, np.ndarray]:
    """``albedo`` (camera RGB), ``albedo_srgb``, and from shading.exr beside it ``shading`` and,
    where written, ``illuminance_lux``."""
    found = {"albedo": camera_rgb(path), "albedo_srgb": stack(path, ("sRGB_R", "sRGB_G", "sRGB_B"))}
    shading = path.with_name("shading.exr")
    found["shading"] = stack(shading, ("S",))[..., 0]
    if "E_lux" in exr_channels(shading):
        found["illuminance_lux"] = stack(shading, ("E_lux",))[..., 0]
    return found


@LABELS.register("albedo", options=("albedo",),
                 description="albedo.exr: the reflectance each pixel sees as camera RGB under the scene light's "
                             "white (R, G, B; a perfect white diffuser is 1) and as linear sRGB (sRGB_R, sRGB_G, "
                             "sRGB_B; Bradford to D65); shading.exr: S, the irradiance there relative to the "
                             "reference white's (the light at illuminant.illuminance_lux), so that clean camera RGB / "
                             "the white's ≈ albedo × S on diffuse surfaces, and E_lux, the illuminance there (lux)",
                 files=("albedo.exr", "shading.exr"), reader=_read_albedo, bytes_per_pixel=32.0,
                 fixed_bytes=8192.0)
def _albedo(item: Item, folder: Path) -> list[Path]:
    from .... import spectra
    from ....colour_ground_truth import adapt_to_d65, band_cmfs, xyz_to_linear_srgb
    from ....image import SpectralImage
    from ....render import render_albedo_map
    from ....render.depth import ALBEDO_SPP

    t0 = time.perf_counter()
    config = item.config
    reflectance, bands = render_albedo_map(config, lens=item.sim.lens)
    edges = np.asarray(bands.edges_nm, dtype=np.float64)
    wavelengths, irradiance = spectra.absolute_irradiance(config.illuminant.spd, config.illuminant.illuminance_lux)
    white = spectra.band_integrals(irradiance / np.pi, wavelengths, bands)  # a white diffuser's band radiance
    radiance = reflectance / np.diff(edges) * white  # ρ_b (band mean) × the white's band radiance
    shape = reflectance.shape

    def camera(data: np.ndarray) -> np.ndarray:
        image = SpectralImage(data.astype(np.float32), np.asarray(bands.centres_nm), edges)
        return clean_camera_rgb(image, config, exposure_s=item.exposure_s).astype(np.float64)

    white_rgb = camera(np.broadcast_to(white, shape))
    albedo = camera(radiance) / white_rgb
    cmfs = band_cmfs(edges)
    white_xyz = white @ cmfs
    srgb = xyz_to_linear_srgb(adapt_to_d65(radiance @ cmfs / white_xyz[1], white_xyz))
    green = min(1, albedo.shape[-1] - 1)
    with np.errstate(invalid="ignore", divide="ignore"):
        shading = np.where(albedo[..., green] > 1e-4, item.clean_rgb[..., green] / (albedo[..., green]
                                                                                   * white_rgb[..., green]), 0.0)
    names = ("Y",) if albedo.shape[-1] == 1 else ("R", "G", "B")
    channels = {name: albedo[..., i] for i, name in enumerate(names)}
    channels.update({f"sRGB_{c}": srgb[..., i] for i, c in enumerate("RGB")})
    albedo_path = write_exr_channels(channels, folder / "albedo.exr",
                                     {"spectral_cam_units": "camera RGB under the light's white (white = 1); "
                                                            "sRGB_*: linear sRGB, D65"})
    lux = float(config.illuminant.illuminance_lux)
    shading_path = write_exr_channels({"S": shading.astype(np.float32), "E_lux": (shading * lux).astype(np.float32)},
                                      folder / "shading.exr",
                                      {"spectral_cam_units": "S: irradiance relative to the reference white's; "
                                                             "E_lux: illuminance at the surface, lux"})
    centre = tuple(n // 2 for n in shape[:2])
    item.records["albedo"] = {
        "files": ["albedo.exr", "shading.exr"], "albedo_channels": list(channels), "shading_channels": ["S", "E_lux"],
        "reference_white_lux": lux,
        "light": config.illuminant.spd, "white_camera_rgb_g1": (white_rgb[centre] / white_rgb[centre][green]).tolist(),
        "relation": "clean_rgb / (white_camera_rgb × its green scale) ≈ albedo × S on diffuse surfaces lit by the "
                    "light alone; S is the irradiance there relative to the reference white's (the light's spectrum "
                    "at reference_white_lux: for a lamp, cos of incidence × visibility; under a scene's own "
                    "emitters or the sun, E_lux = S × reference_white_lux is the illuminance there)",
        "view": f"ideal pinhole over the frame, {ALBEDO_SPP} rays per pixel", "bands_nm": list(bands.centres_nm)}
    item.timings["albedo"] = time.perf_counter() - t0
    return [albedo_path, shading_path]
