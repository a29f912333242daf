"""The scripts around the package (benchmarks/, docs/ figure scripts, examples/, tools/) import
names that exist: they are not run as tests, so a rename in the package broke two benchmarks
silently (a private helper imported inside a script held in a string). Every
``from spectral_cam… import …`` line, in code or in a string, must resolve."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest

pytestmark = pytest.mark.timeout(120)

ROOT = Path(__file__).resolve().parents[1]
IMPORT = re.compile(r"^\s*from\s+(spectral_cam[\w.]*)\s+import\s+\(?([\w\s,]+?)\)?\s*(?:#.*)?$", re.MULTILINE)


def _imports():
    for folder in ("benchmarks", "docs", "examples", "tools"):
        for path in sorted((ROOT / folder).glob("*.py")):
            for module, names in IMPORT.findall(path.read_text(encoding="utf-8")):
                for name in (n.strip() for n in names.replace("\n", " ").split(",")):
                    if name:
                        yield path.relative_to(ROOT), module, name.split(" as ")[0].strip()


def test_every_import_of_the_scripts_resolves():
    missing = []
    for path, module_name, name in _imports():
        try:
            module = importlib.import_module(module_name)
        except ImportError as exc:
            missing.append(f"{path}: {module_name} ({exc})")
            continue
        if not hasattr(module, name):
            try:
                importlib.import_module(f"{module_name}.{name}")
            except ImportError:
                missing.append(f"{path}: {module_name}.{name}")
    assert not missing, missing


def test_the_check_reads_imports_inside_strings():
    found = {(str(p), m, n) for p, m, n in _imports()}
    assert ("benchmarks/bench_render.py", "spectral_cam.cli", "keep_large_blocks") in found
