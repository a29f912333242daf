"""The room's materials (:mod:`spectral_cam.presets.room`): samples of a reflectance set drawn
by their CIELAB lightness and chroma, the procedural patterns its textured surfaces mix
measured spectra with (floor boards, a twill tartan, a rug), and the builders of their
Mitsuba scene-dict BSDFs.

A builder takes its drawn parameters first and the ``mitsuba`` module last, so a layout binds
the parameters (``functools.partial``) and :func:`~spectral_cam.presets.room.room` loads each
material once, when Mitsuba is ready. Every BSDF is two-sided (the room's meshes are seen from
both sides of their faces).

References
----------
.. [1] Keshava, N., & Mustard, J. F. (2002). Spectral unmixing. IEEE Signal Processing
   Magazine 19(1), 44–57 (linear mixing of measured spectra).
.. [2] CIE 15:2004, Colorimetry, §8.2.1 (CIELAB).
.. [3] Palik, E. D. (1985). Handbook of Optical Constants of Solids (Mitsuba's conductors).
"""

from __future__ import annotations

import functools

import numpy as np

from .. import spectra
from .common import mixed_bsdf, reflectance_spectrum

#: Textures: texels on a side and the metres they span.
FLOOR_TEXELS, FLOOR_SPAN_M = 1024, 6.4
WALL_TEXELS, WALL_SPAN_M = 512, 3.0
FABRIC_TEXELS, FABRIC_SPAN_M = 512, 0.512
CONDUCTOR_METALS = ("Al", "Cu", "Au")


# ----------------------------------------------------------------------------- samples
def scaled(sd, factor: float = 1.0, power: float = 1.0, name: str = ""):
    """``sd`` clipped to [1e-4, 1], raised to ``power`` (a stain: absorbance × power, Beer–Lambert)
    and times ``factor`` (a darker copy)."""
    values = np.clip(np.asarray(sd.values, float), 1e-4, 1.0) ** power * factor
    return spectra.Spectrum(sd.wavelengths, values, name or sd.name)


@functools.lru_cache(maxsize=8)
def _lab(set_name: str) -> np.ndarray:
    """CIELAB (D65) of every sample of a reflectance set."""
    from ..colour_ground_truth import illuminant_white_xyz, reflectance_xyz
    from ..reflectance_sets import reflectance_set

    xyz = reflectance_xyz("D65", list(reflectance_set(set_name).sds)) / illuminant_white_xyz("D65")
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[:, 1] - 16, 500 * (f[:, 0] - f[:, 1]), 200 * (f[:, 1] - f[:, 2])], axis=1)


def pick(rng, set_name: str, lightness, chroma_min=0.0, chroma_max=200.0, exclude=()):
    """Index of a sample of the set whose L* and C* (D65) lie in the given ranges (the nearest
    in L* when none does)."""
    lab = _lab(set_name)
    chroma = np.hypot(lab[:, 1], lab[:, 2])
    ok = ((lab[:, 0] >= lightness[0]) & (lab[:, 0] <= lightness[1]) & (chroma >= chroma_min)
          & (chroma <= chroma_max))
    ok[list(exclude)] = False
    candidates = np.flatnonzero(ok)
    if candidates.size == 0:
        return int(np.argmin(np.abs(lab[:, 0] - np.mean(lightness))))
    return int(rng.choice(candidates))


# ----------------------------------------------------------------------------- patterns
@functools.lru_cache(maxsize=4)
def floor_abundances(seed: int, stain: float) -> np.ndarray:
    """Abundances (5, N, N) of the floor's endmembers — pine beam, pine plywood, both stained,
    the joints — over :data:`FLOOR_SPAN_M`; boards run along axis 0 (v, north)."""
    from ..textures import grain_maps

    n = FLOOR_TEXELS
    texel = FLOOR_SPAN_M / n
    grain = grain_maps(n, [1.0, 1.0], period_px=n / 8, stretch=12.0, seed=seed)  # streaks along axis 0
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0xF100]))
    board_w = max(2, int(round(0.15 / texel)))
    out = np.zeros((5, n, n), np.float32)
    seam = np.zeros((n, n), bool)
    for col0 in range(0, n, board_w):
        cols = slice(col0, min(n, col0 + board_w))
        seam[:, col0] = True
        row = -int(rng.integers(0, int(2.0 / texel)))
        while row < n:
            length = int(rng.uniform(0.9, 2.2) / texel)
            rows = slice(max(row, 0), min(n, row + length))
            if rows.start < rows.stop:
                shift = int(rng.integers(0, n))
                g = np.roll(grain[:, :, cols], shift, axis=1)[:, rows]
                s = float(np.clip(stain + rng.normal(0.0, 0.08), 0.05, 1.0))
                out[0, rows, cols] = g[0] * (1 - s)
                out[1, rows, cols] = g[1] * (1 - s)
                out[2, rows, cols] = g[0] * s
                out[3, rows, cols] = g[1] * s
                if row >= 0:
                    seam[row, cols] = True
            row += length
    out[:, seam] = 0.0
    out[4, seam] = 1.0
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=4)
def tartan_abundances(seed: int, colours: int) -> np.ndarray:
    """A twill-woven tartan (``colours``, N, N) over :data:`FABRIC_SPAN_M`: warp and weft of
    the same sett of stripes (4–40 mm), 1-mm threads crossing in a 2/2 twill."""
    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x7A27]))
    n = FABRIC_TEXELS
    texel_mm = 1000 * FABRIC_SPAN_M / n
    sett = []
    while len(sett) < n:
        colour = int(rng.integers(colours)) if sett else 0
        width = int(max(2, rng.choice([4, 6, 10, 16, 24, 40]) / texel_mm))
        sett += [colour] * width
    sett = np.asarray(sett[:n])
    warp = np.broadcast_to(sett[None, :], (n, n))
    weft = np.broadcast_to(sett[:, None], (n, n))
    i, j = np.indices((n, n))
    over = ((i + j) // 2) % 2 == 0  # 2/2 twill
    threads = np.where(over, warp, weft)
    out = np.stack([(threads == k).astype(np.float32) for k in range(colours)])
    out.setflags(write=False)
    return out


@functools.lru_cache(maxsize=4)
def rug_abundances(seed: int, rows: int, cols: int) -> np.ndarray:
    """A rug's pattern (4, rows, cols) over its top: field, border, motif, outline (a border
    band with a chequered motif, a field of outlined diamonds)."""
    import cv2

    from ..textures import fbm

    rng = np.random.default_rng(np.random.SeedSequence([seed, 0x2B6]))
    v, u = np.meshgrid((np.arange(rows) + 0.5) / rows, (np.arange(cols) + 0.5) / cols, indexing="ij")
    edge = np.minimum(np.minimum(u, 1 - u) * cols / rows, np.minimum(v, 1 - v))  # in rug heights
    label = np.zeros((rows, cols), np.int32)  # 0 field
    band = (edge > 0.03) & (edge < 0.14)
    label[band] = 1
    cells = float(rng.uniform(18, 30))
    chequer = ((np.floor(u * cols / rows * cells) + np.floor(v * cells)) % 2 == 0)
    label[band & chequer & (edge > 0.06) & (edge < 0.11)] = 2
    label[(edge <= 0.03) | ((edge >= 0.14) & (edge < 0.16))] = 3
    inner = edge >= 0.16
    nx, ny = float(rng.integers(3, 6)), float(rng.integers(2, 4))
    du, dv = np.abs((u * nx) % 1 - 0.5), np.abs((v * ny) % 1 - 0.5)
    diamond = du + dv
    label[inner & (diamond < 0.36)] = 2
    label[inner & (diamond >= 0.30) & (diamond < 0.36)] = 3
    label[inner & (diamond < 0.12)] = 1
    out = np.stack([(label == k).astype(np.float32) for k in range(4)])
    out = np.stack([cv2.GaussianBlur(m, (0, 0), 0.7) for m in out])
    wear = fbm(max(rows, cols), period_px=max(rows, cols) / 3, seed=seed + 5)[:rows, :cols]
    out[0] += 0.15 * np.clip(wear, 0, None)  # worn towards the field's colour
    out /= out.sum(axis=0, keepdims=True)
    out.setflags(write=False)
    return out.astype(np.float32)


# ----------------------------------------------------------------------------- BSDFs
def twosided(bsdf: dict) -> dict:
    return {"type": "twosided", "bsdf": bsdf}


def uv_scale(span_u: float, span_v: float | None = None, mi=None):
    """The transform from metres on a face to texture coordinates for a texture spanning
    ``span_u`` × ``span_v`` m."""
    span_v = span_u if span_v is None else span_v
    return mi.ScalarTransform4f().scale([1.0 / span_u, 1.0 / span_v, 1.0])


def diffuse(colour, mi) -> dict:
    return twosided({"type": "diffuse", "reflectance": reflectance_spectrum(colour)})


def plastic(colour, alpha: float, mi, *, int_ior: float = 1.49) -> dict:
    """Paint or varnish: a GGX ``roughplastic`` of roughness ``alpha`` over ``colour``."""
    return twosided({"type": "roughplastic", "distribution": "ggx", "alpha": alpha, "int_ior": int_ior,
                     "diffuse_reflectance": reflectance_spectrum(colour)})


def glazed(colour, mi) -> dict:
    return plastic(colour, 0.12, mi, int_ior=1.5)


def metal(name: str, alpha: float, mi) -> dict:
    """A GGX ``roughconductor`` with Mitsuba's measured η, k of ``name`` (Al, Cu, Au)."""
    return twosided({"type": "roughconductor", "distribution": "ggx", "alpha": alpha, "material": name})


def wall(paint, seed: int, mi) -> dict:
    """Plaster painted ``paint``, mixed by low-contrast fBm with the same paint at 0.85 (uneven
    wear) and bump-mapped."""
    from ..textures import abundance_maps, height_field

    worn = scaled(paint, 0.85)
    maps = abundance_maps(WALL_TEXELS, [0.75, 0.25], period_px=WALL_TEXELS / 3, seed=seed, contrast=1.5)
    height = height_field(WALL_TEXELS, period_px=WALL_TEXELS / 24, seed=seed)
    return twosided(mixed_bsdf(mi, [paint, worn], maps, to_uv=uv_scale(WALL_SPAN_M, mi=mi), height=height,
                               bump_scale=0.004))


def floor(ends, seed: int, stain: float, mi) -> dict:
    """The floor's boards (:func:`floor_abundances` over its five ``ends``)."""
    return twosided(mixed_bsdf(mi, ends, floor_abundances(seed, stain), to_uv=uv_scale(FLOOR_SPAN_M, mi=mi)))


def dark_wood(ends, seed: int, mi) -> dict:
    """Stained wood in grain (the table and the sideboard's feet)."""
    from ..textures import grain_maps

    maps = grain_maps(512, [1.0, 1.0], period_px=64, stretch=10.0, seed=seed)
    return twosided(mixed_bsdf(mi, ends, maps, to_uv=uv_scale(2.0, mi=mi)))


def rug(palette, seed: int, texels: tuple[int, int], size_m: tuple[float, float], mi) -> dict:
    """The rug's pattern (:func:`rug_abundances`) in ``palette`` over ``size_m`` (length, width)."""
    return twosided(mixed_bsdf(mi, palette, rug_abundances(seed, *texels), to_uv=uv_scale(*size_m, mi=mi)))


def fabric(ends, seed: int, mi) -> dict:
    """A tartan (:func:`tartan_abundances`) woven of ``ends``."""
    return twosided(mixed_bsdf(mi, ends, tartan_abundances(seed, len(ends)), to_uv=uv_scale(FABRIC_SPAN_M, mi=mi)))


def canvas(colours, seed: int, mi) -> dict:
    """A painting: fractal patches of ``colours`` over its 1 × 0.7 m."""
    from ..textures import abundance_maps

    maps = abundance_maps(256, [1.0] * len(colours), period_px=110, seed=seed, contrast=6.0)
    return twosided(mixed_bsdf(mi, colours, maps, to_uv=uv_scale(1.0, 0.7, mi=mi)))
