"""Users' own meshes in the outdoor presets (``[[scene.assets]]``): PLY, OBJ, glTF/GLB files
placed on the ground by the scene file, their colours turned into reflectance spectra.

Formats (:data:`ASSET_FORMATS`): PLY (ASCII or binary, read here: positions, normals,
texture coordinates, 8-bit or float vertex colours, a MeshLab ``comment TextureFile``); OBJ
(Mitsuba's own loader; its ``.mtl``'s first ``map_Kd`` texture or ``Kd`` colour, read here);
glTF and GLB (through ``trimesh``, the optional ``assets`` extra: the meshes of the default
scene merged, the base-colour texture, the base-colour factor or vertex colours). Ids of bundled
assets (:data:`BUNDLED`, ``spectral_cam/data/assets``) may stand for a file: ``file = "rock"``.

Colour → spectrum. Texture texels and vertex colours are display sRGB (IEC 61966-2-1), a
glTF base-colour factor and an OBJ ``Kd`` linear sRGB, ``colour`` (the fallback for a mesh
with none) display sRGB. Mitsuba's spectral variants turn an RGB ``bitmap`` (not ``raw``), an
``rgb`` value and an RGB mesh attribute into a reflectance spectrum by Jakob & Hanika's
low-dimensional sigmoid-polynomial fit [1]_, which reproduces an in-gamut sRGB colour under
D65 (tests/presets/test_assets.py: ΔE2000 < 2 through the render). Every asset is a
two-sided Lambertian surface (``twosided`` ``diffuse``: a scanned or exported mesh's winding
is not to be trusted).

Placement (ground frame, :class:`spectral_cam.presets.outdoor.GroundView`: east, north, up;
metres): the mesh is turned so its ``up`` axis (``y`` for OBJ and glTF, whose exporters and
specification use it, ``z`` for PLY) points up, the middle of its bounding box's bottom face
goes to ``position_m``, scaled by ``scale`` (file units are metres), turned by
``rotation_deg`` (about east, then north, then up) or ``"random"`` (about up, by
``scene.layout_seed``). ``count`` > 1 places that many copies as Mitsuba instances of one
``shapegroup`` (or, in the JIT variants of Mitsuba up to 3.9.1, where instances cost a
kernel trace each, one merged mesh: :func:`use_instances`), their feet uniform over the disc
of ``spread_m`` around ``position_m`` or, with ``spread_m = 0``, over the ground the frame
sees. Shape names (the segmentation's): ``name`` (default the file's stem) for one copy and
for merged copies; instances ``name_<n>`` (each its own segment in the scalar variants; the
JIT variants' shape-index AOV reports the inner mesh ``name`` instead:
:func:`spectral_cam.presets.scatter.instanced_meshes`).

Here: the scene-file entry, the colour and the placing of each asset. The files are read by
:mod:`spectral_cam.presets.mesh_files`; copies become instances or one merged mesh in
:mod:`spectral_cam.presets.placement`.

References
----------
.. [1] Jakob, W., & Hanika, J. (2019). A Low-Dimensional Function Space for Efficient Spectral
   Upsampling. Computer Graphics Forum 38(2), 147–155 (Mitsuba 3's ``srgb`` spectra).
.. [2] Turk, G. (1994). The PLY Polygon File Format; Wavefront OBJ and MTL (Alias|Wavefront);
   Khronos Group (2021), glTF 2.0 Specification (§3.4: +Y up, metres; base colour).
.. [3] IEC 61966-2-1:1999 (the sRGB transfer function).
"""

from __future__ import annotations

import dataclasses
import math
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from ..errors import ConfigError
from .mesh_files import MESH_FORMATS, MeshData, srgb_to_linear
# the meshes' placing, importable from here as before (scatter.py and the tests import it so)
from .placement import (asset_mesh, camera_matrix, ground_in_view, merge_copies, place_copies,  # noqa: F401
                        use_instances)

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["ASSET_FORMATS", "BUNDLED", "AssetSpec", "asset_from_table", "check_asset_file", "read_asset",
           "MeshData", "asset_objects", "asset_bsdf", "asset_mesh", "srgb_to_linear", "ASSET_KEYS", "ground_in_view",
           "use_instances", "place_copies", "merge_copies", "camera_matrix"]

#: The file formats an asset may be in, by suffix (:data:`~spectral_cam.presets.mesh_files.MESH_FORMATS`).
ASSET_FORMATS = {suffix: fmt.description for suffix, fmt in MESH_FORMATS.items()}
TEXTURE_SUFFIXES = (".png", ".jpg", ".jpeg", ".exr", ".hdr", ".tga", ".bmp")
#: The bundled assets (spectral_cam/data/assets; provenance and licence in its README).
ASSET_FOLDER = Path(__file__).resolve().parent.parent / "data" / "assets"
BUNDLED = {"rock": "rock.ply", "crate": "crate.obj", "mushroom": "mushroom.glb"}
ASSET_KEYS = ("file", "name", "position_m", "scale", "rotation_deg", "colour", "count", "spread_m", "up", "texture")
#: Shape names the presets use themselves (an asset named so would replace or shadow them).
RESERVED_NAMES = ("ground", "sky", "lamp", "object", "plant", "weed", "chart", "chart_board", "chart_patch",
                  "backdrop", "sensor", "integrator")
MAX_COPIES = 60000


def fail_key(key: str, value: Any, rule: str) -> None:
    """Raise the one-line ConfigError of a bad ``[[scene.assets]]`` or ``[[scene.scatter]]`` value."""
    raise ConfigError(f"{key} = {value!r}: {rule}")


def check_entry_table(where: str, table: Any, keys, hint: str) -> None:
    """Refuse an array-of-tables entry that is not a table (``hint`` says what one holds) or that
    has keys other than ``keys``, naming the valid ones."""
    if not isinstance(table, Mapping):
        fail_key(where, table, hint)
    unknown = sorted(set(table) - set(keys))
    if unknown:
        raise ConfigError(f"unknown key(s) {', '.join(f'{where}.{k}' for k in unknown)}; valid: {', '.join(keys)}")


def _formats() -> str:
    return "; ".join(f".{suffix}: {what}" for suffix, what in ASSET_FORMATS.items())


def asset_path(file: str) -> Path:
    """The file an asset's ``file`` names: a bundled asset's id, else the path itself."""
    return ASSET_FOLDER / BUNDLED[file] if file in BUNDLED else Path(file)


# ----------------------------------------------------------------------------- checks without Mitsuba
def check_asset_file(path: str | Path, key: str = "file") -> str:
    """The format of an asset file, after a structural check that needs no Mitsuba (header,
    element counts, size); the suffix names the format.

    Raises
    ------
    ConfigError
        When the file is missing, of an unknown format, or corrupt, naming the valid formats.
    """
    path = Path(path)
    suffix = path.suffix.lower().lstrip(".")
    if suffix not in ASSET_FORMATS:
        fail_key(key, str(path), f"unknown asset format; valid: {_formats()}; or a bundled asset: {', '.join(BUNDLED)}")
    if not path.is_file():
        fail_key(key, str(path), f"file does not exist (relative paths are read from the scene file's folder; "
                              f"bundled assets: {', '.join(BUNDLED)})")
    try:
        MESH_FORMATS[suffix].check(path)
    except (OSError, ValueError, KeyError, IndexError, UnicodeDecodeError, struct.error) as exc:
        fail_key(key, str(path), f"not a readable {suffix.upper()} file ({exc}); valid: {_formats()}")
    return suffix


# ----------------------------------------------------------------------------- the scene-file entry
@dataclass(frozen=True)
class AssetSpec:
    """One ``[[scene.assets]]`` entry (see the module's description)."""

    file: str
    name: str
    position_m: tuple[float, ...] = (0.0, 0.0, 0.0)
    scale: float = 1.0
    rotation_deg: tuple[float, ...] | str = (0.0, 0.0, 0.0)
    colour: tuple[float, ...] = (0.5, 0.5, 0.5)
    count: int = 1
    spread_m: float = 0.0
    up: str = "auto"
    texture: str = ""

    @property
    def path(self) -> Path:
        return asset_path(self.file)

    @property
    def format(self) -> str:
        return self.path.suffix.lower().lstrip(".")

    @property
    def up_axis(self) -> str:
        return self.up if self.up != "auto" else ("z" if self.format == "ply" else "y")

    def to_table(self) -> dict:
        return {"file": self.file, "name": self.name, "position_m": list(self.position_m), "scale": self.scale,
                "rotation_deg": self.rotation_deg if isinstance(self.rotation_deg, str) else list(self.rotation_deg),
                "colour": list(self.colour), "count": self.count, "spread_m": self.spread_m, "up": self.up,
                "texture": self.texture}


def _resolve(value: str, base_dir: Path) -> str:
    if value in BUNDLED:
        return value
    path = Path(value).expanduser()
    return str((path if path.is_absolute() else base_dir / path).resolve())


def _numbers(key: str, value: Any, count: int, bound: float, what: str) -> tuple[float, ...]:
    if (not isinstance(value, (list, tuple)) or len(value) != count
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and abs(v) <= bound
                       for v in value)):
        fail_key(key, value, f"give {count} finite numbers within ±{bound:g} ({what})")
    return tuple(float(v) for v in value)


def asset_from_table(table: Any, index: int, base_dir: str | Path = ".") -> AssetSpec:
    """Validate one ``[[scene.assets]]`` table; ``file`` and ``texture`` are read relative to
    ``base_dir`` (the scene file's folder) and checked (:func:`check_asset_file`).

    Raises
    ------
    ConfigError
        For an unknown key, a missing, unknown or corrupt file or a value out of range.
    """
    if isinstance(table, AssetSpec):
        return table
    where = f"scene.assets[{index}]"
    check_entry_table(where, table, ASSET_KEYS, "give a table: file = ..., position_m = [east, north, up], ...")
    file = table.get("file")
    if not isinstance(file, str) or not file:
        fail_key(f"{where}.file", file, f"give the mesh file ({', '.join('.' + s for s in ASSET_FORMATS)}) or a bundled "
                                     f"asset ({', '.join(BUNDLED)})")
    file = _resolve(file, Path(base_dir))
    check_asset_file(asset_path(file), f"{where}.file")
    name = table.get("name", Path(file).stem if file not in BUNDLED else file)
    if not isinstance(name, str) or not name or not name.replace("_", "").isalnum() or not name[0].isalpha():
        fail_key(f"{where}.name", name, "give a segmentation name: a letter, then letters, digits and _")
    if name in RESERVED_NAMES or name.startswith(("ground_far", "scatter_", "asset_group")):
        fail_key(f"{where}.name", name, f"is a name the presets use ({', '.join(RESERVED_NAMES)}); choose another")
    position = _numbers(f"{where}.position_m", table.get("position_m", [0.0, 0.0, 0.0]), 3, 1e5,
                        "east, north, up in metres from the look point")
    scale = table.get("scale", 1.0)
    if not (isinstance(scale, (int, float)) and not isinstance(scale, bool) and math.isfinite(scale)
            and 0 < scale <= 1e4):
        fail_key(f"{where}.scale", scale, "must be a number in (0, 1e4] (the file's units are metres)")
    rotation = table.get("rotation_deg", [0.0, 0.0, 0.0])
    if rotation != "random":
        rotation = _numbers(f"{where}.rotation_deg", rotation, 3, 360.0,
                            "degrees about east, north, up; or \"random\" about up")
    colour = _numbers(f"{where}.colour", table.get("colour", [0.5, 0.5, 0.5]), 3, 1.0, "display sRGB in [0, 1]")
    if min(colour) < 0:
        fail_key(f"{where}.colour", list(colour), "give three display-sRGB values in [0, 1]")
    count = table.get("count", 1)
    if not (isinstance(count, int) and not isinstance(count, bool) and 1 <= count <= MAX_COPIES):
        fail_key(f"{where}.count", count, f"must be a whole number in 1..{MAX_COPIES}")
    spread = table.get("spread_m", 0.0)
    if not (isinstance(spread, (int, float)) and not isinstance(spread, bool) and 0 <= spread <= 1e4):
        fail_key(f"{where}.spread_m", spread, "must lie in [0, 1e4] m (0: copies over the ground in view)")
    up = table.get("up", "auto")
    if up not in ("auto", "y", "z"):
        fail_key(f"{where}.up", up, "valid: auto (y for OBJ and glTF, z for PLY), y, z")
    texture = table.get("texture", "")
    if not isinstance(texture, str):
        fail_key(f"{where}.texture", texture, "give an image file's path")
    if texture:
        texture = _resolve(texture, Path(base_dir))
        if Path(texture).suffix.lower() not in TEXTURE_SUFFIXES or not Path(texture).is_file():
            fail_key(f"{where}.texture", texture, f"give an existing image ({', '.join(TEXTURE_SUFFIXES)})")
    return AssetSpec(file, name, position, float(scale), rotation, colour, count, float(spread), up, texture)


# ----------------------------------------------------------------------------- reading
def read_asset(spec: AssetSpec, mi) -> MeshData:
    """The asset's mesh and colours as read from its file (``spec.texture`` replaces a texture).

    Raises
    ------
    ConfigError
        When the file cannot be read as its format, naming the valid formats.
    """
    path = spec.path
    try:
        data = MESH_FORMATS[spec.format].read(path, mi)
    except ConfigError:
        raise
    except Exception as exc:  # a format library's own error: say which file and what is valid
        raise ConfigError(f"asset {spec.name!r}: cannot read {path} as {spec.format.upper()} ({exc}); valid: "
                          f"{_formats()}") from None
    if len(data.faces) == 0 or not np.all(np.isfinite(data.vertices)):
        raise ConfigError(f"asset {spec.name!r}: {path} has no triangles or has non-finite vertices")
    if spec.texture:
        if data.uv is None:
            raise ConfigError(f"asset {spec.name!r}: texture {spec.texture} given, but {path} has no texture "
                              "coordinates")
        data.texture_file, data.texture = spec.texture, None
    return data


# ----------------------------------------------------------------------------- into Mitsuba
def asset_bsdf(mi, data: MeshData, colour_srgb) -> dict:
    """The asset's two-sided Lambertian BSDF: its texture, else its vertex colours, else its own
    colour, else ``colour_srgb`` (display sRGB) — RGB that Mitsuba's spectral variants upsample
    (Jakob & Hanika 2019)."""
    if data.texture_file:
        reflectance = {"type": "bitmap", "filename": data.texture_file, "filter_type": "bilinear",
                       "wrap_mode": "repeat"}
    elif data.texture is not None:
        reflectance = {"type": "bitmap", "bitmap": mi.Bitmap(np.ascontiguousarray(data.texture, dtype=np.float32)),
                       "filter_type": "bilinear", "wrap_mode": "repeat"}
    elif data.colours is not None:
        reflectance = {"type": "mesh_attribute", "name": "vertex_color"}
    else:
        linear = data.colour if data.colour is not None else srgb_to_linear(colour_srgb)
        reflectance = {"type": "rgb", "value": [float(v) for v in np.clip(linear, 0.0, 1.0)]}
    return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": reflectance}}


def _rotation(axis: int, degrees: float) -> np.ndarray:
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    i, j = [k for k in range(3) if k != axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def normalising_matrix(spec: AssetSpec, vertices: np.ndarray) -> np.ndarray:
    """4 × 4: the file's ``up`` axis to +z, then the middle of the bounding box's bottom face to
    the origin."""
    m = np.eye(4)
    if spec.up_axis == "y":
        m[:3, :3] = _rotation(0, 90.0)  # (x, y, z) → (x, −z, y): +y goes up
    turned = vertices @ m[:3, :3].T
    low, high = turned.min(axis=0), turned.max(axis=0)
    m[:3, 3] = -np.array([(low[0] + high[0]) / 2, (low[1] + high[1]) / 2, low[2]])
    return m


def placing_matrix(spec: AssetSpec, position, turn_deg: float | None) -> np.ndarray:
    """4 × 4 in the ground frame: scale, turn (``rotation_deg`` about east, north, up, or
    ``turn_deg`` about up), then move to ``position``."""
    if turn_deg is not None:
        rotation = _rotation(2, turn_deg)
    else:
        rx, ry, rz = spec.rotation_deg
        rotation = _rotation(2, rz) @ _rotation(1, ry) @ _rotation(0, rx)
    m = np.eye(4)
    m[:3, :3] = rotation * spec.scale
    m[:3, 3] = position
    return m


# ----------------------------------------------------------------------------- copies
def _copies(config: "SceneConfig", lens: "ThinLens", spec: AssetSpec, index: int):
    """Feet (count, 3) and turns (count,) of an asset's copies (ground frame), by layout_seed."""
    rng = np.random.default_rng(np.random.SeedSequence([config.scene.layout_seed, 0xA55E7, index]))
    turns = rng.uniform(0.0, 360.0, spec.count) if spec.rotation_deg == "random" else None
    base = np.asarray(spec.position_m, dtype=float)
    if spec.count == 1:
        return base[None], turns
    if spec.spread_m > 0:
        radius = spec.spread_m * np.sqrt(rng.uniform(0, 1, spec.count))
        angle = rng.uniform(0, 2 * np.pi, spec.count)
        feet = base + np.stack([radius * np.cos(angle), radius * np.sin(angle), np.zeros(spec.count)], axis=1)
        return feet, turns
    box, inside = ground_in_view(config, lens, 3.0 * config.scene.distance_m)
    found = np.empty((0, 2))
    for _ in range(100):
        candidates = rng.uniform(box[:2], box[2:], size=(4 * spec.count, 2))
        found = np.concatenate([found, candidates[inside(candidates)]])
        if len(found) >= spec.count:
            break
    else:
        raise ConfigError(f"scene.assets[{index}]: no ground in view to place {spec.count} copies on")
    feet = np.concatenate([found[:spec.count], np.full((spec.count, 1), base[2])], axis=1)
    return feet, turns


def asset_objects(config: "SceneConfig", lens: "ThinLens", mi) -> dict:
    """Scene-dict entries of every ``[[scene.assets]]`` entry: one mesh ``name`` for a single
    copy; for more, :func:`place_copies` (a shapegroup ``asset_group_<k>`` and instances
    ``name_<n>``, or one merged mesh ``name``)."""
    from .outdoor import GroundView

    view = GroundView.from_config(config)
    camera = camera_matrix(view)
    objects: dict = {}
    for index, spec in enumerate(config.scene.assets):
        data = read_asset(spec, mi)
        bsdf = asset_bsdf(mi, data, spec.colour)
        normal = normalising_matrix(spec, data.vertices)
        feet, turns = _copies(config, lens, spec, index)
        places = [placing_matrix(spec, feet[k], None if turns is None else float(turns[k])) for k in range(len(feet))]
        if spec.count == 1:
            objects[spec.name] = asset_mesh(mi, spec.name, data, bsdf, camera @ places[0] @ normal)
            continue
        local = dataclasses.replace(data, vertices=data.vertices @ normal[:3, :3].T + normal[:3, 3],
                                    normals=None if data.normals is None else data.normals @ normal[:3, :3].T)
        objects.update(place_copies(mi, camera, local, bsdf, places, name=spec.name, group_key=f"asset_group_{index}",
                                    merged_key=spec.name))
    return objects
