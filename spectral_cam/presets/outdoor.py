"""What the outdoor presets (``tabletop``, ``vegetation``) share: a camera looking down at the
ground, and their light — Mitsuba's ``sunsky`` at ``[sky]``'s date, time and place, or a lamp
of ``[illuminant]``'s spectrum.

Ground frame: origin at the ground point the camera looks at, x east, y north, z up (metres).
The camera stands ``scene.distance_m`` from that point along its view, which has the compass
heading ``sky.heading_deg`` and the pitch ``scene.view_pitch_deg`` (< 0 down); presets place
objects in the ground frame and :class:`GroundView` maps them into the camera frame every
preset uses (camera at the origin, view +z, +y up, +x image-left).

Mitsuba's ``sunsky`` takes its ``sun_direction`` in world coordinates and its ``to_world`` as
the frame whose +z is up (measured on 3.9.1: with ``to_world`` turning +z to +y the sun stands
along the given world vector). Its radiance is absolute (W m⁻² sr⁻¹ nm⁻¹: a sun 65° high gives
about 1.5 W m⁻² nm⁻¹ at 550 nm on the ground), and zero outside 320–720 nm, where the
Hosek–Wilkie tables end.

References
----------
.. [1] Hosek, L., & Wilkie, A. (2012). An analytic model for full spectral sky-dome radiance.
   ACM Transactions on Graphics 31(4), 95; Mitsuba 3, plugin ``sunsky``.
.. [2] Howell, J. R., A Catalog of Radiation Heat Transfer Configuration Factors, C-11
   (a rectangle parallel to a point's surface, the lamp's irradiance).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..solar import enu_to_camera, sun_position
from .common import light_irradiance, reads_light, spectrum_dict
from .relief import GroundRelief, ReliefBSDF, cell_texels, displaced_ground

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

#: Presets lit by the sun and sky when ``scene.light = "auto"``.
OUTDOOR_LIGHT_DEFAULT = "sunsky"
#: Side of the square ground plane around the look point (m): beyond the horizon of any view.
GROUND_SIZE_M = 400.0
#: The indoor lamp: a square area light this many metres on a side, this high over the look point.
LAMP_SIDE_M, LAMP_HEIGHT_M = 0.8, 1.6


@dataclass(frozen=True)
class GroundView:
    """The camera over the ground: ``rotation`` takes ground (east, north, up) vectors into the
    camera frame, ``camera_m`` is the camera's position in the ground frame."""

    rotation: np.ndarray
    camera_m: np.ndarray

    @classmethod
    def from_config(cls, config: "SceneConfig") -> "GroundView":
        rotation = enu_to_camera(config.sky.heading_deg, config.scene.view_pitch_deg)
        view = rotation.T @ np.array([0.0, 0.0, 1.0])  # the view direction in ground coordinates
        return cls(rotation, -config.scene.distance_m * view)

    @property
    def height_m(self) -> float:
        return float(self.camera_m[2])

    def to_camera(self, points_m) -> np.ndarray:
        """Ground-frame points (…, 3) in camera coordinates."""
        return (np.asarray(points_m, dtype=float) - self.camera_m) @ self.rotation.T

    def transform(self, mi, local=None):
        """A Mitsuba transform placing a ground-frame object (``local``: its own transform in
        the ground frame) in the camera frame."""
        matrix = np.eye(4)
        matrix[:3, :3] = self.rotation
        matrix[:3, 3] = -self.rotation @ self.camera_m
        placed = mi.ScalarTransform4f(matrix)
        return placed @ local if local is not None else placed


def view_width_m(config: "SceneConfig", lens: "ThinLens") -> float:
    """Width of the field of view at the look point (m)."""
    return lens.sensor_width_m * config.scene.distance_m / lens.image_distance_m


def ground_point_in_frame(view: GroundView, lens: "ThinLens", rng, height_m: float, margin: float):
    """Where a ray through a uniformly drawn point of the frame's middle ``margin`` (a
    fraction of its width and height) meets the plane ``height_m`` above the ground (None
    above the horizon)."""
    half_x = margin * lens.sensor_width_m / (2 * lens.image_distance_m)
    half_y = margin * lens.sensor_height_m / (2 * lens.image_distance_m)
    direction = view.rotation.T @ np.array([rng.uniform(-half_x, half_x), rng.uniform(-half_y, half_y), 1.0])
    if direction[2] >= 0:
        return None
    t = (height_m - view.camera_m[2]) / direction[2]
    return view.camera_m + t * direction if t > 0 else None


def scatter_on_ground(config: "SceneConfig", lens: "ThinLens", rng, *, margin: float, spacing: float,
                      centre_height: float, noun: str, reserved=()):
    """Yield (east, north, size) of ``scene.object_count`` things on the ground, one at a time
    (the caller may draw more from ``rng`` between them): each size a fraction
    ``scene.object_size`` of the view's width, each centre (``centre_height`` × size above the
    ground) where a ray through a uniformly drawn point of the frame's middle ``margin`` meets
    that height, no farther than 3·``distance_m`` and no nearer to another than ``spacing`` × the
    sum of their sizes (1000 tries each).

    Raises
    ------
    ConfigError
        When the next one does not fit (the message names ``noun`` and the remedy).
    """
    from ..errors import ConfigError

    s = config.scene
    view = GroundView.from_config(config)
    width = view_width_m(config, lens)
    placed: list[tuple[float, float, float]] = [tuple(r) for r in reserved]  # kept clear (a chart)
    for n in range(s.object_count):
        size = width * rng.uniform(*s.object_size)
        for _ in range(1000):
            point = ground_point_in_frame(view, lens, rng, centre_height * size, margin)
            if point is None or np.hypot(*point[:2]) > 3 * s.distance_m:
                continue
            if all(math.hypot(point[0] - e, point[1] - nn) > spacing * (size + z) for e, nn, z in placed):
                break
        else:
            raise ConfigError(f"scene.object_count = {s.object_count}: only {n} {noun} of "
                              f"{s.object_size[0]:g}–{s.object_size[1]:g} of the view's width fit; lower "
                              "scene.object_count or scene.object_size")
        placed.append((float(point[0]), float(point[1]), float(size)))
        yield placed[-1]


def light_kind(config: "SceneConfig") -> str:
    """``"sunsky"`` or ``"illuminant"``: how an outdoor preset is lit."""
    return OUTDOOR_LIGHT_DEFAULT if config.scene.light == "auto" else config.scene.light


def lit_by_sky(config: "SceneConfig") -> bool:
    """Whether ``config`` is a preset lit by Mitsuba's sun and sky (its light is read from the
    render like an XML scene's emitters, :mod:`spectral_cam.render.lights`)."""
    return (not config.scene.mitsuba_xml and reads_light(config.scene.preset)
            and light_kind(config) in ("sunsky", "overcast"))


def sunsky(config: "SceneConfig", view: GroundView, mi) -> dict:
    """Mitsuba's sun and sky with the sun where NOAA puts it and the sky's zenith up."""
    from ..errors import ConfigError

    sky = config.sky
    sun = sun_position(sky.date, sky.hour, utc_offset_h=sky.utc_offset_h, latitude_deg=sky.latitude_deg,
                       longitude_deg=sky.longitude_deg)
    if sun.elevation_deg <= 0.0:
        raise ConfigError(f"the sun is {-sun.elevation_deg:.1f}° below the horizon at {sky.date} {sky.hour:g} h "
                          f"(UTC{sky.utc_offset_h:+g}) at {sky.latitude_deg:g}° N, {sky.longitude_deg:g}° E, so the "
                          "sky model has no light; choose a daytime sky.hour, or scene.light = \"illuminant\"")
    up = view.rotation @ np.array([0.0, 0.0, 1.0])
    east = view.rotation @ np.array([1.0, 0.0, 0.0])
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = east, np.cross(up, east), up  # local +z is up
    return {"type": "sunsky", "to_world": mi.ScalarTransform4f(frame), "turbidity": float(sky.turbidity),
            "sun_direction": [float(v) for v in view.rotation @ sun.direction_enu()]}


def lamp_irradiance_factor(half_side_m: float, height_m: float) -> float:
    """E/L under the centre of a square Lambertian emitter parallel to the ground:
    4·A/√(1+A²)·atan(A/√(1+A²)) with A = half side / height (sr; → side²/height² when small)."""
    a = half_side_m / height_m
    return 4.0 * a / math.sqrt(1 + a * a) * math.atan(a / math.sqrt(1 + a * a))


def overhead_lamp(config: "SceneConfig", view: GroundView, mi, bsdf: dict) -> dict:
    """A square area light of ``[illuminant]``'s spectrum over the look point, its radiance set
    so the ground under its centre receives ``illuminance_lux``."""
    wavelengths, irradiance = light_irradiance(config)
    radiance = irradiance / lamp_irradiance_factor(LAMP_SIDE_M / 2, LAMP_HEIGHT_M)
    local = (mi.ScalarTransform4f().translate([0.0, 0.0, LAMP_HEIGHT_M]).rotate([1, 0, 0], 180.0)
             .scale([LAMP_SIDE_M / 2, LAMP_SIDE_M / 2, 1.0]))  # facing down
    return {"type": "rectangle", "to_world": view.transform(mi, local), "bsdf": bsdf,
            "emitter": {"type": "area", "radiance": spectrum_dict((wavelengths, radiance))}}


#: Rows of the overcast sky's latitude–longitude map (twice as many columns).
OVERCAST_ROWS = 256


def overcast_radiance(zenith_deg) -> np.ndarray:
    """The CIE standard overcast sky's relative radiance L(θ)/L_z = (1 + 2·cos θ)/3 (0 below
    the horizon); its horizontal irradiance is (7π/9)·L_z.

    References
    ----------
    .. [1] Moon, P., & Spencer, D. E. (1942). Illumination from a non-uniform sky. Illuminating
       Engineering 37, 707–726; CIE S 011/E:2003, type 1 (CIE standard overcast sky).
    """
    cos = np.cos(np.radians(np.asarray(zenith_deg, dtype=float)))
    return np.where(cos > 0, (1.0 + 2.0 * cos) / 3.0, 0.0)


def overcast_sky(config: "SceneConfig", view: GroundView, mi) -> dict:
    """The CIE standard overcast sky, no sun, D65 in spectrum, as an ``envmap`` whose zenith
    radiance gives ``illuminant.illuminance_lux`` on the ground: L_z(λ) = 9·E(λ)/(7π), E the
    D65 irradiance of that illuminance (the map's rows are zenith angles; its +y is up)."""
    from .. import spectra

    rows = OVERCAST_ROWS
    zenith = (np.arange(rows) + 0.5) * 180.0 / rows
    wl, irradiance = spectra.absolute_irradiance("D65", config.illuminant.illuminance_lux)
    d65 = float(spectra.sample(spectra.illuminant("D65"), np.array([560.0]))[0])
    e560 = float(np.interp(560.0, wl, irradiance))
    # a grey RGB emitter in a spectral variant is CIE D65 × MI_CIE_D65_NORMALIZATION (1/99) × its value
    value = 9.0 * e560 / (7.0 * np.pi) / (float(mi.MI_CIE_D65_NORMALIZATION) * d65)
    grid = np.repeat((value * overcast_radiance(zenith))[:, None], 2 * rows, axis=1)
    bitmap = np.repeat(grid[..., None], 3, axis=-1).astype(np.float32)
    up = view.rotation @ np.array([0.0, 0.0, 1.0])
    east = view.rotation @ np.array([1.0, 0.0, 0.0])
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = east, up, np.cross(east, up)  # the map's +y is up
    return {"type": "envmap", "bitmap": mi.Bitmap(bitmap), "to_world": mi.ScalarTransform4f(frame)}


def light(config: "SceneConfig", view: GroundView, mi) -> dict:
    """The preset's light as scene-dict entries."""
    if light_kind(config) == "sunsky":
        from .clouds import cloud_layer

        return {"sky": sunsky(config, view, mi), **cloud_layer(config, view, mi)}
    if light_kind(config) == "overcast":
        return {"sky": overcast_sky(config, view, mi)}
    black = {"type": "diffuse", "reflectance": {"type": "uniform", "value": 0.0}}
    return {"lamp": overhead_lamp(config, view, mi, black)}


#: Texels on a side of a textured ground's colours and of its height map, the share of it covered
#: by leaf litter (dry grass and leaves), and its relief: the clods' size (texels of the height
#: map) and rms slope (rise per run, on bare dry soil; :func:`spectral_cam.textures.ground_maps`).
GROUND_TEXELS, GROUND_RELIEF_TEXELS, GROUND_LITTER_COVER = 1024, 2048, 0.15
GROUND_CLOD_TEXELS, GROUND_RELIEF = 16.0, 0.6
#: A textured ground spans this many view widths around the look point (mirrored beyond).
GROUND_TEXTURE_VIEWS = 3.0


def ground_texels(lens: "ThinLens") -> tuple[int, int]:
    """Texels on a side of a textured ground's colours and of its height map for this frame: the
    power of two that gives about 0.7 colour texel and 1.4 height texels a pixel at the look point
    (a 480-px frame: :data:`GROUND_TEXELS` and :data:`GROUND_RELIEF_TEXELS`, the most), at least
    128 and 256. The fields' periods are fractions of the texture, so a smaller frame samples the
    same patches coarser; its clods, :data:`GROUND_CLOD_TEXELS` texels, stay at the pixel scale.
    A 32-px test frame built 2048² fields for 2.4 s a layout."""
    wanted = lens.width_px * GROUND_TEXELS / 480.0  # 1024 colour texels over 3 view widths of 480 px
    colour = int(min(GROUND_TEXELS, max(128, 2 ** math.ceil(math.log2(max(wanted, 1.0))))))
    return colour, int(min(GROUND_RELIEF_TEXELS, 2 * colour))


def ground_moisture(config: "SceneConfig") -> float:
    """The share of a textured ground that is wet, drawn by ``layout_seed`` uniformly over
    :data:`spectral_cam.textures.MOISTURE_SHARE`."""
    from ..textures import MOISTURE_SHARE

    rng = np.random.default_rng(np.random.SeedSequence([int(config.scene.layout_seed), 0x3E7]))
    return float(rng.uniform(*MOISTURE_SHARE))


def textured_ground_bsdf(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """The ground as a mixture of measured spectra: the samples of ``scene.soil_reflectances``
    and leaf litter (the USGS dry grass and dry oak leaf) in patches and grains of fractal
    noise, wet in the hollows (each soil's wet spectrum by
    :func:`spectral_cam.soil_moisture.wet_reflectance`, over :func:`ground_moisture` of the
    ground; a sample measured wet and the litter are left as they are), with clods, cracks and hollows as a bump map
    of the same fields (:func:`spectral_cam.textures.ground_maps`); drawn by ``layout_seed``.
    The texture spans :data:`GROUND_TEXTURE_VIEWS` view widths around the look point,
    :func:`ground_texels` on a side (about a pixel each at the look point; its height map twice
    as many), mirrored beyond; the bump map's scale is a height-map texel
    in metres (its heights are in texels), so the relief's slopes are the same in every view.
    Returned as a :class:`~spectral_cam.presets.relief.ReliefBSDF` carrying that height map, so
    that :func:`ground` displaces the ground by it where the frame sees it (micro-shadows).

    References
    ----------
    .. [1] Keshava, N., & Mustard, J. F. (2002). IEEE Signal Processing Magazine 19(1), 44–57.
    .. [2] Lekner, J., & Dorf, M. C. (1988). Applied Optics 27(7), 1278–1280.
    """
    from ..reflectance_sets import reflectance_set
    from ..soil_moisture import wet_spectrum
    from ..textures import ground_maps
    from .common import mixed_bsdf

    soil_set = reflectance_set(config.scene.soil_reflectances)
    plants = reflectance_set("usgs_vegetation")
    names = list(soil_set.names)
    litter = [sd for name, sd in zip(plants.names, plants.sds) if name.startswith("dry")]
    endmembers = list(soil_set.sds) + litter
    names += [n for n in plants.names if n.startswith("dry")]
    covers = ([(1 - GROUND_LITTER_COVER) / len(soil_set.sds)] * len(soil_set.sds)
              + [GROUND_LITTER_COVER / len(litter)] * len(litter))
    seed = int(config.scene.layout_seed)
    texels, relief_texels = ground_texels(lens)
    abundances, wetness, height = ground_maps(
        texels, covers, period_px=texels / 4, seed=seed,
        litter=range(len(soil_set.sds), len(endmembers)), moisture=ground_moisture(config),
        relief_size=relief_texels, clod_period_px=GROUND_CLOD_TEXELS, slope=GROUND_RELIEF)
    # the soils get wet twins, the litter not: dry grass and leaves on wet soil darken less, and
    # each twin is one more level of the blend tree every ray's kernel evaluates
    wettable = [k for k, name in enumerate(names[:len(soil_set.sds)]) if "wet" not in name.lower()]
    maps = [a * (1.0 - wetness) if k in wettable else a for k, a in enumerate(abundances)]
    maps += [abundances[k] * wetness for k in wettable] if wetness.any() else []
    spectra = endmembers + ([wet_spectrum(endmembers[k]) for k in wettable] if wetness.any() else [])
    texel_m = GROUND_TEXTURE_VIEWS * view_width_m(config, lens) / relief_texels
    bsdf = mixed_bsdf(mi, spectra, np.stack(maps), to_uv=_texture_uv(config, lens, mi), height=np.array(height),
                      bump_scale=texel_m)
    tan_half = (lens.sensor_width_m / (2 * lens.image_distance_m), lens.sensor_height_m / (2 * lens.image_distance_m))
    return ReliefBSDF(bsdf, GroundRelief(height, texel_m, band_texels=GROUND_CLOD_TEXELS, tan_half=tan_half,
                                         cell=cell_texels(relief_texels, lens.width_px, GROUND_TEXTURE_VIEWS)))


def _texture_uv(config: "SceneConfig", lens: "ThinLens", mi, turn_deg: float = 0.0):
    """The ground square's texture coordinates mapped onto a texture spanning
    :data:`GROUND_TEXTURE_VIEWS` view widths around the look point (uv 0.5), turned by
    ``turn_deg`` about it."""
    scale = GROUND_SIZE_M / (GROUND_TEXTURE_VIEWS * view_width_m(config, lens))
    return (mi.ScalarTransform4f().translate([0.5, 0.5, 0.0]).rotate([0, 0, 1], turn_deg)
            .scale([scale, scale, 1.0]).translate([-0.5, -0.5, 0.0]))


def table_bsdf(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """A wooden table top: the USGS pine woods mixed in long streaks of grain along the view's
    width (:func:`spectral_cam.textures.grain_maps`), spanning :data:`GROUND_TEXTURE_VIEWS`
    view widths, mirrored beyond."""
    from ..reflectance_sets import reflectance_set
    from ..textures import grain_maps
    from .common import mixed_bsdf

    woods = list(reflectance_set("usgs_wood").sds)
    maps = grain_maps(GROUND_TEXELS, [1.0] * len(woods), period_px=GROUND_TEXELS / 8, stretch=12.0,
                      seed=int(config.scene.layout_seed))
    return mixed_bsdf(mi, woods, maps, to_uv=_texture_uv(config, lens, mi, -config.sky.heading_deg))


def backdrop(config: "SceneConfig", lens: "ThinLens", mi, view: GroundView) -> dict:
    """A wall behind the table: a vertical plane 1.5 view widths beyond the look point, across
    the view and as high as the view reaches there, of the USGS stones (limestone, basalt,
    concrete) in fractal patches: a room's wall instead of a void."""
    from ..reflectance_sets import reflectance_set
    from ..textures import abundance_maps
    from .common import mixed_bsdf

    width = view_width_m(config, lens)
    h = math.radians(config.sky.heading_deg)
    ahead = np.array([math.sin(h), math.cos(h), 0.0])
    right = np.array([math.cos(h), -math.sin(h), 0.0])
    centre = 1.5 * width * ahead
    half_w, half_h = 4.0 * width, 4.0 * width
    frame = np.eye(4)
    frame[:3, 0], frame[:3, 1], frame[:3, 2] = right * half_w, np.array([0.0, 0.0, half_h]), -ahead
    frame[:3, 3] = centre + np.array([0.0, 0.0, half_h])
    stones = list(reflectance_set("usgs_stone").sds)
    maps = abundance_maps(GROUND_TEXELS // 2, [1.0] * len(stones), period_px=GROUND_TEXELS / 8,
                          seed=int(config.scene.layout_seed) + 17)
    return {"backdrop": {"type": "rectangle", "bsdf": mixed_bsdf(mi, stones, maps),
                         "to_world": view.transform(mi, mi.ScalarTransform4f(frame))}}


def ground(view: GroundView, mi, bsdf: dict):
    """The ground plane (z = 0 in the ground frame), :data:`GROUND_SIZE_M` on a side; a
    textured ground's (:func:`textured_ground_bsdf`, which carries its relief) as one mesh,
    displaced by its relief where the frame sees it (:func:`spectral_cam.presets.relief.displaced_ground`)."""
    half = GROUND_SIZE_M / 2
    if isinstance(bsdf, ReliefBSDF):
        return displaced_ground(view, mi, bsdf, half)
    return {"type": "rectangle", "to_world": view.transform(mi, mi.ScalarTransform4f().scale([half, half, 1.0])),
            "bsdf": bsdf}


#: The far ground reaches this far (m): to the horizon of any view (a ray 0.003° below it).
FAR_GROUND_M = 20000.0
#: Distant terrain (:func:`terrain`): a ring of hills from ``TERRAIN_RANGE_M[0]`` to
#: ``[1]`` metres out, at most ``TERRAIN_HEIGHT_M`` high (a crest 2–3 km out rises up to 3° over the
#: horizon, below any sun high enough to light a scene), its azimuth steps ``TERRAIN_STEP_DEG``
#: within 60° of the view's heading (coarser behind) and ``TERRAIN_RINGS`` rings: about 3000 triangles.
TERRAIN_RANGE_M, TERRAIN_HEIGHT_M, TERRAIN_STEP_DEG, TERRAIN_RINGS = (900.0, 6000.0), 150.0, 1.0, 12


def terrain_heights(east_m, north_m, seed: int = 0) -> np.ndarray:
    """Heights (m) of the distant hills at ground-frame points: OpenSimplex fBm of a 2.5-km
    period (4 octaves), positive part, under an envelope rising from 0 at the ring's inner edge
    to :data:`TERRAIN_HEIGHT_M` 1.5 km farther out; 0 inside :data:`TERRAIN_RANGE_M`."""
    from opensimplex import OpenSimplex

    x, y = np.asarray(east_m, dtype=np.float64), np.asarray(north_m, dtype=np.float64)
    noise = OpenSimplex(seed=int(seed) + 7877)
    field = np.zeros_like(x)
    amplitude, period = 1.0, 2500.0
    for octave in range(4):
        field += amplitude * np.vectorize(noise.noise2)(x / period + 13.1 * octave, y / period - 7.7 * octave)
        amplitude, period = amplitude * 0.5, period / 2.0
    r = np.hypot(x, y)
    envelope = np.clip((r - TERRAIN_RANGE_M[0]) / 1500.0, 0.0, 1.0)
    envelope = envelope * envelope * (3 - 2 * envelope)
    return TERRAIN_HEIGHT_M * envelope * np.clip(0.35 + field, 0.0, None) / 1.2


def terrain_mesh(view: GroundView, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Vertices (ground frame), faces (facing up) and texture coordinates of the ring of hills
    around the look point: azimuth steps of :data:`TERRAIN_STEP_DEG` within 60° of the view's
    heading, growing to 10° behind it, :data:`TERRAIN_RINGS` rings spaced geometrically over
    :data:`TERRAIN_RANGE_M`; each vertex 1 m lower than its hill so that the ring's flat edges sink
    under the far ground instead of fighting with it."""
    view_dir = view.rotation.T @ np.array([0.0, 0.0, 1.0])
    heading = math.atan2(view_dir[0], view_dir[1])  # from north towards east
    steps, a = [], 0.0
    while a < 2 * math.pi - 1e-9:
        steps.append(a)
        off = min(a, 2 * math.pi - a)  # angular distance from the heading
        a += math.radians(TERRAIN_STEP_DEG if off < math.radians(60) else min(10.0, TERRAIN_STEP_DEG + (off - math.radians(60)) * 12))
    azimuth = heading + np.array(steps)
    radii = np.geomspace(*TERRAIN_RANGE_M, TERRAIN_RINGS)
    az, rr = np.meshgrid(azimuth, radii, indexing="ij")  # (A, R)
    east, north = rr * np.sin(az), rr * np.cos(az)
    up = terrain_heights(east, north, seed) - 1.0
    vertices = np.stack([east, north, up], axis=-1).reshape(-1, 3)
    n_a, n_r = az.shape
    idx = np.arange(n_a * n_r).reshape(n_a, n_r)
    nxt = np.roll(idx, -1, axis=0)  # the ring closes
    v00, v01, v10, v11 = idx[:, :-1], idx[:, 1:], nxt[:, :-1], nxt[:, 1:]
    # azimuth grows clockwise seen from above (east of north): (outward, clockwise) faces down, so reverse
    faces = np.concatenate([np.stack([v00, v11, v01], -1).reshape(-1, 3), np.stack([v00, v10, v11], -1).reshape(-1, 3)])
    texcoords = np.stack([east / (2 * TERRAIN_RANGE_M[1]) + 0.5, north / (2 * TERRAIN_RANGE_M[1]) + 0.5], -1).reshape(-1, 2)
    return vertices, faces, texcoords


#: The hills' cover: green grass and pasture, dry grass, woods (leaves at half their reflectance:
#: a canopy's shadows) and bare soil, their shares drawn per seed.
TERRAIN_TEXELS, TERRAIN_CANOPY_SHADE = 512, 0.5


def terrain(view: GroundView, mi, seed: int = 0) -> dict:
    """The ring of hills (:func:`terrain_mesh`) as a mesh of a mixture of vegetation and soil
    spectra (:func:`spectral_cam.textures.abundance_maps`, fields of ~600 m): the horizon of
    a wide view is a line of hills, not the far ground's ruler-straight edge."""
    from ..reflectance_sets import reflectance_set
    from ..spectrum import Spectrum
    from ..textures import abundance_maps
    from .common import mixed_bsdf
    from .meshes import mitsuba_mesh

    plants, soils = reflectance_set("usgs_vegetation"), reflectance_set("usgs_soils")
    by_name = dict(zip(plants.names, plants.sds))
    oak = by_name["green_oak_leaf1_fresh_ASD"]
    woods = Spectrum(oak.wavelengths, TERRAIN_CANOPY_SHADE * np.asarray(oak.values), "canopy")
    endmembers = [by_name["green_lawn_grass_GDS91_BECK"], by_name["dry_grass_golden_dry_GDS480_ASD"], woods,
                  soils.sds[-1]]
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x7E77A]))
    covers = rng.dirichlet([3.0, 1.5, 2.0, 0.5]) + 0.02
    maps = abundance_maps(TERRAIN_TEXELS, covers, period_px=TERRAIN_TEXELS / 16, seed=int(seed) + 31337)
    vertices, faces, texcoords = terrain_mesh(view, seed)
    return {"terrain": mitsuba_mesh(mi, "terrain", vertices, faces, mixed_bsdf(mi, endmembers, np.array(maps)),
                                    view.transform(mi), texcoords=texcoords)}


def far_ground(view: GroundView, mi, bsdf: dict, *, seed: int = 0, hills: bool = True) -> dict:
    """Four strips on z = 0 around the ground square, out to :data:`FAR_GROUND_M`: the ground to
    the horizon (the square ends 200 m out, which left a black band under the horizon), in the
    same plane without overlapping it (no z-fighting), kept apart from the textured square
    whose texture coordinates need its small extent for float precision; and with ``hills``, the
    ring of distant hills of ``seed`` (:func:`terrain`) standing on them."""
    near, far = GROUND_SIZE_M / 2, FAR_GROUND_M
    strips = {"north": ((0.0, (near + far) / 2), (far, (far - near) / 2)),
              "south": ((0.0, -(near + far) / 2), (far, (far - near) / 2)),
              "east": (((near + far) / 2, 0.0), ((far - near) / 2, near)),
              "west": ((-(near + far) / 2, 0.0), ((far - near) / 2, near))}
    entries = {f"ground_far_{side}": {
        "type": "rectangle", "bsdf": bsdf,
        "to_world": view.transform(mi, mi.ScalarTransform4f().translate([cx, cy, 0.0]).scale([hx, hy, 1.0]))}
        for side, ((cx, cy), (hx, hy)) in strips.items()}
    if hills:
        entries.update(terrain(view, mi, seed))
    return entries
