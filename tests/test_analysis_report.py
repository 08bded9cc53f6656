"""write_report: files, traceability (a copy of the run gives identical tables), partial
runs and user errors without tracebacks, optional sections."""

from __future__ import annotations

import math
import shutil

import pandas as pd
import pytest

from squeezebench.report import run_report as report
from squeezebench.analysis.rundata import load_run
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
                 "resonance.png", "plate_fits.png", "conventions_grid.csv", "columns.csv"):
        assert (run_dir / "report" / name).is_file(), name
    text = index.read_text()
    for needle in ("Appendix: Provenance", "Appendix: Conventions used", "Audit of the paper", "sha256", "E_i = 67000000000 Pa"):
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


@pytest.fixture(scope="module")
def partial(tmp_path_factory):
    """A run of one protocol with a hard-case summary beside it, and its report's text: a
    partial run and an optional section in one report (some 4 CPU-s each)."""
    run_dir = build_run(tmp_path_factory.mktemp("partial") / "run", protocols=("powered_columns",))
    (run_dir / "hardcases").mkdir()
    pd.DataFrame({"case": ["pf_0.001"], "passed": [True]}).to_csv(run_dir / "hardcases" / "summary.csv",
                                                                  index=False)
    return run_dir, report.write_report(run_dir).read_text()


def test_partial_run_says_what_is_missing(partial):
    run_dir, text = partial
    assert "protocol &#x27;resonator_cutting&#x27; is not in this run" in text
    table3 = pd.read_csv(run_dir / "report" / "table3.csv")
    assert set(table3["status"]) == {"not measured"}
    # numbers stay numbers: missing is an empty cell (NaN), the status says why
    assert table3["value"].isna().all() and table3["value"].dtype == float
    assert table3["paper_value"].dtype == float and table3["paper_value"].notna().any()
    table5 = pd.read_csv(run_dir / "report" / "table5.csv")
    assert set(table5["status"]) == {"not measured"}


def test_optional_sections_plug_in(partial):
    _, text = partial
    assert "pf_0.001" in text
    assert "no study/ folder" in text   # left out, and said so in the summary


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


def test_default_report_has_no_empty_sections(reported):
    """No hard-case or study section when their folders are absent: nothing red, nothing empty."""
    _, index = reported
    text = index.read_text()
    assert "Hard cases" not in text and "class='missing'" not in text


def test_every_column_is_in_the_dictionary(reported):
    run_dir, _ = reported
    dictionary = pd.read_csv(run_dir / "report" / "columns.csv", keep_default_na=False)
    assert not (dictionary["meaning"] == "not described").any(), \
        dictionary[dictionary["meaning"] == "not described"]["name"].tolist()
    run = load_run(run_dir)
    for frame in [run.measurements] + [pd.read_csv(p) for p in (run_dir / "report").glob("*.csv")
                                      if p.name != "columns.csv" and p.read_text().strip()]:
        assert set(frame.columns) <= set(dictionary["name"])


def test_tables_for_people_and_machines(reported):
    """The HTML shows the paper's precision plus one digit in display units; the CSV keeps
    SI machine names, the uncertainty, the tolerance and the origin of each cell."""
    run_dir, index = reported
    text = index.read_text()
    assert "3.716e+04" not in text and "37160" in text          # printed frequency, as printed
    assert "power (mW)" in text and "amplitude (µm pp)" in text and "velocity (m/s pp)" in text
    table3 = pd.read_csv(run_dir / "report" / "table3.csv")
    for column in ("expanded_uncertainty", "tolerance", "agrees", "origin", "calibrated_on"):
        assert column in table3
    # the synthetic run predates provenance columns: never called measured
    assert set(table3["origin"].dropna()) <= {"bench not recorded", "campaign setting"}
    table5 = pd.read_csv(run_dir / "report" / "table5.csv")
    assert set(table5["origin"]) == {"derived"}


def test_a_run_without_the_papers_plates_is_reported_whole(tmp_path):
    """Only a plate the paper never measured: its characterisation, fits and figure, no error."""
    from test_analysis_synthetic import VOLTAGES_VPP, RunBuilder, _geometry, _scene

    from squeezebench.analysis import model

    geometry = _geometry(3e-3, 12e-3, 10e-3)
    shape = model.PlateGeometry(**geometry, n_powered_piezos=6)
    builder = RunBuilder(tmp_path / "lab")
    convention = model.REPORT_CONVENTION
    # Q takes the sign of Eq. 12's a under the reading (negative with E_i = 67 GPa), tan theta' the
    # sign that makes the power positive: the signs that give a plate that moves and takes power
    q_true = math.copysign(3.1, model.amplitude_pp_m(1.0, 10.0, shape, convention))
    tan_true = math.copysign(0.9, model.power_w(q_true, 1.0, 10.0, 61_000.0, shape, convention))
    for voltage in VOLTAGES_VPP:
        amplitude = model.amplitude_pp_m(q_true, voltage, shape, convention)
        power = model.power_w(q_true, tan_true, voltage, 61_000.0, shape, convention)
        builder.point("lab", "plate_lab_plate_3mm", "characterisation", "lab_plate_3mm", 61_000.0, voltage,
                      power, amplitude * 2 * 3.141592653589793 * 61_000.0, n_powered_piezos=6)
    run_dir = builder.write({"lab_plate_3mm.yaml": _scene(geometry)})
    text = report.write_report(run_dir).read_text()
    assert "lab_plate_3mm" in text and (run_dir / "report" / "plate_fits.png").is_file()
    fig5 = pd.read_csv(run_dir / "report" / "fig5.csv")
    q = fig5[(fig5["item"] == "lab_plate_3mm") & (fig5["quantity"] == "q")]["value"].astype(float).iloc[0]
    assert q == pytest.approx(q_true, rel=1e-3)
    assert "class='missing'" not in text and "Not available" not in text
    assert "Table 5 and Figs. 8-9: the run has no characterisation of large_plate" in text


def test_the_headline_opens_the_report_and_ends_the_command(reported):
    """The same lines atop the page (before any table) and printed by `report`, last before the path."""
    from squeezebench import commands

    run_dir, index = reported
    lines = (run_dir / "report" / report.HEADLINE_FILE).read_text().splitlines()
    assert 2 <= len(lines) <= 10 and "stored points" in lines[0]
    assert lines[1].startswith("The chain is verified")   # the synthetic run's settings come back
    page = index.read_text()
    assert page.index("class='headline") < page.index("<table")
    printed = commands._finished(index).splitlines()   # what report and reproduce print last
    assert printed[-len(lines) - 1:-1] == lines and printed[-1].startswith("report written to")


def test_tables_3_and_4_carry_what_physics_predicts_beside_print(reported):
    """Each predicted cell is the plate model's number for the paper's plate (never the run's):
    beside the printed value, with U (k = 2) and its deviation from print."""
    from squeezebench.plates import predicted_plates

    run_dir, index = reported
    predictions = predicted_plates.predictions().set_index(["table", "item"])
    for name, title in (("table3", "Table 3"), ("table4", "Table 4")):
        table = pd.read_csv(run_dir / "report" / f"{name}.csv", dtype={"item": str})
        frequency = table[table["quantity"] == "frequency_hz"].set_index("item")
        for item, row in frequency.iterrows():
            expected = predictions.loc[(title, item)]
            assert row["predicted_value"] == pytest.approx(expected["predicted_frequency_hz"])
            assert row["predicted_expanded_uncertainty"] == pytest.approx(expected["predicted_frequency_u_hz"])
            assert row["predicted_difference"] == pytest.approx(row["predicted_value"] / row["paper_value"] - 1)
        assert table.loc[table["quantity"] == "voltage_vpp", "predicted_value"].isna().all()   # an input
    assert index.read_text().count("<div class='physics'>physics ") >= 3 * 4 + 3 * 4


def test_the_predicted_responses_u_is_the_propagation_of_its_tolerances():
    """Closed form against a Monte Carlo of v ~ d31 q / (h^2 sqrt(E rho)), P ~ d31^2 q / (h^2 sqrt(E rho)),
    every input rectangular within its tolerance but the sheet's thickness, triangular."""
    import numpy as np

    from squeezebench.plates import laminate, predicted_plates

    rng = np.random.default_rng(7)
    t = laminate.relative_tolerances(2e-3)
    draw = {name: 1 + (rng.triangular(-half, 0, half, 400_000) if name == "thickness_m"
                       else rng.uniform(-half, half, 400_000)) for name, half in t.items()}
    q = 1 + rng.uniform(-predicted_plates.MECHANICAL_Q_TOLERANCE, predicted_plates.MECHANICAL_Q_TOLERANCE, 400_000)
    omega_mass = draw["thickness_m"] ** 2 * np.sqrt(draw["young_pa"] * draw["density_kg_m3"])
    closed = predicted_plates.response_relative_u(2e-3)
    assert 2 * np.std(draw["d31_c_per_n"] * q / omega_mass) == pytest.approx(closed["velocity_pp_mps"], rel=0.05)
    assert 2 * np.std(draw["d31_c_per_n"] ** 2 * q / omega_mass) == pytest.approx(closed["power_w"], rel=0.05)
    omega2_mass = draw["thickness_m"] ** 3 * draw["young_pa"]   # the amplitude v / w: w^2 M ~ E h^3
    assert 2 * np.std(draw["d31_c_per_n"] * q / omega2_mass) == pytest.approx(closed["amplitude_pp_m"], rel=0.05)
    assert 2 * np.std(draw["d31_c_per_n"]) == pytest.approx(closed["tan_theta"], rel=0.05)


def test_table5s_physics_reads_the_predicted_plate_through_the_same_inversion(monkeypatch):
    """Q inverted from the predicted amplitude scales with the shared damping figure; tan theta'
    (P / (Q f)) does not: the damping cancels in the mechanical power, which is why its U holds
    only d31's tolerance; the dielectric loss (under 1 %), which no Q sets, is all that moves it."""
    from squeezebench.analysis import characterisation, model
    from squeezebench.plates import damping, plate_modes, predicted_plates

    geometry = model.PlateGeometry(2e-3, 0.5e-3, 14e-3, 9e-3, n_powered_piezos=8, n_powered_groups=4)
    before = characterisation.predicted_large_plate_q_tan(geometry, model.PAPER_CONVENTION)
    row = predicted_plates._predictions().set_index("item").loc["large_plate"]
    dielectric = damping.dielectric_power_w(row["predicted_frequency_hz"], row["clamped_capacitance_f"], 1.0,
                                            plate_modes.NCE41.tan_delta)
    mechanical = predicted_plates.large_plate_response()["power_w_per_vpp2"] - dielectric
    assert 0 < dielectric < 0.01 * mechanical
    monkeypatch.setattr(predicted_plates, "MECHANICAL_Q", 2 * predicted_plates.MECHANICAL_Q)
    predicted_plates._predictions.cache_clear()
    try:
        after = characterisation.predicted_large_plate_q_tan(geometry, model.PAPER_CONVENTION)
    finally:   # the shared Q back before the cache forgets, or the next call caches the doubled one
        monkeypatch.undo()
        predicted_plates._predictions.cache_clear()
    assert after["q"][0] == pytest.approx(2 * before["q"][0], rel=1e-9)
    assert after["tan_theta"][0] == pytest.approx(
        before["tan_theta"][0] * (mechanical + dielectric / 2) / (mechanical + dielectric), rel=1e-9)
    # the large plate's own U: the closed form's with its placement and bond terms
    assert before["q"][1] / before["q"][0] == pytest.approx(predicted_plates.large_plate_response()["amplitude_rel_U"])
    assert before["q"][1] / before["q"][0] > predicted_plates.response_relative_u(2e-3)["amplitude_pp_m"]
