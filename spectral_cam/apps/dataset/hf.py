"""Typed Hugging Face columns and streaming shards of a finished dataset folder.

:func:`write_parquet_shards` writes ``data/split=<split>/NNNNN-of-NNNNN.parquet``: one row per
finished item with every label as a typed ``datasets`` column (PNG labels as ``Image`` with the
file's bytes embedded, EXR, DNG and JSON labels as arrays and numbers, the sampled parameters,
``split``), the ``datasets.Features`` stored in each file's schema. The card's YAML header names
the shards per split (:func:`hf_configs`), so ``datasets.load_dataset(DIR)`` returns a
``DatasetDict`` of the splits, decoded, from any working folder: nothing in a row is a path to
resolve. :func:`write_webdataset_shards` writes ``webdataset/split=<split>/NNNNNN.tar``: every file of
each item as ``<id>.<file name>``, byte for byte, for streaming with the ``webdataset`` package
(or any tar reader).

Every label is read through :func:`spectral_cam.apps.dataset.loader.read_item` (the same arrays
:class:`~spectral_cam.apps.dataset.loader.SyntheticDataset` serves). ``datasets`` is optional
(``pip install 'spectral_cam[hf]'``); nothing here imports it at package import.

References
----------
.. [1] Hugging Face ``datasets``: "Dataset features" (``Image``, ``Array2D`` … ``Array5D``,
   ``Value``, ``List``), "Structure your repository" (``configs``/``data_files`` per split in the
   README's YAML), ``Features.arrow_schema`` (features kept in the Parquet schema's metadata).
.. [2] Apache Parquet format specification; ``pyarrow.parquet.ParquetWriter``.
.. [3] WebDataset format (github.com/webdataset/webdataset): POSIX tar files whose members
   sharing a key (the name up to the first dot) form one sample, stored contiguously.
"""

from __future__ import annotations

import json
import tarfile
from pathlib import Path
from typing import Any, Iterable, Iterator, Mapping, Sequence

import numpy as np

from ...errors import ConfigError
from ...io import staged_directory
from .loader import batchable, read_item

__all__ = ["datasets_installed", "PARQUET_DIR", "WEBDATASET_DIR", "IMAGE_LABELS", "write_parquet_shards", "write_webdataset_shards",
           "hf_features", "hf_configs", "parquet_shards", "webdataset_shards"]

#: Folder of the Parquet shards (Hugging Face's usual ``data/``) and of the WebDataset tars. Each
#: split's shards are in ``split=<name>/``: a file or folder named ``train-…``, ``val-…`` or
#: ``test-…`` would make ``load_dataset("imagefolder", data_dir=DIR)`` infer splits from those
#: names and find no image in them (``datasets.data_files``' split keywords need a non-word
#: character before the name; ``=`` is none).
PARQUET_DIR = "data"
WEBDATASET_DIR = "webdataset"
#: Labels kept as their PNG/JPEG file, decoded by ``datasets.Image`` (PIL): the developed image,
#: its pinhole twin, and the 16-bit instance and class ids (PIL mode ``I;16``: ids as written).
IMAGE_LABELS = ("image", "all_in_focus", "segmentation", "semantic")
#: Rows per Parquet row group: a few items at once in memory while writing.
_ROWS_PER_GROUP = 8
#: Records kept whole, as JSON text, beside their typed numbers.
_RECORDS = ("meta", "camera", "illuminant")


def datasets_installed() -> bool:
    """Whether the ``datasets`` package is importable here (the Parquet shards need it)."""
    import importlib.util

    return importlib.util.find_spec("datasets") is not None


def _require_datasets():
    try:
        import datasets
    except ImportError:
        raise ConfigError("typed Hugging Face columns need the `datasets` package: pip install "
                          "'spectral_cam[hf]' (then rerun the same `spectral-cam dataset` command: it resumes "
                          "and writes the shards)") from None
    return datasets


# ----------------------------------------------------------------------------- rows
def _done_rows(metadata: Sequence[Mapping[str, Any]]) -> list[dict]:
    return sorted((dict(row) for row in metadata), key=lambda row: row["index"])


def _image_file(folder: Path, label: str, meta: Mapping[str, Any]) -> Path | None:
    for name in meta.get("files", []):
        path = Path(name)
        if path.stem == label and path.suffix.lower() in (".png", ".jpg", ".jpeg"):
            return folder / name
    return None


def _item_values(output: Path, row: Mapping[str, Any], params: Sequence[str]) -> dict[str, Any]:
    """One item's column values: image files as ``{"bytes", "path"}``, the loader's arrays, the
    records' numbers (:func:`~.loader.batchable`) and JSON text, the row's scalars and parameters."""
    folder = output / "items" / row["id"]
    meta = json.loads((folder / "meta.json").read_text(encoding="utf-8"))
    images = {label: _image_file(folder, label, meta) for label in IMAGE_LABELS}
    item = read_item(folder)  # every label the item holds; those embedded as files are dropped below
    values: dict[str, Any] = {"id": str(row["id"]), "index": int(row["index"]), "split": row.get("split", "train"),
                              "seed": row.get("seed"), "exposure_s": row.get("exposure_s")}
    values.update({key: row.get(key) for key in params})
    for label, path in images.items():
        if path is not None:
            values[label] = {"bytes": path.read_bytes(), "path": f"items/{row['id']}/{path.name}"}
    numbers = batchable({k: v for k, v in item.items() if k in ("camera", "illuminant")})
    for key, value in item.items():
        if images.get(key) is not None:
            continue
        if key in _RECORDS:
            values[f"{key}_json"] = json.dumps(value, default=_json_default, sort_keys=True)
            if key in numbers:
                values[key] = numbers[key]
        else:
            values[key] = value
    return values


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON")


# ----------------------------------------------------------------------------- features
class _Shapes:
    """Dtypes and shapes of each column over every row, for the one ``Features`` all shards share."""

    def __init__(self):
        self.arrays: dict[str, tuple[np.dtype, set[tuple]]] = {}
        self.scalars: dict[str, list] = {}
        self.structs: dict[str, "_Shapes"] = {}
        self.images: set[str] = set()
        self.order: list[str] = []

    def add(self, values: Mapping[str, Any]) -> None:
        for key, value in values.items():
            if key not in self.order:
                self.order.append(key)
            if isinstance(value, dict) and set(value) == {"bytes", "path"}:
                self.images.add(key)
            elif isinstance(value, dict):
                self.structs.setdefault(key, _Shapes()).add(value)
            elif isinstance(value, np.ndarray):
                dtype, shapes = self.arrays.get(key, (value.dtype, set()))
                self.arrays[key] = (np.promote_types(dtype, value.dtype), shapes | {value.shape})
            else:
                self.scalars.setdefault(key, []).append(value)

    def features(self) -> dict:
        datasets = _require_datasets()
        out = {}
        for key in self.order:
            if key in self.images:
                out[key] = datasets.Image()
            elif key in self.structs:
                out[key] = datasets.Features(self.structs[key].features())
            elif key in self.arrays:
                out[key] = _array_feature(*self.arrays[key])
            else:
                out[key] = _scalar_feature(self.scalars[key])
        return out


def _array_feature(dtype: np.dtype, shapes: set[tuple]):
    """``Array2D`` … ``Array5D`` of the arrays' common shape (the first axis None where it varies:
    the only axis those may leave open), a fixed-length ``List`` for a vector, and nested
    ``List`` where any other axis varies among items (e.g. the number of lights)."""
    datasets = _require_datasets()
    ndims = {len(s) for s in shapes}
    value = datasets.Value(np.dtype(dtype).name)
    if len(ndims) != 1:
        raise ConfigError(f"a label has arrays of {sorted(ndims)} dimensions among the items; one label, one rank")
    ndim = ndims.pop()
    axes = [sorted({s[k] for s in shapes}) for k in range(ndim)]
    if ndim == 1:
        return datasets.List(value, length=axes[0][0] if len(axes[0]) == 1 else -1)
    if all(len(a) == 1 for a in axes[1:]) and 2 <= ndim <= 5:
        shape = (axes[0][0] if len(axes[0]) == 1 else None, *(a[0] for a in axes[1:]))
        return getattr(datasets, f"Array{ndim}D")(shape=shape, dtype=np.dtype(dtype).name)
    feature = value
    for _ in range(ndim):
        feature = datasets.List(feature)
    return feature


def _scalar_feature(values: list):
    """The ``datasets`` type of a column of numbers, strings or lists (pyarrow's inference over
    every row), or ``string`` (JSON text) where the rows mix types."""
    import pyarrow as pa

    datasets = _require_datasets()
    try:
        arrow_type = pa.array(values).type
    except (pa.ArrowInvalid, pa.ArrowTypeError):
        return datasets.Value("string")
    if pa.types.is_null(arrow_type):
        return datasets.Value("string")
    return datasets.Features.from_arrow_schema(pa.schema([("v", arrow_type)]))["v"]


def _coerce(value: Any, feature) -> Any:
    """A value in the form its feature encodes: JSON text for a column typed string from mixed rows."""
    datasets = _require_datasets()
    if isinstance(feature, datasets.Value) and feature.dtype in ("string", "large_string") and value is not None \
            and not isinstance(value, str):
        return json.dumps(value, default=_json_default, sort_keys=True)
    return value


def hf_features(output: str | Path, metadata: Sequence[Mapping[str, Any]], params: Sequence[str] = ()):
    """The ``datasets.Features`` of a dataset's Parquet rows (reads every item once).

    Parameters
    ----------
    output
        The dataset folder.
    metadata
        Its ``metadata.jsonl`` rows (:func:`~.card.metadata_rows`).
    params
        Sampled parameter keys (their own columns, as in metadata.jsonl).

    Returns
    -------
    datasets.Features
    """
    datasets = _require_datasets()
    shapes = _Shapes()
    for row in _done_rows(metadata):
        shapes.add(_item_values(Path(output), row, params))
    return datasets.Features(shapes.features())


# ----------------------------------------------------------------------------- Parquet
def _chunks(rows: Sequence[dict], size: int) -> list[list[dict]]:
    return [list(rows[k:k + size]) for k in range(0, len(rows), size)]


def _by_split(rows: Iterable[dict], splits: Sequence[str]) -> dict[str, list[dict]]:
    grouped = {name: [] for name in splits}
    for row in rows:
        grouped.setdefault(row.get("split", "train"), []).append(row)
    return {name: found for name, found in grouped.items() if found}


def write_parquet_shards(output: str | Path, metadata: Sequence[Mapping[str, Any]], *, splits: Sequence[str],
                         params: Sequence[str] = (), shard_items: int = 1000) -> dict[str, list[str]]:
    """Write ``<output>/data/split=<split>/NNNNN-of-NNNNN.parquet`` (the folder replaced in one rename).

    Parameters
    ----------
    output
        The dataset folder.
    metadata
        Its ``metadata.jsonl`` rows (each with ``id``, ``index``, ``split``).
    splits
        The spec's split names, in order (a split without items gets no file).
    params
        Sampled parameter keys, each its own column.
    shard_items
        Items per file at most.

    Returns
    -------
    dict
        ``{split: [shard paths relative to output]}``.

    Raises
    ------
    ConfigError
        Without the ``datasets`` package.

    References
    ----------
    .. [1] Hugging Face ``datasets``: ``Features.encode_example``, ``Features.arrow_schema``.
    """
    import pyarrow.parquet as pq

    output = Path(output)
    features = hf_features(output, metadata, params)
    schema = features.arrow_schema
    written: dict[str, list[str]] = {}
    with staged_directory(output / PARQUET_DIR, force=True) as stage:
        for split, rows in _by_split(_done_rows(metadata), splits).items():
            shards = _chunks(rows, shard_items)
            for k, shard in enumerate(shards):
                name = f"split={split}/{k:05d}-of-{len(shards):05d}.parquet"
                (stage / name).parent.mkdir(exist_ok=True)
                with pq.ParquetWriter(stage / name, schema) as writer:
                    for group in _chunks(shard, _ROWS_PER_GROUP):
                        writer.write_table(_table(output, group, params, features))
                written.setdefault(split, []).append(f"{PARQUET_DIR}/{name}")
    return written


def _table(output: Path, rows: Sequence[dict], params: Sequence[str], features):
    """The rows' values as an Arrow table of ``features`` (``datasets`` encodes the images and
    builds its array extension types from the NumPy arrays)."""
    datasets = _require_datasets()
    columns: dict[str, list] = {key: [] for key in features}
    for row in rows:
        values = _item_values(output, row, params)
        for key, feature in features.items():
            columns[key].append(_coerce(values.get(key), feature))
    table = datasets.Dataset.from_dict(columns, features=features).data.table
    return table.replace_schema_metadata(features.arrow_schema.metadata)


def parquet_shards(output: str | Path) -> dict[str, list[str]]:
    """``{split: [shard paths relative to output]}`` of the Parquet shards in a dataset folder."""
    return _shards(Path(output), PARQUET_DIR, "*.parquet")


def _shards(output: Path, folder: str, pattern: str) -> dict[str, list[str]]:
    found: dict[str, list[str]] = {}
    for path in sorted((output / folder).glob(f"split=*/{pattern}")):
        found.setdefault(path.parent.name.removeprefix("split="), []).append(path.relative_to(output).as_posix())
    return found


def hf_configs(shards: Mapping[str, Sequence[str]], splits: Sequence[str]) -> list[str]:
    """The card's YAML ``configs`` lines: the default config's ``data_files``, one entry per
    split holding items (in the spec's order), each a glob of its Parquet shards."""
    lines = ["configs:", "- config_name: default", "  data_files:"]
    for split in [s for s in splits if s in shards] + sorted(set(shards) - set(splits)):
        lines += [f"  - split: {split}", f"    path: {PARQUET_DIR}/split={split}/*.parquet"]
    return lines


# ----------------------------------------------------------------------------- WebDataset
def _tar_info(name: str, size: int) -> tarfile.TarInfo:
    """A regular file's header: owner, group and time fixed, so a shard depends on its items only."""
    info = tarfile.TarInfo(name)
    info.size, info.mode, info.mtime, info.uid, info.gid, info.uname, info.gname = size, 0o644, 0, 0, 0, "", ""
    return info


def _item_members(output: Path, row: Mapping[str, Any]) -> Iterator[tuple[str, Path]]:
    """(member name, file) of an item: ``<id>.<file name>``, meta.json last as the item wrote it."""
    folder = output / "items" / row["id"]
    meta = json.loads((folder / "meta.json").read_text(encoding="utf-8"))
    for name in meta.get("files", []):
        if "/" in name or not (folder / name).is_file():
            continue
        yield f"{row['id']}.{name}", folder / name


def write_webdataset_shards(output: str | Path, metadata: Sequence[Mapping[str, Any]], *, splits: Sequence[str],
                            shard_items: int = 1000) -> dict[str, list[str]]:
    """Write ``<output>/webdataset/split=<split>/NNNNNN.tar``: each item's files as ``<id>.<file name>``
    (e.g. ``000042.image.png``, ``000042.depth.exr``, ``000042.meta.json``), byte for byte,
    the members of one item together, items in index order, at most ``shard_items`` a tar.

    POSIX.1-2001 (pax) tar, as Python's ``tarfile`` and the ``webdataset`` package read it::

        import webdataset as wds
        for sample in wds.WebDataset("webdataset/split=train/{000000..000003}.tar"):
            sample["__key__"], sample["image.png"], sample["depth.exr"]   # bytes

    Returns
    -------
    dict
        ``{split: [tar paths relative to output]}``.

    References
    ----------
    .. [1] WebDataset format: keys and extensions split at the first dot of the member's base name.
    .. [2] IEEE Std 1003.1-2001, pax interchange format; Python ``tarfile.PAX_FORMAT``.
    """
    output = Path(output)
    written: dict[str, list[str]] = {}
    with staged_directory(output / WEBDATASET_DIR, force=True) as stage:
        for split, rows in _by_split(_done_rows(metadata), splits).items():
            for k, shard in enumerate(_chunks(rows, shard_items)):
                name = f"split={split}/{k:06d}.tar"
                (stage / name).parent.mkdir(exist_ok=True)
                with tarfile.open(stage / name, "w", format=tarfile.PAX_FORMAT) as tar:
                    for row in shard:
                        for member, path in _item_members(output, row):
                            with open(path, "rb") as handle:
                                tar.addfile(_tar_info(member, path.stat().st_size), handle)
                written.setdefault(split, []).append(f"{WEBDATASET_DIR}/{name}")
    return written


def webdataset_shards(output: str | Path) -> dict[str, list[str]]:
    """``{split: [tar paths relative to output]}`` of the WebDataset shards in a dataset folder."""
    return _shards(Path(output), WEBDATASET_DIR, "*.tar")
