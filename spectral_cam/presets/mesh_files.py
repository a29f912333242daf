"""Users' mesh files as :class:`MeshData`: PLY (read here), OBJ (Mitsuba's loader, its ``.mtl``
read here) and glTF/GLB (through ``trimesh``, the optional ``assets`` extra), each format with
a structural check that needs no Mitsuba (header, element counts, size) and a reader
(:data:`MESH_FORMATS`). Colours come out linear sRGB; texture coordinates in Mitsuba's
convention (v = 0 at the image's top row). :mod:`spectral_cam.presets.assets` places them.

References
----------
.. [1] Turk, G. (1994). The PLY Polygon File Format; Wavefront OBJ and MTL (Alias|Wavefront);
   Khronos Group (2021), glTF 2.0 Specification (§3.4: +Y up, metres; base colour).
.. [2] IEC 61966-2-1:1999 (the sRGB transfer function).
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

__all__ = ["MeshData", "MeshFormat", "MESH_FORMATS", "srgb_to_linear", "read_ply"]


def srgb_to_linear(values) -> np.ndarray:
    """Display sRGB (0–1) → linear sRGB (IEC 61966-2-1)."""
    v = np.asarray(values, dtype=np.float64)
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


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


# ----------------------------------------------------------------------------- PLY
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

def _ascii_element(tokens: list, offset: int, count: int, props: list) -> tuple[list, int]:
    """``count`` rows of an ASCII element from ``tokens[offset:]``; the offset after them."""
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
    return rows, offset


def _binary_list_element(data: bytes, offset: int, count: int, props: list, endian: str) -> tuple[list, int]:
    """``count`` rows of a binary element holding lists, read row by row (most files hold
    triangles: n small); the offset after them."""
    rows = []
    for _ in range(count):
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
    return rows, offset


def _ply_tables(header: _PlyHeader, data: bytes) -> dict:
    """element name -> (its properties, its rows: a structured array where it holds no list,
    else a list of rows)."""
    endian = ">" if header.fmt == "binary_big_endian" else "<"
    tokens = data.split() if header.fmt == "ascii" else None
    offset, tables = 0, {}
    for name, count, props in header.elements:
        if tokens is not None:
            rows, offset = _ascii_element(tokens, offset, count, props)
        elif not any(isinstance(kind, tuple) for _, kind in props):
            dtype = np.dtype([(p, endian + kind) for p, kind in props])
            rows = np.frombuffer(data, dtype, count, offset)
            offset += dtype.itemsize * count
        else:
            rows, offset = _binary_list_element(data, offset, count, props, endian)
        tables[name] = (props, rows)
    return tables


def _ply_column(tables: dict, element: str, prop: str):
    """One property of an element as float64 (None when the element lacks it)."""
    props, rows = tables[element]
    names = [p for p, _ in props]
    if prop not in names:
        return None
    if isinstance(rows, np.ndarray):
        return rows[prop].astype(np.float64)
    k = names.index(prop)
    return np.asarray([row[k] for row in rows], dtype=np.float64)


def read_ply(path: Path, mi=None) -> MeshData:
    """A PLY file's mesh: positions, its polygons fanned into triangles, and where given normals,
    texture coordinates (``u v``, ``s t`` or ``texture_u texture_v``), vertex colours (8-bit or
    float) and a MeshLab ``comment TextureFile``. ``mi`` is unused (the readers' signature)."""
    header = _ply_header(path)
    tables = _ply_tables(header, path.read_bytes()[header.body:])

    def column(element: str, prop: str):
        return _ply_column(tables, element, prop)

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


# ----------------------------------------------------------------------------- OBJ
def _check_obj(path: Path) -> None:
    vertices = faces = 0
    with open(path, "rb") as handle:
        for line in handle:
            vertices += line.startswith(b"v ")
            faces += line.startswith(b"f ")
            if vertices >= 3 and faces:
                return
    raise ValueError("no vertices ('v ') and faces ('f ') found")


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
    :func:`~spectral_cam.presets.placement.asset_mesh` computes them itself."""
    with open(path, "rb") as handle:
        return any(line.lstrip().startswith((b"vn ", b"vn\t")) for line in handle)


def read_obj(path: Path, mi) -> MeshData:
    """An OBJ file's mesh through Mitsuba's loader, with its ``.mtl``'s first texture or colour."""
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


# ----------------------------------------------------------------------------- glTF
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


def read_gltf(path: Path, mi=None) -> MeshData:
    """A glTF/GLB file's meshes (the default scene's, merged by trimesh) with its base-colour
    texture, factor or vertex colours. ``mi`` is unused (the readers' signature)."""
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


# ----------------------------------------------------------------------------- the formats
@dataclass(frozen=True)
class MeshFormat:
    """A mesh file format: what it is (for messages), its structural check without Mitsuba
    (raises ``ValueError`` and the like on a bad file) and its reader ``(path, mi) -> MeshData``."""

    description: str
    check: Callable[[Path], None]
    read: Callable[..., MeshData]


#: The mesh formats by file suffix.
MESH_FORMATS = {
    "ply": MeshFormat("PLY (ASCII or binary; vertex colours, texture coordinates)", _check_ply, read_ply),
    "obj": MeshFormat("Wavefront OBJ (with its .mtl's map_Kd or Kd)", _check_obj, read_obj),
    "gltf": MeshFormat("glTF 2.0 (needs trimesh: pip install 'spectral_cam[assets]')", _check_gltf, read_gltf),
    "glb": MeshFormat("binary glTF 2.0 (needs trimesh)", _check_gltf, read_gltf),
}
