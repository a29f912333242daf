"""The design document is the repository's own: every docstring that cites it names one of
its headings, and nothing cites a file outside the repository."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import spectral_cam

pytestmark = pytest.mark.timeout(30)

REPO = Path(spectral_cam.__file__).parent.parent
PACKAGE = Path(spectral_cam.__file__).parent
CITATION = re.compile(r'docs/design\.md[,\s(]*"([^"]+)"')


def _headings() -> list[str]:
    text = (REPO / "docs" / "design.md").read_text(encoding="utf-8")
    return [line.lstrip("#").strip().replace("`", "").lower() for line in text.splitlines() if line.startswith("#")]


def test_every_citation_of_the_design_names_a_heading():
    headings = _headings()
    missing = []
    for path in PACKAGE.rglob("*.py"):
        for cited in CITATION.findall(path.read_text(encoding="utf-8")):
            name = " ".join(cited.replace("`", "").split()).lower()
            if not any(h == name or h.startswith(name) for h in headings):
                missing.append(f"{path.relative_to(REPO)}: {cited!r}")
    assert not missing, "citations of headings docs/design.md lacks:\n" + "\n".join(missing)


def test_nothing_cites_a_design_file_outside_the_repository():
    for path in [*PACKAGE.rglob("*.py"), REPO / "README.md"]:
        text = path.read_text(encoding="utf-8")
        assert "DESIGN.md" not in text and "../shared" not in text, path


def test_the_design_lists_the_physical_ranges_the_code_enforces():
    from spectral_cam.scene import MAX_SPP, PHYSICAL_RANGES

    text = (REPO / "docs" / "design.md").read_text(encoding="utf-8")
    for key, (low, high, unit) in PHYSICAL_RANGES.items():
        assert f"| `{key}` | {low:g} | {high:g} | {unit} |" in text, key
    assert f"1..{MAX_SPP}" in text


@pytest.mark.parametrize("script, table, block", [
    ("bench_develop", "bench_develop.csv", "readme_block"), ("bench_render", "render.csv", "readme_block"),
    ("bench_fireflies", "fireflies.csv", "readme_block"), ("bench_realism", "realism.csv", "readme_block"),
    ("bench_realism", "realism_seeds.csv", "seeds_block")])
def test_the_readme_speed_blocks_come_from_the_committed_csvs(script, table, block):
    """README numbers come from committed CSVs: each benchmark's README block is what its script
    writes from its CSV in docs/bench/."""
    import csv
    import importlib.util

    root = Path(__file__).resolve().parents[1]
    spec = importlib.util.spec_from_file_location(script, root / "benchmarks" / f"{script}.py")
    bench = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(bench)
    with open(root / "docs" / "bench" / table, newline="") as handle:
        rows = list(csv.DictReader(handle))
    assert getattr(bench, block)(rows) in (root / "README.md").read_text(encoding="utf-8")
