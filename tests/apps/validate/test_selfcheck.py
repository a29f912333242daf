"""``spectral-cam validate --self`` (spectral_cam.apps.validate.selfcheck) passes its physics checks."""

from __future__ import annotations

import time

import pytest

from spectral_cam.cli import main


@pytest.mark.timeout(120)
def test_self_checks_pass(tmp_path, capsys, read_csv):
    table = tmp_path / "checks.csv"
    started = time.perf_counter()
    assert main(["validate", "--self", "--csv", str(table), "-q"]) == 0
    seconds = time.perf_counter() - started
    printed = capsys.readouterr().out
    assert "measured" in printed and "reference" in printed and "tolerance" in printed
    rows = read_csv(table)
    checks = {row["check"] for row in rows}
    assert {"radiometry vs colour-science", "thin-lens CoC", "√n law (shot noise)", "EMVA 1288 round trip",
            "DNG / LibRaw agreement"} <= checks
    assert all(row["passed"] == "True" for row in rows)
    assert f"{len(rows)}/{len(rows)} checks pass" in printed
    assert seconds < 60.0  # small and fast (measured ≈ 5 s)
