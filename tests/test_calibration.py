"""The deskew calibration protocol: a resistor through the plate's channels measures the
CH2 delay the bench really has, and the corrected Fig. 2c stress power comes back to the truth."""

from __future__ import annotations

import json

import numpy as np
import pytest

from squeezebench import paths
from squeezebench.analysis.calibration import current_gain_ratio, deskew_of_run, gain_weight
from squeezebench.analysis.rundata import load_run
from squeezebench.analysis.tables import reduced_points
from squeezebench.analysis.uncertainty import with_expanded_uncertainties
from squeezebench.protocols.campaign import run_campaign
from squeezebench.simbench import physics
from squeezebench.simbench.effects import build_pipeline
from squeezebench.simbench.scene import load_scene
from squeezebench.protocols.variants import campaign_with_effects
from squeezebench.yamlfiles import dump_yaml, load_strict

PROBE_DELAY_S, SKEW_S = 8e-9, 1e-9
GAINS = {"ch1_rel": 0.01, "ch2_rel": -0.01, "ch3_rel": 0.0}
PROBE_GAIN = 0.02
ERRORS = [{"current_probe_delay": {"delay_s": PROBE_DELAY_S}}, {"channel_skew": {"ch2_delay_s": SKEW_S}},
          {"scope_gain_error": GAINS}, {"current_probe_gain_error": {"gain_rel": PROBE_GAIN}}]


@pytest.fixture(scope="module")
def calibrated_run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("calibration")
    paper = load_strict(paths.paper_campaign().read_text())
    stress = next(run for run in paper["runs"] if run["name"] == "fig2c_stress")
    campaign = {key: paper[key] for key in ("acquisition", "safety")}
    campaign["runs"] = [
        {"name": "deskew", "protocol": "deskew_calibration", "bench": {"scene": "one_column_1mm.yaml"},
         "plate": {"n_powered_columns": 1, "n_powered_piezos": 4},
         "parameters": {"load_ohm": 100, "frequency_hz": 37560}},
        stress]
    (tmp / "campaign.yaml").write_text(dump_yaml(campaign))
    erring = campaign_with_effects(tmp / "campaign.yaml", tmp / "inputs", ERRORS)
    return run_campaign(erring, out_dir=tmp / "run", progress=False)


def test_the_resistor_measures_the_bench_delay_and_gain_ratio(calibrated_run):
    run = load_run(calibrated_run)
    deskew = deskew_of_run(run)
    assert deskew.delay_s == pytest.approx(PROBE_DELAY_S + SKEW_S, abs=2 * deskew.std_uncertainty_s)
    assert deskew.std_uncertainty_s < 1e-9   # ten times better than the uncorrected +-10 ns
    rows = run.protocol("deskew_calibration")
    ratio, allowed = current_gain_ratio(reduced_points(run, rows))
    expected = (1 + GAINS["ch2_rel"]) * (1 + PROBE_GAIN) / (1 + GAINS["ch1_rel"])
    assert ratio.value == pytest.approx(expected, abs=3 * ratio.std_uncertainty + 1e-4)
    assert abs(ratio.value - 1) < allowed


def test_the_calibration_costs_bench_time(calibrated_run):
    journal = [json.loads(line) for line in (calibrated_run / "journal.jsonl").read_text().splitlines()]
    calibration = next(entry for entry in journal if entry["protocol"] == "deskew_calibration")
    assert calibration["campaign_bench_time_s"] > 1.0   # four averaged records, ranging, drive ramps
    assert journal[-1]["campaign_bench_time_s"] > calibration["campaign_bench_time_s"]


def test_deskew_corrects_the_fig2c_stress_power(calibrated_run):
    run = load_run(calibrated_run)
    rows = run.protocol("detuning")
    stress = reduced_points(run, rows[rows["detuning_phase"] == "stress"])
    plain, corrected = with_expanded_uncertainties(stress), with_expanded_uncertainties(stress, deskew_of_run(run))
    point = stress.iloc[0]
    scene = load_scene(calibrated_run / "inputs" / "one_column_1mm.yaml")
    truth = physics.steady_state(scene.state(scene.initial_state), scene.electronics, point.generator_frequency_hz,
                                 point.generator_amplitude_vpp, build_pipeline(scene)).power_w
    g1, current = 1 + GAINS["ch1_rel"], (1 + GAINS["ch2_rel"]) * (1 + PROBE_GAIN)
    alpha = gain_weight()   # the gain check leaves g1^(1+alpha) (g2 g_probe)^(1-alpha)
    before = plain["power_w"].iloc[0] / (g1 * current) - truth
    after = corrected["power_w"].iloc[0] / (g1 ** (1 + alpha) * current ** (1 - alpha)) - truth
    # 9 ns at power factor 0.018: the delay dominates (~10 % of the power); one 16-average
    # point of 500 samples also carries ~1 % of noise, which the bounds leave room for
    assert abs(before) > 0.08 * truth
    assert abs(after) < 0.2 * abs(before)
    assert abs(corrected["power_w"].iloc[0] - truth) <= corrected["power_w_U"].iloc[0]
    assert corrected["power_w_U"].iloc[0] < 0.5 * plain["power_w_U"].iloc[0]
    assert plain["power_w_dominant"].iloc[0].startswith("CH2 delay")
    assert np.isfinite(corrected["power_w_uncorrected"]).all()


def test_errors_on_erring_benches_with_and_without_calibration(tmp_path):
    """quick's three kinds of step (`small_quick`, with its calibration) on two erring
    benches: expanded uncertainties cover the truth, and the calibration's bench time is
    part of the campaign's."""
    import small_quick
    from squeezebench.protocols.bench_errors import errors_on_benches, p95_by_run
    from squeezebench.protocols.variants import with_calibration, without_calibration

    quick = small_quick.small_quick(tmp_path)   # with its calibration, as quick ships
    plain = errors_on_benches(without_calibration(small_quick.small_quick(tmp_path / "plain")), range(1, 3))
    calibrated = errors_on_benches(with_calibration(quick, tmp_path / "calibrated.yaml", 37000.0), range(1, 3))
    for errors in (plain, calibrated):
        assert errors["covered"].mean() >= 0.95
        assert set(errors["bench_seed"]) == {1, 2}
    assert all(calibrated.attrs["bench_time_s"][s] > plain.attrs["bench_time_s"][s] + 1.0 for s in (1, 2))
    summary = p95_by_run(plain)
    assert set(summary["quantity"]) == {"power_w", "velocity_pp_mps"}
    assert (summary["p95_abs_rel_error"] > 1e-3).all()   # the instruments' errors, not noise


# -- a known lag corrected, not only budgeted (issue 28) -----------------------------------------
LAG_S = 17e-9   # a current probe behind the voltage probe, as Tektronix's deskew note has it


@pytest.fixture(scope="module")
def characterised(tmp_path_factory):
    """{bench: run directory} of one small plate's Fig. 5 characterisation after a deskew
    calibration, on a bench whose current probe lags 17 ns and on one without the lag."""
    tmp = tmp_path_factory.mktemp("lag")
    paper = load_strict(paths.paper_campaign().read_text())
    campaign = {key: paper[key] for key in ("acquisition", "safety")}
    campaign["runs"] = [
        {"name": "deskew", "protocol": "deskew_calibration", "bench": {"scene": "small_plate_1.yaml"},
         "plate": {"n_powered_columns": 1, "n_powered_piezos": 4},
         "parameters": {"load_ohm": 100, "frequency_hz": 45000}},
        {"name": "fig5", "protocol": "characterisation", "bench": {"scene": "small_plate_1.yaml"},
         "plate": {"n_powered_columns": 1, "n_powered_piezos": 4},
         "parameters": {"search": {"start_hz": 30000, "stop_hz": 60000, "points": 31},
                        "voltages_vpp": [10, 20, 30, 40]}}]
    (tmp / "campaign.yaml").write_text(dump_yaml(campaign))
    lagging = campaign_with_effects(tmp / "campaign.yaml", tmp / "inputs", [{"current_probe_delay": {"delay_s": LAG_S}}])
    return {"lag": run_campaign(lagging, out_dir=tmp / "lag", progress=False),
            "none": run_campaign(tmp / "campaign.yaml", out_dir=tmp / "none", progress=False)}


def test_q_and_tan_theta_are_computed_from_the_deskewed_power(characterised):
    """With the lag measured by the deskew run, Fig. 5's tan theta' is the lag-free bench's
    (not 2 % off), Q, which reads no power, is unchanged, and the budgets carry the
    calibration's delay term instead of the specified +-10 ns."""
    from squeezebench.analysis import model, uncertainty
    from squeezebench.analysis.characterisation import characterise_plate, characterise_plates

    convention = model.PAPER_CONVENTION
    lag, none = (characterise_plates(load_run(characterised[bench]), convention)["small_plate_1"]
                 for bench in ("lag", "none"))
    uncorrected = characterise_plate("small_plate_1", lag.points.assign(power_w=lag.points["power_w_uncorrected"]),
                                     lag.geometry, convention)
    assert abs(uncorrected.tan_theta.value / none.tan_theta.value - 1) > 0.01   # the lag the run corrects
    assert lag.tan_theta.value == pytest.approx(none.tan_theta.value, rel=0.003)
    assert lag.q.value == pytest.approx(uncorrected.q.value, rel=1e-12)
    deskew = deskew_of_run(load_run(characterised["lag"]))
    assert deskew.delay_s == pytest.approx(LAG_S, abs=2 * deskew.std_uncertainty_s)
    budgets = {name: uncertainty.characterisation_budgets(lag, convention, correction)[1]
               for name, correction in (("specified", None), ("calibrated", deskew))}
    delay = {name: next(t.std_uncertainty for t in budget.terms if t.name.startswith("CH2 delay"))
             for name, budget in budgets.items()}
    assert delay["calibrated"] < 0.2 * delay["specified"]


def test_without_a_deskew_a_lagging_probe_leaves_the_stress_point_flagged(tmp_path):
    """The Fig. 2c stress point (power factor 0.018) on a bench whose current probe lags
    17 ns, no deskew run: every stored power's U holds its error (the delay's bias bound,
    issue 46; the former +-10 ns rectangle missed the stress point by 1.22 U), and the
    report says a deskew run would shrink the U the bound dominates."""
    from squeezebench.report.run_report import write_report
    from squeezebench.analysis.uncertainty import needs_deskew, run_uncertainties

    paper = load_strict(paths.paper_campaign().read_text())
    stress = next(run for run in paper["runs"] if run["name"] == "fig2c_stress")
    campaign = {**{key: paper[key] for key in ("acquisition", "safety")}, "runs": [stress]}
    (tmp_path / "campaign.yaml").write_text(dump_yaml(campaign))
    lagging = campaign_with_effects(tmp_path / "campaign.yaml", tmp_path / "inputs",
                                    [{"current_probe_delay": {"delay_s": LAG_S}}])
    run_dir = run_campaign(lagging, out_dir=tmp_path / "run", progress=False)
    points = run_uncertainties(load_run(run_dir)).points
    point = points[points["detuning_phase"] == "stress"].iloc[0]
    scene = load_scene(run_dir / "inputs" / "one_column_1mm.yaml")
    truth = physics.steady_state(scene.state(scene.initial_state), scene.electronics, point.generator_frequency_hz,
                                 point.generator_amplitude_vpp, build_pipeline(load_scene(
                                     paths.scenes_dir() / "one_column_1mm.yaml"))).power_w
    assert abs(point["power_w"] - truth) > 0.15 * truth   # the lag moves it far
    assert abs(point["power_w"] - truth) <= point["power_w_U"]
    for _, other in points.iterrows():
        setting = physics.steady_state(scene.state(scene.initial_state), scene.electronics,
                                       other.generator_frequency_hz, other.generator_amplitude_vpp,
                                       build_pipeline(load_scene(paths.scenes_dir() / "one_column_1mm.yaml")))
        assert abs(other["power_w"] - setting.power_w) <= other["power_w_U"]
    report_dir = write_report(run_dir).parent
    html = (report_dir / "index.html").read_text()
    assert "Needs a deskew calibration" in html and "fig2c_stress" in html.split("Needs a deskew calibration")[1][:300]
    flagged = len(needs_deskew(points))
    assert flagged >= 1 and f"{flagged} stored power" in (report_dir / "headline.txt").read_text()
