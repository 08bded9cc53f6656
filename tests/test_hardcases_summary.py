"""benchmarks/hardcases_summary.py: its numerical hard cases pass and the CSV it writes is
what the report's "Hard cases" section shows (the fault cases are covered by test_faults)."""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import SimpleNamespace

import pandas as pd

from squeezebench.report.study import hardcases_section

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "hardcases_summary.py"


def _script():
    spec = importlib.util.spec_from_file_location("hardcases_summary", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_numerical_hard_cases_pass_and_the_report_shows_them(tmp_path, capsys):
    assert _script().main(["--out", str(tmp_path), "--no-faults"]) == 0
    summary = pd.read_csv(tmp_path / "hardcases" / "summary.csv")
    assert list(summary.columns[:3]) == ["case", "tolerance", "outcome"]
    assert (summary["outcome"] == "pass").all()
    assert "case" in capsys.readouterr().out
    out_dir = tmp_path / "report"
    out_dir.mkdir()
    section = hardcases_section(SimpleNamespace(run=SimpleNamespace(run_dir=tmp_path), out_dir=out_dir))
    assert "summary.csv" in section.body_html and "power factor 0.001" in section.body_html
