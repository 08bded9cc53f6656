"""The column dictionary of a run: name, unit and meaning of every column a pandas user
meets in measurements/*/*.parquet and in the report's CSVs (written as
report/columns.csv, so nobody needs the source code to read a run). A name means the
same in every file; "unit" is the column's own unit ("unit": the row's `unit` column)."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

#: name -> (unit, meaning). "pp" is peak-to-peak; "1" a pure number.
COLUMNS: dict[str, tuple[str, str]] = {
    # measurement rows (protocols.steps.StepContext.record, protocols.storage)
    "run_name": ("", "campaign run the row belongs to"),
    "protocol": ("", "procedure: resonance_search, detuning, resonator_cutting, powered_columns, characterisation"),
    "plate": ("", "plate measured (scene or bench plate name)"),
    "scene_state": ("", "state of the plate asked of the operator (e.g. a cut length); empty: the plate as mounted"),
    "step_id": ("", "step of the run (unit of storage and resume)"),
    "point_index": ("1", "index of the point within its step"),
    "generator_frequency_hz": ("Hz", "frequency set on the generator"),
    "generator_amplitude_vpp": ("V pp", "generator output amplitude set"),
    "amplifier_gain": ("1", "voltage gain of the power amplifier"),
    "piezo_voltage_setpoint_vpp": ("V pp", "piezo voltage asked for (amplifier gain x generator amplitude)"),
    "n_powered_columns": ("1", "columns of piezos driven"),
    "n_powered_piezos": ("1", "piezos driven (n_c of Eqs. 25, 27)"),
    "averages": ("1", "scope acquisitions averaged per record"),
    "record_length": ("1", "samples per scope record"),
    "scope_power_w": ("W", "the scope's own mean of CH1 x CH2 (cross-check)"),
    "scope_velocity_pp_v": ("V pp", "the scope's peak-to-peak of the vibrometer output"),
    "vibrometer_scale_mps_per_v": ("m/s per V", "vibrometer decoder range"),
    "velocity_pp_mps": ("m/s pp", "vibration velocity, peak-to-peak"),
    "scope_piezo_voltage_pp_v": ("V pp", "the scope's peak-to-peak of the piezo voltage"),
    "scope_current_pp_a": ("A pp", "the scope's peak-to-peak of the piezo current"),
    "scope_frequency_hz": ("Hz", "the scope's frequency measurement"),
    "waveform_file": ("", "raw record of the point, relative to the run directory"),
    "bench_time_s": ("s", "bench clock at the end of the point (virtual on a simulated bench)"),
    "bench": ("", "'simulated' (a scene answered) or 'real' (instruments on a bench)"),
    "bench_input": ("", "copy of the scene (simulated) or bench file (real) under inputs/"),
    "bench_input_sha256": ("", "sha256 of that file"),
    "instrument_ids": ("", "JSON: role -> the instrument's identification reply"),
    "resonance_frequency_hz": ("Hz", "resonance found by the search"),
    "sweep": ("", "true for a point of the resonance search's frequency sweep"),
    "velocity_level_pp_mps": ("m/s pp", "velocity level v0 of a detuning series (Fig. 2)"),
    "target_velocity_ratio": ("1", "velocity fraction reached by detuning before regaining v0"),
    "detuning_phase": ("", "resonance, detuned, regained or stress (Fig. 2)"),
    "reachable": ("", "false when the safety limit prevented the point"),
    "plate_length_mm": ("mm", "resonator length after cutting (Table 3)"),
    "n_antinodes": ("1", "antinodes along the length (Table 3)"),
    "configuration": ("", "Table 4 configuration"),
    # report tables (analysis.tables)
    "table": ("", "paper table or figure the row belongs to"),
    "item": ("", "column of the paper's table (plate length, configuration, plate, estimate)"),
    "quantity": ("", "machine name of the quantity; its unit is in `unit`"),
    "unit": ("", "SI unit of value, uncertainties and paper_value"),
    "value": ("unit", "this run's value"),
    "std_uncertainty": ("unit", "standard uncertainty (k = 1) of value from the record fits"),
    "expanded_uncertainty": ("unit", "expanded uncertainty (k = 2) of value: its whole budget (noise, instrument "
                                     "specifications; for Q and tan theta' also the geometry and NCE 41 tolerances)"),
    "scope_value": ("unit", "the scope's on-line number for the same quantity (cross-check)"),
    "paper_value": ("unit", "value printed in the paper"),
    "paper_source": ("", "where the paper prints it"),
    "relative_difference": ("1", "(value - paper_value) / |paper_value|"),
    "tolerance": ("unit", "expanded_uncertainty plus half the printed value's last digit"),
    "agrees": ("", "|value - paper_value| <= tolerance"),
    "origin": ("", "measured (real bench), simulated, calibration input, derived or campaign setting"),
    "calibrated_on": ("", "the scene calibration that returns this printed value (round trip); empty: none"),
    "status": ("", "measured, not measured or not reachable"),
    "resonator_thickness_mm": ("mm", "resonator thickness of the plate"),
    "frequency_hz": ("Hz", "frequency measured in the record"),
    "voltage_vpp": ("V pp", "piezo voltage"),
    "power_w": ("W", "electrical power into the piezos"),
    "power_resonance_w": ("W", "power at resonance P0 of the series"),
    "power_ratio": ("1", "Pt / P0 (Fig. 2)"),
    # per-plate readings and Table 5 under each reading (analysis.audit)
    "reading": ("", "reading of the paper's open conventions: 'paper' (the text's) or 'inferred' (analysis.readings)"),
    "q": ("1", "quality factor Q of the plate (Eq. 27)"),
    "q_u": ("1", "standard uncertainty of q"),
    "tan_theta": ("1", "loss tangent tan theta' (Eq. 25)"),
    "tan_theta_u": ("1", "standard uncertainty of tan_theta"),
    "printed": ("", "value printed in the paper"),
    # uncertainty budgets (analysis.uncertainty)
    "term": ("", "one term of an uncertainty budget"),
    "type": ("", "GUM type of the term: A (this record's statistics) or B (specification, tolerance)"),
    "relative": ("1", "the term's standard uncertainty over |value|"),
    "share": ("1", "the term's share of the combined variance"),
    "source": ("", "where the term's size comes from (manual, datasheet, assumption)"),
    "floor_p95_rel": ("1", "p95 relative error the instruments' specified errors leave, whatever the averaging"),
    "dominant_term": ("", "largest term of the budget"),
    "point": ("", "the systematics study's point: table3 (Table 3), stress (Fig. 2c), sweep (a Fig. 5 "
                  "plate), search (the resonance search), campaign (the whole paper campaign)"),
    "benches": ("1", "simulated benches, each with its own draw of the instruments' errors"),
    "calibrated_floor_p95_rel": ("1", "floor_p95_rel after the deskew calibration"),
    "calibrated_averages": ("1", "scope averages where the calibrated floor is reached"),
    "calibrated_bench_time_s": ("s", "bench time per trial there, the calibration's included"),
    "covered_fraction": ("1", "stored points whose expanded uncertainty (k = 2) covers the truth, over all benches"),
    "benches_fully_covered": ("1", "benches on which every stored point is covered"),
    "benches_mostly_covered": ("1", "benches on which at least half the stored points are covered"),
    "benches_interval_low": ("1", "Wilson 95 % interval of the fraction of benches mostly covered: low end"),
    "benches_interval_high": ("1", "Wilson 95 % interval of the fraction of benches mostly covered: high end"),
    "median_rel_expanded_u": ("1", "median relative expanded uncertainty (k = 2) of the points"),
    "lifted_by": ("", "what would lower the dominant term"),
    "power_w_U": ("W", "expanded uncertainty (k = 2) of power_w"),
    "power_w_dominant": ("", "dominant term of power_w's budget"),
    "velocity_pp_mps_U": ("m/s pp", "expanded uncertainty (k = 2) of velocity_pp_mps"),
    "velocity_pp_mps_dominant": ("", "dominant term of velocity_pp_mps's budget"),
    "piezo_voltage_vpp": ("V pp", "piezo voltage measured in the record"),
    "piezo_voltage_vpp_U": ("V pp", "expanded uncertainty (k = 2) of piezo_voltage_vpp"),
    "piezo_voltage_vpp_dominant": ("", "dominant term of piezo_voltage_vpp's budget"),
    "frequency_hz_U": ("Hz", "expanded uncertainty (k = 2) of frequency_hz"),
    "frequency_hz_dominant": ("", "dominant term of frequency_hz's budget"),
    "points": ("1", "stored points budgeted"),
    "median_expanded_relative": ("1", "median of U / |value| over the points"),
    # accuracy study (analysis.study)
    "experiment": ("", "accuracy-study experiment: the setting varied"),
    "scene": ("", "scene file of the study trial"),
    "state": ("", "scene state of the study trial"),
    "periods_per_record": ("1", "signal periods per scope record"),
    "search_points": ("1", "frequency points of the resonance search's sweep"),
    "search_tolerance_hz": ("Hz", "refinement tolerance of the resonance search"),
    "settle_s": ("s", "wait after a voltage step before acquiring"),
    "n_voltages": ("1", "voltages of a characterisation sweep"),
    "tracking": ("", "resonance re-found before each point"),
    "settings": ("", "the settings of a configuration, as text"),
    "n_trials": ("1", "repeats of a configuration on fresh noise"),
    "n_repeats": ("1", "distinct repeats (for the systematics experiments: benches) behind the row"),
    "median_rel_error": ("1", "median relative error against the scene's truth"),
    "p95_abs_rel_error": ("1", "95th percentile of |relative error| against the scene's truth"),
    "on_front": ("", "configuration on its experiment's Pareto front (error vs bench time)"),
    # the reading search (conventions_grid.csv, analysis.readings.AXES)
    "materials": ("", "reading axis: E_i as printed or 67 GPa"),
    "voltage": ("", "reading axis: V of Eqs. 25/27 peak-to-peak, amplitude or rms"),
    "eq27_amplitude": ("", "reading axis: A of Eq. 27 peak-to-peak or amplitude"),
    "published_amplitude": ("", "reading axis: the published 1 um peak-to-peak or amplitude"),
    "n_c": ("", "reading axis: what n_c counts"),
    "b_p": ("", "reading axis: which piezo side is b_p"),
    "wavelength": ("", "reading axis: lambda as printed or from the mode"),
    "neutral_plane": ("", "reading axis: where z0 lies"),
    "c11_reduced": ("", "reading axis: c'11 = c11 / (1 - nu^2) or c11"),
    "eq25_with_pi": ("", "reading axis: Eq. 25 with its factor pi"),
    "eq25_coefficient": ("1", "reading axis: Eq. 25's coefficient (3/4 printed, 3/8 with the Eq. 20 slip)"),
    "defined": ("", "the reading gives finite numbers"),
    "amplitude_pp_m": ("m", "amplitude pp at the published operating point under the reading"),
    "table4_tan_theta_mean": ("1", "mean tan theta' of the Table 4 plates under the reading"),
    "amplitude_ratio": ("1", "computed / published amplitude"),
    "tan_theta_ratio": ("1", "computed / published tan theta'"),
    "table4_tan_ratio": ("1", "computed / published Table 4 tan theta'"),
    "matches_amplitude": ("", "amplitude reproduced within 10 %"),
    "matches_tan_theta": ("", "tan theta' reproduced within 10 %"),
    "matches_table4_tan": ("", "Table 4 tan theta' reproduced within 10 %"),
    "log_misfit": ("1", "RMS of log10(computed / published) over the published numbers"),
    "all_within": ("1", "largest |ratio - 1| over the published numbers"),
    # what the plate model predicts (analysis.predicted_plates)
    "predicted_frequency_hz": ("Hz", "working (n, 0) mode's frequency predicted by the plate model from geometry and materials"),
    "predicted_frequency_u_hz": ("Hz", "expanded uncertainty (k = 2) of the prediction from material and thickness tolerances"),
    "printed_frequency_hz": ("Hz", "resonance frequency printed in the paper"),
    "frequency_deviation": ("1", "predicted / printed - 1"),
    "predicted_antinodes": ("1", "interior antinodes of the predicted working mode"),
    "printed_antinodes": ("1", "antinodes printed in the paper"),
    "predicted_half_wavelength_mm": ("mm", "mean spacing of the predicted mode's interior nodal lines"),
    "printed_half_wavelength_mm": ("mm", "half-wavelength stated in the paper (empty: not stated)"),
    "predicted_velocity_pp_mps": ("m/s pp", "velocity at the plate centre at resonance at the printed voltage, predicted (shared q_mech)"),
    "printed_velocity_pp_mps": ("m/s pp", "velocity printed in the paper (empty: not printed)"),
    "predicted_power_w": ("W", "power at resonance at the printed voltage, predicted (mechanical loss only)"),
    "printed_power_w": ("W", "power printed in the paper"),
}


def dictionary(frames: list[pd.DataFrame]) -> pd.DataFrame:
    """Name, unit and meaning of every column of `frames` (in first-seen order); a column
    without an entry is listed with meaning 'not described' so a test can catch it."""
    names = list(dict.fromkeys(c for frame in frames for c in frame.columns))
    rows = [{"name": n, "unit": COLUMNS.get(n, ("", ""))[0],
             "meaning": COLUMNS.get(n, ("", "not described"))[1]} for n in names]
    return pd.DataFrame(rows, columns=["name", "unit", "meaning"])


def write(path: Path, frames: list[pd.DataFrame]) -> Path:
    dictionary(frames).to_csv(path, index=False)
    return path
