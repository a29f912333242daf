"""Dataset labels: what an item writes beside its RAW, one :data:`LABELS` entry each.

``[dataset] outputs`` names entries of :data:`LABELS`; an item renders its scene once
(:func:`spectral_cam.job.simulate`) and every entry it names writes its files into the item's
staging folder. Adding a label is one entry here::

    @LABELS.register("normals", options=("normals",), description="normals.exr: ...")
    def _normals(item: Item, folder: Path) -> list[Path]:
        ...                                       # write folder / "normals.exr"
        item.records["normals"] = {"file": "normals.exr", ...}   # its meta.json entry
        return [folder / "normals.exr"]

An entry's ``options`` are the meta.json keys it records (each None in an item without the
label). The physics of the labels lives here too: the signed defocus map
(:func:`defocus_map_px`), the noise-free camera RGB (:func:`clean_camera_rgb`) and the blur
measured against depth (:func:`measure_scene_blur`).

References
----------
.. [1] docs/design.md, "Registries" and "Result folder (job.py)".
.. [2] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10 (circle of confusion).
.. [3] EMVA Standard 1288, Release 4.0 Linear (2021), §2 (mean photo-electrons).
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import ConfigError
from ...exr import write_exr_channels
from ...io import staged_directory
from ...job import Simulation, result_meta, simulate, write_files
from ...metrics.blur import measure_blur
from ...records import write_json
from ...registry import Registry
from ...scene import SceneConfig

__all__ = ["LABELS", "DEFAULT_OUTPUTS", "BLUR_PRESETS", "Item", "write_item", "defocus_map_px",
           "clean_camera_rgb", "measure_scene_blur"]

#: What an item can write besides meta.json: ``[dataset] outputs`` name → entry (a function
#: ``(item, folder) -> files``; ``options``: the meta.json keys it records). Their order here
#: is the order of ``outputs`` in dataset.json and meta.json.
LABELS = Registry("dataset output")
#: Presets whose blur the item measures (per depth) when it renders the all-in-focus image.
BLUR_PRESETS = ("dof_targets", "point_sources", "tabletop", "vegetation")
#: Bands of predicted blur the outdoor presets' blur is measured in: |CoC| from 1 px up, each
#: band this factor wide; a band is measured where it keeps this many pixels.
COC_BAND_FACTOR, COC_BAND_MIN_PIXELS = 1.25, 150


@dataclass
class Item:
    """One dataset item in memory while its labels are written.

    Attributes
    ----------
    sim : Simulation
        The item's scene through render → expose → develop (its ``lens`` built once).
    measure_blur : bool
        Measure blur against depth (a sweep of a :data:`BLUR_PRESETS` scene).
    records : dict
        meta.json entries the labels record (keys declared in their ``options``).
    timings : dict
        Seconds per stage; a label that times itself records ``timings[name]`` (its time
        is then not counted under ``"write"``).
    """

    sim: Simulation
    measure_blur: bool = False
    records: dict = field(default_factory=dict)
    timings: dict = field(default_factory=dict)

    @property
    def config(self) -> SceneConfig:
        """The item's scene."""
        return self.sim.config

    @property
    def exposure_s(self) -> float:
        """The exposure the RAW was made with (s)."""
        return float(self.sim.raw.meta["exposure_s"])

    @functools.cached_property
    def clean_rgb(self) -> np.ndarray:
        """The noise-free camera RGB of the main render (:func:`clean_camera_rgb`)."""
        return clean_camera_rgb(self.sim.radiance, self.config, exposure_s=self.exposure_s)

    @functools.cached_property
    def shape_map(self) -> tuple[np.ndarray, list[dict]]:
        """Which shape each pixel sees through the frame's pinhole, and each shape's name and
        material (:func:`spectral_cam.render.render_shape_map`): rendered once for the labels
        that need it (segmentation, flow)."""
        from ...render import render_shape_map

        return render_shape_map(self.config, lens=self.sim.lens, with_materials=True)


# ----------------------------------------------------------------------------- the labels
def _result_file(item: Item, folder: Path, *, name: str) -> list[Path]:
    """A file of the render job's result folder (:func:`spectral_cam.job.write_files`)."""
    return write_files(item.sim, folder, [name])


for _name, _description in (
        ("raw", "raw.dng: the simulated RAW: CFA mosaic, uint16 DN with its black and white levels and DNG colour "
                "tags (read by LibRaw, dcraw, darktable, Adobe's SDK)"),
        ("image", "image.<isp.outputs>: the developed sRGB image (every isp.outputs format)"),
        ("radiance", "radiance.exr: spectral radiance per nm, Fichet et al. layout (opt-in)"),
        ("depth", "depth.exr: camera-space z, metres (channel Z; inf where no surface)"),
        ("camera", "camera.json: intrinsics K (pixels), OpenCV distortion, pose world → camera (OpenCV and "
                   "OpenGL axes), focus, aperture, exposure"),
        ("illuminant", "illuminant.json: the light's camera RGB (max 1, green 1, unit length), CIE xy, CCT and Duv"),
        ("photon_counts", "photon_counts.npz: a QIS or SPAD item's frames (packed bits) and record; nothing for "
                          "the other sensor kinds"),
        ("events", "events.npz and events.png: an event sensor item's (x, y, t µs, p) and its event frame; nothing "
                   "for the other sensor kinds")):
    LABELS.add(_name, functools.partial(_result_file, name=_name), description=_description)


@LABELS.register("defocus", options=("defocus",),
                 description="defocus.exr: signed thin-lens CoC diameter in pixels, channel CoC")
def _defocus(item: Item, folder: Path) -> list[Path]:
    path = write_exr_channels({"CoC": defocus_map_px(item.sim.lens, item.sim.radiance.depth_m)}, folder / "defocus.exr",
                      {"spectral_cam_units": "signed CoC diameter, pixels (+ behind focus)"})
    item.records["defocus"] = {"file": "defocus.exr", "channel": "CoC", "units": "px",
                               "formula": "A*f*(z - z_f)/(z*(z_f - f))/pixel_pitch, A = f/N",
                               "sign": "+ behind the focus plane, - in front"}
    return [path]


@LABELS.register("all_in_focus", options=("all_in_focus", "blur"),
                 description="all_in_focus.<isp.outputs>: the same pose through an ideal pinhole (no blur, "
                             "distortion or motion) at the same exposure")
def _all_in_focus(item: Item, folder: Path) -> list[Path]:
    t0 = time.perf_counter()
    config, exposure_s = item.config, item.exposure_s
    # the ideal pinhole: no blur, no aperture shape, no distortion (the undistortion label maps the
    # item's image onto it), no motion
    sharp_config = config.replace(**{"lens.model": "pinhole", "exposure.time_s": exposure_s, "lens.blades": 0,
                                     "lens.distortion": [0.0] * 5, "motion.camera_velocity_mps": [0.0] * 3,
                                     "motion.camera_angular_velocity_dps": [0.0] * 3,
                                     "motion.object_velocity_mps": [0.0] * 3})
    sharp = simulate(sharp_config, lens=item.sim.lens, with_depth=False)
    files = write_files(sharp, folder, ["image"], image_stem="all_in_focus")
    item.timings["all_in_focus"] = time.perf_counter() - t0
    item.records["all_in_focus"] = {
        "lens_model": "pinhole", "exposure_s": exposure_s, "files": sorted(p.name for p in files),
        "render": {k: v for k, v in sharp.radiance.meta.items() if k not in ("optics", "timings_s", "model_decisions")},
        "model_decisions": sharp.radiance.meta.get("model_decisions", {})}
    if item.measure_blur and config.scene.preset in BLUR_PRESETS and not config.scene.mitsuba_xml:
        t0 = time.perf_counter()
        pinhole = clean_camera_rgb(sharp.radiance, sharp_config, exposure_s=exposure_s).sum(axis=-1)
        item.records["blur"] = measure_scene_blur(config, item.sim.radiance.depth_m, pinhole,
                                                  item.clean_rgb.sum(axis=-1), lens=item.sim.lens)
        item.timings["blur_measurement"] = time.perf_counter() - t0
    return files


def _estimate_note(radiance) -> str:
    """What the label's radiance is: the renderer's estimator (mean, or the adaptive median of
    means, with the share of pixels it changed)."""
    record = ((radiance.meta or {}).get("model_decisions") or {}).get("estimator") or {}
    if record.get("choice") == "amon":
        return (f"adaptive median of {record['passes']} pass means (Buisine et al. 2021): fireflies removed; "
                f"{100 * record.get('median_share', 0.0):.3g} % of pixels took the median, biased low where "
                "rare bright paths (caustics) are real; elsewhere the unbiased mean of the samples")
    return "the mean of the samples (unbiased, Monte-Carlo noise and any fireflies included)"


@LABELS.register("clean_rgb", options=("clean_rgb",),
                 description="clean_rgb.exr: noise-free linear camera RGB (1 = white level - black level) of the "
                             "render's radiance estimate: its Monte-Carlo noise stays, fireflies do not where the "
                             "adaptive median of means was chosen (model_decisions.estimator)")
def _clean_rgb(item: Item, folder: Path) -> list[Path]:
    sensor = item.config.sensor
    channels = ("Y",) if sensor.cfa == "none" else ("R", "G", "B")
    clean = item.clean_rgb
    path = write_exr_channels({name: clean[..., i] for i, name in enumerate(channels)}, folder / "clean_rgb.exr",
                      {"spectral_cam_units": "linear camera RGB, 1 = white level - black level"})
    item.records["clean_rgb"] = {
        "file": "clean_rgb.exr", "channels": list(channels), "units": "linear camera RGB; 1 = white level - black level",
        "electrons_per_unit": (2 ** sensor.bit_depth - 1 - sensor.black_level_dn) / item.sim.raw.meta["K_dn_per_e"],
        "excludes": "shot, read, dark and fixed-pattern noise, dark signal, clipping, quantisation",
        "radiance_estimate": _estimate_note(item.sim.radiance)}
    return [path]


@LABELS.register("undistortion", options=("undistortion",),
                 description="undistortion.exr: for each undistorted pixel, its column and row in the image "
                             "(cv2.remap's map_x, map_y; identity without lens.distortion)")
def _undistortion(item: Item, folder: Path) -> list[Path]:
    from ...optics.distortion import undistortion_map

    coefficients = item.config.lens.distortion
    map_x, map_y = undistortion_map(item.sim.lens, coefficients)
    path = write_exr_channels({"map_x": map_x, "map_y": map_y}, folder / "undistortion.exr",
                              {"spectral_cam_units": "pixel coordinates of the rendered image, centres at integers"})
    item.records["undistortion"] = {"file": "undistortion.exr", "channels": ["map_x", "map_y"],
                                    "model": "Brown-Conrady, OpenCV order [k1, k2, p1, p2, k3]",
                                    "coefficients": list(coefficients),
                                    "use": "cv2.remap(image, map_x, map_y, cv2.INTER_LINEAR)"}
    return [path]


#: Codes of the health map's ``state`` channel (0: no plant at the pixel).
HEALTH_CODES = {"healthy": 1, "stressed": 2, "dry": 3, "weed": 4}


#: :func:`plant_map`'s owner of a pixel that shows a weed (−1: no plant).
WEED = -2


def plant_map(config: SceneConfig, lens) -> tuple[np.ndarray, list[dict]] | None:
    """Which plant each pixel's ray shows — an index into the returned plants' health
    records (:func:`spectral_cam.presets.vegetation.plant_health`), :data:`WEED` for a weed, −1
    for none — for a vegetation scene of PROSPECT-D plants through ``lens``; None for any
    other scene. The health label and the drift study's classifier both read it.

    References
    ----------
    .. [1] Jakob, W., et al. (2022). Mitsuba 3, plugin ``aov`` (shape_index).
    """
    from ...presets.vegetation import plant_health, vegetation_layout
    from ...render import render_shape_map

    scene = config.scene
    if scene.preset != "vegetation" or scene.mitsuba_xml or scene.plant_reflectances != "prospect":
        return None
    plants = plant_health(config, len(vegetation_layout(config, lens)))
    index, names = render_shape_map(config, lens=lens)
    owner_of = np.full(len(names) + 1, -1, np.int32)  # shape index → owner (the last: a miss, −1)
    for k, name in enumerate(names):
        owner_of[k] = WEED if name.startswith("weed_") else -1
    positions = {name: k for k, name in enumerate(names)}
    for k, plant in enumerate(plants):
        if plant["plant"] in positions:
            owner_of[positions[plant["plant"]]] = k
    return owner_of[index], plants


@LABELS.register("health", options=("health",),
                 description="health.exr: per pixel, the chlorophyll (µg/cm², channel cab) and health state "
                             "(channel state: 0 none, 1 healthy, 2 stressed, 3 dry, 4 a weed) of the plant seen "
                             "there; "
                             "meta.json lists each plant's state and PROSPECT-D traits (vegetation with "
                             "plant_reflectances = 'prospect')")
def _health(item: Item, folder: Path) -> list[Path]:
    found = plant_map(item.config, item.sim.lens)
    if found is None:
        item.records["health"] = {"plants": [], "note": "no plants with a leaf model in this scene"}
        return []
    t0 = time.perf_counter()
    owner, plants = found
    cab = np.zeros(owner.shape, np.float32)
    state = np.zeros(owner.shape, np.float32)
    for k, plant in enumerate(plants):
        here = owner == k
        cab[here], state[here] = plant["traits"]["cab"], HEALTH_CODES[plant["state"]]
        plant["pixels"] = int(here.sum())
    state[owner == WEED] = HEALTH_CODES["weed"]
    path = write_exr_channels({"cab": cab, "state": state}, folder / "health.exr",
                              {"spectral_cam_units": "cab: chlorophyll a+b, ug/cm2; state: 0 none, 1 healthy, "
                                                     "2 stressed, 3 dry, 4 weed"})
    item.records["health"] = {"file": "health.exr", "channels": ["cab", "state"], "codes": HEALTH_CODES,
                              "model": "PROSPECT-D (Feret et al. 2017) via prosail", "plants": plants}
    item.timings["health"] = time.perf_counter() - t0
    return [path]


def shape_class(name: str) -> str:
    """A shape's class: its name without the index its preset numbers it by (``patch_07`` →
    ``patch``, ``plant_3`` → ``plant``); an XML scene's shape id as it is."""
    stem, _, tail = name.rpartition("_")
    return stem if stem and tail.isdigit() else name


def shape_reflectance(config: SceneConfig, name: str) -> str | None:
    """Where a preset shape's reflectance comes from, where its preset names it by it (the
    ColorChecker patches, dead-leaves samples, plants, depth-target checkers); None otherwise
    (an XML scene's materials are its own)."""
    from ...spectra import COLORCHECKER_PATCH_NAMES

    scene = config.scene
    if scene.mitsuba_xml:
        return None
    kind, number = shape_class(name), name.rpartition("_")[2]
    if kind in ("patch", "chart_patch") and number.isdigit() and int(number) < len(COLORCHECKER_PATCH_NAMES):
        return f"ColorChecker '{COLORCHECKER_PATCH_NAMES[int(number)]}' (BabelColor average)"
    if kind == "leaves" and scene.preset == "dead_leaves":
        from ...reflectance_sets import reflectance_set

        return f"{scene.leaf_reflectances}: {reflectance_set(scene.leaf_reflectances).names[int(number)]}"
    if kind == "backdrop" and scene.preset == "dead_leaves":
        from ...presets.dead_leaves import BACKDROP_REFLECTANCE

        return f"flat {BACKDROP_REFLECTANCE:g}"
    if kind == "plant":
        return "PROSPECT-D leaf (health state in health.exr)" if scene.plant_reflectances == "prospect" \
            else f"reflectance set {scene.plant_reflectances}"
    if kind == "plane" and scene.preset == "dof_targets":
        return "checkerboard of flat 0.1 and 0.8"
    return None


@LABELS.register("segmentation", options=("segmentation",),
                 description="segmentation.png: per pixel, the 16-bit instance id of the shape its ray meets "
                             "through an ideal pinhole (the all-in-focus view; 0: nothing; each disc of dead_leaves "
                             "its own); meta.json maps each id to the shape's name, class, material, reflectance "
                             "source and pixel count")
def _segmentation(item: Item, folder: Path) -> list[Path]:
    import cv2

    t0 = time.perf_counter()
    index, shapes = item.shape_map
    if len(shapes) >= 65535:
        raise ConfigError(f"{len(shapes)} shapes do not fit a 16-bit segmentation (at most 65534)")
    ids = (index + 1).astype(np.uint16)  # 0: no shape
    path = folder / "segmentation.png"
    if not cv2.imwrite(str(path), ids):
        raise OSError(f"could not write {path}")
    counts = np.bincount(ids.ravel(), minlength=len(shapes) + 1)
    table = [{"id": k + 1, "name": shape["name"], "class": shape_class(shape["name"]), "material": shape["material"],
              "reflectance": shape.get("reflectance") or shape_reflectance(item.config, shape["name"]),
              "pixels": int(counts[k + 1]),
              **{key: shape[key] for key in ("depth_m", "radius_px") if key in shape}}
             for k, shape in enumerate(shapes)
             if counts[k + 1] or not shape.get("leaf")]  # a dead-leaves disc is listed where it shows
    item.records["segmentation"] = {
        "file": "segmentation.png", "dtype": "uint16", "background_id": 0, "pixels_unlabelled": int(counts[0]),
        "view": "ideal pinhole through the frame (the all-in-focus view), one ray per pixel through a random "
                "point of it (as the depth label's)",
        "instances": table}
    item.timings["segmentation"] = time.perf_counter() - t0
    return [path]


#: The frame's camera the coverage label traces, per lens model the render used (the layered
#: model composites the thin lens's blur: its rays are the thin lens's).
_COVERAGE_CAMERA = {"layered": "thin", "auto": "thin"}


@LABELS.register("coverage", options=("coverage",),
                 description="coverage.exr: the soft segmentation of the thin-lens image under defocus: per pixel "
                             "the three instances (ids as in segmentation.png; channels id_0..id_2) whose surfaces "
                             "take the most of its rays through the aperture, and their fractions (coverage_0.."
                             "coverage_2; Cryptomatte's ranked pairs); meta.json: the camera traced and the rays")
def _coverage(item: Item, folder: Path) -> list[Path]:
    from ...render import render_coverage_map
    from ...render.depth import COVERAGE_RANKS

    t0 = time.perf_counter()
    lens_model = item.sim.radiance.meta.get("lens_model", item.config.lens.model)
    camera = _COVERAGE_CAMERA.get(lens_model, lens_model)
    passes = 64
    ids, coverage, shapes = render_coverage_map(item.config, lens=item.sim.lens, model=camera, passes=passes)
    channels = {}
    for rank in range(COVERAGE_RANKS):
        channels[f"id_{rank}"] = (ids[..., rank] + 1).astype(np.float32)  # segmentation.png's ids: 0 none
        channels[f"coverage_{rank}"] = coverage[..., rank]
    path = write_exr_channels(channels, folder / "coverage.exr",
                              {"spectral_cam_units": "id_k: instance id (segmentation.png's; 0 none); coverage_k: "
                                                     "fraction of the pixel's rays"})
    item.records["coverage"] = {
        "file": "coverage.exr", "channels": list(channels), "ranks": COVERAGE_RANKS, "rays_per_pixel": passes,
        "camera": camera, "ids": "segmentation.png's instance ids (meta.json segmentation.instances names them)",
        "definition": "coverage_k: the fraction of the pixel's rays (random points of the pixel and of the "
                      "aperture) whose first surface is instance id_k, ranked by coverage; rays that escape "
                      "and lower ranks hold the rest"}
    item.timings["coverage"] = time.perf_counter() - t0
    return [path]


@LABELS.register("flow", options=("flow",),
                 description="flow.exr: forward optical flow over the exposure, pixels (channels dx, dy; x right, "
                             "y down): where each pixel's point at mid-exposure is imaged at the exposure's end "
                             "minus at its start; meta.json holds the camera's and the object's velocities")
def _flow(item: Item, folder: Path) -> list[Path]:
    from ...render.motion import is_object_part, motion_flow_px

    t0 = time.perf_counter()
    config, motion = item.config, item.config.motion
    moving = None
    if motion.object and any(motion.object_velocity_mps):
        index, shapes = item.shape_map
        ids = [k for k, shape in enumerate(shapes) if is_object_part(shape["name"], motion.object)]
        moving = np.isin(index, ids)
    flow = motion_flow_px(config, item.sim.lens, np.asarray(item.sim.radiance.depth_m), moving,
                          exposure_s=item.exposure_s)
    path = write_exr_channels({"dx": flow[..., 0], "dy": flow[..., 1]}, folder / "flow.exr",
                              {"spectral_cam_units": "pixels, exposure start to end; x right, y down"})
    to_opencv = np.array([-1.0, -1.0, 1.0])  # Mitsuba's camera axes (x left, y up) to OpenCV's
    item.records["flow"] = {
        "file": "flow.exr", "channels": ["dx", "dy"], "units": "px over the whole exposure, x right, y down",
        "exposure_s": item.exposure_s, "pose_of_points": "the exposure's middle (the depth label's)",
        "camera_velocity_mps_opencv": (np.asarray(motion.camera_velocity_mps) * to_opencv).tolist(),
        "camera_angular_velocity_dps": list(motion.camera_angular_velocity_dps),
        "object": motion.object or None,
        "object_velocity_mps_opencv": (np.asarray(motion.object_velocity_mps) * to_opencv).tolist(),
        "object_pixels": None if moving is None else int(moving.sum()),
        "largest_px": float(np.hypot(flow[..., 0], flow[..., 1]).max()) if flow.size else 0.0}
    item.timings["flow"] = time.perf_counter() - t0
    return [path]


@LABELS.register("albedo", options=("albedo",),
                 description="albedo.exr: the reflectance each pixel sees as camera RGB under the scene light's "
                             "white (R, G, B; a perfect white diffuser is 1) and as linear sRGB (sRGB_R, sRGB_G, "
                             "sRGB_B; Bradford to D65); shading.exr: S, the irradiance there relative to the "
                             "reference white's (the light at illuminant.illuminance_lux), so that clean camera RGB / "
                             "the white's ≈ albedo × S on diffuse surfaces, and E_lux, the illuminance there (lux)")
def _albedo(item: Item, folder: Path) -> list[Path]:
    from ... import spectra
    from ...colour_ground_truth import adapt_to_d65, band_cmfs, xyz_to_linear_srgb
    from ...image import SpectralImage
    from ...render import render_albedo_map
    from ...render.depth import ALBEDO_SPP

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


@LABELS.register("illuminant_map", options=("illuminant_map",),
                 description="illuminant_map.exr: per pixel, the camera RGB (green 1; channels R, G, B) of the "
                             "light arriving at the surface seen there (a white diffuser's response, interreflections "
                             "included) and each light's share of its green (share_0, share_1, …: LSMI's mixture "
                             "map; an XML scene's emitters, a sunsky's sun and sky apart); meta.json names each "
                             "light with its own camera RGB, xy and CCT; 0 where unlit")
def _illuminant_map(item: Item, folder: Path) -> list[Path]:
    from ...render.light_mixture import render_light_mixture

    t0 = time.perf_counter()
    mixture = render_light_mixture(item.config, lens=item.sim.lens)
    rgb = mixture.illuminant_rgb
    channels = {c: rgb[..., i].astype(np.float32) for i, c in enumerate("RGB")}
    channels.update({f"share_{k}": mixture.shares[..., k].astype(np.float32) for k in range(len(mixture.names))})
    path = write_exr_channels(channels, folder / "illuminant_map.exr",
                              {"spectral_cam_units": "R, G, B: camera RGB of the light, green 1; share_k: fraction "
                                                     "of the green signal from light k (0 where unlit)"})
    lights = [{"share_channel": f"share_{k}", "name": name, "camera_rgb_g1": mixture.camera_rgb_g1[k].tolist(),
               **chroma, "pixels_mostly_lit": int((mixture.shares[..., k] > 0.5).sum())}
              for k, (name, chroma) in enumerate(zip(mixture.names, mixture.chromaticities()))]
    item.records["illuminant_map"] = {
        "file": "illuminant_map.exr", "channels": list(channels), "lights": lights,
        "definition": "R, G, B: the camera's response to a white diffuser at the surface each pixel sees (E/pi, "
                      "every light, interreflections included), green 1; share_k = G_k / sum_j G_j with light k "
                      "alone (Kim et al. 2021, LSMI); clean_rgb / (R, G, B) is the image white-balanced per pixel",
        "view": "ideal pinhole through the frame (the all-in-focus view)", "spp_per_light_and_channel": mixture.spp,
        "pixels_unlit": int(mixture.unlit.sum())}
    item.timings["illuminant_map"] = time.perf_counter() - t0
    return [path]


#: Outputs of an item unless the spec's ``[dataset] outputs`` says otherwise (the spectral
#: cube, 31 float32 channels, is opt-in).
DEFAULT_OUTPUTS = ("raw", "image", "depth", "defocus", "all_in_focus", "clean_rgb")


def write_item(config: SceneConfig, target: str | Path, *, outputs: Sequence[str], measure_blur: bool = False,
               dataset: Mapping[str, Any] | None = None) -> dict:
    """Render one item and write its folder atomically: the labels, then meta.json.

    Parameters
    ----------
    config
        The item's validated scene.
    target
        The item folder; it appears in one rename when complete (an older one is replaced).
    outputs
        Names of :data:`LABELS` to write.
    measure_blur
        Measure blur against depth when the all-in-focus image is rendered (blur presets).
    dataset
        The item's record in meta.json (``index``, ``id``, ``seed``, ``spec_hash``, ``params``,
        ``outputs``).

    Returns
    -------
    dict
        The meta.json content: :func:`spectral_cam.job.result_meta` with ``dataset`` first
        and each label's records last.
    """
    for name in outputs:
        LABELS.check(name, key="dataset.outputs")
    started = time.perf_counter()
    with staged_directory(target, force=True) as stage:
        item = Item(simulate(config), measure_blur=measure_blur)
        written: list[Path] = []
        by_label: dict[str, list[str]] = {}  # what each output wrote: some write nothing for some scenes
        write_s = 0.0
        for name in outputs:
            t0 = time.perf_counter()
            files = LABELS[name](item, stage)
            by_label[name] = [path.name for path in files]
            written += files
            if name not in item.timings:
                write_s += time.perf_counter() - t0
        timings = {**item.sim.timings_s, "write": write_s, **item.timings}
        timings["total"] = time.perf_counter() - started
        record = dict(dataset or {})
        record["labels"] = by_label
        record["file_checks"] = {path.name: file_check(path) for path in written}
        meta = result_meta(item.sim, written, timings, dataset=record)
        meta.update({key: item.records.get(key) for entry in LABELS.values() for key in entry.options})
        write_json(meta, stage / "meta.json")
    return meta


def file_check(path: Path) -> dict:
    """Size (bytes) and SHA-256 of a written file: what a resumed run verifies, so a truncated
    ``raw.dng`` or a 0-byte ``image.png`` is rendered again instead of counted as done.

    References
    ----------
    .. [1] FIPS 180-4, Secure Hash Standard (SHA-256).
    """
    import hashlib

    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return {"bytes": Path(path).stat().st_size, "sha256": digest.hexdigest()}


# ----------------------------------------------------------------------------- label physics
def defocus_map_px(lens, depth_m: np.ndarray) -> np.ndarray:
    """Signed circle-of-confusion diameter in pixels at every pixel of a depth map.

    ``c = A·f·(z − z_f) / (z·(z_f − f)) / p`` with aperture diameter A = f/N, pixel pitch
    p and camera-space depth z: positive behind the focus plane (z > z_f), negative in
    front of it, zero on it; where nothing was hit (z = ∞) the limit A·f/(z_f − f)/p.

    Parameters
    ----------
    lens : ThinLens
        The item's lens and sensor geometry (:meth:`spectral_cam.optics.ThinLens.from_config`).
    depth_m : numpy.ndarray
        (H, W) camera-space z (m), ``inf`` where no surface was hit.

    Returns
    -------
    numpy.ndarray
        (H, W) float32 signed CoC diameter (pixels).

    Examples
    --------
    >>> from spectral_cam.optics import ThinLens
    >>> lens = ThinLens(0.025, 2.5, 2.0, 0.006, 0.004, 1000, 667)   # f = 25 mm, f/2.5, 6 µm pixels
    >>> defocus_map_px(lens, np.array([[1.0, 2.0, 4.0]])).round(2)
    array([[-21.1 ,   0.  ,  10.55]], dtype=float32)

    References
    ----------
    .. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10.
    .. [2] Potmesil, M., & Chakravarty, I. (1981). A lens and aperture camera model for
       synthetic image generation. SIGGRAPH '81, 297–305 (signed CoC for depth of field).
    """
    z = np.asarray(depth_m, dtype=np.float64)
    magnitude = lens.coc_diameter_px(z)
    sign = np.where(np.isinf(z), 1.0, np.sign(z - lens.focus_distance_m))
    return (sign * magnitude).astype(np.float32)


def clean_camera_rgb(radiance, config: SceneConfig, *, exposure_s: float) -> np.ndarray:
    """Noise-free linear camera RGB: every channel at every pixel, before CFA sampling.

    ``x_c = t·cos⁴θ·Σ_b L_b·w_b,c · K / (W − B)``: the mean photo-electrons of channel c
    through the sensor's own signal model (:func:`spectral_cam.sensor.signal_model`: band
    weights of the measured QE, lens and filter transmission, camera equation; or the
    photon-weighted camera film), scaled so that 1 is the white level above black, the
    scale of the RAW after black subtraction and normalisation. No shot, read, dark or
    fixed-pattern noise, no dark signal, no clipping (values above 1 are beyond
    saturation), no quantisation.

    Parameters
    ----------
    radiance : SpectralImage
        Band integrals of radiance (W·m⁻²·sr⁻¹), (H, W, B), or camera film channels.
    config : SceneConfig
        The item's scene (sensor, lens, ISO).
    exposure_s : float
        Exposure time (s), the one the RAW was exposed with.

    Returns
    -------
    numpy.ndarray
        (H, W, 3) float32 (camera r, g, b), or (H, W, 1) for a monochrome sensor.

    References
    ----------
    .. [1] EMVA Standard 1288, Release 4.0 Linear (2021), §2.1–2.2 (μ_e = η·μ_p, gain K).
    """
    from ...sensor import signal_model, system_gain

    sensor = config.sensor
    model = signal_model(radiance, config)
    scale = exposure_s * system_gain(sensor, config.exposure.iso) / (2 ** sensor.bit_depth - 1 - sensor.black_level_dn)
    rgb = np.asarray(radiance.data, dtype=np.float64) @ (np.asarray(model.weights, dtype=np.float64) * scale)
    if model.cos4 is not None:
        rgb *= np.asarray(model.cos4, dtype=np.float64)[..., None]
    return rgb.astype(np.float32)


def measure_scene_blur(config: SceneConfig, depth_m: np.ndarray, sharp: np.ndarray,
                       blurred: np.ndarray, *, lens=None) -> list[dict]:
    """Measured and thin-lens blur per depth of a ``dof_targets`` or ``point_sources`` item.

    ``dof_targets``: the pixels of each plane (from the depth map), shrunk by the largest
    predicted blur radius of the plane and the planes that border it, + 2 px, so that no other
    plane's blur and no frame edge reaches them. ``point_sources``: each source is a connected blob of the all-in-focus image above 1 %
    of its peak (the background is black), its depth the depth map's median over the blob; the region is a
    disc of radius (predicted blur radius + blob radius + 3 px) around it, measured only
    when it lies inside the frame and no other source's blur spot reaches it. The
    prediction only sizes the regions; the measurement is
    :func:`spectral_cam.metrics.blur.measure_blur` between the all-in-focus (pinhole) and
    the main image.

    Both images are rendered at the sensor's resolution, so a hard edge in the pinhole image
    aliases (its harmonics above Nyquist fold back), which the disc model cannot blur away
    as the lens did: on the 8-px checkers of ``dof_targets`` the measured diameter reads
    about 0.5, 0.25, 0.13 and 0.07 px high at 1.5, 3.3, 6.6 and 10 px (the same bias
    appears on synthetic, 16×-supersampled checkers); on ``point_sources`` it stays within
    the Monte-Carlo scatter (≈1–2 %).

    Parameters
    ----------
    config
        The item's scene.
    depth_m
        (H, W) camera-space z (m).
    sharp, blurred
        (H, W) linear all-in-focus and main images at the same exposure.
    lens : ThinLens, optional
        The lens the item was rendered through (default: built from ``config``).

    Returns
    -------
    list of dict
        ``{"depth_m", "predicted_coc_px", "measured_coc_px", "pixels", "note"}`` per depth,
        nearest first (``measured_coc_px`` None, with the reason in ``note``, where no
        usable region was left).

    Raises
    ------
    ConfigError
        For a scene of another preset.

    References
    ----------
    .. [1] Ray, S. F. (2002). Applied Photographic Optics, 3rd ed., ch. 10.
    """
    from scipy import ndimage

    from ...optics import ThinLens

    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens
    depth = np.asarray(depth_m, dtype=np.float64)
    finite = np.isfinite(depth)
    height, width = depth.shape
    results = []
    if config.scene.preset == "dof_targets":
        depths = sorted(set(float(z) for z in config.scene.depths_m))
        predicted = {z: float(lens.coc_diameter_px(z)) for z in depths}
        planes = {z: finite & (np.abs(depth - z) <= 1e-3 * z) for z in depths}
        for z in depths:
            region = planes[z]
            # only the planes that border this one (and its own blur) can blur light into it
            ring = ndimage.binary_dilation(region, iterations=2) & ~region
            reach = [predicted[z]] + [predicted[w] for w in depths if w != z and (ring & planes[w]).any()]
            margin = 0.5 * max(reach) + 2.0
            padded = np.pad(region, 1, constant_values=False)
            inner = ndimage.distance_transform_edt(padded)[1:-1, 1:-1] > margin
            period = 2 * config.scene.checker_px  # the same apparent checker at every depth
            if predicted[z] > period:  # issue 25 #21: 51.6 px "measured" against 26.7 predicted
                results.append(_blur_row(z, predicted[z], sharp, blurred, np.zeros_like(inner),
                                         f"blur {predicted[z]:.1f} px exceeds the checker period {period:g} px: the "
                                         "texture averages away, not measurable (raise scene.checker_px)"))
                continue
            results.append(_blur_row(z, predicted[z], sharp, blurred, inner,
                                     None if inner.any() else f"no pixels {margin:.1f} px inside the plane"))
        return results
    if config.scene.preset in ("tabletop", "vegetation"):
        return _blur_in_coc_bands(lens, depth, sharp, blurred)
    if config.scene.preset != "point_sources":
        raise ConfigError(f"blur is measured on {', '.join(BLUR_PRESETS)} scenes; got "
                          f"scene.preset = {config.scene.preset!r}")
    sharp_image = np.asarray(sharp, dtype=np.float64)
    # the background is black; diffraction's faint skirt aside, a source is above 1 % of the peak
    labels, count = ndimage.label(sharp_image > 0.01 * sharp_image.max(), structure=np.ones((3, 3), dtype=bool))
    sources = []
    for label in range(1, count + 1):
        blob = labels == label
        blob_depth = depth[blob & finite]
        if blob_depth.size == 0:
            continue  # a sub-pixel source the one-sample depth render missed: no depth to test
        rows, cols = np.nonzero(blob)
        weights = sharp_image[blob]
        z = float(np.median(blob_depth))
        sources.append({"z": z, "row": float(rows @ weights / weights.sum()),
                        "col": float(cols @ weights / weights.sum()),
                        "r_img": math.sqrt(blob.sum() / math.pi), "c": float(lens.coc_diameter_px(z))})
    yy, xx = np.mgrid[0:height, 0:width]
    for source in sources:
        reach = 0.5 * source["c"] + source["r_img"] + 3.0
        row, col = source["row"], source["col"]
        note = None
        if not (reach <= row + 0.5 and reach <= col + 0.5 and row + reach <= height - 0.5
                and col + reach <= width - 0.5):
            note = "blur spot leaves the frame"
        elif any(math.hypot(row - o["row"], col - o["col"]) < reach + 0.5 * o["c"] + o["r_img"]
                 for o in sources if o is not source):
            note = "blur spot overlaps another source's"
        region = ((yy - row) ** 2 + (xx - col) ** 2 <= reach * reach) if note is None else np.zeros_like(finite)
        results.append(_blur_row(source["z"], source["c"], sharp, blurred, region, note))
    return sorted(results, key=lambda r: r["depth_m"])


def _blur_in_coc_bands(lens, depth: np.ndarray, sharp, blurred) -> list[dict]:
    """Blur per band of predicted |CoC| (bands :data:`COC_BAND_FACTOR` wide from 1 px) of a
    scene whose depth varies smoothly (a ground plane): each band's pixels farther than half the
    frame's largest blur + 2 px from any pixel outside the band, measured where that leaves
    :data:`COC_BAND_MIN_PIXELS` pixels and the sharp image has texture there (an edge-free
    region has no blur to measure). Rows report the band's median depth and predicted CoC."""
    from scipy import ndimage

    finite = np.isfinite(depth)
    coc = np.where(finite, np.abs(lens.coc_diameter_px(np.where(finite, depth, 1.0))), np.inf)
    margin = 0.5 * float(coc[finite].max()) + 2.0 if finite.any() else 0.0
    gradient = np.hypot(*np.gradient(np.asarray(sharp, dtype=np.float64)))
    texture_floor = 0.05 * float(np.percentile(gradient, 99)) if gradient.size else 0.0
    results = []
    low = 1.0
    while finite.any() and low < float(coc[finite].max()):
        high = low * COC_BAND_FACTOR
        band = (coc >= low) & (coc < high)
        inner = ndimage.distance_transform_edt(np.pad(band, 1))[1:-1, 1:-1] > margin
        if inner.sum() >= COC_BAND_MIN_PIXELS:
            note = None if np.mean(gradient[inner] > texture_floor) > 0.05 else "no texture in the band"
            region = inner if note is None else np.zeros_like(inner)
            results.append(_blur_row(float(np.median(depth[inner])), float(np.median(coc[inner])), sharp, blurred,
                                     region, note))
        low = high
    return sorted(results, key=lambda r: r["depth_m"])


def _blur_row(depth: float, predicted: float, sharp, blurred, region, note: str | None) -> dict:
    pixels = int(region.sum())
    measured = measure_blur(sharp, blurred, region, max_diameter_px=2.0 * predicted + 6.0) if pixels else None
    return {"depth_m": depth, "predicted_coc_px": predicted,
            "measured_coc_px": None if measured is None or not math.isfinite(measured) else measured,
            "pixels": pixels, "note": note}
