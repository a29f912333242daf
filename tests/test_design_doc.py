"""docs/design.md's folder map against the package on disk.

Every module and subpackage under ``spectral_cam/`` (each ``.py`` file, by its file name, excluding
``__init__``/``__main__`` and ``data/``) is named in the "Folder map" block, and every file or
folder the block names exists: the map cannot silently fall behind the package (issue 41 listed 7
of 12 sensor modules).
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import spectral_cam

pytestmark = pytest.mark.timeout(60)

PACKAGE = Path(spectral_cam.__file__).parent
REPO = PACKAGE.parent


def folder_map() -> str:
    text = (REPO / "docs" / "design.md").read_text(encoding="utf-8")
    section = text.split("### Folder map", 1)[1].split("\n### ", 1)[0]
    return section.split("```\n", 2)[1]


def entries() -> dict[str, str]:
    """Entry key (``scene.py``, ``isp/``, ``apps/stress/``) → its text, continuation lines included.

    An entry starts on a line indented two spaces; deeper-indented lines continue it.
    """
    out: dict[str, str] = {}
    key = None
    for line in folder_map().splitlines():
        match = re.match(r"  (\S+)", line)
        if match and not line.startswith("   "):
            key = match.group(1)
            out[key] = line[len(key) + 2:]
        elif line.startswith("   ") and key:
            out[key] += "\n" + line
        else:
            key = None
    return out


def _package_entry(folder: Path, table: dict[str, str]) -> tuple[str, str]:
    """The entry of ``folder`` or of its nearest ancestor that has one (``apps/dataset/`` holds
    ``labels/``'s modules)."""
    while folder != PACKAGE:
        key = folder.relative_to(PACKAGE).as_posix() + "/"
        if key in table:
            return key, table[key]
        folder = folder.parent
    return "", "\n".join(f"{k} {v}" for k, v in table.items())


def _unnamed() -> list[str]:
    table = entries()
    whole = folder_map()
    missing = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE)
        if rel.parts[0] == "data" or path.stem in ("__init__", "__main__"):
            continue
        if len(rel.parts) == 1:
            if not re.search(rf"(?<![\w/]){re.escape(path.name)}\b", whole):
                missing.append(rel.as_posix())
            continue
        _, text = _package_entry(path.parent, table)
        if not re.search(rf"(?<![\w./]){re.escape(path.name)}\b", text):
            missing.append(rel.as_posix())
    for init in sorted(PACKAGE.rglob("__init__.py")):
        folder = init.parent
        if folder == PACKAGE:
            continue
        key = folder.relative_to(PACKAGE).as_posix() + "/"
        parent_key, parent_text = _package_entry(folder.parent, table)
        if key not in table and f"{folder.name}/" not in parent_text:
            missing.append(key)
    return missing


def test_the_folder_map_names_every_module_and_package():
    missing = _unnamed()
    assert not missing, "docs/design.md's Folder map does not name: " + ", ".join(missing)


def test_every_file_and_folder_the_folder_map_names_exists():
    table = entries()
    absent = [key for key in table if not (PACKAGE / key).exists()]
    for key, text in table.items():
        folder = PACKAGE / key if key.endswith("/") else PACKAGE
        for name in re.findall(r"[\w/]+\.py\b", text):
            places = [folder / name, PACKAGE / name, REPO / name] + list(folder.rglob(name))
            if not any(p.exists() for p in places):
                absent.append(f"{key}: {name}")
    assert not absent, "docs/design.md's Folder map names what is not there: " + ", ".join(absent)


def test_the_checker_finds_a_module_the_map_leaves_out(monkeypatch):
    import sys
    # the checker itself: the map with sensor/'s olpf.py taken out
    text = folder_map()
    monkeypatch.setattr(sys.modules[__name__], "folder_map",
                        lambda: re.sub(r"\bolpf(\.py)?\b", "", text))
    assert "sensor/olpf.py" in _unnamed()
