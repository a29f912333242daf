"""The package's structure: no import cycles, data flowing one way, apps and CLI on top.

The reference is the package's own source read as text (``ast``): every import, at module
level or inside a function, except those only for type checkers (``if TYPE_CHECKING:``),
is an edge between two modules. Tarjan's algorithm finds the strongly connected components;
any with more than one module is a cycle (Tarjan, R. E. (1972). SIAM J. Comput. 1(2), 146–160).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import spectral_cam

pytestmark = pytest.mark.timeout(60)

ROOT = Path(spectral_cam.__file__).parent
PACKAGE_ROOT = ROOT
PACKAGE = "spectral_cam"


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in ROOT.rglob("*.py")}


def _type_checking_nodes(tree: ast.AST) -> set[int]:
    hidden = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            hidden.update(id(child) for child in ast.walk(node))
    return hidden


def _resolve(module: str, is_package: bool, level: int, target: str | None) -> str:
    base = module.split(".") if is_package else module.split(".")[:-1]
    if level > 1:
        base = base[: len(base) - (level - 1)]
    return ".".join(base + ([target] if target else []))


def import_graph() -> dict[str, set[str]]:
    """Module → the package modules it imports (submodule names resolved where they exist)."""
    modules = _modules()
    graph: dict[str, set[str]] = {name: set() for name in modules}
    for name, path in modules.items():
        tree = ast.parse(path.read_text(encoding="utf-8"))
        hidden = _type_checking_nodes(tree)
        is_package = path.name == "__init__.py"
        for node in ast.walk(tree):
            if id(node) in hidden:
                continue
            targets = []
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = (_resolve(name, is_package, node.level, node.module) if node.level
                        else node.module or "")
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                           for alias in node.names]
            for target in targets:
                while target and target not in modules:
                    target = target.rpartition(".")[0]
                if target.startswith(PACKAGE) and target != name:
                    graph[name].add(target)
    return graph


def strongly_connected(graph: dict[str, set[str]]) -> list[list[str]]:
    """Tarjan's strongly connected components."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    out: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph[node]):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while True:
                item = stack.pop()
                on_stack.discard(item)
                component.append(item)
                if item == node:
                    break
            out.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return out


#: The package's floors, lowest first, by top-level module or package ("__init__" is
#: spectral_cam's own public face). A module may import its own floor or a lower one. The order is
#: that of the imports, not of the data: the renderer asks the sensor model what it needs
#: (``spp = "auto"``), the sensor writes RawImage and the ISP's tone curves into its DNG, and the
#: scene file validates the keys its presets, ISP stages and sensor kinds declare.
FLOORS: tuple[tuple[str, ...], ...] = (
    ("errors", "registry", "keys", "io", "records", "machine", "progress", "viz", "_lazy_colour"),
    ("cfa", "image", "exr", "spectral_exr", "xml_scene", "solar", "metering"),
    ("spectrum", "cie", "spectra", "cameras", "colour_ground_truth", "reflectance_sets", "leaves",
     "soil_moisture", "textures"),
    ("optics",),
    ("metrics",),
    ("presets",),
    ("raw",),
    ("isp",),
    ("sensor",),
    ("control",),
    ("scene",),
    ("budget", "radiance_targets"),
    ("render",),
    ("camera_record", "job", "__init__"),
    ("apps",),
    ("cli", "data"),
)

#: Every import that climbs to a higher floor: (module, imported module, why). Any other fails.
ALLOWED_UPWARD: tuple[tuple[str, str, str], ...] = (
    ("spectral_cam.scene.camera_sections", "spectral_cam.render.lens_models",
     "lens.model is checked against LENS_MODELS (a user's module may add to it)"),
    ("spectral_cam.scene.sections", "spectral_cam.render.lens_models",
     "[lens] is assembled from the keys LENS_MODELS' entries declare"),
)


def _floor_name(module: str) -> str:
    parts = module.split(".")
    return "__init__" if len(parts) == 1 else parts[1]


def _floor_of() -> dict[str, int]:
    return {name: i for i, floor in enumerate(FLOORS) for name in floor}


def upward_imports(graph: dict[str, set[str]]) -> set[tuple[str, str]]:
    """Every (module, imported module) whose target sits on a higher floor."""
    floor = _floor_of()
    return {(m, t) for m, targets in graph.items() for t in targets
            if floor[_floor_name(t)] > floor[_floor_name(m)]}


def layering_block() -> str:
    """The floors and the allowed upward imports as design.md's "Layering" shows them."""
    lines = ["floors, lowest first (a module imports its own floor or a lower one):"]
    lines += [f"{i:3d}  " + " ".join(floor) for i, floor in enumerate(FLOORS, start=1)]
    lines.append("imports up a floor, each allowed by name (any other fails the test):")
    for module, target, reason in ALLOWED_UPWARD:
        lines.append(f"  {module.removeprefix(PACKAGE + '.')} → {target.removeprefix(PACKAGE + '.')}: "
                     f"{reason}")
    return "\n".join(lines)


def test_every_module_sits_on_a_floor():
    unplaced = sorted({_floor_name(m) for m in import_graph()} - set(_floor_of()))
    assert not unplaced, f"add these to a floor in FLOORS (and design.md's Layering): {unplaced}"


def test_every_upward_import_is_named_and_every_named_one_exists():
    graph = import_graph()
    found = upward_imports(graph)
    allowed = {(m, t) for m, t, _ in ALLOWED_UPWARD}
    assert not found - allowed, "imports up a floor not in ALLOWED_UPWARD: " + ", ".join(
        f"{m} -> {t}" for m, t in sorted(found - allowed))
    assert not allowed - found, "ALLOWED_UPWARD entries no longer in the code (remove them): " + \
        ", ".join(f"{m} -> {t}" for m, t in sorted(allowed - found))


def test_an_upward_import_is_found_where_there_is_one():
    # the checker itself, on a made-up edge: the sensor importing the renderer
    graph = {"spectral_cam.sensor.noise": {"spectral_cam.render.trace", "spectral_cam.errors"}}
    assert upward_imports(graph) == {("spectral_cam.sensor.noise", "spectral_cam.render.trace")}


def test_the_design_shows_the_layering_the_test_enforces():
    design = (ROOT.parent / "docs" / "design.md").read_text(encoding="utf-8")
    assert f"```\n{layering_block()}\n```" in design, (
        "docs/design.md's Layering block differs from FLOORS/ALLOWED_UPWARD; it should read:\n"
        + layering_block())


def test_the_import_graph_has_no_cycle():
    cycles = [c for c in strongly_connected(import_graph()) if len(c) > 1]
    assert not cycles, "import cycles: " + "; ".join(" <-> ".join(c) for c in cycles)


def test_a_cycle_is_found_where_there_is_one():
    # the detector itself, on a known graph
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert [c for c in strongly_connected(graph) if len(c) > 1] == [["a", "b", "c"]]


def _reaches(graph, start: str, prefix: str) -> list[str]:
    return sorted(t for t in graph[start] if t == prefix or t.startswith(prefix + "."))


@pytest.mark.parametrize("lower, higher", [
    ("spectral_cam.sensor", "spectral_cam.render"),       # the sensor knows nothing of Mitsuba
    ("spectral_cam.isp", "spectral_cam.sensor"),          # the ISP sees RAW + metadata only
    ("spectral_cam.isp", "spectral_cam.render"),
    ("spectral_cam.isp", "spectral_cam.spectra"),
    ("spectral_cam.raw", "spectral_cam.sensor"),
    ("spectral_cam.raw", "spectral_cam.isp"),             # the hue/sat map's model lives in raw/ (issue 41 #5)
    ("spectral_cam.metrics", "spectral_cam.render"),
])
def test_data_flows_one_way(lower, higher):
    graph = import_graph()
    offenders = {m: _reaches(graph, m, higher) for m in graph if m == lower or m.startswith(lower + ".")}
    assert not {m: t for m, t in offenders.items() if t}


def test_the_sensor_reads_nothing_of_the_isp_but_its_tone_curves():
    """design.md's named exception: sensor/ reads isp/tone.py (the BaselineExposure and
    ProfileToneCurve a RAW carries); the hue/sat map it fits comes from raw/, not isp/."""
    graph = import_graph()
    reached = {t for m in graph if m == "spectral_cam.sensor" or m.startswith("spectral_cam.sensor.")
               for t in _reaches(graph, m, "spectral_cam.isp")}
    assert reached <= {"spectral_cam.isp.tone"}, sorted(reached)


def test_only_apps_and_cli_import_apps_and_cli():
    graph = import_graph()
    for module, targets in graph.items():
        if module.startswith(("spectral_cam.apps", "spectral_cam.cli")):
            continue
        upward = [t for t in targets if t.startswith(("spectral_cam.apps", "spectral_cam.cli"))]
        assert not upward, f"{module} imports {upward}"


def test_only_the_renderer_imports_mitsuba():
    # "the sensor knows nothing of Mitsuba": Mitsuba and drjit stay inside render/
    for path in PACKAGE_ROOT.rglob("*.py"):
        name = _module_name(path)
        if name == "spectral_cam.render" or name.startswith("spectral_cam.render."):
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else [])
            assert not any(n.split(".")[0] in ("mitsuba", "drjit") for n in names), f"{name} imports {names}"


#: Size limits (issue 41): a module a reader can hold, a function a reader can follow.
MAX_MODULE_LINES = 600
MAX_FUNCTION_CODE_LINES = 80


def _code_lines(node: ast.AST, lines: list[str]) -> int:
    """A function's lines of code: its body's non-blank, non-comment lines, the docstring left out."""
    body = node.body
    start = body[0].lineno
    if isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
        start = body[0].end_lineno + 1
    return sum(1 for line in lines[start - 1:node.end_lineno] if line.strip() and not line.strip().startswith("#"))


def test_no_module_over_600_lines_and_no_function_over_80_lines_of_code():
    long_modules, long_functions = [], []
    for path in ROOT.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        lines = text.splitlines()
        if len(lines) > MAX_MODULE_LINES:
            long_modules.append(f"{path.relative_to(ROOT)} ({len(lines)})")
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and _code_lines(node, lines) > MAX_FUNCTION_CODE_LINES:
                long_functions.append(f"{path.relative_to(ROOT)}:{node.name} ({_code_lines(node, lines)})")
    assert not long_modules, f"modules over {MAX_MODULE_LINES} lines: {long_modules}"
    assert not long_functions, f"functions over {MAX_FUNCTION_CODE_LINES} lines of code: {long_functions}"


def test_a_class_inside_a_function_says_why_mitsuba_needs_it():
    """A Mitsuba Python plugin must subclass the variant's ``mi.BSDF``/``mi.Sensor``/…, which exist only
    once a variant is set, so its class is defined in the function that registers it; the comment or
    docstring within three lines above the class says so. Any other class lives at module level."""
    unexplained = []
    for path in ROOT.rglob("*.py"):
        text = path.read_text(encoding="utf-8")
        lines = text.splitlines()
        for outer in ast.walk(ast.parse(text)):
            if not isinstance(outer, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for inner in ast.walk(outer):
                if isinstance(inner, ast.ClassDef):
                    near = " ".join(lines[max(0, inner.lineno - 4):inner.lineno]).lower()
                    doc = (ast.get_docstring(outer) or "").lower()
                    if "mitsuba" not in near + doc or "variant" not in near + doc:
                        unexplained.append(f"{path.relative_to(ROOT)}:{outer.name}>{inner.name}")
    assert not unexplained, f"classes inside functions without a comment on Mitsuba's variant: {unexplained}"
