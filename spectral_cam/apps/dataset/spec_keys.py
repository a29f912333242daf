"""The scene keys a dataset spec names, and the file paths in its values.

A spec's keys are the scene file's (``section.key`` of :class:`~spectral_cam.scene.SceneConfig`);
:func:`check_key` refuses any other, saying which would be valid, and :func:`is_whole` tells the
keys typed ``int`` (whose draws and sweep values are whole numbers). Relative CSV/XML paths resolve
against the spec's folder (:func:`resolve_paths`, :func:`resolve_paths_table`, which also expands
``{ files = "glob" }`` into a choice), and the spec hash reads such files by their content
(:func:`by_content`), so the same spec and files give the same items in any folder.
"""

from __future__ import annotations

import dataclasses
import functools
import hashlib
from pathlib import Path
from typing import Any, Mapping

from ...errors import ConfigError
from ...scene import SceneConfig

__all__ = ["check_key", "is_whole", "by_content", "resolve_paths", "resolve_paths_table"]


def _section_fields() -> dict[str, dict[str, dataclasses.Field]]:
    """{section: {key: dataclass field}} of every scene-file key."""
    out = {}
    for section in dataclasses.fields(SceneConfig):
        # the fields of the section's default instance: its factory may be the class or a function making one
        out[section.name] = {f.name: f for f in dataclasses.fields(section.default_factory())}
    return out


_FIELDS = _section_fields()


def check_key(dotted: str, origin: str) -> tuple[str, str]:
    """``(section, key)`` of a scene key ``"section.key"``; ``origin`` names where it was given.

    Raises
    ------
    ConfigError
        For an unknown section or key, listing the valid ones.
    """
    section, _, key = dotted.partition(".")
    if section not in _FIELDS or not key:
        raise ConfigError(f"{origin}: {dotted!r} is not a scene key; use section.key with a section "
                          f"among {', '.join(_FIELDS)}")
    if key not in _FIELDS[section]:
        raise ConfigError(f"{origin}: unknown key {dotted!r}; valid keys of [{section}]: "
                          f"{', '.join(_FIELDS[section])}")
    return section, key


def is_whole(dotted: str) -> bool:
    """True for keys whose type is a whole number only (sampled values get rounded)."""
    section, key = dotted.split(".", 1)
    kinds = str(_FIELDS[section][key].type).replace(" ", "").split("|")
    return kinds == ["int"]


@functools.lru_cache(maxsize=256)
def _file_digest(path: str, modified_ns: int, size: int) -> str:
    """A file's content digest (cached per path, modification time and size: an edited file is read again)."""
    return "sha256:" + hashlib.sha256(Path(path).read_bytes()).hexdigest()


def by_content(value: Any) -> Any:
    """``value`` with every existing CSV/XML file path replaced by its content's digest."""
    if isinstance(value, dict):
        return {k: by_content(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [by_content(v) for v in value]
    if isinstance(value, str) and value.lower().endswith((".csv", ".xml")) and Path(value).is_file():
        status = Path(value).stat()
        return _file_digest(str(Path(value).resolve()), status.st_mtime_ns, status.st_size)
    return value


def resolve_paths(value: Any, base_dir: Path) -> Any:
    """Make relative CSV/XML paths (in values and choices) absolute against ``base_dir``."""
    if isinstance(value, str) and value.lower().endswith((".csv", ".xml")):
        path = Path(value).expanduser()
        return str((path if path.is_absolute() else base_dir / path).resolve())
    if isinstance(value, list):
        return [resolve_paths(v, base_dir) for v in value]
    return value


def resolve_paths_table(table: Mapping[str, Any], base_dir: Path) -> dict:
    """A distribution table with its paths absolute; ``{ files = "rooms/*.xml" }`` becomes the
    choice of the files that pattern matches (relative to the spec's folder, sorted, so the
    drawn file of an item does not depend on the order the file system lists them)."""
    if "files" in table:
        pattern = table["files"]
        if set(table) - {"files", "weights"} or not isinstance(pattern, str) or not pattern.strip():
            raise ConfigError(f"{{ files = {pattern!r} }}: give one glob pattern, e.g. {{ files = \"rooms/*.xml\" }}")
        absolute = Path(pattern).expanduser()
        absolute = absolute if absolute.is_absolute() else base_dir / absolute
        found = sorted(str(p.resolve()) for p in Path(absolute.anchor).glob(str(absolute.relative_to(absolute.anchor)))
                       if p.is_file())
        if not found:
            raise ConfigError(f"{{ files = {pattern!r} }} matches no file (looked for {absolute})")
        if "weights" in table:
            raise ConfigError(f"{{ files = {pattern!r} }}: weights apply to an explicit choice list")
        return {"choice": found}
    return {k: (resolve_paths(v, base_dir) if k == "choice" else v) for k, v in table.items()}
