"""Issue 28 #3: callables as pipelines. Integer images are scaled by their type like a command's
files, a callable can take the cell's context (the chart's layout, the illuminant, the exposure),
its traceback reaches the report, and balancing on the scored white reference is flagged."""

from __future__ import annotations

import textwrap

import pytest

from spectral_cam.apps.validate import plan_from_dict, run_plan

pytestmark = pytest.mark.timeout(180)

ISP = textwrap.dedent('''
    """A small ISP for the tests: ours, as-shot white balance, encoded to sRGB in several types."""
    import numpy as np

    from spectral_cam.isp import ISPConfig, develop
    from spectral_cam.raw import read_raw

    seen = []


    def _srgb(path):
        linear = np.clip(develop(read_raw(path), ISPConfig(tone="linear", demosaic="bilinear")).linear, 0, 1)
        return np.where(linear <= 0.0031308, 12.92 * linear, 1.055 * linear ** (1 / 2.4) - 0.055)


    def as_float(path):
        return _srgb(path)


    def as_uint8(path):
        return np.round(_srgb(path) * 255).astype(np.uint8)


    def as_uint16(path):
        return np.round(_srgb(path) * 65535).astype(np.uint16)


    def white_patch_balance(path, context):
        """Balances on the white reference the metric scores, found from the context."""
        seen.append(context)
        image = _srgb(path) ** 2.2
        white = context.patches[context.white_index]
        rows = slice(int(white["row"] - white["half_height_px"] / 2), int(white["row"] + white["half_height_px"] / 2))
        columns = slice(int(white["column"] - white["half_width_px"] / 2),
                        int(white["column"] + white["half_width_px"] / 2))
        return image / image[rows, columns].reshape(-1, 3).mean(axis=0)


    def _inner(value):
        return value["missing"]


    def fails_deep(path, *, context=None):
        return _inner({"present": 1})
    ''')


def _plan(tmp_path, functions):
    (tmp_path / "test_isp_module.py").write_text(ISP)
    return plan_from_dict({
        "validate": {"illuminants": ["D65"], "cameras": ["nikon_d850"], "reflectance_sets": ["colorchecker"],
                     "patch_px": 12, "gap_px": 4, "swatches": "none"},
        "sensor": {"read_noise_e": 0.0, "prnu": 0.0, "dsnu_e": 0.0, "dark_current_e_per_s": 0.0},
        "pipeline": [{"name": name, "type": "callable", "function": f"test_isp_module:{name}",
                      "python_path": ["."], "output": output} for name, output in functions]},
        base_dir=tmp_path)


def test_a_callable_scores_the_same_as_uint8_uint16_and_float(tmp_path):
    """The same develop returned as float, uint16 and uint8 sRGB: the same scores (uint8's
    quantisation moves the mean by < 0.05 ΔE2000; measured 0.004). Unscaled, a uint8 image scored
    2.23 where its float twin scored 1.02 (issue 28)."""
    result = run_plan(_plan(tmp_path, [("as_float", "srgb"), ("as_uint16", "srgb"), ("as_uint8", "srgb")]))
    means = {cell.pipeline: cell.stats["delta_e_mean"] for cell in result.cells}
    assert all(cell.status == "pass" for cell in result.cells)
    assert means["as_uint16"] == pytest.approx(means["as_float"], abs=0.005)
    assert means["as_uint8"] == pytest.approx(means["as_float"], abs=0.05)


def test_a_callable_gets_the_cells_context_and_balancing_on_the_scored_white_is_flagged(tmp_path):
    """A function taking a context finds the white reference from it; balancing on it makes that
    patch exactly grey, so the white-balance error the metric reports there is the patch's own tint
    (1.4°: BabelColor's white 9.5 in linear sRGB), not a measurement, and the cell says so."""
    import sys

    result = run_plan(_plan(tmp_path, [("white_patch_balance", "linear_srgb")]))
    (cell,) = result.cells
    (context,) = sys.modules["test_isp_module"].seen
    assert (context.set_name, context.illuminant, context.camera) == ("colorchecker", "D65", "nikon_d850")
    assert len(context.patches) == 24 and context.patches[context.white_index]["role"] == "white reference"
    assert context.frame_size[0] > 0 and context.exposure_s > 0
    assert cell.stats["wb_angular_error_deg"] == pytest.approx(1.39, abs=0.1)
    assert any("white-balances on the patch the metric scores" in w for w in cell.warnings)
    ours = run_plan(plan_from_dict({"validate": {"illuminants": ["D65"], "cameras": ["nikon_d850"], "patch_px": 12,
                                                 "swatches": "none"}, "pipeline": [{"type": "ours"}]}))
    assert not ours.cells[0].warnings  # as-shot balance: no warning


def test_a_failing_callable_shows_where_it_failed(tmp_path):
    """The error cell keeps the user's traceback (the function and line that raised), and the report
    prints it."""
    from spectral_cam.apps.validate.report import render_html

    result = run_plan(_plan(tmp_path, [("fails_deep", "linear_srgb")]))
    (cell,) = result.cells
    assert cell.status == "error" and cell.failures == ["KeyError: 'missing'"]
    assert "in _inner" in cell.traceback and 'return value["missing"]' in cell.traceback
    page = render_html(result)
    assert "<h2>Errors</h2>" in page and "in _inner" in page


def test_the_context_a_callable_gets_is_documented_field_by_field(tmp_path):
    """Issue 39 #21: every field of the context a callable (or a command, as JSON) gets, and every
    key of its patches, is named where users read: the README's validation section, docs/design.md
    and the callable pipeline's docstring (it was only in a TOML comment)."""
    import dataclasses
    import sys
    from pathlib import Path

    from spectral_cam.apps.validate.pipelines import CallablePipeline, CellContext

    run_plan(_plan(tmp_path, [("white_patch_balance", "linear_srgb")]))
    context = sys.modules["test_isp_module"].seen[-1]
    fields = [f.name for f in dataclasses.fields(CellContext)]
    patch_keys = list(context.patches[0])
    root = Path(__file__).resolve().parents[3]
    readme = (root / "README.md").read_text(encoding="utf-8")
    readme = readme[readme.index("## Validating a colour pipeline"):]
    readme = readme[:readme.index("\n## ", 10)]
    design = (root / "docs" / "design.md").read_text(encoding="utf-8")
    for where, text in (("README.md", readme), ("docs/design.md", design), ("docstring", CallablePipeline.__doc__)):
        missing = [name for name in fields + patch_keys if f"`{name}`" not in text]
        assert not missing, (where, missing)
