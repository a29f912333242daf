"""Pipeline types (spectral_cam.apps.validate.pipelines): broken user pipelines are flagged,
failing programs become error cells, external commands are measured like our ISP, and each
type accepts the plan keys its registry entry declares."""

from __future__ import annotations

import os
import signal
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from spectral_cam.apps.validate import PIPELINES, load_plan, plan_from_dict, run_plan
from spectral_cam.cli import main
from spectral_cam.errors import ConfigError

BROKEN_ISP = '''
import spectral_cam as sc
from spectral_cam.isp import ISPConfig


def swapped(raw_path):
    """A correct development whose red and blue channels are then swapped."""
    linear = sc.develop(sc.read_raw(raw_path), ISPConfig(tone="linear")).linear
    return linear[..., ::-1]


def crashes(raw_path):
    raise RuntimeError("this ISP is broken")
'''


def one_chart_plan(patch_px: int) -> str:
    """The [validate] table of a one-cell plan: D65, the Nikon D850, the ColorChecker."""
    return f'''
[validate]
illuminants = ["D65"]
cameras = ["nikon_d850"]
reflectance_sets = ["colorchecker"]
patch_px = {patch_px}

'''


@pytest.fixture(scope="module")
def user_pipelines(tmp_path_factory, read_csv):
    folder = tmp_path_factory.mktemp("user_isp")
    (folder / "broken_isp.py").write_text(BROKEN_ISP)
    cli = Path(sys.executable).with_name("spectral-cam")
    assert cli.is_file(), f"the spectral-cam console script is missing next to {sys.executable}"
    plan = one_chart_plan(12) + f'''
[[pipeline]]
name = "ours-dng"
type = "ours"
isp = {{ colour_matrix = "dng", tone = "linear" }}

[[pipeline]]
name = "swapped-rb"
type = "callable"
function = "broken_isp:swapped"
python_path = ["."]
output = "linear_srgb"

[[pipeline]]
name = "crashes"
type = "callable"
function = "broken_isp:crashes"
python_path = ["."]

[[pipeline]]
name = "cli-develop"
type = "command"
command = "'{cli}' develop {{input}} -o {{output}} -q"
output_suffix = ".exr"
output = "linear_srgb"

[[pipeline]]
name = "exits-1"
type = "command"
command = "'{sys.executable}' -c 'import sys; sys.exit(\\"no {{input}} today\\")' {{output}}"
'''
    (folder / "plan.toml").write_text(plan)
    out = folder / "report"
    status = main(["validate", str(folder / "plan.toml"), "-o", str(out), "-q"])
    return status, out, read_csv(out / "cells.csv"), read_csv(out / "patches.csv")


@pytest.mark.timeout(120)
def test_swapped_red_and_blue_is_flagged_failing(user_pipelines):
    status, out, cells, patches = user_pipelines
    assert status == 1  # some cell does not pass
    by_name = {row["pipeline"]: row for row in cells}
    assert by_name["ours-dng"]["status"] == "pass"
    swapped = by_name["swapped-rb"]
    assert swapped["status"] == "fail"
    assert float(swapped["delta_e_mean"]) > 10.0  # measured ≈ 17
    assert float(swapped["delta_e_max"]) > 30.0
    assert "delta_e_mean" in swapped["failures"]
    # a near-neutral white stays near neutral when R and B swap (measured 2.2°)...
    assert float(swapped["wb_angular_error_deg"]) < 5.0
    # ...but the chromatic patches move far: blue and red swap roles
    blue = next(p for p in patches if p["pipeline"] == "swapped-rb" and p["patch"] == "blue")
    assert float(blue["delta_e2000"]) > 30.0
    html = (out / "report.html").read_text()
    assert "swapped-rb" in html and "FAIL" in html


@pytest.mark.timeout(120)
def test_failing_programs_are_errors_and_commands_are_measured(user_pipelines):
    status, out, cells, patches = user_pipelines
    by_name = {row["pipeline"]: row for row in cells}
    assert by_name["crashes"]["status"] == "error" and "this ISP is broken" in by_name["crashes"]["failures"]
    assert by_name["exits-1"]["status"] == "error" and "exit status 1" in by_name["exits-1"]["failures"]
    # `spectral-cam develop` run as an external command on the DNG = our ISP on the RAW
    ours = np.array([float(p["delta_e2000"]) for p in patches if p["pipeline"] == "ours-dng"])
    command = np.array([float(p["delta_e2000"]) for p in patches if p["pipeline"] == "cli-develop"])
    assert by_name["cli-develop"]["status"] == "pass"
    np.testing.assert_allclose(command, ours, atol=0.02)


@pytest.mark.timeout(60)
def test_each_type_takes_the_keys_its_registry_entry_declares(tmp_path):
    assert list(PIPELINES) == ["ours", "rawpy", "callable", "command"]
    with pytest.raises(ConfigError, match="unknown key.*'demosaic'.*valid: name, type, isp"):
        plan_from_dict({"validate": {}, "pipeline": [{"type": "ours", "demosaic": "AHD"}]}, base_dir=tmp_path)
    with pytest.raises(ConfigError, match="a callable pipeline needs function = 'module:function'"):
        plan_from_dict({"validate": {}, "pipeline": [{"type": "callable"}]}, base_dir=tmp_path)
    plan = plan_from_dict({"validate": {}, "pipeline": [
        {"name": "libraw", "type": "rawpy", "demosaic": "ahd", "white_balance": "manual", "wb_gains": [2, 1, 1.5]}]})
    described = plan.to_dict()["pipelines"][0]
    assert described == {"name": "libraw", "type": "rawpy", "demosaic": "AHD", "white_balance": "manual",
                         "wb_gains": [2.0, 1.0, 1.5], "output_color": "XYZ", "highlight_mode": "clip",
                         "fbdd_noise_reduction": "off", "median_filter_passes": 0}
    assert list(described)[2:] == list(PIPELINES["rawpy"].options)


HOSTILE_FOLDERS = ["x;touch pwned;", "$(touch pwned)", "a'b\"c `touch pwned` d"]


@pytest.mark.timeout(120)
@pytest.mark.parametrize("folder_name", HOSTILE_FOLDERS)
def test_command_placeholders_cannot_inject_a_shell_command(tmp_path, monkeypatch, folder_name):
    """A command run through a shell script sees the DNG and output paths quoted (issue 12 #15)."""
    monkeypatch.chdir(tmp_path)
    cli = Path(sys.executable).with_name("spectral-cam")
    plan = tmp_path / "plan.toml"
    plan.write_text(one_chart_plan(8) + f'''
[[pipeline]]
name = "via-shell"
type = "command"
command = "sh -c \\"'{cli}' develop {{input}} -o {{output}} -q\\""
output_suffix = ".exr"

[[pipeline]]
name = "via-environment"
type = "command"
command = "sh -c '\\"{cli}\\" develop \\"$SPECTRAL_CAM_INPUT\\" -o \\"$SPECTRAL_CAM_OUTPUT\\" -q' {{input}} {{output}}"
output_suffix = ".exr"
''')
    out = tmp_path / folder_name / "report"
    assert main(["validate", str(plan), "-o", str(out), "-q"]) == 0
    assert not list(tmp_path.rglob("pwned")), "a folder name ran a command"
    assert {row.split(",")[4] for row in (out / "cells.csv").read_text().splitlines()[1:]} == {
        "via-shell", "via-environment"}


@pytest.mark.timeout(60)
def test_a_callables_python_path_is_scoped_to_the_call(tmp_path):
    """python_path is on sys.path while the function is imported and called, not after (#17)."""
    folder = tmp_path / "isp"
    folder.mkdir()
    (folder / "scoped_isp.py").write_text(
        "import sys\nSEEN = []\n"
        "def develop(path):\n"
        "    import numpy as np\n"
        "    SEEN.append(any(p.endswith('isp') for p in sys.path))\n"
        "    return np.full((24, 36, 3), 0.5)\n")
    plan = plan_from_dict({"validate": {"illuminants": ["D65"], "cameras": ["nikon_d850"],
                                        "reflectance_sets": ["colorchecker"], "patch_px": 4},
                           "pipeline": [{"name": "scoped", "type": "callable", "function": "scoped_isp:develop",
                                         "python_path": ["isp"]}]}, base_dir=tmp_path)
    before = list(sys.path)
    run_plan(plan, tmp_path / "report")
    assert sys.path == before
    assert sys.modules["scoped_isp"].SEEN == [True]


LIBRAW_BY_HAND = '''
import sys

import numpy as np
import rawpy

with rawpy.imread(sys.argv[1]) as raw:
    xyz = raw.postprocess(demosaic_algorithm=rawpy.DemosaicAlgorithm.AHD, use_camera_wb=True, no_auto_bright=True,
                          adjust_maximum_thr=0.0, gamma=(1, 1), output_bps=16, output_color=rawpy.ColorSpace.XYZ,
                          user_flip=0)
np.save(sys.argv[2], xyz.astype(np.float64) / 65535)
'''


@pytest.mark.timeout(180)
def test_a_relative_output_folder_reaches_commands_and_alike_failures_stop(tmp_path, monkeypatch, read_csv):
    """Issue 39 #2: `validate PLAN -o report/` run from another folder than the plan's. Commands run
    in the plan's folder, so the paths they get must be absolute: LibRaw run by a script as a
    command scores what the rawpy pipeline scores on every cell (before: every command cell failed,
    its DNG not found). A command failing the same way on every cell, its message naming the cell's
    own DNG and scratch file, is stopped after three cells."""
    plans = tmp_path / "plans"
    plans.mkdir()
    (plans / "libraw_by_hand.py").write_text(LIBRAW_BY_HAND)
    (plans / "plan.toml").write_text(f'''
[validate]
illuminants = ["D65", "A"]
cameras = ["nikon_d850"]
reflectance_sets = ["colorchecker"]
patch_px = 8
gap_px = 2
swatches = "none"

[[exposure]]
name = "base"
[[exposure]]
name = "under"
auto_fraction = 0.3

[[pipeline]]
name = "libraw"
type = "rawpy"

[[pipeline]]
name = "libraw-command"
type = "command"
command = "'{sys.executable}' libraw_by_hand.py {{input}} {{output}}"
output_suffix = ".npy"
output = "xyz"

[[pipeline]]
name = "cannot-read"
type = "command"
command = "'{sys.executable}' -c 'import sys; sys.exit(\\"cannot read \\" + sys.argv[1] + \\" into \\" + sys.argv[2])' {{input}} {{output}}"
''')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    assert main(["validate", str(plans / "plan.toml"), "-o", "report", "-q"]) == 1  # cannot-read's cells
    cells = read_csv(elsewhere / "report" / "cells.csv")
    assert not list(plans.glob("report*")), "a relative path was resolved in the plan's folder"
    by = {(row["illuminant"], row["exposure"], row["pipeline"]): row for row in cells}
    for illuminant in ("D65", "A"):
        for exposure in ("base", "under"):
            command, libraw = by[illuminant, exposure, "libraw-command"], by[illuminant, exposure, "libraw"]
            assert command["status"] != "error", command["failures"]
            assert float(command["delta_e_mean"]) == pytest.approx(float(libraw["delta_e_mean"]), abs=1e-9)
    failing = [row for row in cells if row["pipeline"] == "cannot-read"]
    assert [row["status"] for row in failing] == ["error"] * 4
    assert all("cannot read /" in row["failures"] for row in failing[:3])  # absolute paths
    assert failing[3]["failures"].startswith("not run: it failed the same way on its last 3 cells")


@pytest.mark.timeout(120)
@pytest.mark.parametrize("cfa", ["QUAD_RGGB", "RGBW"])
def test_libraw_cells_of_a_tile_libraw_cannot_read_are_refused_with_the_reason(tmp_path, cfa):
    """Issue 39 #30: LibRaw maps a DNG's CFAPattern onto 2×2 (or X-Trans) tables; it reads a Quad
    Bayer DNG's 4×4 tile as a 2×2 and an RGBW DNG's as four other colours. Such a cell is refused
    with the reason (it scored ΔE 26–28 as if the pipeline were wrong); ours develops the same RAW."""
    import rawpy
    import tifffile

    plan = plan_from_dict({"validate": {"illuminants": ["D65"], "cameras": ["nikon_d850"], "patch_px": 12,
                                        "reflectance_sets": ["colorchecker"], "swatches": "none"},
                           "sensor": {"cfa": cfa}, "render": {"bands": "auto"},
                           "pipeline": [{"name": "libraw", "type": "rawpy"},
                                        {"name": "ours", "type": "ours", "isp": {"tone": "linear"}}]})
    result = run_plan(plan, tmp_path / "report")
    dng = next((tmp_path / "report" / "raw").glob("*.dng"))
    with tifffile.TiffFile(dng) as tif:  # the tile the DNG holds, read without LibRaw
        page = next(p for p in tif.pages if 33421 in p.tags)
        written = tuple(page.tags[33421].value)
    with rawpy.imread(str(dng)) as raw:
        read, colours = np.asarray(raw.raw_pattern), bytes(raw.color_desc)
    assert written == (4, 4) and (read.shape != written or b"W" not in colours)  # LibRaw misreads it
    libraw, ours = result.cell(pipeline="libraw"), result.cell(pipeline="ours")
    assert libraw.status == "error" and libraw.stats == {}
    assert "LibRaw cannot read this RAW's" in libraw.failures[0] and cfa in libraw.failures[0]
    assert ours.status == "pass"


TOOL = '''
import os
import sys

import numpy as np
import rawpy

mode, source, out = sys.argv[1], sys.argv[-2], sys.argv[-1]
for argument in sys.argv[2:-2]:  # settings folders: made where their path says, quotes and all
    folder = argument.split("=", 1)[-1]
    if not os.path.isdir(os.path.dirname(folder)):
        sys.exit(f"no folder {os.path.dirname(folder)!r}")
    os.makedirs(folder)
with rawpy.imread(source) as raw:
    xyz = raw.postprocess(use_camera_wb=True, no_auto_bright=True, adjust_maximum_thr=0.0, gamma=(1, 1),
                          output_bps=16, output_color=rawpy.ColorSpace.XYZ, user_flip=0) / 65535
if mode == "flipped":
    xyz = xyz[::-1, ::-1]
if mode == "trimmed":  # 40 px off the bottom and the right, more than registration searches
    xyz = xyz[:-40, :-40]
np.save(out, xyz)
'''


def _tool_plan(folder: Path, pipelines: str, *, patch_px: int = 8) -> Path:
    (folder / "tool.py").write_text(TOOL)
    plan = folder / "plan.toml"
    plan.write_text(one_chart_plan(patch_px) + 'swatches = "none"\n' + pipelines)
    return plan


@pytest.mark.timeout(120)
def test_placeholders_inside_arguments_reach_the_program_without_shell_quotes(tmp_path):
    """Issue 39 #30: `--configdir={work_dir}/config` (and the darktable recipe's `{work_dir}/config`)
    with a report folder whose name holds a space: the program gets the path itself (exec passes
    arguments as they are; quotes were part of the path and made a stray `'…/config` tree in the
    plan's folder); a `sh -c` script still gets it quoted (a shell parses it)."""
    plans = tmp_path / "plans"
    plans.mkdir()
    plan = _tool_plan(plans, f'''
[[pipeline]]
name = "settings-folders"
type = "command"
command = "'{sys.executable}' tool.py plain --configdir={{work_dir}}/config {{work_dir}}/cache {{input}} {{output}}"
output_suffix = ".npy"
output = "xyz"

[[pipeline]]
name = "through-sh"
type = "command"
command = "sh -c \\"'{sys.executable}' tool.py plain {{work_dir}}/sh-config {{input}} {{output}}\\""
output_suffix = ".npy"
output = "xyz"
''')
    out = tmp_path / "out dir" / "report"
    assert main(["validate", str(plan), "-o", str(out), "-q"]) == 0
    assert sorted(p.name for p in plans.iterdir()) == ["plan.toml", "tool.py"]  # nothing stray


@pytest.mark.timeout(120)
def test_a_timed_out_shell_command_leaves_no_process_running(tmp_path):
    """Issue 39 #30: at timeout_s the command's whole process group is killed, a shell's children
    too (killing the shell alone left `sleep` running)."""
    plan = _tool_plan(tmp_path, '''
[[pipeline]]
name = "hangs"
type = "command"
command = ": {input} {output}; sleep 60 & echo $! > child.pid; wait"
shell = true
timeout_s = 2
''')
    result = run_plan(load_plan(plan))
    (cell,) = result.cells
    assert cell.status == "error" and "no result within 2 s" in cell.failures[0]
    child = int((tmp_path / "child.pid").read_text())
    deadline = time.monotonic() + 5
    while _running(child) and time.monotonic() < deadline:
        time.sleep(0.05)
    try:
        assert not _running(child), "the shell's child outlived the timeout"
    finally:
        if _running(child):
            os.kill(child, signal.SIGKILL)


def _running(pid: int) -> bool:
    """Whether a process exists and is not a zombie (/proc/PID/stat's state)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return False
    return state not in ("Z", "X")


@pytest.mark.timeout(60)
def test_an_impossible_input_min_bytes_is_refused_with_the_valid_range(tmp_path):
    """Issue 39 #30: input_min_bytes = 2**62 said "MemoryError: " at the first cell."""
    with pytest.raises(ConfigError, match=r"input_min_bytes = 4611686018427387904; give a whole number of bytes "
                                          r"in 0\.\.1073741824"):
        plan_from_dict({"validate": {}, "pipeline": [{"type": "command", "command": "x {input} {output}",
                                                      "input_min_bytes": 2 ** 62}]}, base_dir=tmp_path)


@pytest.mark.timeout(120)
def test_a_misregistered_tool_image_is_called_misregistered_with_what_was_measured(tmp_path):
    """Issue 39 #30: a tool's image flipped, or trimmed by more than registration searches, was
    reported as "black at the white reference". The flipped image's luminance correlates with the
    RAW's at r < 0.75 (numpy's corrcoef on the same pixels; a registered one > 0.9)."""
    plan = _tool_plan(tmp_path, "".join(f'''
[[pipeline]]
name = "{mode}"
type = "command"
command = "'{sys.executable}' tool.py {mode} {{input}} {{output}}"
output_suffix = ".npy"
output = "xyz"
''' for mode in ("plain", "flipped", "trimmed")), patch_px=12)
    result = run_plan(load_plan(plan))
    assert result.cell(pipeline="plain").status == "pass"
    flipped, trimmed = result.cell(pipeline="flipped"), result.cell(pipeline="trimmed")
    assert flipped.status == trimmed.status == "error"
    assert "misregistered" in flipped.failures[0] and "r = " in flipped.failures[0]
    assert "cannot register" in trimmed.failures[0] and "crop" in trimmed.failures[0]
    assert not any("black" in cell.failures[0] for cell in (flipped, trimmed))
