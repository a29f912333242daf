"""Make the bundled assets of this folder, procedurally (no outside source): a rock (binary
PLY with sRGB vertex colours), a wooden crate (OBJ + MTL + PNG texture) and a mushroom
(GLB with an embedded base-colour texture, written through trimesh). Deterministic: run
``python spectral_cam/data/assets/make_assets.py`` to make them again (the GLB needs trimesh).
Released into the public domain (CC0 1.0) with the rest of this folder's files.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def png_bytes(rgb: np.ndarray) -> bytes:
    """An 8-bit RGB PNG (no library needed)."""
    height, width, _ = rgb.shape
    raw = b"".join(b"\x00" + rgb[row].astype(np.uint8).tobytes() for row in range(height))

    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


def rock(rng) -> None:
    """rock.ply: a flattened, noise-displaced icosphere 0.3 m across, z up, grey-brown vertex
    colours varying with the noise."""
    from spectral_cam.presets.scatter import _smooth_noise, icosphere

    directions, faces = icosphere(3)
    noise = _smooth_noise(rng, directions, octaves=4)
    vertices = directions * (1.0 + 0.15 * noise)[:, None] * np.array([0.15, 0.11, 0.08])
    vertices[:, 2] -= vertices[:, 2].min()
    shade = np.clip(0.5 + 0.35 * noise, 0.0, 1.0)[:, None]
    colours = np.rint(255 * ((1 - shade) * np.array([0.36, 0.33, 0.30]) + shade * np.array([0.62, 0.56, 0.48])))
    header = (f"ply\nformat binary_little_endian 1.0\ncomment spectral_cam bundled asset, CC0 1.0\n"
              f"element vertex {len(vertices)}\nproperty float x\nproperty float y\nproperty float z\n"
              "property uchar red\nproperty uchar green\nproperty uchar blue\n"
              f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n").encode()
    vertex = np.zeros(len(vertices), dtype=[("p", "<f4", 3), ("c", "u1", 3)])
    vertex["p"], vertex["c"] = vertices, colours
    face = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", 3)])
    face["n"], face["i"] = 3, faces
    (HERE / "rock.ply").write_bytes(header + vertex.tobytes() + face.tobytes())


def crate(rng) -> None:
    """crate.obj/.mtl/.png: a 0.4 m wooden crate, y up (as Blender writes OBJ), each face the
    whole plank texture (64 × 64: planks with dark seams and a frame)."""
    size = 64
    y, x = np.mgrid[0:size, 0:size]
    plank = (y // 16) % 4
    base = np.array([[0.72, 0.53, 0.33], [0.66, 0.48, 0.29], [0.76, 0.58, 0.37], [0.69, 0.50, 0.31]])[plank]
    grain = 0.06 * np.sin(x / 3.0 + 2.0 * np.sin(y / 5.0 + plank))[..., None]
    texture = base + grain
    texture[(y % 16) < 1] *= 0.45  # seams between planks
    frame = (x < 5) | (x >= size - 5) | (y < 5) | (y >= size - 5)
    texture[frame] = np.array([0.45, 0.32, 0.20])
    (HERE / "crate.png").write_bytes(png_bytes(np.rint(255 * np.clip(texture, 0, 1))))
    (HERE / "crate.mtl").write_text("# spectral_cam bundled asset, CC0 1.0\nnewmtl wood\nKd 0.5 0.35 0.2\n"
                                    "map_Kd crate.png\n")
    h = 0.2
    lines = ["# spectral_cam bundled asset, CC0 1.0: a wooden crate, 0.4 m, +y up", "mtllib crate.mtl", "o crate"]
    lines += [f"vt {u} {v}" for u, v in ((0, 0), (1, 0), (1, 1), (0, 1))]
    vertices, faces = [], []
    for axis in range(3):
        a, b = [k for k in range(3) if k != axis]
        for sign in (-1, 1):
            corners = ((-1, -1), (1, -1), (1, 1), (-1, 1)) if sign > 0 else ((-1, -1), (-1, 1), (1, 1), (1, -1))
            ids = []
            for da, db in corners:  # counter-clockwise seen from outside for (axis, a, b) right-handed
                point = [0.0, 0.0, 0.0]
                point[axis], point[a], point[b] = sign * h, da * h, db * h
                point[1] += h  # standing on y = 0
                vertices.append("v {:.4f} {:.4f} {:.4f}".format(*point))
                ids.append(len(vertices))
            faces.append("f " + " ".join(f"{i}/{k + 1}" for k, i in enumerate(ids)))
    (HERE / "crate.obj").write_text("\n".join(lines[:3] + vertices + lines[3:] + ["usemtl wood"] + faces) + "\n")


def mushroom(rng) -> None:
    """mushroom.glb: a 0.12 m toadstool (a lathe: stem and domed cap), y up, an embedded
    32 × 64 texture: a red cap with white spots over a cream stem."""
    import trimesh
    from PIL import Image

    segments = 32
    # profile from the stem's foot to the cap's top: (radius, height, v)
    stem = [(0.012, 0.0), (0.011, 0.03), (0.010, 0.06)]
    cap_angles = np.linspace(0.0, np.pi / 2, 8)
    cap = [(0.045 * np.cos(t) + 0.001, 0.06 + 0.035 * np.sin(t)) for t in cap_angles]
    profile = np.asarray([(0.0, 0.0)] + stem + [(0.045, 0.058)] + cap + [(0.0, 0.095)])
    v_of = np.linspace(0.02, 0.98, len(profile))
    vertices, uvs, faces = [], [], []
    for s in range(segments + 1):
        angle = 2 * np.pi * s / segments
        for (r, z), v in zip(profile, v_of):
            vertices.append((r * np.cos(angle), z, -r * np.sin(angle)))  # y up
            uvs.append((s / segments, v))
    ring = len(profile)
    for s in range(segments):
        for k in range(ring - 1):
            a, b = s * ring + k, (s + 1) * ring + k
            faces += [(a, b, b + 1), (a, b + 1, a + 1)]
    height, width = 64, 32
    texture = np.zeros((height, width, 3))
    rows = np.arange(height)[:, None]
    texture[:] = np.array([0.93, 0.88, 0.78])  # stem (the image's lower rows: v small)
    cap_rows = rows < height * (1 - v_of[len(stem) + 1])
    texture[np.broadcast_to(cap_rows, (height, width))] = np.array([0.78, 0.12, 0.08])
    for _ in range(14):  # white spots on the cap
        cy, cx = rng.uniform(2, height * 0.45), rng.uniform(0, width)
        yy, xx = np.mgrid[0:height, 0:width]
        texture[((yy - cy) ** 2 + ((xx - cx + width / 2) % width - width / 2) ** 2) < 3.0] = np.array([0.95, 0.95, 0.9])
    image = Image.fromarray(np.rint(255 * texture).astype(np.uint8))
    material = trimesh.visual.material.PBRMaterial(baseColorTexture=image, metallicFactor=0.0, roughnessFactor=1.0)
    mesh = trimesh.Trimesh(np.asarray(vertices), np.asarray(faces),
                           visual=trimesh.visual.TextureVisuals(uv=np.asarray(uvs), material=material), process=False)
    mesh.export(HERE / "mushroom.glb")


if __name__ == "__main__":
    rock(np.random.default_rng(1))
    crate(np.random.default_rng(2))
    mushroom(np.random.default_rng(3))
    for path in sorted(HERE.iterdir()):
        print(f"{path.name}: {path.stat().st_size} bytes")
