"""Make the bitmap textures of the bundled XML scenes (scenes/mixed_light_room.xml,
scenes/glass_sphere.xml): procedural wood, fabric, wallpaper, plaster and paint, written as small
8-bit sRGB PNGs beside this script. Nothing is downloaded; the same seed writes the same files.

Mitsuba's spectral variants turn each texel's sRGB into a smooth reflectance spectrum (Jakob &
Hanika 2019), so these files are all a scene needs; a grey texel (R = G = B) becomes a spectrally
flat reflectance, which is why the surfaces the tests balance to grey (the mixed-light room's back
wall and cylinder) have greyscale textures.

Noise is white noise filtered in the Fourier domain (a Gaussian of σ pixels, or a 1/f^β power law
for fBm), which makes every pattern periodic: a texture tiled by the scene's ``to_uv`` shows no seam.

Usage::

    python scenes/textures/make_textures.py          # rewrites the PNGs here

References
----------
.. [1] Jakob, W., & Hanika, J. (2019). A low-dimensional function space for efficient spectral
   upsampling. Computer Graphics Forum 38(2), 147–155 (Mitsuba 3's ``bitmap`` in spectral variants).
.. [2] Lewis, J. P. (1989). Algorithms for solid noise synthesis. SIGGRAPH '89, 263–270
   (noise by spectral synthesis: filtered white noise).
.. [3] Perlin, K. (1985). An image synthesizer. SIGGRAPH '85, 287–296 (turbulence, marble and
   wood as a periodic function of a noise-warped coordinate).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

HERE = Path(__file__).resolve().parent


# ----------------------------------------------------------------------------- noise
def noise(rng, shape, sigma=(4.0, 4.0)) -> np.ndarray:
    """Periodic Gaussian-filtered white noise, zero mean, unit σ; ``sigma`` (rows, columns) in
    pixels: anisotropic σ stretches the noise into fibres."""
    white = rng.standard_normal(shape)
    fy, fx = np.meshgrid(np.fft.fftfreq(shape[0]), np.fft.rfftfreq(shape[1]), indexing="ij")
    gain = np.exp(-2 * np.pi ** 2 * ((fy * sigma[0]) ** 2 + (fx * sigma[1]) ** 2))
    field = np.fft.irfft2(np.fft.rfft2(white) * gain, s=shape)
    return (field - field.mean()) / (field.std() + 1e-12)


def fbm(rng, shape, beta=2.0, cutoff=2.0) -> np.ndarray:
    """Periodic fractional Brownian noise (power ∝ f^-β), zero mean, unit σ; frequencies above
    1/``cutoff`` cycles per pixel are left out."""
    white = rng.standard_normal(shape)
    fy, fx = np.meshgrid(np.fft.fftfreq(shape[0]), np.fft.rfftfreq(shape[1]), indexing="ij")
    f = np.hypot(fy, fx)
    gain = np.where(f > 0, np.maximum(f, 1e-6) ** (-beta / 2), 0.0) * (f < 1.0 / cutoff)
    field = np.fft.irfft2(np.fft.rfft2(white) * gain, s=shape)
    return (field - field.mean()) / (field.std() + 1e-12)


def mix(a, b, t) -> np.ndarray:
    """Linear blend of colours (…, 3) by weights t (…), clipped to [0, 1]."""
    t = np.clip(np.asarray(t, dtype=np.float64), 0.0, 1.0)[..., None]
    return np.asarray(a, dtype=np.float64) * (1 - t) + np.asarray(b, dtype=np.float64) * t


#: Colours kept per texture: a palette PNG is a third of an RGB one's size, and 64 levels of a
#: texture's few hues show no banding at the scenes' scale (Mitsuba expands a palette to RGB).
PALETTE = 64


def save(path: Path, image: np.ndarray) -> Path:
    """Write display sRGB in [0, 1] (H, W, 3) as an 8-bit palette PNG, or grey (H, W) as a
    one-channel PNG (R = G = B: a flat reflectance), at ``path``."""
    data = np.round(np.clip(image, 0.0, 1.0) * 255).astype(np.uint8)
    if data.ndim == 2:  # one channel: Mitsuba reads it as a grey (flat) reflectance
        Image.fromarray(data, mode="L").save(path, optimize=True)
    else:
        picture = Image.fromarray(data, mode="RGB")
        picture.quantize(PALETTE, method=Image.Quantize.MEDIANCUT, dither=Image.Dither.NONE).save(path, optimize=True)
    return path


# ----------------------------------------------------------------------------- wood
def wood_boards(rng, shape, boards: int, light, dark, *, joints=1, ring_px=9.0, seam=0.35) -> np.ndarray:
    """Boards running along the columns (x), ``boards`` across the rows: per board its own tone,
    grain (rings of a noise-warped coordinate, Perlin 1985), fibres and ``joints`` end joints;
    dark seams between boards. Display sRGB in [0, 1]."""
    height, width = shape
    rows = np.arange(height)[:, None] * np.ones((1, width))
    cols = np.ones((height, 1)) * np.arange(width)[None, :]
    board = (rows * boards // height).astype(int)
    warp = 6.0 * noise(rng, shape, (6.0, 60.0)) + 2.0 * noise(rng, shape, (2.0, 14.0))
    fibres = noise(rng, shape, (0.6, 12.0))
    out = np.zeros(shape + (3,))
    edge_px = height / boards
    for b in range(boards):
        inside = board == b
        offset = rng.uniform(0, width)
        # rings: distance to the log's centre seen from the board's face, plus the warp
        radius = np.hypot((rows - (b + 0.5) * edge_px) * rng.uniform(1.5, 3.0), rng.uniform(20, 60)) + warp
        grain = 0.5 + 0.5 * np.sin(2 * np.pi * radius / ring_px * rng.uniform(0.7, 1.3))
        tone = rng.uniform(-0.25, 0.25)
        value = np.clip(0.45 + tone + 0.35 * grain ** 3 + 0.08 * fibres, 0, 1)
        board_colour = mix(light, dark, 1 - value)
        out[inside] = board_colour[inside]
        for j in range(joints):  # end joints: a dark line across the board
            x = (offset + j * width / joints) % width
            out[inside & (np.abs(cols - x) < 1.0)] *= seam
    between = (rows % edge_px) < 1.0  # the seam between boards
    out[between] *= seam
    return out


# ----------------------------------------------------------------------------- the mixed-light room
def floor_oak(rng) -> np.ndarray:
    """Oak strip floor, one 1.2 m tile of eight 15-cm boards (512 × 512 px)."""
    return wood_boards(rng, (512, 512), 8, (0.86, 0.71, 0.52), (0.50, 0.35, 0.21), joints=1, ring_px=11.0)


def kilim(rng) -> np.ndarray:
    """A flat-woven rug (2.4 × 1.6 m, 384 × 256 px): madder red field, indigo and ochre stepped
    diamonds, a cream and indigo border, a row of fringe left clear at each short end, weave
    noise."""
    height, width = 256, 384
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    red, indigo, ochre = np.array([0.54, 0.19, 0.15]), np.array([0.18, 0.22, 0.38]), np.array([0.78, 0.60, 0.28])
    cream = np.array([0.88, 0.84, 0.72])
    out = np.zeros((height, width, 3)) + red
    # stepped diamonds on a 64-px lattice (Manhattan distance, quantised to 4-px steps)
    cy, cx = (y - 32) % 64 - 32, (x - 32) % 64 - 32
    d = (np.abs(np.floor(cy / 4)) + np.abs(np.floor(cx / 4))).astype(int)
    out[(d >= 4) & (d < 6)] = indigo
    out[d < 2] = ochre
    out[(d >= 7) & (d < 8)] = cream
    border = np.minimum(np.minimum(y, height - 1 - y), np.minimum(x - 8, width - 9 - x))
    out[(border >= 0) & (border < 14)] = indigo
    out[(border >= 4) & (border < 8) & ((x.astype(int) // 6 + y.astype(int) // 6) % 2 == 0)] = cream
    out[(x < 8) | (x > width - 9)] = cream * 0.9  # fringe
    weave = 0.08 * np.cos(np.pi * x) * np.cos(np.pi * y)
    wear = 0.08 * fbm(rng, (height, width), 2.2)
    return out * (1 + weave + wear)[..., None]


def kilim_mask(rng) -> np.ndarray:
    """Where the rug lies (grey 1) on its own uv square, 0 on a one-texel rim: with ``clamp``
    wrapping the floor beyond the rug reads 0, the wood (96 × 64 px)."""
    out = np.zeros((64, 96))
    out[1:-1, 1:-1] = 1.0
    return out


def wallpaper(rng) -> np.ndarray:
    """Striped wallpaper tile (256 × 256 px, 0.75 m): sage and deep green stripes, a column of
    ochre sprigs in the light stripe, paper grain."""
    height, width = 256, 256
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    sage, green, ochre = np.array([0.55, 0.62, 0.45]), np.array([0.14, 0.30, 0.24]), np.array([0.78, 0.55, 0.18])
    stripe = (x % 128) < 64
    out = np.where(stripe[..., None], sage, green)
    out[(np.abs((x % 128) - 64) < 2) | (np.abs(x % 128) < 2)] = ochre * 0.8
    # sprigs: small ellipses in the middle of the light stripe, two per tile
    for cy in (64, 192):
        for k, angle in enumerate((0.6, -0.6, 1.6)):
            ey, ex = cy + 10 * np.sin(angle) * (k - 1), 32 + 10 * np.cos(angle) * (k - 1)
            out[((y - ey) / 9) ** 2 + ((x - ex) / 4) ** 2 < 1] = ochre
    out[((y % 128) - 64) ** 2 + ((x % 128) - 96) ** 2 < 16] = sage * 1.15  # dots in the dark stripe
    grain = 0.05 * noise(rng, (height, width), (1.0, 1.0)) + 0.05 * fbm(rng, (height, width), 2.0)
    return out * (1 + grain)[..., None]


def plaster_wall(rng) -> np.ndarray:
    """The back wall (6 × 4 m, 576 × 384 px, grey only: spectrally flat): mottled plaster, a
    darker dado below a rail at 0.9 m, a skirting board, and a framed black-and-white print."""
    height, width = 384, 576
    px = width / 6.0  # pixels per metre
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    up = (height - 1 - y) / px  # metres above the floor (the image's bottom row is the floor)
    wall = 0.74 + 0.035 * fbm(rng, (height, width), 2.4, cutoff=4.0)
    wall = np.where(up < 0.9, wall - 0.26, wall)
    wall[np.abs(up - 0.9) < 0.025] = 0.82
    wall[np.abs(up - 0.875) < 0.006] = 0.35  # the rail's shadow line
    wall[up < 0.12] = 0.30
    wall[np.abs(up - 0.12) < 0.008] = 0.55
    # a print 1.0 × 0.7 m: centre 0.35 m left of the wall's middle (image x grows to world −x), 1.5 m up
    cx, cy, half_w, half_h = width / 2 - 0.35 * px, height - 1 - 1.5 * px, 0.5 * px, 0.35 * px
    frame = (np.abs(x - cx) < half_w) & (np.abs(y - cy) < half_h)
    mat = (np.abs(x - cx) < half_w - 4) & (np.abs(y - cy) < half_h - 4)
    photo = (np.abs(x - cx) < half_w - 13) & (np.abs(y - cy) < half_h - 13)
    wall[frame] = 0.06
    wall[mat] = 0.86
    hills = cy + 8 + 10 * np.sin((x - cx) / 9.0) + 6 * noise(rng, (height, width), (1.0, 8.0))
    scene = np.where(y > hills, 0.20 + 0.10 * noise(rng, (height, width), (1.5, 1.5)),
                     0.62 - 0.010 * (y - cy) + 0.05 * fbm(rng, (height, width), 2.0))
    wall[photo] = scene[photo]
    return np.clip(wall, 0, 1)


def crate(rng) -> np.ndarray:
    """The box's faces (256 × 256 px each, every face the whole image): a crate of three
    yellow-painted pine slats, paint worn to the wood at the edges, dark gaps and nail heads."""
    height, width = 256, 256
    wood = wood_boards(rng, (height, width), 3, (0.85, 0.68, 0.45), (0.52, 0.34, 0.16), joints=0, ring_px=7.0)
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    slat = y % (height / 3)
    worn = fbm(rng, (height, width), 2.2) + 1.8 * np.exp(-np.minimum(slat, height / 3 - slat) / 6)  # worn edges
    paint = np.array([0.93, 0.74, 0.10]) * (1 + 0.05 * noise(rng, (height, width), (1.0, 1.0)))[..., None]
    out = np.where((worn > 1.3)[..., None], wood, paint)
    out[(y % (height / 3)) < 3] *= 0.25
    out[(np.minimum(x, width - 1 - x) < 10)] *= 0.8  # the corner posts, a shade darker
    for cy in (height / 6, height / 2, 5 * height / 6):
        for cx in (18, width - 19):
            out[(y - cy) ** 2 + (x - cx) ** 2 < 9] = 0.18
    return out


def ball_red(rng) -> np.ndarray:
    """A red rubber ball in sphere coordinates (u around, v pole to pole; 256 × 128 px): red with
    a white equator band between two thin navy lines, and pimples."""
    height, width = 128, 256
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    out = np.zeros((height, width, 3)) + np.array([0.75, 0.08, 0.06])
    band = np.abs(y - height / 2)
    out[band < 9] = (0.92, 0.90, 0.84)
    out[(band >= 9) & (band < 12)] = (0.10, 0.14, 0.35)
    pimples = 0.10 * np.cos(2 * np.pi * x / 8) * np.cos(2 * np.pi * y / 8) + 0.04 * noise(rng, (height, width), (1, 1))
    return out * (1 + pimples)[..., None]


def yarn_blue(rng) -> np.ndarray:
    """A ball of blue wool (256 × 128 px, sphere coordinates): strands at alternating angles in
    three blues with dark gaps between them."""
    height, width = 128, 256
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    phase = np.where((x // 64 + y // 32) % 2 == 0, x + y, x - y) + 3 * noise(rng, (height, width), (4, 4))
    strand = np.abs(np.sin(np.pi * phase / 5.0))
    shade = noise(rng, (height, width), (6, 6))
    colour = mix((0.10, 0.22, 0.62), (0.28, 0.45, 0.85), 0.5 + 0.5 * shade)
    return colour * (0.35 + 0.65 * strand)[..., None]


def concrete(rng) -> np.ndarray:
    """The grey cylinder (grey only): a cast-concrete planter with rings every 0.1 m, pores and
    mottling (u around, v along; 256 × 128 px)."""
    height, width = 128, 256
    y = np.mgrid[0:height, 0:width][0].astype(np.float64)
    value = 0.50 + 0.05 * fbm(rng, (height, width), 2.2)
    value[(y % 16) < 1.5] = 0.24
    pores = noise(rng, (height, width), (0.6, 0.6)) > 2.2
    value[pores] = 0.18
    return np.clip(value, 0, 1)


# ----------------------------------------------------------------------------- the glass-sphere table
def walnut_top(rng) -> np.ndarray:
    """A walnut table top (1.8 × 1.1 m, 512 × 320 px, not tiled): four boards along its length."""
    return wood_boards(rng, (320, 512), 4, (0.50, 0.37, 0.27), (0.17, 0.11, 0.07), joints=0, ring_px=13.0, seam=0.3)


def linen_backdrop(rng) -> np.ndarray:
    """A slate-blue linen backdrop (256 × 256 px tile, 0.5 m): plain weave with slubs (threads
    thicker for a stretch) and dye mottle."""
    height, width = 256, 256
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    weave = 0.5 + 0.5 * np.cos(np.pi * x) * np.cos(np.pi * y)
    slubs = (np.maximum(noise(rng, (height, width), (0.5, 14.0)), 0)
             + np.maximum(noise(rng, (height, width), (14.0, 0.5)), 0))
    mottle = fbm(rng, (height, width), 2.3)
    colour = mix((0.14, 0.22, 0.27), (0.30, 0.38, 0.42), 0.5 + 0.25 * mottle + 0.2 * slubs)
    return colour * (0.82 + 0.18 * weave)[..., None]


def tea_towel(rng) -> np.ndarray:
    """A red-and-white checked cotton cloth (256 × 256 px tile, 0.2 m)."""
    height, width = 256, 256
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    warp, weft = (x % 64) < 32, (y % 64) < 32
    red, white = np.array([0.55, 0.11, 0.11]), np.array([0.74, 0.72, 0.68])
    out = mix(white, red, 0.5 * warp + 0.5 * weft)
    thread = 0.06 * np.cos(np.pi * x / 1.5) * np.cos(np.pi * y / 1.5) + 0.03 * noise(rng, (height, width), (1.5, 1.5))
    return out * (1 + thread)[..., None]


def book_cloth(rng) -> np.ndarray:
    """Book covers (256 × 256 px, every face of a cube the whole image): ochre cloth with a dark
    spine band and gilt title bars on one half, cream page edges on the other."""
    height, width = 256, 256
    y, x = np.mgrid[0:height, 0:width].astype(np.float64)
    cloth = np.array([0.70, 0.45, 0.10]) * (1 + 0.06 * noise(rng, (height, width), (0.7, 0.7)))[..., None]
    out = cloth.copy()
    out[np.abs(y - 128) < 20] *= 0.45
    out[(np.abs(y - 128) < 5) & (np.abs(x - 128) < 60)] = (0.85, 0.72, 0.35)
    pages = (0.90, 0.86, 0.76) * (1 - 0.15 * (np.sin(np.pi * y / 1.2) ** 2))[..., None]
    return np.where((x > 200)[..., None], pages, out)


TEXTURES = {"floor_oak.png": floor_oak, "kilim.png": kilim, "kilim_mask.png": kilim_mask,
            "wallpaper.png": wallpaper,
            "plaster_wall.png": plaster_wall, "crate.png": crate, "ball_red.png": ball_red,
            "yarn_blue.png": yarn_blue, "concrete.png": concrete, "walnut_top.png": walnut_top,
            "linen_backdrop.png": linen_backdrop, "tea_towel.png": tea_towel, "book_cloth.png": book_cloth}


def main(folder: Path = HERE) -> None:
    """Write every texture of :data:`TEXTURES` into ``folder``, each from its own seed (its place
    in the table)."""
    total = 0
    for seed, (name, make) in enumerate(TEXTURES.items()):
        path = save(folder / name, make(np.random.default_rng(1000 + seed)))
        total += path.stat().st_size
        print(f"{path.name}: {path.stat().st_size / 1024:.0f} KiB")
    print(f"total {total / 1024:.0f} KiB")


if __name__ == "__main__":
    main()
