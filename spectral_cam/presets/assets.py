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
import json
import math
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping

import numpy as np

from ..errors import ConfigError

if TYPE_CHECKING:  # pragma: no cover
    from ..optics import ThinLens
    from ..scene import SceneConfig

__all__ = ["ASSET_FORMATS", "BUNDLED", "AssetSpec", "asset_from_table", "check_asset_file", "read_asset",
           "MeshData", "asset_objects", "asset_bsdf", "asset_mesh", "srgb_to_linear", "ASSET_KEYS", "ground_in_view",
           "use_instances", "place_copies", "merge_copies", "camera_matrix"]

#: The file formats an asset may be in, by suffix.
ASSET_FORMATS = {
    "ply": "PLY (ASCII or binary; vertex colours, texture coordinates)",
    "obj": "Wavefront OBJ (with its .mtl's map_Kd or Kd)",
    "gltf": "glTF 2.0 (needs trimesh: pip install 'spectral_cam[assets]')",
    "glb": "binary glTF 2.0 (needs trimesh)",
}
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


def srgb_to_linear(values) -> np.ndarray:
    """Display sRGB (0–1) → linear sRGB (IEC 61966-2-1)."""
    v = np.asarray(values, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def asset_path(file: str) -> Path:
    """The file an asset's ``file`` names: a bundled asset's id, else the path itself."""
    return ASSET_FOLDER / BUNDLED[file] if file in BUNDLED else Path(file)


# ----------------------------------------------------------------------------- checks without Mitsuba
_PLY_TYPES = {"char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1", "short": "i2", "int16": "i2",
              "ushort": "u2", "uint16": "u2", "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
              "float": "f4", "float32": "f4", "double": "f8", "float64": "f8"}


@dataclass
class _PlyHeader:
    fmt: str
    elements: list  # (name, count, [(prop, dtype) | (prop, ("list", count dtype, item dtype))])
    comments: list
    body: int  # byte offset of the data


def _ply_header(path: Path) -> _PlyHeader:
    with open(path, "rb") as handle:
        head = handle.read(1 << 16)
    end = head.find(b"end_header")
    if not head.startswith(b"ply") or end < 0:
        raise ValueError("no 'ply' magic or no end_header in the first 64 KiB")
    body = head.index(b"\n", end) + 1
    fmt, elements, comments = "", [], []
    for line in head[:end].decode("ascii", "replace").splitlines()[1:]:
        words = line.split()
        if not words:
            continue
        if words[0] == "format":
            fmt = words[1]
        elif words[0] in ("comment", "obj_info"):
            comments.append(" ".join(words[1:]))
        elif words[0] == "element":
            elements.append((words[1], int(words[2]), []))
        elif words[0] == "property":
            if not elements:
                raise ValueError("a property before any element")
            if words[1] == "list":
                elements[-1][2].append((words[4], ("list", _PLY_TYPES[words[2]], _PLY_TYPES[words[3]])))
            else:
                elements[-1][2].append((words[2], _PLY_TYPES[words[1]]))
    if fmt not in ("ascii", "binary_little_endian", "binary_big_endian"):
        raise ValueError(f"unknown format {fmt!r}")
    return _PlyHeader(fmt, elements, comments, body)


def _check_ply(path: Path) -> None:
    header = _ply_header(path)
    counts = {name: count for name, count, _ in header.elements}
    if counts.get("vertex", 0) < 3 or counts.get("face", 0) < 1:
        raise ValueError("needs a vertex element (3 or more) and a face element (a point cloud is no surface)")
    props = [p for name, _, ps in header.elements if name == "vertex" for p, _ in ps]
    if not {"x", "y", "z"} <= set(props):
        raise ValueError("the vertex element has no x, y, z")
    if header.fmt != "ascii":
        fixed = sum(np.dtype(t).itemsize for name, _, ps in header.elements if name == "vertex" for _, t in ps
                    if not isinstance(t, tuple))
        if path.stat().st_size < header.body + fixed * counts["vertex"]:
            raise ValueError("the file ends before its vertices do (truncated)")


def _check_obj(path: Path) -> None:
    vertices = faces = 0
    with open(path, "rb") as handle:
        for line in handle:
            vertices += line.startswith(b"v ")
            faces += line.startswith(b"f ")
            if vertices >= 3 and faces:
                return
    raise ValueError("no vertices ('v ') and faces ('f ') found")


def _check_gltf(path: Path) -> None:
    import importlib.util

    if importlib.util.find_spec("trimesh") is None:
        raise ValueError("glTF/GLB assets are read through trimesh, which is not installed: pip install trimesh "
                         "(or the 'assets' extra)")
    if path.suffix.lower() == ".glb":
        with open(path, "rb") as handle:
            magic, version, length = struct.unpack("<4sII", handle.read(12).ljust(12, b"\0"))
        if magic != b"glTF" or version != 2:
            raise ValueError("no binary glTF 2.0 header (magic 'glTF', version 2)")
        if length != path.stat().st_size:
            raise ValueError(f"its header says {length} bytes, the file has {path.stat().st_size} (truncated?)")
        return
    document = json.loads(path.read_text(encoding="utf-8"))
    if not isinstance(document, dict) or "asset" not in document or not document.get("meshes"):
        raise ValueError("not a glTF 2.0 document with meshes")


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
        {"ply": _check_ply, "obj": _check_obj, "gltf": _check_gltf, "glb": _check_gltf}[suffix](path)
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
@dataclass
class MeshData:
    """A triangle mesh as read: positions (n, 3), triangles (m, 3), and where present normals
    (n, 3), texture coordinates (n, 2; Mitsuba's: v = 0 at the image's top row, the flip of OBJ's,
    PLY's and trimesh's v up, which Mitsuba's own OBJ loader flips), linear-sRGB vertex colours
    (n, 3), a texture (a file Mitsuba reads, or a linear-sRGB (h, w, 3) array) or a linear-sRGB
    colour."""

    vertices: np.ndarray
    faces: np.ndarray
    normals: np.ndarray | None = None
    uv: np.ndarray | None = None
    colours: np.ndarray | None = None
    texture_file: str = ""
    texture: np.ndarray | None = None
    colour: tuple[float, float, float] | None = None


def _read_ply(path: Path) -> MeshData:
    header = _ply_header(path)
    data = path.read_bytes()[header.body:]
    endian = ">" if header.fmt == "binary_big_endian" else "<"
    tokens = data.split() if header.fmt == "ascii" else None
    offset, tables = 0, {}
    for name, count, props in header.elements:
        if tokens is not None:
            rows = []
            for _ in range(count):
                row = []
                for _, kind in props:
                    if isinstance(kind, tuple):
                        n = int(tokens[offset])
                        row.append([float(t) for t in tokens[offset + 1:offset + 1 + n]])
                        offset += 1 + n
                    else:
                        row.append(float(tokens[offset]))
                        offset += 1
                rows.append(row)
            tables[name] = (props, rows)
            continue
        if not any(isinstance(kind, tuple) for _, kind in props):
            dtype = np.dtype([(p, endian + kind) for p, kind in props])
            tables[name] = (props, np.frombuffer(data, dtype, count, offset))
            offset += dtype.itemsize * count
            continue
        rows = []
        for _ in range(count):  # lists: most files hold triangles; read row by row (n small)
            row = []
            for _, kind in props:
                if isinstance(kind, tuple):
                    size_t, item_t = np.dtype(endian + kind[1]), np.dtype(endian + kind[2])
                    n = int(np.frombuffer(data, size_t, 1, offset)[0])
                    row.append(np.frombuffer(data, item_t, n, offset + size_t.itemsize))
                    offset += size_t.itemsize + n * item_t.itemsize
                else:
                    item_t = np.dtype(endian + kind)
                    row.append(float(np.frombuffer(data, item_t, 1, offset)[0]))
                    offset += item_t.itemsize
            rows.append(row)
        tables[name] = (props, rows)

    def column(element: str, prop: str):
        props, rows = tables[element]
        names = [p for p, _ in props]
        if prop not in names:
            return None
        if isinstance(rows, np.ndarray):
            return rows[prop].astype(np.float64)
        k = names.index(prop)
        return np.asarray([row[k] for row in rows], dtype=np.float64)

    vertices = np.stack([column("vertex", a) for a in "xyz"], axis=1)
    props, rows = tables["face"]
    names = [p for p, _ in props]
    key = "vertex_indices" if "vertex_indices" in names else "vertex_index"
    k = names.index(key)
    faces = [(poly[0], poly[i], poly[i + 1]) for poly in (row[k] for row in rows) for i in range(1, len(poly) - 1)]
    out = MeshData(vertices, np.asarray(faces, dtype=np.int64))
    normals = [column("vertex", a) for a in ("nx", "ny", "nz")]
    if all(n is not None for n in normals):
        out.normals = np.stack(normals, axis=1)
    for u_name, v_name in (("u", "v"), ("s", "t"), ("texture_u", "texture_v")):
        u, v = column("vertex", u_name), column("vertex", v_name)
        if u is not None and v is not None:
            out.uv = np.stack([u, 1.0 - v], axis=1)  # v up (OpenGL's, MeshLab's) → Mitsuba's
            break
    colours = [column("vertex", c) for c in ("red", "green", "blue")]
    if all(c is not None for c in colours):
        rgb = np.stack(colours, axis=1)
        kinds = dict(tables["vertex"][0])
        if np.dtype(kinds["red"]).kind in "iu":
            rgb = rgb / float(np.iinfo(np.dtype(kinds["red"])).max)
        out.colours = srgb_to_linear(np.clip(rgb, 0.0, 1.0))
    for comment in header.comments:  # MeshLab's texture reference
        if comment.startswith("TextureFile"):
            candidate = path.parent / comment.split(None, 1)[1].strip()
            if candidate.is_file() and out.uv is not None:
                out.texture_file = str(candidate)
    if len(out.faces) and (out.faces.min() < 0 or out.faces.max() >= len(vertices)):
        raise ValueError("a face names a vertex the file does not have")
    return out


def _mtl_material(obj: Path) -> tuple[str, tuple | None]:
    """The first material's diffuse texture (a file) and colour (linear) of an OBJ's .mtl."""
    library = None
    with open(obj, "r", encoding="utf-8", errors="replace") as handle:
        for line in handle:
            if line.startswith("mtllib"):
                library = obj.parent / line.split(None, 1)[1].strip()
                break
    if library is None or not library.is_file():
        return "", None
    texture, colour = "", None
    for line in library.read_text(encoding="utf-8", errors="replace").splitlines():
        words = line.split()
        if not words:
            continue
        if words[0] == "newmtl" and (texture or colour):
            break  # the first material only
        if words[0] == "map_Kd" and len(words) > 1:
            candidate = obj.parent / words[-1]  # options (-s, -o …) come before the file
            texture = str(candidate) if candidate.is_file() else ""
        elif words[0] == "Kd" and len(words) >= 4:
            colour = tuple(float(w) for w in words[1:4])
    return texture, colour


def _obj_has_normals(path: Path) -> bool:
    """Whether the OBJ file gives vertex normals (``vn`` lines). Without them Mitsuba computes
    them with a scatter-add whose order follows its threads (issue 39 #17), so
    :func:`asset_mesh` computes them itself."""
    with open(path, "rb") as handle:
        return any(line.lstrip().startswith((b"vn ", b"vn\t")) for line in handle)


def _read_obj(path: Path, mi) -> MeshData:
    mesh = mi.load_dict({"type": "obj", "filename": str(path), "face_normals": False})
    params = mi.traverse(mesh)
    vertices = np.asarray(params["vertex_positions"], dtype=np.float64).reshape(-1, 3)
    out = MeshData(vertices, np.asarray(params["faces"], dtype=np.int64).reshape(-1, 3))
    if mesh.has_vertex_normals() and _obj_has_normals(path):  # else Mitsuba summed them on its threads: ours
        out.normals = np.asarray(params["vertex_normals"], dtype=np.float64).reshape(-1, 3)
    if mesh.has_vertex_texcoords():
        out.uv = np.asarray(params["vertex_texcoords"], dtype=np.float64).reshape(-1, 2)  # flipped by Mitsuba
    texture, colour = _mtl_material(path)
    if texture and out.uv is not None:
        out.texture_file = texture
    elif colour is not None:
        out.colour = colour
    return out


def _read_gltf(path: Path) -> MeshData:
    import trimesh

    mesh = trimesh.load(str(path), force="mesh", process=False)
    out = MeshData(np.asarray(mesh.vertices, dtype=np.float64), np.asarray(mesh.faces, dtype=np.int64))
    if len(out.faces) == 0:
        raise ValueError("no triangles")
    out.normals = np.asarray(mesh.vertex_normals, dtype=np.float64)
    visual = mesh.visual
    if getattr(visual, "kind", None) == "texture":
        material = visual.material
        image = getattr(material, "baseColorTexture", None) or getattr(material, "image", None)
        factor = getattr(material, "baseColorFactor", None)
        if factor is None:
            factor = getattr(material, "main_color", None)
        if image is not None and visual.uv is not None:
            out.uv = np.asarray(visual.uv, dtype=np.float64) * [1.0, -1.0] + [0.0, 1.0]  # trimesh's v up
            out.texture = srgb_to_linear(np.asarray(image.convert("RGB"), dtype=np.float64) / 255.0)
        elif factor is not None:
            factor = np.asarray(factor, dtype=np.float64)[:3]
            out.colour = tuple(factor / 255.0 if factor.max() > 1.0 else factor)
    elif getattr(visual, "kind", None) == "vertex":
        rgb = np.asarray(visual.vertex_colors, dtype=np.float64)[:, :3] / 255.0
        out.colours = srgb_to_linear(rgb)
    return out


def read_asset(spec: AssetSpec, mi) -> MeshData:
    """The asset's mesh and colours as read from its file (``spec.texture`` replaces a texture).

    Raises
    ------
    ConfigError
        When the file cannot be read as its format, naming the valid formats.
    """
    path = spec.path
    try:
        if spec.format == "ply":
            data = _read_ply(path)
        elif spec.format == "obj":
            data = _read_obj(path, mi)
        else:
            data = _read_gltf(path)
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


def asset_mesh(mi, name: str, data: MeshData, bsdf: dict, matrix: np.ndarray | None = None):
    """A Mitsuba mesh of ``data`` (its positions and normals moved by the 4 × 4 ``matrix``, a
    rotation, uniform scale and translation), with texture coordinates and the
    ``vertex_color`` attribute where it has them."""
    vertices, normals = data.vertices, data.normals
    if matrix is not None:
        vertices = vertices @ matrix[:3, :3].T + matrix[:3, 3]
        if normals is not None:
            normals = normals @ matrix[:3, :3].T
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    mesh = mi.Mesh(name, len(vertices), len(data.faces), props=props, has_vertex_normals=True,
                   has_vertex_texcoords=data.uv is not None)
    mesh.set_id(name)  # a scene dict's key names it too; a shapegroup's inner mesh keeps this one
    params = mi.traverse(mesh)
    floats, indices = type(params["vertex_positions"]), type(params["faces"])  # the variant's own (scalar too)
    if data.colours is not None:
        mesh.add_attribute("vertex_color", 3, floats(np.ascontiguousarray(data.colours, dtype=np.float32).ravel()))
        params = mi.traverse(mesh)
    params["vertex_positions"] = floats(np.ascontiguousarray(vertices, dtype=np.float32).ravel())
    params["faces"] = indices(np.ascontiguousarray(data.faces, dtype=np.uint32).ravel())
    if data.uv is not None:
        params["vertex_texcoords"] = floats(np.ascontiguousarray(data.uv, dtype=np.float32).ravel())
    params.update()
    if normals is not None and np.all(np.isfinite(normals)):
        unit = normals / np.maximum(np.linalg.norm(normals, axis=1, keepdims=True), 1e-12)
        params["vertex_normals"] = floats(np.ascontiguousarray(unit, dtype=np.float32).ravel())
        params.update()
    else:  # ours, in a fixed order: Mitsuba's sums follow its threads' timing (issue 39 #17)
        from .meshes import set_vertex_normals, vertex_normals

        set_vertex_normals(mi, mesh, vertex_normals(vertices, data.faces))
    return mesh


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
#: Fraction of the frame (each way) a copy's foot may lie beyond and still be drawn (its body
#: reaches into view).
VIEW_MARGIN = 1.1


def ground_in_view(config: "SceneConfig", lens: "ThinLens", reach_m: float):
    """``(box, inside)``: a ground-frame box ``(east0, north0, east1, north1)`` around the ground
    the frame (grown by :data:`VIEW_MARGIN`) sees within ``reach_m`` of the camera's foot, and a
    function telling which (n, 2) ground points lie in that region."""
    from .outdoor import GroundView

    view = GroundView.from_config(config)
    half_x = VIEW_MARGIN * lens.sensor_width_m / (2 * lens.image_distance_m)
    half_y = VIEW_MARGIN * lens.sensor_height_m / (2 * lens.image_distance_m)
    foot = view.camera_m[:2]

    def inside(points: np.ndarray) -> np.ndarray:
        points = np.asarray(points, dtype=float).reshape(-1, 2)
        ground = np.concatenate([points, np.zeros((len(points), 1))], axis=1)
        camera = view.to_camera(ground)
        z = camera[:, 2]
        in_frame = (z > 0) & (np.abs(camera[:, 0]) <= half_x * z) & (np.abs(camera[:, 1]) <= half_y * z)
        return in_frame & (np.hypot(*(points - foot).T) <= reach_m)

    # the frame's outline cast onto the ground, each ray held to reach_m: the region's bounding box
    t = np.linspace(-1.0, 1.0, 17)
    edge = np.concatenate([np.stack([t, np.full_like(t, s)], 1) for s in (-1, 1)]
                          + [np.stack([np.full_like(t, s), t], 1) for s in (-1, 1)])
    points = [foot]
    for u, v in edge:
        direction = view.rotation.T @ np.array([u * half_x, v * half_y, 1.0])
        horizontal = np.hypot(*direction[:2])
        if direction[2] < 0:
            hit = view.camera_m + (-view.camera_m[2] / direction[2]) * direction
            if np.hypot(*(hit[:2] - foot)) <= reach_m:
                points.append(hit[:2])
                continue
        if horizontal > 1e-12:
            points.append(foot + reach_m * direction[:2] / horizontal)
    points = np.asarray(points)
    return (*points.min(axis=0), *points.max(axis=0)), inside


def camera_matrix(view) -> np.ndarray:
    """4 × 4: ground frame → the presets' camera frame (:meth:`GroundView.transform` in NumPy)."""
    m = np.eye(4)
    m[:3, :3] = view.rotation
    m[:3, 3] = -view.rotation @ view.camera_m
    return m


def use_instances(mi) -> bool:
    """Whether copies become Mitsuba ``instance``s of a ``shapegroup`` (else one merged mesh).

    Instances hold a transform each (measured in ``scalar_spectral``: 10 000 instances of a
    528-triangle stone peaked at 165 MB against 118 MB for one). In the JIT variants of
    Mitsuba up to 3.9.1, though, every instance is traced into the kernel as a virtual-call
    target of its own: 300 instances took 17 s and 258 MB, 1000 took 68 s and 732 MB (llvm,
    32² px, 1 spp), where 10 000 copies merged into one mesh took 18 s and 1.0 GB (mitsuba3
    issue #1017; pull request #1945, "Resolve instancing at the scene level", came after
    3.9.1). So: instances in the scalar variants and in Mitsuba releases after 3.9.1, merged
    copies in the JIT variants before.
    """
    import re

    if mi.variant().startswith("scalar"):
        return True
    version = tuple(int(part) for part in re.findall(r"\d+", str(mi.__version__))[:3])
    return version > (3, 9, 1)


def merge_copies(data: MeshData, matrices) -> MeshData:
    """One mesh holding ``data`` moved by each 4 × 4 matrix (rotation, uniform scale, move)."""
    mats = np.asarray(matrices, dtype=np.float64).reshape(-1, 4, 4)
    k, n = len(mats), len(data.vertices)
    vertices = np.einsum("kij,nj->kni", mats[:, :3, :3], data.vertices) + mats[:, None, :3, 3]
    faces = data.faces[None] + (np.arange(k, dtype=np.int64) * n)[:, None, None]
    out = MeshData(vertices.reshape(-1, 3), faces.reshape(-1, 3), texture_file=data.texture_file,
                   texture=data.texture, colour=data.colour)
    if data.normals is not None:
        out.normals = np.einsum("kij,nj->kni", mats[:, :3, :3], data.normals).reshape(-1, 3)
    if data.uv is not None:
        out.uv = np.tile(data.uv, (k, 1))
    if data.colours is not None:
        out.colours = np.tile(data.colours, (k, 1))
    return out


def place_copies(mi, camera: np.ndarray, data: MeshData, bsdf: dict, placements, *, name: str, group_key: str,
                 merged_key: str, first: int = 0) -> dict:
    """Scene-dict entries of ``data`` at each ground-frame 4 × 4 in ``placements`` (``camera``:
    :func:`camera_matrix`): a shapegroup ``group_key`` holding mesh ``name`` and instances
    ``<name>_<first + n>`` where :func:`use_instances`, else one mesh ``merged_key`` (named
    ``name``) holding every copy."""
    if use_instances(mi):
        entries = {group_key: {"type": "shapegroup", name: asset_mesh(mi, name, data, bsdf)}}
        ref = {"type": "ref", "id": group_key}
        for n, local in enumerate(placements):
            entries[f"{name}_{first + n}"] = {"type": "instance", "shapegroup": ref,
                                              "to_world": mi.ScalarTransform4f(camera @ local)}
        return entries
    return {merged_key: asset_mesh(mi, name, merge_copies(data, [camera @ local for local in placements]), bsdf)}


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
