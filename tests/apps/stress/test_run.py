"""The stress runner: the STUDIES registry, run_studies and ``spectral-cam stress``."""

from __future__ import annotations

import dataclasses
import json
from html.parser import HTMLParser

import pytest

from spectral_cam.apps.stress import STUDIES, StressSettings, run_studies
from spectral_cam.apps.stress.summary import SUMMARY_FIELDS, summary_row, write_summary
from spectral_cam.cli import main
from spectral_cam.errors import ConfigError


def test_every_study_declares_the_settings_it_reads():
    fields = {field.name for field in dataclasses.fields(StressSettings)}
    assert list(STUDIES) == ["demosaic", "exposure", "optics", "bokeh", "illuminants", "lenses", "olpf", "rolling", "shading", "photon_events"]
    declared = set()
    for name, entry in STUDIES.items():
        assert set(entry.options) <= fields, name
        assert entry.description and callable(entry.function.measure) and callable(entry.function.plot)
        declared |= set(entry.options)
    assert declared == fields  # no setting is read by no study


def test_run_studies_refuses_unknown_study_names(tmp_path):
    with pytest.raises(ConfigError, match="unknown stress study 'bokhe'; valid: demosaic, exposure"):
        run_studies(tmp_path, StressSettings.quick(), only=["bokhe"])


def test_summary_csv_formats_numbers_for_people(tmp_path):
    rows = [summary_row("optics", "a, b", "ratio", 0.012345, "ratio"), summary_row("x", "y", "none", None, "px"),
            summary_row("x", "y", "big", 4.534e6, "spp", "note")]
    assert write_summary(rows, tmp_path) == ["summary.csv", "summary.html"]
    lines = (tmp_path / "summary.csv").read_text(encoding="utf-8").splitlines()
    assert lines == [",".join(SUMMARY_FIELDS), 'optics,"a, b",ratio,0.01235,ratio,', "x,y,none,,px,",
                     "x,y,big,4.534e+06,spp,note"]


class _Tables(HTMLParser):
    """Each HTML table's rows as lists of cell texts, by the standard library's parser."""

    def __init__(self):
        super().__init__()
        self.tables, self.cell = [], None

    def handle_starttag(self, tag, attrs):
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self.cell = ""

    def handle_endtag(self, tag):
        if tag in ("td", "th"):
            self.tables[-1][-1].append(self.cell)
            self.cell = None

    def handle_data(self, data):
        if self.cell is not None:
            self.cell += data


def test_summary_is_an_html_page_of_one_table_per_study_not_an_image(tmp_path):
    """Issue 39 #20: 272 rows drawn as a 1360 × 4197 image could not be read; the page holds every
    row as text, one table per study, with markup in the notes shown as text."""
    rows = [summary_row("optics", f"f/{n}", "CoC", n / 3, "px") for n in range(1, 201)]
    rows += [summary_row("bokeh", "layered", "error <b>x</b> & y", 0.0123456, "relative", "<script>alert(1)</script>")]
    assert write_summary(rows, tmp_path) == ["summary.csv", "summary.html"]
    assert not (tmp_path / "summary.png").exists()
    page = (tmp_path / "summary.html").read_text(encoding="utf-8")
    parser = _Tables()
    parser.feed(page)
    assert [len(table) for table in parser.tables] == [201, 2]  # header + rows per study
    assert parser.tables[0][0] == ["case", "metric", "value", "unit", "note"]
    assert parser.tables[0][3] == ["f/3", "CoC", "1", "px", ""]
    assert parser.tables[1][1] == ["layered", "error <b>x</b> & y", "0.01235", "relative", "<script>alert(1)</script>"]
    assert "<script>" not in page


@pytest.mark.timeout(300)  # 106 s measured on 2 loaded cores
def test_stress_cli_writes_charts_and_summary_and_never_overwrites(tmp_path, capsys):
    out = tmp_path / "stress"
    assert main(["stress", "-o", str(out), "--quick", "--only", "illuminants"]) == 0
    assert "stress: illuminants:" in capsys.readouterr().err
    names = {p.name for p in out.iterdir()}
    assert {"illuminants_delta_e.png", "summary.csv", "summary.html", "results.json"} <= names
    assert "summary.png" not in names  # hundreds of rows are a page to read, not an image (issue 39 #20)
    summary = (out / "summary.csv").read_text().splitlines()
    assert summary[0] == "study,case,metric,value,unit,note" and len(summary) > 30
    results = json.loads((out / "results.json").read_text())
    assert set(results["studies"]) == {"illuminants"} and results["timings_s"]["illuminants"] > 0
    assert main(["stress", "-o", str(out), "--quick", "--only", "illuminants"]) == 2
    assert "--force" in capsys.readouterr().err
    blocked = main(["stress", "-o", str(out / "summary.csv" / "x"), "--quick", "--only", "illuminants"])
    assert blocked == 2 and "cannot write" in capsys.readouterr().err
    assert not [p for p in tmp_path.rglob(".*partial*")]
    assert main(["stress", "-o", str(out), "--quick", "--only", "illuminants", "--force", "-q"]) == 0
    assert capsys.readouterr().err == ""
