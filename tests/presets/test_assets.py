"""Users' own meshes (``[[scene.assets]]``, spectral_cam/presets/assets.py): the scene-file
checks, the readers, and the colour of a textured asset through the render.

The colour reference is colour-science's sRGB → CIELAB of each texel (IEC 61966-2-1 decoding,
D65 white); the render's is the XYZ of the radiance a flat-lit (D65 lamp straight above) asset
returns, relative to the perfect diffuser's L = E/π (Jakob & Hanika 2019's upsampling is what
turns the texel into the reflectance spectrum, in Mitsuba's spectral variants)."""

from __future__ import annotations

import math
import struct
from pathlib import Path

import numpy as np
import pytest

from spectral_cam.errors import ConfigError
from spectral_cam.presets.assets import BUNDLED, MeshData, asset_from_table, check_asset_file, srgb_to_linear
from spectral_cam.presets.mesh_files import read_ply as _read_ply
from spectral_cam.scene import load_scene, scene_from_dict

pytestmark = pytest.mark.timeout(600)

QUAD = "v -1 -1 0\nv 1 -1 0\nv 1 1 0\nv -1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"


def _outdoor(**scene):
    return {"scene": {"preset": "tabletop", "object_count": 0, "ground": "flat", **scene},
            "sensor": {"width_px": 24, "height_px": 16}, "render": {"spp": 4}}


def _ply(path: Path, vertices, faces, colours=None, binary=True) -> Path:
    """A PLY of triangles, with 8-bit colours when given."""
    props = "property float x\nproperty float y\nproperty float z\n"
    if colours is not None:
        props += "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    fmt = "binary_little_endian" if binary else "ascii"
    header = (f"ply\nformat {fmt} 1.0\nelement vertex {len(vertices)}\n{props}element face {len(faces)}\n"
              "property list uchar int vertex_indices\nend_header\n").encode()
    if binary:
        fields = [("p", "<f4", 3)] + ([("c", "u1", 3)] if colours is not None else [])
        vertex = np.zeros(len(vertices), dtype=fields)
        vertex["p"] = vertices
        if colours is not None:
            vertex["c"] = colours
        face = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", 3)])
        face["n"], face["i"] = 3, faces
        path.write_bytes(header + vertex.tobytes() + face.tobytes())
    else:
        rows = [" ".join(f"{v:g}" for v in p) + ("" if colours is None else " " + " ".join(str(int(c)) for c in colours[k]))
                for k, p in enumerate(vertices)]
        rows += [f"3 {a} {b} {c}" for a, b, c in faces]
        path.write_bytes(header + ("\n".join(rows) + "\n").encode())
    return path


# ----------------------------------------------------------------------------- the scene file
def test_bundled_assets_load_and_round_trip(tmp_path):
    scene = scene_from_dict(_outdoor(assets=[{"file": "rock", "position_m": [0.1, 0.0, 0.0]},
                                             {"file": "crate", "rotation_deg": "random", "scale": 0.5},
                                             {"file": "mushroom", "count": 3, "spread_m": 0.2}]))
    assert [a.name for a in scene.scene.assets] == ["rock", "crate", "mushroom"]
    assert scene.scene.assets[0].up_axis == "z" and scene.scene.assets[1].up_axis == "y"
    (tmp_path / "s.toml").write_text(scene.to_toml())
    assert load_scene(tmp_path / "s.toml") == scene
    for name, file in BUNDLED.items():  # and each is a well-formed file of its format
        assert check_asset_file(Path(__file__).parents[2] / "spectral_cam" / "data" / "assets" / file) == file.split(".")[1]


def test_relative_paths_resolve_against_the_scene_file(tmp_path):
    (tmp_path / "meshes").mkdir()
    (tmp_path / "meshes" / "quad.obj").write_text(QUAD)
    (tmp_path / "s.toml").write_text('[scene]\npreset = "tabletop"\n\n[[scene.assets]]\nfile = "meshes/quad.obj"\n'
                                     'name = "tile"\n')
    scene = load_scene(tmp_path / "s.toml")
    assert scene.scene.assets[0].file == str((tmp_path / "meshes" / "quad.obj").resolve())
    assert scene.scene.assets[0].name == "tile"


@pytest.mark.parametrize("table, message", [
    ({"file": "missing.ply"}, "does not exist"),
    ({"file": "mesh.stl"}, "unknown asset format; valid: .ply"),
    ({"file": "rock", "scale": -1.0}, "scale"),
    ({"file": "rock", "scale": 0.0}, "scale"),
    ({"file": "rock", "position_m": [0.0, float("nan"), 0.0]}, "position_m"),
    ({"file": "rock", "position_m": [0.0, 0.0]}, "position_m"),
    ({"file": "rock", "rotation_deg": "spin"}, "rotation_deg"),
    ({"file": "rock", "colour": [1.2, 0.0, 0.0]}, "colour"),
    ({"file": "rock", "count": 0}, "count"),
    ({"file": "rock", "name": "ground"}, "presets use"),
    ({"file": "rock", "up": "x"}, "up"),
    ({"file": "rock", "shiny": True}, "unknown key"),
])
def test_bad_assets_are_refused_with_a_message(table, message):
    with pytest.raises(ConfigError, match=message):
        scene_from_dict(_outdoor(assets=[table]))


def test_corrupt_files_are_refused_before_rendering(tmp_path):
    (tmp_path / "junk.ply").write_bytes(b"\x00\x01 not a ply at all")
    (tmp_path / "empty.obj").write_text("# nothing\n")
    (tmp_path / "bad.glb").write_bytes(b"glTF" + struct.pack("<II", 2, 999) + b"\0" * 8)
    vertices = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    whole = _ply(tmp_path / "whole.ply", vertices, [[0, 1, 2]]).read_bytes()
    (tmp_path / "cut.ply").write_bytes(whole[:whole.index(b"end_header") + 20])
    for name, what in (("junk.ply", "PLY"), ("empty.obj", "OBJ"), ("bad.glb", "GLB"), ("cut.ply", "truncated")):
        with pytest.raises(ConfigError, match=what):
            asset_from_table({"file": str(tmp_path / name)}, 0)
    asset_from_table({"file": str(tmp_path / "whole.ply")}, 0)


def test_assets_need_an_outdoor_preset_and_names_of_their_own():
    with pytest.raises(ConfigError, match="outdoor preset"):
        scene_from_dict({"scene": {"preset": "colorchecker", "assets": [{"file": "rock"}]}})
    with pytest.raises(ConfigError, match="name of its own"):
        scene_from_dict(_outdoor(assets=[{"file": "rock"}, {"file": "rock"}]))


# ----------------------------------------------------------------------------- the readers
def test_ply_ascii_and_binary_read_the_same(tmp_path):
    rng = np.random.default_rng(0)
    vertices = rng.uniform(-1, 1, (6, 3)).astype(np.float32)
    faces = np.array([[0, 1, 2], [2, 3, 4], [4, 5, 0]])
    colours = rng.integers(0, 256, (6, 3))
    a = _read_ply(_ply(tmp_path / "a.ply", vertices, faces, colours, binary=False))
    b = _read_ply(_ply(tmp_path / "b.ply", vertices, faces, colours, binary=True))
    for got in (a, b):
        np.testing.assert_allclose(got.vertices, vertices, atol=1e-6)
        np.testing.assert_array_equal(got.faces, faces)
        np.testing.assert_allclose(got.colours, srgb_to_linear(colours / 255.0), atol=1e-6)


# ----------------------------------------------------------------------------- colour through the render
#: In-gamut display-sRGB colours (8-bit): ColorChecker-like skins, sky, foliage, and saturated ones.
COLOURS = np.array([[115, 82, 68], [194, 150, 130], [98, 122, 157], [87, 108, 67], [175, 54, 60], [70, 148, 73]])
CELL_TEXELS = 8  # each colour a block of 8 × 8 texels: bilinear filtering blends only at the block edges
QUAD_M = (0.06, 0.04)  # a quad 6 cm east × 4 cm north, 3 × 2 colour blocks


def _texture() -> np.ndarray:
    """(16, 24, 3) uint8: the colours in 2 rows × 3 columns of blocks, row 0 at the image's top."""
    return np.kron(COLOURS.reshape(2, 3, 3), np.ones((CELL_TEXELS, CELL_TEXELS, 1))).astype(np.uint8)


def _cell_centres(position):
    """Ground (east, north) of each colour block's centre on a quad centred at ``position``:
    the image's top row lies north (v up in OBJ's convention)."""
    w, h = QUAD_M
    return [(position[0] + (c + 0.5) * w / 3 - w / 2, position[1] + h / 2 - (r + 0.5) * h / 2)
            for r in range(2) for c in range(3)]


def _textured_assets(folder: Path) -> list[dict]:
    """The quad with the texture as OBJ + MTL + PNG, as GLB (trimesh, if installed), and as a
    PLY whose vertices carry the colours; each at its own place, 2 mm over the ground."""
    import cv2

    cv2.imwrite(str(folder / "colours.png"), _texture()[..., ::-1])
    w, h = QUAD_M
    (folder / "quad.mtl").write_text("newmtl m\nKd 1 1 1\nmap_Kd colours.png\n")
    (folder / "quad.obj").write_text("mtllib quad.mtl\n" + QUAD.replace("v -1 -1", f"v {-w / 2} {-h / 2}")
                                     .replace("v 1 -1", f"v {w / 2} {-h / 2}").replace("v 1 1", f"v {w / 2} {h / 2}")
                                     .replace("v -1 1", f"v {-w / 2} {h / 2}"))
    assets = [{"file": str(folder / "quad.obj"), "name": "obj_quad", "up": "z", "position_m": [-0.035, 0.025, 0.002]}]
    vertices, faces, colours = [], [], []
    for k, (east, north) in enumerate(_cell_centres((0.0, 0.0))):
        vertices += [(east + dx * w / 6, north + dy * h / 4, 0.0) for dx, dy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
        faces += [(4 * k, 4 * k + 1, 4 * k + 2), (4 * k, 4 * k + 2, 4 * k + 3)]
        colours += [COLOURS[k]] * 4
    _ply(folder / "cells.ply", np.array(vertices), np.array(faces), np.array(colours))
    assets.append({"file": str(folder / "cells.ply"), "name": "ply_cells", "position_m": [0.035, 0.025, 0.002]})
    try:
        import trimesh
        from PIL import Image
    except ImportError:
        return assets
    material = trimesh.visual.material.PBRMaterial(baseColorTexture=Image.fromarray(_texture()))
    quad = trimesh.Trimesh([[-w / 2, 0, h / 2], [w / 2, 0, h / 2], [w / 2, 0, -h / 2], [-w / 2, 0, -h / 2]],
                           [[0, 1, 2], [0, 2, 3]], process=False,  # y up: north is −z
                           visual=trimesh.visual.TextureVisuals(uv=[[0, 0], [1, 0], [1, 1], [0, 1]], material=material))
    quad.export(folder / "quad.glb")
    assets.append({"file": str(folder / "quad.glb"), "name": "glb_quad", "position_m": [-0.035, -0.025, 0.002]})
    return assets


def _pixel(config, lens, east, north, up=0.002):
    """The (row, column) where a ground point appears (pinhole; Mitsuba's +x is image-left)."""
    from spectral_cam.presets.outdoor import GroundView

    x, y, z = GroundView.from_config(config).to_camera([east, north, up])
    scale = lens.image_distance_m / (config.sensor.pixel_pitch_um * 1e-6)
    return config.sensor.height_px / 2 - scale * y / z, config.sensor.width_px / 2 - scale * x / z


def test_texture_colours_render_within_delta_e_2(tmp_path, variant):
    """Each texel colour, rendered flat-lit by a D65 lamp straight above and read as XYZ
    relative to the perfect diffuser, lies within ΔE2000 2 of colour-science's CIELAB of
    that sRGB colour: OBJ texture, PLY vertex colours, GLB texture, and a plain ``colour``."""
    import colour

    from spectral_cam.colour_ground_truth import spectral_to_xyz
    from spectral_cam.optics import ThinLens
    from spectral_cam.render import render

    assets = _textured_assets(tmp_path)
    plain = [115 / 255, 82 / 255, 68 / 255]
    assets.append({"file": str(tmp_path / "quad.obj"), "name": "plain", "up": "z", "position_m": [0.035, -0.025, 0.0],
                   "colour": plain, "texture": ""})
    (tmp_path / "nomtl.obj").write_text(QUAD)  # no material: the colour key applies
    assets[-1]["file"] = str(tmp_path / "nomtl.obj")
    assets[-1]["scale"] = 0.015
    assets[-1]["position_m"] = [0.035, -0.025, 0.002]
    lux = 1000.0
    config = scene_from_dict({
        "scene": {"preset": "tabletop", "object_count": 0, "ground": "flat", "light": "illuminant",
                  "distance_m": 1.0, "view_pitch_deg": -89.0, "assets": assets},
        "illuminant": {"spd": "D65", "illuminance_lux": lux},
        "lens": {"model": "pinhole", "focal_length_mm": 4.0, "focus_distance_m": 1.0},
        "sensor": {"width_px": 96, "height_px": 64, "pixel_pitch_um": 6.0},
        "render": {"spp": 128, "bands": "camera", "spectral_output": False, "diffraction": "off", "variant": variant, "seed": 3}})
    lens = ThinLens.from_config(config.lens, config.sensor)
    xyz = spectral_to_xyz(render(config, with_depth=False, lens=lens))
    white = np.array(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    white_xyz = colour.xy_to_XYZ(white) * lux / math.pi  # the perfect diffuser: L = E/π, Y in cd/m²
    reference = colour.XYZ_to_Lab(colour.sRGB_to_XYZ(COLOURS / 255.0), white)

    def measured(east, north):
        row, col = (int(round(v - 0.5)) for v in _pixel(config, lens, east, north))
        patch = xyz[row - 2:row + 3, col - 2:col + 3].reshape(-1, 3).mean(axis=0)
        return colour.XYZ_to_Lab(patch / white_xyz[1], white)

    results = {}
    for asset in config.scene.assets[:-1]:
        lab = np.array([measured(e, n) for e, n in _cell_centres(asset.position_m)])
        results[asset.name] = np.asarray(colour.delta_E(lab, reference, method="CIE 2000"))
    e, n = config.scene.assets[-1].position_m[:2]
    results["plain"] = np.atleast_1d(colour.delta_E(measured(e, n), reference[0], method="CIE 2000"))
    print({name: np.round(d, 2).tolist() for name, d in results.items()})
    for name, delta in results.items():
        assert np.all(delta <= 2.0), (name, delta)
    assert set(results) >= {"obj_quad", "ply_cells", "plain"}


@pytest.mark.timeout(300)
def test_texture_colours_develop_within_delta_e_2_through_the_camera(tmp_path):
    """The issue's check through the whole chain: the textures flat-lit by D65, recorded by the
    default camera (the Nikon D850's measured filters; noise off), written as a RAW and developed
    (as-shot white balance, sRGB tone curve only; a 50 % sRGB grey asset sets the exposure's
    scale) lie within ΔE2000 2 of colour-science's CIELAB of their sRGB with the root-polynomial
    colour correction (measured 0.6–1.4). With the DNG's 3 × 3 matrix the camera's own colour
    error shows on the saturated red (measured 2.5–2.7): within the 3.0 the same matrix leaves on
    the ColorChecker (README, "Validation"), so that is the camera's, not the upsampling's."""
    import dataclasses

    import colour

    from spectral_cam.isp import develop
    from spectral_cam.job import simulate
    from spectral_cam.optics import ThinLens

    assets = _textured_assets(tmp_path)
    (tmp_path / "nomtl.obj").write_text(QUAD)
    assets.append({"file": str(tmp_path / "nomtl.obj"), "name": "grey", "up": "z", "position_m": [0.035, -0.025, 0.002],
                   "colour": [0.5, 0.5, 0.5], "texture": "", "scale": 0.015})
    quiet = {"shot_noise": False, "read_noise_e": 0.0, "prnu": 0.0, "dsnu_e": 0.0, "dark_current_e_per_s": 0.0}
    config = scene_from_dict({
        "scene": {"preset": "tabletop", "object_count": 0, "ground": "flat", "light": "illuminant",
                  "distance_m": 1.0, "view_pitch_deg": -89.0, "assets": assets},
        "illuminant": {"spd": "D65", "illuminance_lux": 1000.0},
        "lens": {"model": "pinhole", "focal_length_mm": 4.0, "focus_distance_m": 1.0},
        "sensor": {"width_px": 96, "height_px": 64, "pixel_pitch_um": 6.0, **quiet},
        "exposure": {"compensation_ev": -1.0},  # no texel near clipping
        "isp": {"tone": "srgb", "colour_matrix": "root_polynomial"},
        "render": {"spp": 32, "bands": "camera", "spectral_output": False, "diffraction": "off", "seed": 3}})
    lens = ThinLens.from_config(config.lens, config.sensor)
    simulated = simulate(config)
    white = np.array(colour.CCS_ILLUMINANTS["CIE 1931 2 Degree Standard Observer"]["D65"])
    reference = colour.XYZ_to_Lab(colour.sRGB_to_XYZ(COLOURS / 255.0), white)

    def errors(image):
        linear = colour.cctf_decoding(np.clip(np.asarray(image, np.float64), 0, 1), function="sRGB")

        def patch(east, north):
            row, col = (int(round(v - 0.5)) for v in _pixel(config, lens, east, north))
            return linear[row - 2:row + 3, col - 2:col + 3].reshape(-1, 3).mean(axis=0)

        scale = colour.cctf_decoding(0.5, function="sRGB") / patch(*config.scene.assets[-1].position_m[:2]).mean()
        out = {}
        for asset in config.scene.assets[:-1]:
            lab = [colour.XYZ_to_Lab(colour.sRGB_to_XYZ(scale * patch(e, n), apply_cctf_decoding=False), white)
                   for e, n in _cell_centres(asset.position_m)]
            out[asset.name] = np.asarray(colour.delta_E(np.array(lab), reference, method="CIE 2000"))
        return out

    fitted = errors(simulated.developed.image)
    matrix = errors(develop(simulated.raw, dataclasses.replace(config.isp, colour_matrix="dng")).image)
    print({name: np.round(d, 2).tolist() for name, d in {**fitted, **{k + " (3x3)": v for k, v in matrix.items()}}.items()})
    assert set(fitted) >= {"obj_quad", "ply_cells"}
    for name in fitted:
        assert np.all(fitted[name] <= 2.0), (name, fitted[name])
        assert np.all(matrix[name] <= 3.0), (name, matrix[name])


def test_mesh_data_into_mitsuba_keeps_its_colours(variant):
    """A mesh built from MeshData carries its texture coordinates and vertex colours."""
    import mitsuba as mi

    from spectral_cam.presets.assets import asset_bsdf, asset_mesh

    mi.set_variant(variant)
    data = MeshData(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float), np.array([[0, 1, 2]]),
                    uv=np.array([[0, 0], [1, 0], [0, 1]], float), colours=np.full((3, 3), 0.2))
    mesh = asset_mesh(mi, "tri", data, asset_bsdf(mi, data, (0.5, 0.5, 0.5)))
    assert mesh.has_vertex_texcoords() and mesh.has_attribute("vertex_color")
    assert mesh.id() == "tri"
