"""Fig. 2 detuning on the noise-free simulated bench: the procedure reaches its targets."""

from __future__ import annotations

import pytest

from test_protocols_support import noise_free_scene, results, run_rows

SEARCH = {"start_hz": 36000, "stop_hz": 38500, "points": 26, "tolerance_hz": 0.5}


def detuning_run(scene, plate, **parameters):
    return {"name": "fig2", "protocol": "detuning", "bench": {"scene": str(scene)}, "plate": plate,
            "parameters": {"search": SEARCH, **parameters}}


@pytest.fixture(scope="module")
def one_column(tmp_path_factory):
    tmp_path = tmp_path_factory.mktemp("one_column")
    scene = noise_free_scene(tmp_path, "one_column_1mm.yaml")
    _, rows = run_rows(tmp_path, [detuning_run(scene, {"n_powered_columns": 1, "n_powered_piezos": 4},
                                               velocity_levels_pp_mps=[0.125, 0.25])])
    return results(rows, "detuning")


def test_v0_is_set_at_resonance(one_column):
    at_resonance = one_column[one_column["detuning_phase"] == "resonance"]
    assert list(at_resonance["velocity_level_pp_mps"]) == [0.125, 0.25]
    assert (at_resonance["velocity_pp_mps"] / at_resonance["velocity_level_pp_mps"]).between(0.99, 1.01).all()
    # Velocity is proportional to voltage (Eq. 1): twice v0 takes twice the voltage.
    voltages = list(at_resonance["piezo_voltage_setpoint_vpp"])
    assert voltages[1] / voltages[0] == pytest.approx(2.0, rel=0.02)


@pytest.mark.parametrize("ratio", [0.8, 0.6, 0.5])
def test_detuned_to_the_ratio_then_regained(one_column, ratio):
    for level, group in one_column.groupby("velocity_level_pp_mps"):
        v0 = float(group[group["detuning_phase"] == "resonance"]["velocity_pp_mps"].iloc[0])
        f0 = float(group[group["detuning_phase"] == "resonance"]["generator_frequency_hz"].iloc[0])
        voltage0 = float(group[group["detuning_phase"] == "resonance"]["piezo_voltage_setpoint_vpp"].iloc[0])
        at_ratio = group[group["target_velocity_ratio"] == ratio]
        detuned = at_ratio[at_ratio["detuning_phase"] == "detuned"].iloc[0]
        regained = at_ratio[at_ratio["detuning_phase"] == "regained"].iloc[0]
        assert detuned["generator_frequency_hz"] > f0           # raised, as the paper did
        assert detuned["velocity_pp_mps"] / v0 == pytest.approx(ratio, abs=0.01)
        assert detuned["piezo_voltage_setpoint_vpp"] == pytest.approx(voltage0)
        assert regained["generator_frequency_hz"] == detuned["generator_frequency_hz"]
        assert bool(regained["reachable"]) and regained["velocity_pp_mps"] / v0 == pytest.approx(1.0, abs=0.01)
        # Linear plate: regaining v0 from ratio * v0 takes voltage / ratio.
        assert regained["piezo_voltage_setpoint_vpp"] / voltage0 == pytest.approx(1.0 / ratio, rel=0.03)


def test_nine_column_plate_runs_out_of_voltage_at_half_of_0p375(tmp_path):
    scene = noise_free_scene(tmp_path, "nine_column_1mm.yaml")
    _, rows = run_rows(tmp_path, [detuning_run(scene, {"n_powered_columns": 9, "n_powered_piezos": 36},
                                               velocity_levels_pp_mps=[0.375], velocity_ratios=[0.8, 0.5])])
    rows = results(rows, "detuning")
    regained = rows[rows["detuning_phase"] == "regained"].set_index("target_velocity_ratio")
    assert not bool(regained.loc[0.5, "reachable"])
    assert regained.loc[0.5, "piezo_voltage_setpoint_vpp"] == pytest.approx(100.0)   # stopped at the limit
    assert regained.loc[0.5, "velocity_pp_mps"] < 0.99 * 0.375


def test_stress_point_needs_the_raised_limit(tmp_path):
    scene = noise_free_scene(tmp_path, "one_column_1mm.yaml")
    run = detuning_run(scene, {"n_powered_columns": 1, "n_powered_piezos": 4}, velocity_levels_pp_mps=[0.375],
                       velocity_ratios=[], stress_frequency_hz=37560.0, stress_velocity_level_pp_mps=0.375)
    run["safety"] = {"max_piezo_voltage_vpp": 240}
    _, rows = run_rows(tmp_path, [run])
    stress = results(rows, "detuning").query("detuning_phase == 'stress'").iloc[0]
    assert stress["generator_frequency_hz"] == 37560.0
    assert 100.0 < stress["piezo_voltage_setpoint_vpp"] <= 240.0
    # the closing re-centring comes after every Fig. 2 point, the stress point's too
    assert results(rows, "detuning").sort_values("bench_time_s")["detuning_phase"].iloc[-1] == "closing"


def test_a_closing_recentring_after_the_last_point_reads_the_resonance_without_a_power(one_column):
    """The plate's last row is its closing re-centring: after every Fig. 2 point, at the last
    level's P0 voltage, a dated reading of the resonance (on the noise-free bench, where P0's
    re-centring put it) that keeps no waveform, so no power is reduced from it."""
    by_time = one_column.sort_values("bench_time_s")
    closing = by_time.iloc[-1]
    assert closing["detuning_phase"] == "closing" and closing["step_id"] == "closing"
    assert (one_column["detuning_phase"] == "closing").sum() == 1 and closing["waveform_file"] is None
    last_p0 = by_time[(by_time["detuning_phase"] == "resonance") & (by_time["velocity_level_pp_mps"] == 0.25)].iloc[0]
    assert closing["velocity_level_pp_mps"] == 0.25
    assert closing["piezo_voltage_setpoint_vpp"] == pytest.approx(last_p0["piezo_voltage_setpoint_vpp"])
    assert closing["tracked_resonance_frequency_hz"] == pytest.approx(last_p0["tracked_resonance_frequency_hz"],
                                                                      abs=SEARCH["tolerance_hz"])
    assert closing["tracked_resonance_bench_time_s"] > by_time.iloc[-2]["bench_time_s"]
