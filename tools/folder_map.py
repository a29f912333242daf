"""docs/design.md's "Folder map" block, generated from the package's own docstrings.

The map is where a newcomer looks for the room for a change, so it must not fall behind the
package (issue 41 found it naming 7 of sensor/'s 12 modules). It is made from what the package
says about itself, read with :mod:`ast` (nothing is imported):

* a top-level module: its file name and the first sentence of its docstring (``__init__.py``: its
  ``__all__``);
* a package: its folder, the first sentence of its ``__init__`` docstring, then its modules by file
  name, each with its docstring's lead clause in brackets where that says more than the file name
  (a subpackage shows as ``labels/``, with an entry of its own after its parent's);
* each folder of ``spectral_cam/data/``: its README's title;
* then a fixed tail for the folders around the package (:data:`TAIL`).

Entries go by the floors of design.md's "Layering" block, lowest first (``__init__.py`` first,
``data/`` last): the shared basics, then the physics from optics up to render, then apps/ and cli/.
tests/test_design_doc.py checks that the block equals :func:`folder_map_block`::

    python tools/folder_map.py           # print the block

    python tools/folder_map.py --write   # replace the block in docs/design.md
    python tools/folder_map.py --check   # exit 1 with a diff when the block differs
"""

from __future__ import annotations

import argparse
import ast
import difflib
import re
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / "spectral_cam"
DESIGN = REPO / "docs" / "design.md"
HEADING = "### Folder map"

#: Column of an entry's text (two-space indent + a 17-wide name) and the width lines wrap at.
TEXT_COLUMN = 19
WIDTH = 104
#: A module's lead clause longer than this is left out (the file name then stands alone).
MAX_CLAUSE = 48
#: A first sentence longer than this (two lines) loses its brackets, then its last clauses.
MAX_SENTENCE = 2 * (WIDTH - TEXT_COLUMN)

#: The folders around the package; the generator does not look at them.
TAIL = """\
scenes/  scene files       plans/  validation plans, dataset specs      tests/  pytest (tiny images, fast)
benchmarks/  scripts writing CSV + PNG (not tests): bench_render (vs bare Mitsuba), bench_develop (vs
             rawpy), bench_demosaic, bench_diffraction, bench_samplers, dng_tools, …; README blocks
tools/  scripts that write generated files (this map, colour-science's tables)
docs/  this file, figures, bench/stress charts
"""

#: Words that do not make a clause say more than its file name ("Study (a)", "The ``flow`` label").
_FILLER = {"the", "a", "an", "of", "and", "study", "label", "preset", "spectral", "cam"}
#: First words a module's clause keeps capitalised (names, not sentence starts).
_PROPER = {"Mitsuba", "Adobe's", "Menon,", "Brown–Conrady", "Python", "Dask", "Bayer"}
#: Abbreviations whose full stop does not end a sentence.
_ABBREVIATIONS = ("e.g.", "i.e.", "et al.", "vs.", "cf.", "approx.")


def _docstring(path: Path) -> str:
    return ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""


def _role(match: re.Match) -> str:
    """A Sphinx role's text as it reads: ``~`` keeps the last dotted part, ``.`` is dropped."""
    tilde, target = match.groups()
    return target.split(".")[-1] if tilde else target.lstrip(".")


def _plain(text: str) -> str:
    """Docstring markup to plain text: roles (:func:`~.x.y` → y), literals, ``*emphasis*``."""
    text = re.sub(r":\w+:`(~?)([^`]*)`", _role, text)
    return re.sub(r"\*([^*]+)\*", r"\1", text.replace("``", ""))


def first_sentence(doc: str) -> str:
    """The first sentence of a docstring's first paragraph, markup removed, one line."""
    paragraph = " ".join(doc.strip().split("\n\n", 1)[0].split())
    start = 0
    while True:
        match = re.search(r"(?<!\.)[.!?](\s|$)", paragraph[start:])
        if not match:
            return _plain(paragraph)
        end = start + match.end()
        if not paragraph[:end].rstrip().endswith(_ABBREVIATIONS):
            return _plain(paragraph[:end].strip())
        start = end


def _restates(clause: str, path: Path) -> bool:
    """Whether a clause says no more than the module's file and folder names ("Radiometry",
    "Study (b)", "The ``flow`` label")."""
    names = {n for n in [path.stem, *path.stem.split("_"), *path.parent.name.split("_")]
             if len(n) > 2}
    for word in re.findall(r"[a-z0-9]+", clause.lower()):
        if word in _FILLER or len(word) <= 2:
            continue
        if not any(word.startswith(n) or n.startswith(word) for n in names):
            return False
    return True


def _depths(text: str) -> list[int]:
    """Each character's bracket depth (a closing bracket at its inner depth)."""
    depths, depth = [], 0
    for char in text:
        depth += char == "("
        depths.append(depth)
        depth -= char == ")" and depth > 0
    return depths


def _unbracketed(text: str) -> str:
    """``text`` without its bracketed asides, nested ones and one left open at the end included."""
    kept = "".join(c for c, d in zip(text, _depths(text)) if d == 0)
    return re.sub(r"\s+([,;:.])", r"\1", re.sub(r"\s{2,}", " ", kept)).strip()


def _clauses(paragraph: str) -> list[str]:
    """A paragraph split where a clause ends outside brackets: ``: ``, ``; ``, `` — `` or a
    full stop (not an ellipsis)."""
    masked = "".join(c if d == 0 else "x" for c, d in zip(paragraph, _depths(paragraph)))
    cuts = [(m.start(), m.end()) for m in re.finditer(r": |; | — |(?<!\.)\.(?:\s|$)", masked)]
    starts = [0] + [end for _, end in cuts]
    ends = [start for start, _ in cuts] + [len(paragraph)]
    return [paragraph[a:b] for a, b in zip(starts, ends)]


def lead_clause(doc: str, path: Path) -> str:
    """A module's docstring cut to its lead clause (before ``:``, ``;`` or a dash), brackets
    dropped, or the clause after it where the lead restates the file name or is only a literal
    (a command's usage); empty where neither is shorter than :data:`MAX_CLAUSE`."""
    paragraph = " ".join(doc.strip().split("\n\n", 1)[0].split())
    for raw in _clauses(paragraph)[:2]:
        clause = _unbracketed(_plain(raw))
        literal = re.fullmatch(r"``[^`]*``\S*", raw.strip())
        if clause and not literal and not _restates(clause, path):
            break
    else:
        return ""
    if len(clause) > MAX_CLAUSE:
        return ""
    first = clause.split(" ", 1)[0]
    if first[1:] == first[1:].lower() and first not in _PROPER:
        clause = clause[0].lower() + clause[1:]
    return clause


def short_sentence(doc: str) -> str:
    """:func:`first_sentence`, brackets dropped where it is longer than :data:`MAX_SENTENCE`,
    then cut at a clause's end with `` …`` if still longer."""
    sentence = first_sentence(doc)
    if len(sentence) <= MAX_SENTENCE:
        return sentence
    sentence = _unbracketed(sentence)
    if len(sentence) <= MAX_SENTENCE:
        return sentence
    cuts = [m.start() for m in re.finditer(r"[,;:] | — ", sentence) if m.start() < MAX_SENTENCE]
    return sentence[:cuts[-1] if cuts else MAX_SENTENCE].rstrip() + " …"


def _entry(name: str, text: str, more: str = "") -> list[str]:
    """One entry: the name in a 17-wide column after two spaces, its text wrapped at :data:`WIDTH`
    under column :data:`TEXT_COLUMN`; ``more`` starts on a line of its own."""
    head = f"  {name}".ljust(TEXT_COLUMN) if len(name) < TEXT_COLUMN - 2 else f"  {name}  "
    indent = " " * TEXT_COLUMN
    lines = textwrap.wrap(text, WIDTH, initial_indent=head, subsequent_indent=indent,
                          break_long_words=False, break_on_hyphens=False) or [head.rstrip()]
    if more:
        lines += textwrap.wrap(more, WIDTH, initial_indent=indent, subsequent_indent=indent,
                               break_long_words=False, break_on_hyphens=False)
    return lines


def _public_api(init: Path) -> str:
    """``__init__.py``'s entry text: its ``__all__`` as the names it exports (``*NAME`` items
    spread from a module-level literal, as ``*_LAZY``'s keys)."""
    literals: dict[str, object] = {}
    for node in ast.parse(init.read_text(encoding="utf-8")).body:
        if not (isinstance(node, ast.Assign) and isinstance(node.targets[0], ast.Name)):
            continue
        target = node.targets[0].id
        if target == "__all__" and isinstance(node.value, (ast.List, ast.Tuple)):
            names = []
            for item in node.value.elts:
                if isinstance(item, ast.Starred) and isinstance(item.value, ast.Name):
                    names += list(literals.get(item.value.id, ()))
                else:
                    names.append(ast.literal_eval(item))
            return "public API (__all__): " + ", ".join(names)
        try:
            literals[target] = ast.literal_eval(node.value)
        except ValueError:
            pass
    return first_sentence(_docstring(init))


def _package_entries(folder: Path, package: Path) -> list[str]:
    """A package's entry (folder, ``__init__``'s first sentence, its modules), then its
    subpackages' entries."""
    modules, subpackages = [], []
    for path in sorted(folder.iterdir()):
        if path.suffix == ".py" and path.stem not in ("__init__", "__main__"):
            clause = lead_clause(_docstring(path), path)
            modules.append(f"{path.name} ({clause})" if clause else path.name)
        elif (path / "__init__.py").is_file():
            modules.append(f"{path.name}/")
            subpackages.append(path)
    name = folder.relative_to(package).as_posix() + "/"
    lines = _entry(name, short_sentence(_docstring(folder / "__init__.py")), ", ".join(modules))
    for sub in subpackages:
        lines += _package_entries(sub, package)
    return lines


def _data_entries(package: Path) -> list[str]:
    """One line per folder of ``data/``: its README's title (brackets dropped where too long)."""
    lines = []
    for folder in sorted(p for p in (package / "data").glob("*/") if p.is_dir()):
        readme = folder / "README.md"
        title = readme.read_text(encoding="utf-8").splitlines()[0].lstrip("# ").strip() \
            if readme.is_file() else "package data"
        name = f"data/{folder.name}/"
        if len(name) + len(title) + 2 > WIDTH - TEXT_COLUMN:  # one line: drop its brackets
            title = _unbracketed(title)
        lines += _entry(name, title)
    return lines


def floors(design_text: str) -> list[str]:
    """Top-level module and package names in the order of design.md's "Layering" floors."""
    block = design_text.split("floors, lowest first", 1)[-1].split("imports up a floor", 1)[0]
    return [name for line in block.splitlines()[1:]
            for name in (line.split()[1:] if re.match(r"\s*\d+\s", line) else [])]


def _order(package: Path, design_text: str) -> list[Path]:
    """The package's top-level modules and packages: ``__init__.py``, then by floor, then any
    not on a floor by name; ``data/`` is not among them."""
    items = {p.stem: p for p in package.glob("*.py")}
    items.update({p.name: p for p in package.iterdir() if (p / "__init__.py").is_file()})
    ranked = [n for n in ["__init__"] + floors(design_text) if n in items]
    ranked += sorted(n for n in items if n not in ranked and n != "__main__")
    return [items[n] for n in dict.fromkeys(ranked)]


def folder_map_block(package: Path = PACKAGE, design_text: str | None = None) -> str:
    """The text between the Folder map's fences: ``spectral_cam/``, its entries, the tail."""
    if design_text is None:
        design_text = DESIGN.read_text(encoding="utf-8")
    lines = [f"{package.name}/"]
    for path in _order(package, design_text):
        if path.is_dir():
            lines += _package_entries(path, package)
        elif path.stem == "__init__":
            lines += _entry(path.name, _public_api(path))
        else:
            lines += _entry(path.name, short_sentence(_docstring(path)))
    lines += _data_entries(package)
    return "\n".join(lines) + "\n" + TAIL


def _split(design_text: str) -> tuple[str, str, str]:
    """design.md as (before the block, the block, after it); the block is the first fenced one
    after :data:`HEADING`."""
    head, section = design_text.split(HEADING + "\n", 1)
    before, block, after = section.split("```\n", 2)
    return head + HEADING + "\n" + before + "```\n", block, "```\n" + after


def replace_block(design_text: str, block: str) -> str:
    """design.md's text with its Folder map block replaced by ``block``."""
    before, _, after = _split(design_text)
    return before + block + after


def current_block(design_text: str) -> str:
    """The Folder map block as design.md has it now."""
    return _split(design_text)[1]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n", 1)[0])
    action = parser.add_mutually_exclusive_group()
    action.add_argument("--write", action="store_true", help="replace the block in docs/design.md")
    action.add_argument("--check", action="store_true", help="exit 1 with a diff if it differs")
    args = parser.parse_args(argv)
    text = DESIGN.read_text(encoding="utf-8")
    block = folder_map_block(design_text=text)
    if args.write:
        DESIGN.write_text(replace_block(text, block), encoding="utf-8")
        print(f"{DESIGN.relative_to(REPO)}: Folder map, {len(block.splitlines())} lines")
        return 0
    if args.check:
        diff = list(difflib.unified_diff(current_block(text).splitlines(), block.splitlines(),
                                         "docs/design.md", "generated", lineterm=""))
        print("\n".join(diff) if diff else "docs/design.md's Folder map is current")
        return 1 if diff else 0
    sys.stdout.write(block)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
