"""The light of a user's Mitsuba XML scene (or of a preset under the sun and sky), read from
its own emitters.

White balance, the fitted colour matrix and the ground truth need the spectrum that lights the
scene. A preset is lit by ``[illuminant]``, except an outdoor preset under Mitsuba's
``sunsky`` (``scene.light``); an XML scene by its emitters, whatever ``[illuminant]`` says. With ``illuminant.spd = "auto"`` (the default) :func:`resolve_light`
reads each emitter's spectrum as Mitsuba renders it (so ``blackbody``, ``d65``,
regular/irregular/uniform spectra, RGB upsampled under D65, textured area lights, ``constant``,
``envmap`` and ``sunsky`` all work): the mean of ``Emitter.sample_direction``'s spectral
weights, L(λ)/pdf, times the cosine to the surface's normal, over directions from the point
the camera looks at that reach the emitter unoccluded: the spectral irradiance that emitter
sends there (up to a constant factor), what a white diffuser there would see. It picks one emitter
(``illuminant.emitter``, else the one that sends the camera most light, measured by rendering
the scene with each emitter alone, the others dimmed 10²⁰-fold) and returns the scene with
``illuminant.spd`` set to it: ``"blackbody:<K>"`` for a blackbody, else a CSV of its samples.

References
----------
.. [1] Jakob, W., et al. (2022). Mitsuba 3 documentation, "Emitters" (``area``, ``point``,
   ``spot``, ``directional``, ``constant``, ``envmap``, ``sunsky``) and "Spectra"
   (``blackbody``, ``d65``, ``regular``, ``irregular``, ``uniform``).
.. [2] Pharr, Jakob & Humphreys (2023), PBRT 4th ed., §12 (light sampling: an estimate of
   incident radiance integrals from L/pdf).
"""

from __future__ import annotations

import contextlib
import hashlib
import warnings
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ConfigError, RenderError, SceneWarning
from ..scene import SceneConfig

__all__ = ["SceneEmitter", "LightPart", "scene_emitters", "light_parts", "lit_alone", "light_part_spectrum",
           "resolve_light", "LIGHT_GRID_NM"]

#: Wavelengths (nm) at which emitter spectra are sampled: Mitsuba's spectral range, 5 nm.
LIGHT_GRID_NM = np.arange(360.0, 831.0, 5.0)
#: Directions sampled per wavelength group when reading an emitter's spectrum.
DIRECTION_SAMPLES = 4096
#: Frame (px) and samples of the renders that measure which emitter sends the camera most light.
PROBE_SIZE, PROBE_SPP = (48, 32), 16
#: How much the other emitters are dimmed while one is measured.
DIM = 1e-20
# Parameters that set an emitter's strength (scaled to dim it); a temperature is lowered instead.
_STRENGTH_SUFFIXES = ("value", "values", "data", "scale", "sun_scale", "sky_scale")
_COLD_K = 100.0  # a blackbody at 100 K sends ~1e-89 of its 2856-K light in the visible


@dataclass(frozen=True)
class SceneEmitter:
    """One emitter of a scene.

    Attributes
    ----------
    name : str
        Its id, or its shape's id for an area light (``emitter_<n>`` when it has none).
    plugin : str
        Mitsuba's class (``AreaLight``, ``PointLight``, ``ConstantBackgroundEmitter``, ...).
    spectrum : numpy.ndarray
        Relative spectral irradiance it sends to the point the camera looks at, on
        :data:`LIGHT_GRID_NM` (max 1).
    temperature_k : float or None
        The blackbody temperature, for a ``blackbody`` spectrum.
    share : float or None
        Fraction of the light the camera receives that comes from it (when measured).
    """

    name: str
    plugin: str
    spectrum: np.ndarray
    temperature_k: float | None = None
    share: float | None = None


def _emitter_prefixes(mi, scene) -> list[tuple[object, str, str]]:
    """(emitter, name, traverse-key prefix) of every emitter; area lights are named by their shape."""
    by_shape = {}
    for shape in scene.shapes():
        if shape.emitter() is not None:
            by_shape[id(shape.emitter())] = shape.id()
    found = []
    for index, emitter in enumerate(scene.emitters()):
        shape_id = by_shape.get(id(emitter))
        if shape_id is not None:
            name, prefix = shape_id or f"emitter_{index}", f"{shape_id}.emitter." if shape_id else None
        else:
            name, prefix = emitter.id() or f"emitter_{index}", f"{emitter.id()}." if emitter.id() else None
        found.append((emitter, name, prefix))
    return found


#: How the light is read, as meta.json records it.
LIGHT_METHOD = ("the emitter's spectral irradiance on the surfaces the camera sees, averaged over a 24 x 16 grid of "
                "rays through the frame")
#: The grid of camera rays (columns × rows) whose hits are the visible surfaces the light is
#: averaged over, and the emitter directions sampled at each hit.
FRAME_GRID, DIRECTIONS_PER_POINT = (24, 16), 64


@dataclass(frozen=True)
class VisibleSurfaces:
    """Points of the surfaces the camera sees (a grid of rays over the frame) and their normals,
    turned to the camera's side. ``normals`` is None where no ray hits anything (the camera's
    own place then stands for the scene: what its emitters send towards the camera)."""

    points: np.ndarray
    normals: np.ndarray | None


def visible_surfaces(mi, scene, sensor, grid: tuple[int, int] = FRAME_GRID) -> VisibleSurfaces:
    """Where a :data:`FRAME_GRID` of rays through the frame's pixel grid (cell centres) meets the
    scene, each point lifted 10⁻⁴ along its normal to the side the camera sees. Rays that miss
    (the sky) are dropped: they see no surface to light."""
    import drjit as dr

    columns, rows = grid
    u, v = np.meshgrid((np.arange(columns) + 0.5) / columns, (np.arange(rows) + 0.5) / rows)
    count = u.size
    ray, _ = sensor.sample_ray(dr.zeros(mi.Float, count), dr.full(mi.Float, 0.5, count),
                               mi.Point2f(u.ravel().astype(np.float32), v.ravel().astype(np.float32)),
                               mi.Point2f(dr.full(mi.Float, 0.5, count), dr.full(mi.Float, 0.5, count)))
    hit = scene.ray_intersect(ray)
    dr.eval(hit.p, hit.n, ray.d, ray.o)
    valid = np.asarray(hit.is_valid(), dtype=bool)
    if not valid.any():  # nothing but small emitters in view (every ray passed them): the camera's place
        origin = np.stack([np.asarray(c, dtype=np.float64) for c in ray.o], axis=1).mean(axis=0)
        return VisibleSurfaces(origin[None, :], None)
    normal = np.stack([np.asarray(c, dtype=np.float64) for c in hit.n], axis=1)[valid]
    direction = np.stack([np.asarray(c, dtype=np.float64) for c in ray.d], axis=1)[valid]
    normal *= np.where(np.einsum("ij,ij->i", normal, direction) > 0, -1.0, 1.0)[:, None]  # the side seen
    point = np.stack([np.asarray(c, dtype=np.float64) for c in hit.p], axis=1)[valid] + 1e-4 * normal
    return VisibleSurfaces(point, normal)


def _as_array(spectrum, lanes: int = 4) -> np.ndarray:
    """A drjit spectrum of ``lanes`` wavelengths as an (n, lanes) NumPy array."""
    return np.stack([np.asarray(spectrum[i], dtype=np.float64) for i in range(lanes)], axis=1)


def _point3(mi, values: np.ndarray):
    return mi.Point3f(*[np.ascontiguousarray(values[:, i], dtype=np.float32) for i in range(3)])


def _direct(mi, dr, scene, emitter, points: np.ndarray, normals: np.ndarray | None, wavelengths, samples):
    """One emitter sample per point (``samples``: (2, n) uniform numbers): L(λ)/pdf·cos θ (n, 4),
    zero where the scene blocks it (no cosine, no occlusion without normals), and L(λ)/pdf alone."""
    n = len(points)
    it = dr.zeros(mi.Interaction3f, n)
    it.p = _point3(mi, points)
    it.wavelengths = wavelengths
    u = mi.Point2f(*samples.astype(np.float32))
    # test_visibility=True: emitters cannot test it (they hold no scene) and ignore it, except
    # sunsky, which returns zero weights when it is False (Mitsuba 3.9.1); occlusion is ours
    ds, weight = emitter.sample_direction(it, u, True)
    blocked = scene.ray_test(mi.Ray3f(it.p, ds.d, ds.dist * (1 - 1e-4), 0.0, it.wavelengths))
    dr.eval(weight, ds.d, blocked)  # one kernel; converting each lane alone re-traces it
    values = _as_array(weight)
    if normals is None:
        return values, values
    direction = np.stack([np.asarray(c, dtype=np.float64) for c in ds.d], axis=1)
    factor = np.clip(np.einsum("ij,ij->i", direction, normals), 0.0, None) * ~np.asarray(blocked)
    return values * factor[:, None], values


def _irradiance_spectrum(mi, dr, scene, emitter, surfaces: VisibleSurfaces) -> np.ndarray:
    """The spectral irradiance the emitter sends to the surfaces the camera sees, averaged over
    them (each ray of the frame's grid one equal share), on :data:`LIGHT_GRID_NM`: the mean of
    L(λ)/pdf·cos θ over directions sampled at each point, a direction the scene blocks counting
    zero. What grey cards on every visible surface would gather from the emitter: sunlit
    surfaces, which gather most, weigh most, as in a camera's white balance over the frame, and
    no one point (a shadow, a leaf's back) decides it. Light the scene reflects (a soil's warm
    bounce) is not the emitter's and stays out: the illuminant is what the ground truth's colours
    are seen under. Without normals (the camera sees no surface), or where no sampled direction
    reaches the emitter, the cosine and the occlusion are dropped: the spectrum the emitter sends
    towards the points."""
    rng = np.random.default_rng(0)
    repeat = DIRECTION_SAMPLES if len(surfaces.points) == 1 else DIRECTIONS_PER_POINT
    points = np.repeat(surfaces.points, repeat, axis=0)
    normals = None if surfaces.normals is None else np.repeat(surfaces.normals, repeat, axis=0)
    # the same directions at every wavelength (common random numbers): sampling noise scales the
    # whole spectrum instead of moving one group of 4 wavelengths against the next
    samples = rng.random((2, len(points)))
    received, plain = np.zeros(len(LIGHT_GRID_NM)), np.zeros(len(LIGHT_GRID_NM))
    for start in range(0, len(LIGHT_GRID_NM), 4):
        chunk = np.resize(LIGHT_GRID_NM[start:start + 4], 4)
        wavelengths = mi.Spectrum(*[dr.full(mi.Float, float(w), len(points)) for w in chunk])
        direct, unweighted = _direct(mi, dr, scene, emitter, points, normals, wavelengths, samples)
        end = min(4, len(LIGHT_GRID_NM) - start)
        received[start:start + end] = direct.mean(axis=0)[:end]
        plain[start:start + end] = unweighted.mean(axis=0)[:end]
    return received if np.any(received > 0) else plain


def _temperature(params, prefix: str | None) -> float | None:
    if prefix is None:
        return None
    keys = [k for k in params.keys() if k.startswith(prefix) and k.endswith(".temperature")]
    return float(params[keys[0]]) if len(keys) == 1 else None


def _strength_keys(params, prefix: str) -> list[str]:
    """The parameters that dim an emitter: its scale factors where it has them (envmap,
    sunsky), else a blackbody's temperature, else its spectrum's values. One kind only: two
    factors of 10⁻²⁰ underflow float32 to zero, and an all-zero tabulated spectrum or
    environment map has no sampling distribution (Mitsuba refuses it)."""
    keys = [k for k in params.keys() if k.startswith(prefix)]
    for wanted in (("scale", "sun_scale", "sky_scale"), ("temperature",), _STRENGTH_SUFFIXES):
        found = [k for k in keys if k.rsplit(".", 1)[-1] in wanted]
        if found:
            return found
    return []


def _not_finite(name: str) -> ConfigError:
    """The error of an emitter whose light is NaN or infinite (issue 25 #14)."""
    return ConfigError(f"emitter {name!r} sends the camera a light that is not finite (its radiance, intensity or "
                       "irradiance is NaN or too large for float32): give it a finite strength")


@dataclass(frozen=True)
class LightPart:
    """A part of a scene's light that can be dimmed on its own: an emitter, or the sun or the
    sky of a ``sunsky`` emitter (its ``sun_scale`` and ``sky_scale``).

    Attributes
    ----------
    name : str
        The emitter's name (:class:`SceneEmitter`); ``<name>.sun`` and ``<name>.sky`` for the
        parts of a split ``sunsky``.
    emitter : mitsuba.Emitter
        The emitter it belongs to.
    keys : tuple of str
        The ``mi.traverse`` parameters that set its strength.
    weight_key : str or None
        Its emitter's ``sampling_weight`` parameter (None where it has none).
    """

    name: str
    emitter: object
    keys: tuple[str, ...]
    weight_key: str | None = None


def light_parts(mi, scene, *, split_sky: bool = False) -> list[LightPart] | None:
    """The parts of ``scene``'s light (one per emitter; with ``split_sky``, a ``sunsky``'s sun
    and sky apart), or None where an emitter's strength cannot be set (it has no id, or no
    strength parameter)."""
    params = mi.traverse(scene)
    parts = []
    for emitter, name, prefix in _emitter_prefixes(mi, scene):
        keys = _strength_keys(params, prefix) if prefix else []
        if not keys:
            return None
        weight = f"{prefix}sampling_weight" if f"{prefix}sampling_weight" in params.keys() else None
        sun = [k for k in keys if k.endswith(".sun_scale")]
        sky = [k for k in keys if k.endswith(".sky_scale")]
        if split_sky and sun and sky:
            parts += [LightPart(f"{name}.sun", emitter, tuple(sun), weight),
                      LightPart(f"{name}.sky", emitter, tuple(sky), weight)]
        else:
            parts.append(LightPart(name, emitter, tuple(keys), weight))
    return parts


@contextlib.contextmanager
def lit_alone(params, parts: list[LightPart], lit: int):
    """Within the block, only ``parts[lit]`` lights the scene: every other part is dimmed by
    :data:`DIM` (a blackbody cooled to 100 K), and the other emitters' sampling weights are 0 so
    that next-event estimation samples the lit one only (measured: a point light alone beside a
    dimmed one kept a 12 % noise at 64 spp, half its samples spent on the dark one; 0.8 % alone).
    Restores every parameter on leaving."""
    weights = {part.weight_key for part in parts if part.weight_key} - {parts[lit].weight_key}
    original = {k: params[k] if isinstance(params[k], float) else type(params[k])(params[k])
                for k in [k for part in parts for k in part.keys] + sorted(weights)}
    try:
        for index, part in enumerate(parts):
            if index == lit:
                continue
            for key in part.keys:
                params[key] = _COLD_K if key.endswith(".temperature") else original[key] * DIM
        for key in weights:
            params[key] = 0.0
        params.update()
        yield
    finally:
        for key, value in original.items():
            params[key] = value
        params.update()


def _shares(mi, scene, sensor, integrator, emitters) -> list[float] | None:
    """Fraction of the camera's light from each emitter: the scene rendered with each alone
    (the others dimmed by :data:`DIM`) through a small luminance-like film; None where an
    emitter's strength cannot be set (no id, or no strength parameter)."""
    parts = light_parts(mi, scene)
    if parts is None:
        return None
    params = mi.traverse(scene)
    totals = []
    for lit in range(len(parts)):
        with lit_alone(params, parts, lit):
            image = mi.render(scene, sensor=sensor, integrator=integrator, spp=PROBE_SPP, seed=lit)
        totals.append(float(np.asarray(image, dtype=np.float64).sum()))
    for (_, name, _), value in zip(emitters, totals):
        if not np.isfinite(value):  # issue 25 #14: a NaN or overflowing strength read as "give each an id"
            raise _not_finite(name)
    total = sum(totals)
    return [t / total for t in totals] if total > 0 else None


def light_part_spectrum(mi, scene, sensor, part: LightPart) -> np.ndarray:
    """The relative spectral irradiance (max 1, on :data:`LIGHT_GRID_NM`) that ``part`` alone
    sends to the point the camera looks at (as :class:`SceneEmitter`'s ``spectrum``); call it
    inside :func:`lit_alone` for a split ``sunsky``."""
    import drjit as dr

    spectrum = _irradiance_spectrum(mi, dr, scene, part.emitter, visible_surfaces(mi, scene, sensor))
    if not np.all(np.isfinite(spectrum)):
        raise _not_finite(part.name)
    peak = spectrum.max()
    return spectrum / peak if peak > 0 else spectrum


def scene_emitters(config: SceneConfig, *, measure_shares: bool = True, lens=None,
                   variant: str | None = None) -> list[SceneEmitter]:
    """The emitters of ``config``'s XML scene (or sky-lit preset) with their spectra (and,
    when there are several, the share of the camera's light each sends through ``lens``, the
    frame's; default: built from ``config``). ``variant``: the Mitsuba variant already chosen
    (a capture plan's); default: chosen from ``render.variant``.

    Raises
    ------
    ConfigError
        For a preset lit by ``[illuminant]``.
    RenderError
        When Mitsuba cannot load it.
    """
    import drjit as dr
    import mitsuba as mi

    from ..optics import ThinLens
    from ..presets.outdoor import lit_by_sky
    from .scene_dict import build_scene, camera_dict
    from .variants import choose_variant

    if not (config.scene.mitsuba_xml or lit_by_sky(config)):
        raise ConfigError("scene_emitters reads a Mitsuba XML scene (scene.mitsuba_xml) or a preset under the sun "
                          "and sky; other presets are lit by [illuminant]")
    mi.set_variant(choose_variant(config.render.variant) if variant is None else variant)
    lens = ThinLens.from_config(config.lens, config.sensor) if lens is None else lens.layout_lens
    width = PROBE_SIZE[0]
    height = max(1, round(width * lens.height_px / lens.width_px))
    probe = replace(lens, width_px=width, height_px=height, frame_lens=lens.layout_lens)  # same view
    film = {"type": "specfilm", "width": width, "height": height, "rfilter": {"type": "box"},
            "visible": {"type": "spectrum", "value": [(400.0, 1.0), (700.0, 1.0)]}}
    camera = camera_dict(mi, probe, "pinhole", film, PROBE_SPP)
    # clouds pass the sun's light on in its own spectrum: probed as occluders they would balance a
    # frame in a cloud's shadow for the blue sky alone (presets/clouds.py)
    clear = config.replace(**{"sky.cloud_cover": 0.0})
    scene, sensor, integrator = build_scene(mi, clear, probe, camera, {"type": "path", "max_depth": config.render.max_depth})
    found = _emitter_prefixes(mi, scene)
    if not found:
        return []
    params = mi.traverse(scene)
    surfaces = visible_surfaces(mi, scene, sensor)
    emitters = []
    for emitter, name, prefix in found:
        spectrum = _irradiance_spectrum(mi, dr, scene, emitter, surfaces)
        peak = spectrum.max()
        if not np.all(np.isfinite(spectrum)):  # NaN or infinite strength: named, not divided (issue 25 #14)
            raise _not_finite(name)
        emitters.append(SceneEmitter(name, str(emitter).split("[")[0].strip(),
                                     spectrum / peak if peak > 0 else spectrum, _temperature(params, prefix)))
    if measure_shares and len(found) > 1:
        shares = _shares(mi, scene, sensor, integrator, found)
        if shares is not None:
            emitters = [replace(e, share=s) for e, s in zip(emitters, shares)]
    return emitters


def _spectrum_csv(emitter: SceneEmitter) -> str:
    """A CSV of the emitter's spectrum in the cache folder, named by its content."""
    from .variants import probe_cache_path

    text = "wavelength_nm,relative_power\n" + "".join(
        f"{w:g},{v:.9g}\n" for w, v in zip(LIGHT_GRID_NM, emitter.spectrum))
    folder = probe_cache_path().parent / "scene_lights"
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{hashlib.sha256(text.encode()).hexdigest()[:16]}.csv"
    if not path.exists():
        from ..io import atomic_path

        with atomic_path(path) as temporary:
            temporary.write_text(text)
    return str(path)


def resolve_light(config: SceneConfig, *, lens=None, variant: str | None = None) -> tuple[SceneConfig, dict]:
    """The scene with ``illuminant.spd`` set to the light that lights it, and a record of the
    choice (for meta.json's ``model_decisions["illuminant"]``).

    A preset keeps ``[illuminant]`` (``"auto"`` is D65), except one under the sun and sky,
    which is read as an XML scene is. An XML scene with ``spd = "auto"`` takes
    its emitter's spectrum (``illuminant.emitter``, else the one sending the camera most
    light) and names that emitter in ``illuminant.emitter``; with ``spd`` set and no
    ``emitter``, it keeps ``spd`` and warns (:class:`~spectral_cam.errors.SceneWarning`) that
    the emitters light the scene, not ``[illuminant]``; with both set (a scene resolved
    before) it keeps both.

    Raises
    ------
    ConfigError
        ``illuminant.emitter`` names no emitter of the scene (the message lists them), or an
        XML scene has no emitter and ``spd = "auto"``.
    """
    from ..presets.outdoor import lit_by_sky

    spd, chosen_name = config.illuminant.spd, config.illuminant.emitter
    where = config.scene.mitsuba_xml or f"preset {config.scene.preset!r} under the sun and sky"
    if not config.scene.mitsuba_xml and not lit_by_sky(config):
        if chosen_name:
            raise ConfigError(f"illuminant.emitter = {chosen_name!r} names an emitter of an XML scene; the preset "
                              f"{config.scene.preset!r} is lit by [illuminant] spd and illuminance_lux")
        if spd == "auto":
            return config.replace(**{"illuminant.spd": "D65"}), {"choice": "D65", "reason": "the preset's light "
                                                                 "(illuminant.spd = 'auto')"}
        return config, {"choice": spd, "reason": "illuminant.spd"}
    if spd != "auto" and chosen_name:  # resolved before (a re-render, a resolved scene.toml)
        return config, {"choice": spd, "emitter": chosen_name, "reason": "resolved from the scene's emitter earlier"}
    if spd != "auto":
        warnings.warn(f"illuminant.spd = {spd!r} does not light the scene {where} (its "
                      f"emitters do); white balance, the colour matrix and the ground truth use {spd!r} as "
                      "asked. Leave [illuminant] unset to use the scene's own light.", SceneWarning, stacklevel=2)
        return config, {"choice": spd, "reason": "illuminant.spd set for a scene its emitters light (warned)"}
    emitters = scene_emitters(config, lens=lens, variant=variant)
    if not emitters:
        raise ConfigError(f"the XML scene {where} has no emitter, so nothing lights it: add one (an XML scene is "
                          "lit by its own emitters; illuminant.spd only names the light its ground truth assumes)")
    names = [e.name for e in emitters]
    if chosen_name:
        if chosen_name not in names:
            raise ConfigError(f"illuminant.emitter = {chosen_name!r} is not an emitter of {where}; "
                              f"its emitters: {', '.join(names)}")
        chosen, reason = emitters[names.index(chosen_name)], "illuminant.emitter"
    elif len(emitters) == 1:
        chosen, reason = emitters[0], "the scene's only emitter"
    elif all(e.share is not None for e in emitters):
        chosen = max(emitters, key=lambda e: e.share)
        reason = f"sends the camera {100 * chosen.share:.0f} % of its light (each emitter rendered alone)"
    else:
        raise ConfigError(f"the scene {where} has {len(emitters)} emitters whose shares of "
                          f"the light cannot be measured (give each an id); choose one with illuminant.emitter: "
                          f"{', '.join(names)}")
    if chosen.temperature_k is not None:
        resolved = f"blackbody:{chosen.temperature_k:g}"
    else:
        resolved = _spectrum_csv(chosen)
    record = {"choice": resolved, "emitter": chosen.name, "plugin": chosen.plugin, "reason": reason,
              "method": LIGHT_METHOD,
              "emitters": {e.name: {"plugin": e.plugin, "share": e.share, "temperature_k": e.temperature_k}
                           for e in emitters}}
    if not np.any(chosen.spectrum > 0):
        raise RenderError(f"emitter {chosen.name!r} sends no light to what the camera looks at; choose another "
                          f"with illuminant.emitter ({', '.join(names)})")
    return config.replace(**{"illuminant.spd": resolved, "illuminant.emitter": chosen.name}), record

