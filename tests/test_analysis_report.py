"""write_report: files, traceability (a copy of the run gives identical tables), partial
runs and user errors without tracebacks, optional sections."""

from __future__ import annotations

import shutil

import pandas as pd
import pytest

from squeezebench.analysis import report
from squeezebench.errors import UserError
from test_analysis_synthetic import build_run


@pytest.fixture(scope="module")
def reported(tmp_path_factory):
    run_dir = build_run(tmp_path_factory.mktemp("report") / "run")
    return run_dir, report.write_report(run_dir)


def test_report_files(reported):
    run_dir, index = reported
    assert index == run_dir / "report" / "index.html"
    for name in ("table3.csv", "table4.csv", "table5.csv", "fig2.png", "fig5.png", "fig8.png", "fig9.png",
                 "resonance.png", "conventions_grid.csv"):
        assert (run_dir / "report" / name).is_file(), name
    text = index.read_text()
    for needle in ("Provenance", "Conventions used", "Audit of the paper", "sha256", "E_i = 67109 Pa"):
        assert needle in text


def test_tables_have_no_nan_or_inf(reported):
    run_dir, _ = reported
    for name in ("table3", "table4", "table5"):
        text = (run_dir / "report" / f"{name}.csv").read_text().lower()
        assert "nan" not in text and "inf" not in text.replace("info", ""), name


def test_report_on_a_copy_gives_identical_tables(reported, tmp_path):
    run_dir, _ = reported
    copy = tmp_path / "copy"
    shutil.copytree(run_dir, copy)
    shutil.rmtree(copy / "report")
    report.write_report(copy)
    for name in ("table3.csv", "table4.csv", "table5.csv", "conventions_grid.csv"):
        assert (copy / "report" / name).read_bytes() == (run_dir / "report" / name).read_bytes(), name


def test_missing_or_empty_run_dir_is_a_user_error(tmp_path):
    with pytest.raises(UserError, match="no such run directory"):
        report.write_report(tmp_path / "absent")
    (tmp_path / "empty").mkdir()
    with pytest.raises(UserError, match="not a run directory"):
        report.write_report(tmp_path / "empty")


def test_partial_run_says_what_is_missing(tmp_path):
    run_dir = build_run(tmp_path / "partial", protocols=("powered_columns",))
    index = report.write_report(run_dir)
    text = index.read_text()
    assert "protocol &#x27;resonator_cutting&#x27; is not in this run" in text
    table3 = pd.read_csv(run_dir / "report" / "table3.csv")
    assert set(table3["status"]) == {"not measured"}
    assert (table3["value"] == "not measured").all()
    table5 = pd.read_csv(run_dir / "report" / "table5.csv")
    assert set(table5["status"]) == {"not measured"}


def test_optional_sections_plug_in(tmp_path):
    run_dir = build_run(tmp_path / "with_extras", protocols=("powered_columns",))
    (run_dir / "hardcases").mkdir()
    pd.DataFrame({"case": ["pf_0.001"], "passed": [True]}).to_csv(run_dir / "hardcases" / "summary.csv",
                                                                  index=False)
    text = report.write_report(run_dir).read_text()
    assert "pf_0.001" in text
    assert "no study trials" in text


def test_only_journaled_steps_are_read(tmp_path):
    """A step whose journal line is missing (killed before it) is not complete."""
    import json

    from squeezebench.analysis.rundata import load_run

    run_dir = build_run(tmp_path / "journaled", protocols=("powered_columns",))
    steps = sorted((run_dir / "measurements" / "columns").glob("*.parquet"))
    journal = "".join(json.dumps({"run": "columns", "step": p.stem}) + "\n" for p in steps[:2])
    (run_dir / "journal.jsonl").write_text(journal + '{"run": "columns", "st')  # torn last line
    run = load_run(run_dir)
    assert sorted(run.measurements["step_id"].unique()) == sorted(p.stem for p in steps[:2])
