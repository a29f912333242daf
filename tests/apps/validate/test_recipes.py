"""Issue 28 #2: the example plan's recipes for the real raw developers (LibRaw through rawpy,
dcraw, RawTherapee, darktable-cli) run out of the box and score what the same tools score when run
by hand on the same DNG; commands run in the plan's folder, may redirect through a shell, and
their images are registered on the frame."""

from __future__ import annotations

import io
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from spectral_cam.apps.validate import evaluate_patches, plan_from_dict, run_plan
from spectral_cam.apps.validate.pipelines import register
from spectral_cam.colour_ground_truth import patch_linear_srgb
from spectral_cam.errors import ConfigError
from spectral_cam.radiance_targets import reflectance_set, synthetic_chart
from spectral_cam.scene import read_toml

pytestmark = pytest.mark.timeout(300)

PLANS = Path(__file__).resolve().parents[3] / "plans"
TOOLS = {"dcraw": "dcraw", "rawtherapee": "rawtherapee-cli", "darktable": "darktable-cli"}


def _example(pipelines, *, variant=None):
    """The example plan cut to one cell (ColorChecker, D65, D850, base exposure) and the named
    pipelines, read from the file as a user would; ``variant(table)``, where given, adds a second
    pipeline per named one (a changed copy of its table)."""
    data = read_toml(PLANS / "validate_example.toml", "validation plan")
    data["validate"].update(illuminants=["D65"], cameras=["nikon_d850"], reflectance_sets=["colorchecker"], seeds=1,
                            compare=[])
    data["exposure"] = data["exposure"][:1]
    data["pipeline"] = [p for p in data["pipeline"] if p["name"] in pipelines]
    if variant is not None:
        data["pipeline"] += [variant(p) for p in data["pipeline"]]
    return plan_from_dict(data, base_dir=PLANS, source=str(PLANS / "validate_example.toml"))


def _by_hand(tool: str, dng: Path, work: Path) -> np.ndarray:
    """The tool run directly with the flags its recipe documents, as linear sRGB."""
    import colour
    import rawpy
    import tifffile

    if tool == "libraw-ahd":
        with rawpy.imread(str(dng)) as raw:
            xyz = raw.postprocess(demosaic_algorithm=rawpy.DemosaicAlgorithm.AHD, use_camera_wb=True,
                                  no_auto_bright=True, adjust_maximum_thr=0.0, gamma=(1, 1), output_bps=16,
                                  output_color=rawpy.ColorSpace.XYZ,
                                  user_flip=0).astype(float) / 65535
        from spectral_cam.colour_ground_truth import xyz_to_linear_srgb

        return xyz_to_linear_srgb(xyz)
    if tool == "dcraw":
        out = subprocess.run(["dcraw", "-w", "-W", "-4", "-T", "-o", "1", "-c", str(dng)], capture_output=True,
                             check=True).stdout
        return tifffile.imread(io.BytesIO(out)).astype(float) / 65535
    if tool == "rawtherapee":
        padded = work / "padded.dng"  # RawTherapee 5.9 refuses raw files under 100 000 bytes
        padded.write_bytes(dng.read_bytes().ljust(100_000, b"\0"))
        subprocess.run(["rawtherapee-cli", "-q", "-Y", "-t", "-b16", "-p", str(PLANS / "rawtherapee_neutral.pp3"),
                        "-o", str(work / "rt.tif"), "-c", str(padded)], capture_output=True, check=True)
        return colour.cctf_decoding(tifffile.imread(work / "rt.tif").astype(float) / 65535, "sRGB")
    subprocess.run(["darktable-cli", str(dng), str(work / "dt.tif"), "--icc-type", "LIN_REC709",
                    "--apply-custom-presets", "false", "--core", "--configdir", str(work / "dt"),
                    "--conf", "plugins/imageio/format/tiff/bpp=32", "--conf", "plugins/darkroom/workflow=none",
                    "--conf", "plugins/darkroom/chromatic-adaptation=legacy"], capture_output=True, check=True)
    return tifffile.imread(work / "dt.tif").astype(float)


def test_the_recipes_score_what_the_tools_score_by_hand(tmp_path):
    """Each recipe's mean ΔE2000 equals the same tool's, run by hand on the report's DNG and measured
    on the same patches, within 0.05 (measured: identical to 1e-6 for all four)."""
    missing = [program for program in TOOLS.values() if not shutil.which(program)]
    if missing:
        pytest.skip(f"{', '.join(missing)} absent: apt-get install dcraw rawtherapee darktable (as .ci/run does)")
    plan = _example(["libraw-ahd", *TOOLS])
    result = run_plan(plan, tmp_path / "report")
    assert [c.pipeline for c in result.cells] == ["libraw-ahd", *TOOLS] and not plan.skipped_pipelines
    assert all(c.status == "pass" for c in result.cells), [(c.pipeline, c.failures) for c in result.cells]
    assert all(p.version for p in plan.pipelines if p.kind == "command")  # versions recorded
    dng = next((tmp_path / "report" / "raw").glob("*.dng"))
    chart = synthetic_chart(reflectance_set("colorchecker"), "D65", illuminance_lux=plan.illuminance_lux,
                            bands=plan.bands, patch_px=plan.patch_px, gap_px=plan.gap_px)
    reference = patch_linear_srgb("D65", chart.sds)
    frame = chart.radiance.data.shape[:2]
    for cell in result.cells:
        image = _by_hand(cell.pipeline, dng, tmp_path)
        if image.shape[:2] != frame:
            image = register(image, frame, "auto")
        by_hand = evaluate_patches(image, chart, reference)
        assert cell.stats["delta_e_mean"] == pytest.approx(by_hand["delta_e_mean"], abs=0.05), cell.pipeline


def test_an_optional_tool_that_is_absent_is_left_out_with_a_note():
    plan = plan_from_dict({"validate": {}, "pipeline": [
        {"type": "ours"},
        {"name": "nothere", "type": "command", "command": "no-such-raw-tool {input} {output}", "optional": True}]})
    assert [p.name for p in plan.pipelines] == ["ours"]
    assert plan.skipped_pipelines == ("nothere: no-such-raw-tool is not installed",)
    with pytest.raises(ConfigError, match="no pipeline of the plan can run"):
        plan_from_dict({"validate": {}, "pipeline": [
            {"name": "nothere", "type": "command", "command": "no-such-raw-tool {input} {output}", "optional": True}]})


def test_commands_run_in_the_plans_folder_and_may_redirect(tmp_path, monkeypatch):
    """A relative script path resolves beside the plan wherever the run starts (16 of 48 cells
    failed from another folder before), {plan_dir} names that folder, and shell = true lets a tool
    write its image to stdout redirected into {output} (a binary stdout was once decoded as text)."""
    plan_dir = tmp_path / "plan"
    plan_dir.mkdir()
    (plan_dir / "develop.py").write_text(
        "import sys\nimport numpy as np\nfrom spectral_cam.isp import develop\nfrom spectral_cam.raw import read_raw\n"
        "linear = develop(read_raw(sys.argv[1])).linear\n"
        "np.save(sys.stdout.buffer, linear.astype(np.float32))\n")
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    monkeypatch.chdir(elsewhere)
    python = sys.executable
    plan = plan_from_dict({"validate": {"patch_px": 8, "swatches": "none"}, "pipeline": [
        {"name": "relative", "type": "command", "command": f"'{python}' develop.py {{input}} > {{output}}",
         "shell": True, "output_suffix": ".npy"},
        {"name": "plan_dir", "type": "command", "command": f"'{python}' {{plan_dir}}/develop.py {{input}} > {{output}}",
         "shell": True, "output_suffix": ".npy"}]}, base_dir=plan_dir)
    result = run_plan(plan)
    assert [c.status for c in result.cells] == ["pass", "pass"], [c.failures for c in result.cells]
    assert result.cells[0].stats["delta_e_mean"] == pytest.approx(result.cells[1].stats["delta_e_mean"], abs=1e-9)


def test_a_cropped_image_is_registered_on_the_frame():
    """A tool that trims 4 px a side (RawTherapee) or adds a border: the image lands where the frame
    is; pixels it removed are NaN; an uneven or inconsistent crop is refused with what to declare."""
    frame = np.random.default_rng(0).random((20, 30, 3))
    trimmed = frame[4:-4, 4:-4]
    placed = register(trimmed, (20, 30), "auto")
    np.testing.assert_array_equal(placed[4:-4, 4:-4], trimmed)
    assert np.isnan(placed[:4]).all()
    bordered = np.pad(frame, ((2, 2), (3, 3), (0, 0)))
    np.testing.assert_array_equal(register(bordered, (20, 30), "auto"), frame)
    np.testing.assert_array_equal(register(frame[1:-3, 2:], (20, 30), [1, 3, 2, 0])[1:-3, 2:], frame[1:-3, 2:])
    with pytest.raises(ConfigError, match="not an even margin; declare crop"):
        register(frame[1:], (20, 30), "auto")
    with pytest.raises(ConfigError, match="does not turn"):
        register(frame[1:], (20, 30), [0, 0, 0, 0])


def test_an_embedded_icc_profile_decodes_like_the_encoding_it_names():
    """LittleCMS's sRGB profile (written by Pillow's ImageCms: a parametric TRC and D50 colorants)
    decodes through our matrix/TRC reader to colour-science's sRGB decoding within 2e-4; a LUT or
    non-RGB profile is refused with what to do."""
    import colour
    from PIL import ImageCms

    from spectral_cam.apps.validate.icc import MatrixShaperProfile, icc_to_linear_srgb

    profile = ImageCms.ImageCmsProfile(ImageCms.createProfile("sRGB")).tobytes()
    values = np.random.default_rng(0).random((200, 3))
    np.testing.assert_allclose(icc_to_linear_srgb(values, profile), colour.cctf_decoding(values, "sRGB"), atol=2e-4)
    lab = ImageCms.ImageCmsProfile(ImageCms.createProfile("LAB")).tobytes()
    with pytest.raises(ConfigError, match="only RGB profiles"):
        MatrixShaperProfile(lab)


def test_the_tools_embedded_profiles_score_as_their_declared_encodings(tmp_path):
    """RawTherapee (RTv4_sRGB) and darktable (linear Rec. 709) read through the profile they embed
    (output = "icc") score as with the encoding the recipe declares, within 0.01 (measured 0.0002)."""
    missing = [program for program in ("rawtherapee-cli", "darktable-cli") if not shutil.which(program)]
    if missing:
        pytest.skip(f"{', '.join(missing)} absent: apt-get install rawtherapee darktable (as .ci/run does)")
    plan = _example(["rawtherapee", "darktable"], variant=lambda p: {**p, "name": p["name"] + "-icc", "output": "icc"})
    cells = {c.pipeline: c for c in run_plan(plan).cells}
    for name in ("rawtherapee", "darktable"):
        assert cells[f"{name}-icc"].status == "pass"
        assert cells[f"{name}-icc"].stats["delta_e_mean"] == pytest.approx(cells[name].stats["delta_e_mean"], abs=0.01)


def test_an_unevenly_cropped_image_is_found_on_the_frame(tmp_path):
    """A tool that trims 3, 5, 2 and 6 px (top, bottom, left, right): registered automatically
    against the RAW's own luminance (the chart repeats, so the share of the image on the frame breaks
    the tie between periods), it scores as the same develop uncropped, to 1e-9."""
    (tmp_path / "develop.py").write_text(
        "import sys\nimport numpy as np\nfrom spectral_cam.isp import develop\nfrom spectral_cam.raw import read_raw\n"
        "linear = develop(read_raw(sys.argv[1])).linear\n"
        "trim = [int(v) for v in sys.argv[3:]]\n"
        "if trim:\n    linear = linear[trim[0]:linear.shape[0] - trim[1], trim[2]:linear.shape[1] - trim[3]]\n"
        "np.save(sys.argv[2], linear.astype(np.float32))\n")
    python = sys.executable
    plan = plan_from_dict({"validate": {"patch_px": 12, "gap_px": 4, "swatches": "none"}, "pipeline": [
        {"name": "whole", "type": "command", "command": f"'{python}' develop.py {{input}} {{output}}",
         "output_suffix": ".npy"},
        {"name": "trimmed", "type": "command", "command": f"'{python}' develop.py {{input}} {{output}} 3 5 2 6",
         "output_suffix": ".npy"}]}, base_dir=tmp_path)
    whole, trimmed = run_plan(plan).cells
    assert trimmed.status == "pass"
    assert trimmed.stats["delta_e_mean"] == pytest.approx(whole.stats["delta_e_mean"], abs=1e-9)
