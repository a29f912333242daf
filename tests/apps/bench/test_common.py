"""What the benchmarks share: the Pareto front, the CSV and the chart."""

from __future__ import annotations

import csv

import numpy as np
import pytest

from spectral_cam.apps.bench import pareto_front
from spectral_cam.apps.bench.common import mark_front, pareto_chart, write_rows


@pytest.mark.timeout(10)
def test_pareto_front_keeps_only_undominated_points():
    cost = np.array([1.0, 2.0, 3.0, 4.0, 2.5])
    error = np.array([5.0, 3.0, 3.5, 1.0, 2.0])
    # (3, 3.5) is beaten by (2, 3); every other point is best for its cost
    assert pareto_front(cost, error).tolist() == [0, 1, 4, 3]


@pytest.mark.timeout(60)
def test_rows_become_a_csv_with_every_digit_and_a_chart(tmp_path):
    rows = [{"method": name, "spp": spp, "seconds": seconds, "error": error}
            for name, spp, seconds, error in (("a", 4, 0.1, 2.0), ("b", 16, 0.3, 1.0), ("c", 64, 0.2, 1.0 / 3))]
    mark_front(rows, "seconds", "error")
    assert [r["pareto"] for r in rows] == [True, False, True]
    write_rows(rows, tmp_path / "rows.csv")
    with open(tmp_path / "rows.csv") as handle:
        written = list(csv.DictReader(handle))
    assert list(written[0]) == ["method", "spp", "seconds", "error", "pareto"]
    assert [r["spp"] for r in written] == ["4", "16", "64"]
    assert float(written[2]["error"]) == 1.0 / 3
    assert written[0]["pareto"] == "True"
    pareto_chart(rows, tmp_path / "rows.png", x="seconds", y="error", label="method", title="t")
    assert (tmp_path / "rows.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
