"""Pipeline types (spectral_cam.apps.validate.pipelines): broken user pipelines are flagged,
failing programs become error cells, external commands are measured like our ISP, and each
type accepts the plan keys its registry entry declares."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from spectral_cam.apps.validate import PIPELINES, plan_from_dict, run_plan
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
