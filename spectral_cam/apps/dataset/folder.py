"""The dataset folder between runs: its lock, dataset.json, manifest.jsonl, and which items are complete.

A run holds the folder's lock (:func:`folder_lock`), claims it for its spec (:func:`claim_folder`:
dataset.json, staging leftovers and a larger earlier run's items removed), keeps
``manifest.jsonl`` (:func:`write_manifest`, one row per item), and resumes: an item whose folder
holds this spec's, seed's and parameters' files, each of the size and SHA-256 it was written with,
is done (:func:`finished_meta`, :func:`done_row`; after an interrupt, :func:`settle_pending`).
Resumed items rendered on another Mitsuba variant are warned about
(:class:`ResumeVariantWarning`).
"""

from __future__ import annotations

import contextlib
import json
import re
import shutil
import sys
from pathlib import Path
from typing import Any, Iterator, Mapping, Sequence

from ...errors import ConfigError
from ...io import atomic_path
from ...records import json_ready, read_json, write_json
from .labels import file_check
from .spec import DatasetSpec

__all__ = ["ResumeVariantWarning", "claim_folder", "done_row", "finished_meta", "folder_lock", "remove_partials",
           "settle_pending", "warn_on_another_variant", "write_manifest"]

_MANIFEST_KEYS = ("index", "id", "split", "status", "resumed", "seed", "params", "files", "labels", "error", "attempts",
                  "seconds", "exposure_s", "variant", "file_checks", "path")


def done_row(base: Mapping[str, Any], meta: Mapping[str, Any], *, resumed: bool) -> dict:
    """The manifest row of an item found complete on disk (from its meta.json)."""
    item_id = base["id"]
    return {**base, "status": "done", "resumed": resumed, "files": [f"items/{item_id}/{name}" for name in meta["files"]],
            "error": None, "exposure_s": meta.get("sensor", {}).get("exposure_s"),
            "seconds": meta.get("timings_s", {}).get("total"), "variant": meta.get("render", {}).get("variant"),
            "file_checks": meta["dataset"]["file_checks"], "labels": meta["dataset"].get("labels")}


def finished_meta(item_dir: Path, spec_hash: str, outputs: Sequence[str], seed: int, params: Mapping) -> dict | None:
    """The item's meta when its folder is complete for this spec, this item's planned seed
    and parameters (a sweep re-plans items when ``-n`` changes), and these outputs, and every
    file still has the size and SHA-256 it was written with."""
    meta = read_json(item_dir / "meta.json")
    if not isinstance(meta, dict) or not isinstance(meta.get("dataset"), dict):
        return None
    if meta["dataset"].get("spec_hash") != spec_hash or not set(outputs) <= set(meta["dataset"].get("outputs", [])):
        return None
    if meta["dataset"].get("seed") != seed or meta["dataset"].get("params") != json_ready(params):
        return None
    checks = meta["dataset"].get("file_checks")
    if not isinstance(checks, dict):
        return None
    for name in meta.get("files", []):
        if name == "meta.json":
            continue
        path = item_dir / name
        if name not in checks or not path.is_file() or path.stat().st_size != checks[name].get("bytes"):
            return None
        if file_check(path) != checks[name]:
            return None
    return meta


def warn_on_another_variant(rows: Mapping[int, dict], progress: bool) -> None:
    """Warn when the items kept from an earlier run were rendered with another Mitsuba variant
    than the new ones will be: the same seed draws different samples on scalar and LLVM, so
    the dataset would mix two noise realisations without saying so."""
    import warnings

    kept = {r.get("variant") for r in rows.values() if r.get("resumed") and r.get("variant")}
    new = {r.get("variant") for r in rows.values() if not r.get("resumed") and r.get("variant")}
    others = sorted(kept - new)
    if new and others:
        message = (f"resumed items were rendered with {', '.join(others)}, the items rendered now use "
                   f"{', '.join(sorted(new))}: "
                   "the same seed draws other samples on another variant (the manifest records each item's); "
                   "use --force to render every item on this one")
        warnings.warn(message, ResumeVariantWarning, stacklevel=3)
        if progress:
            print(f"dataset: warning: {message}", file=sys.stderr)


class ResumeVariantWarning(UserWarning):
    """A resumed dataset mixes items of two Mitsuba variants."""


def remove_partials(items_dir: Path, item_id: str | None = None) -> None:
    """Remove staging leftovers (``.<id>.partial-*``, ``.<id>.old-*``) of dead attempts."""
    if not items_dir.is_dir():
        return
    pattern = re.compile(rf"^\.{re.escape(item_id) if item_id else '[0-9]+'}\.(partial|old)-")
    for entry in items_dir.iterdir():
        if pattern.match(entry.name):
            shutil.rmtree(entry, ignore_errors=True) if entry.is_dir() else entry.unlink(missing_ok=True)


@contextlib.contextmanager
def folder_lock(output: Path) -> Iterator[None]:
    """Hold ``output``'s ``.dataset.lock`` (created with the folder) for the run.

    Raises
    ------
    ConfigError
        When another run holds it.

    References
    ----------
    .. [1] POSIX ``flock`` (``LOCK_EX | LOCK_NB``), released when the file is closed or the process ends.
    """
    import fcntl

    output.mkdir(parents=True, exist_ok=True)
    handle = open(output / ".dataset.lock", "w")
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise ConfigError(f"another spectral-cam dataset run is writing {output}; wait for it or "
                              f"choose another -o") from None
        yield
    finally:
        handle.close()


def claim_folder(output: Path, spec: DatasetSpec, total: int, per_point: int, *, force: bool) -> None:
    """Claim ``output`` (its lock held) for this spec: refuse another spec's dataset unless
    ``force``, write dataset.json, remove staging leftovers and, with ``force``, the items an
    earlier, larger run left beyond ``total``."""
    items_dir = output / "items"
    info_path = output / "dataset.json"
    previous = read_json(info_path)
    if isinstance(previous, dict) and previous.get("spec_hash") != spec.hash and not force:
        raise ConfigError(
            f"{output} holds a dataset of another spec (hash {str(previous.get('spec_hash'))[:12]}, this spec "
            f"{spec.hash[:12]}); choose a new -o, or pass --force to render every item again")
    write_json({"spec_hash": spec.hash, "items": total, "per_grid_point": per_point, "spec": spec.to_dict()},
               info_path)
    remove_partials(items_dir)
    if force and items_dir.is_dir():  # items of an earlier, larger run are not this dataset's
        for stale in items_dir.iterdir():
            if stale.is_dir() and stale.name.isdigit() and int(stale.name) >= total:
                shutil.rmtree(stale, ignore_errors=True)


def write_manifest(path: Path, rows: Mapping[int, dict]) -> None:
    """One JSON line per item, in index order, atomically."""
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as handle:
            for index in sorted(rows):
                row = {k: rows[index].get(k) for k in _MANIFEST_KEYS}
                handle.write(json.dumps(json_ready(row), ensure_ascii=False, allow_nan=False, default=str) + "\n")


def settle_pending(rows: dict, items_dir: Path, spec: DatasetSpec) -> int:
    """After an interrupt: an item still "pending" whose folder a worker completed before the
    run stopped (its result never came back) is done; the manifest says so, as a rerun would
    find. Returns how many such items there were."""
    settled = 0
    for index, row in rows.items():
        if row["status"] != "pending":
            continue
        meta = finished_meta(items_dir / row["id"], spec.hash, spec.outputs, row["seed"], row["params"])
        if meta is not None:
            rows[index] = done_row(row, meta, resumed=False)
            settled += 1
    return settled
