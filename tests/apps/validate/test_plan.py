"""Validation plans (spectral_cam.apps.validate.plan): errors that name what
is valid, --set overrides."""

from __future__ import annotations

import json

import pytest

from spectral_cam.apps.validate import (
    load_plan,
    plan_from_dict,
)
from spectral_cam.cli import main
from spectral_cam.errors import ConfigError


@pytest.mark.timeout(60)
def test_plan_errors_name_what_is_valid(tmp_path, capsys, example_plan_path):
    base = {"validate": {"illuminants": ["D65"]}, "pipeline": [{"type": "ours"}]}

    def fails(match, **changes):
        data = json.loads(json.dumps(base))
        for dotted, value in changes.items():
            section, _, key = dotted.partition("__")
            if key:
                data.setdefault(section, {})[key] = value
            else:
                data[section] = value
        with pytest.raises(ConfigError, match=match):
            plan_from_dict(data, base_dir=tmp_path)

    fails("valid: illuminants, cameras", validate__colour="red")
    fails("unknown camera 'leica'", validate__cameras=["leica"])
    fails("unknown illuminant", validate__illuminants=["D66"])
    fails("valid: synthetic, render", validate__chart="photo")
    fails("ColorChecker preset only", validate__chart="render", validate__reflectance_sets=["cie2017"])
    fails("valid: ours, rawpy, callable, command", pipeline=[{"type": "darktable"}])
    fails(r"valid \(this LibRaw\): LINEAR", pipeline=[{"type": "rawpy", "demosaic": "AMAZE2"}])
    fails("valid: camera, auto, daylight, manual", pipeline=[{"type": "rawpy", "white_balance": "sunny"}])
    fails("cannot import module", pipeline=[{"type": "callable", "function": "no_such_module:f"}])
    fails("placeholders", pipeline=[{"type": "command", "command": "cp in out"}])
    fails("isp.demosaic", pipeline=[{"type": "ours", "isp": {"demosaic": "magic"}}])
    fails("names must be unique", pipeline=[{"type": "ours"}, {"type": "ours"}])
    fails("set by the chart", sensor={"width_px": 100})
    fails("comes from validate.cameras", sensor={"model": "nikon_d850"})
    fails("exposure.iso", exposure=[{"iso": -1}])
    fails("must be a number > 0", validate__thresholds={"mean_delta_e": 0})
    # the CLI prints one line, no traceback, exit status 2
    plan = tmp_path / "bad.toml"
    plan.write_text('[validate]\nreflectance_sets = ["munsell"]\n[[pipeline]]\ntype = "ours"\n')
    assert main(["validate", str(plan), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "unknown reflectance set 'munsell'" in err and "Traceback" not in err
    assert not (tmp_path / "out").exists()
    assert main(["validate", "--self", str(plan)]) == 2
    # --set overrides reach the plan
    overridden = load_plan(example_plan_path, overrides=["validate.cameras=[\"canon_eos_5d_mkiii\"]",
                                                         "validate.patch_px=8"])
    assert overridden.cameras == ("canon_eos_5d_mkiii",) and overridden.patch_px == 8
