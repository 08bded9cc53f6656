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
    "protocol": ("", "procedure: resonance_search, detuning, resonator_cutting, powered_columns, characterisation, calibration, cartography"),
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
    "piezo_thickness_mm": ("mm", "piezo thickness the campaign states for its dielectric loss (plate.piezo_loss)"),
    "piezo_tan_delta_at_reference": ("1", "piezos' loss tangent at the reference field (plate.piezo_loss)"),
    "piezo_loss_reference_field_v_per_mm": ("V/mm", "field amplitude of that loss tangent (plate.piezo_loss)"),
    "piezo_loss_exponent": ("1", "tan delta ~ field^exponent (plate.piezo_loss; 0: constant)"),
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
    "tracked_resonance_frequency_hz": ("Hz", "resonance as the re-centring before a Fig. 2 P0 (or, on the "
                                             "closing row, after the plate's last point) read it (the vertex "
                                             "of its readings' top; P0 is set at its best reading)"),
    "tracked_resonance_frequency_hz_u": ("Hz", "standard uncertainty of tracked_resonance_frequency_hz (the fit's)"),
    "tracked_resonance_bench_time_s": ("s", "mean bench time of that re-centring's readings"),
    "sweep": ("", "true for a point of the resonance search's frequency sweep"),
    "velocity_level_pp_mps": ("m/s pp", "velocity level v0 of a detuning series (Fig. 2)"),
    "target_velocity_ratio": ("1", "velocity fraction reached by detuning before regaining v0"),
    "detuning_phase": ("", "resonance, detuned, regained, stress or closing "
                              "(Fig. 2; closing: the re-centring after the plate's last point, no power)"),
    "reachable": ("", "false when the safety limit prevented the point"),
    "plate_length_mm": ("mm", "resonator length after cutting (Table 3)"),
    "n_antinodes": ("1", "antinodes along the length (Table 3)"),
    "configuration": ("", "Table 4 configuration"),
    "grid_row": ("1", "row of a map's grid (one y), in visiting order (cartography)"),
    "x_m": ("m", "map point along the plate's length, from its corner (the grid's, as asked)"),
    "y_m": ("m", "map point across the plate's width, from its corner (the grid's, as asked)"),
    "stage_x_m": ("m", "x the stage's encoder read after the move (SMC100 TP)"),
    "stage_y_m": ("m", "y the stage's encoder read after the move (SMC100 TP)"),
    "in_touch_area": ("", "the point counts in the map's homogeneity figures"),
    # a reduced map point (report/map_points.csv, analysis.cartography)
    "velocity_pp_mps_u": ("m/s pp", "standard uncertainty of velocity_pp_mps from the record fit (noise only)"),
    "velocity_phase_rad": ("rad", "phase of the velocity against the piezo voltage, wrapped to (-pi, pi]"),
    "velocity_phase_rad_u": ("rad", "standard uncertainty of velocity_phase_rad from the record fits"),
    "signed_velocity_pp_mps": ("m/s pp", "velocity_pp_mps with the sign of cos(velocity_phase_rad): the mode's shape"),
    # a map's summary (report/map_summary.csv)
    "drive_frequency_hz": ("Hz", "median generator frequency of the map"),
    "predicted_mode_frequency_hz": ("Hz", "frequency of the plate model's working mode the map is compared with"),
    "n_points": ("1", "points of the map"),
    "n_touch_points": ("1", "points in the touch area (the homogeneity figures' points)"),
    "mean_velocity_pp_mps": ("m/s pp", "mean velocity amplitude of the touch area's points (their own: no grid correction)"),
    "mean_velocity_pp_mps_U": ("m/s pp", "expanded uncertainty (k for 95 % under its budget) of the mean: noise and the shared velocity scale"),
    "mean_amplitude_pp_m": ("m pp", "mean displacement over the touch area, mean_velocity_pp_mps / (2 pi f)"),
    "mean_amplitude_pp_m_U": ("m pp", "expanded uncertainty (k for 95 % under its budget) of mean_amplitude_pp_m"),
    "criterion_amplitude_pp_m": ("m pp", "the displacement a fingertip needs to feel the squeeze film (1 um pp)"),
    "voltage_for_criterion_vpp": ("V pp", "piezo voltage that brings mean_amplitude_pp_m to the criterion (linear response)"),
    "min_velocity_pp_mps": ("m/s pp", "smallest velocity amplitude over the touch area"),
    "max_velocity_pp_mps": ("m/s pp", "largest velocity amplitude of the touch area's points (their own: no grid correction)"),
    "max_velocity_pp_mps_U": ("m/s pp", "expanded uncertainty (k for 95 % under its budget) of the largest: noise and the shared velocity scale"),
    "coefficient_of_variation": ("1", "standard deviation over mean of the touch area's velocity amplitudes over their cells: "
                                      "the points' figure corrected for where the grid fell on the mode (read between the points)"),
    "coefficient_of_variation_U": ("1", "expanded uncertainty (k for 95 % under its budget) of the coefficient of variation (points' noise; generator frequency through the re-tuned steps' levels; the grid correction's own error, the reading's misfit; the cells' quadrature)"),
    "coefficient_of_variation_uncorrected": ("1", "the coefficient of variation of the touch area's points alone, before the grid correction"),
    "coefficient_of_variation_grid_correction": ("1", "what the grid correction added to the points' coefficient of variation (minus the grid's error where it fell)"),
    "share_of_peak": ("1", "threshold, as a share of the largest amplitude, for fraction_above_share"),
    "fraction_above_share": ("1", "share of the touch area at or above share_of_peak of the largest amplitude, "
                                  "over the points' cells: the share of the points corrected for where the grid fell on the mode"),
    "fraction_above_share_U": ("1", "expanded uncertainty (k for 95 % under its budget) of fraction_above_share "
                                    "(points' noise; the grid correction's own error, the reading's misfit; the cells' quadrature)"),
    "fraction_above_share_uncorrected": ("1", "the share of the touch area's points at or above share_of_peak of the largest, before the grid correction"),
    "fraction_above_share_grid_correction": ("1", "what the grid correction added to the points' share (minus the grid's error where it fell)"),
    "width_uniformity": ("1", "share of the map's mean square in its width-averaged part: 1 for an (n, 0) mode"),
    "n_nodal_lines": ("1", "sign changes of the width-averaged signed map along x"),
    "nodal_line_spacing_m": ("m", "mean spacing of those nodal lines (half a flexural wavelength)"),
    "mac_with_predicted": ("1", "modal assurance criterion of the signed map against the model's working mode"),
    # the scenes' figures at resonance (report/scenes.csv, simbench.scene.scenes_table)
    "scene_file": ("", "scene file of the plate under inputs/"),
    "c0_nf": ("nF", "clamped capacitance C0 of the powered piezos, eps33^T (1 - k31^2) A / t"),
    "effective_coupling": ("1", "effective coupling k_eff = sqrt(C_m / (C0 + C_m)) of the motional branch"),
    "material_k31": ("1", "the piezo material's k31 (datasheet), the bound k_eff cannot exceed"),
    "power_factor": ("1", "power factor P / (V I) at resonance on the scene's bench"),
    "modal_mass_g": ("g", "modal mass of the working mode referred to the measurement point"),
    "plate_mass_g": ("g", "mass of the plate with its piezos"),
    "modal_mass_ratio": ("1", "modal_mass_g / plate_mass_g"),
    "shunt_share": ("1", "share of the measured power lost in the current shunt at resonance"),
    "shunt_share_detuned": ("1", "shunt_share at the Fig. 2 50 % detuning, voltage raised to regain v0"),
    "loss_w_per_um2": ("W per um pp^2", "plate power over the squared amplitude (um pp)"),
    "force_factor_vs_datasheet": ("1", "calibrated force factor n_c psi over the datasheet pin-force value"),
    "q_mech": ("1", "mechanical quality factor of the working mode in the scene"),
    "resonance_frequency_hz_U": ("Hz", "expanded uncertainty (k for 95 % under its budget) of resonance_frequency_hz"),
    # report tables (analysis.tables)
    "table": ("", "paper table or figure the row belongs to"),
    "item": ("", "column of the paper's table (plate length, configuration, plate, estimate)"),
    "quantity": ("", "machine name of the quantity; its unit is in `unit`"),
    "unit": ("", "SI unit of value, uncertainties and paper_value"),
    "value": ("unit", "this run's value"),
    "std_uncertainty": ("unit", "standard uncertainty (k = 1) of value from the record fits"),
    "expanded_uncertainty": ("unit", "expanded uncertainty (k for 95 % under its budget's distribution, its limits as specified and as the world reads them, at any bias within its bias bounds; Table 5: k = 2) of value: its whole budget (noise, instrument "
                                     "specifications; for Q and tan theta' also the geometry and NCE 41 tolerances)"),
    "scope_value": ("unit", "the scope's on-line number for the same quantity (cross-check)"),
    "paper_value": ("unit", "value printed in the paper"),
    "paper_source": ("", "where the paper prints it"),
    "relative_difference": ("1", "(value - paper_value) / |paper_value|"),
    "tolerance": ("unit", "expanded_uncertainty plus half the printed value's last digit"),
    "agrees": ("", "|value - paper_value| <= tolerance"),
    "predicted_value": ("unit", "what the plate model predicts from geometry and datasheets, no printed result in: "
                                "for the paper's plate in Tables 3-5 (plates.predicted_plates), for the run's "
                                "scene plate in fig5_predicted.csv (simbench.predicted)"),
    "scene_kind": ("", "replay (a scene calibrated to reproduce printed numbers) or predicted (geometry and "
                       "datasheets only)"),
    "value_over_predicted": ("1", "value / predicted_value"),
    "agrees_with_prediction": ("", "|value - predicted_value| <= the two expanded uncertainties in quadrature"),
    "predicted_expanded_uncertainty": ("unit", "expanded uncertainty (k = 2) of predicted_value from the material, geometry, d31 and "
                            "damping tolerances"),
    "predicted_difference": ("1", "(predicted_value - paper_value) / |paper_value|"),
    "origin": ("", "measured (real bench), simulated, calibration input, derived or campaign setting"),
    "calibrated_on": ("", "the scene calibration that returns this printed value (round trip); empty: none"),
    "status": ("", "measured, not measured or not reachable"),
    "resonator_thickness_mm": ("mm", "resonator thickness of the plate"),
    "frequency_hz": ("Hz", "frequency measured in the record"),
    "voltage_vpp": ("V pp", "piezo voltage"),
    "power_w": ("W", "electrical power into the piezos"),
    "power_resonance_w": ("W", "power at resonance P0 of the series"),
    "power_ratio": ("1", "Pt / P0 (Fig. 2), corrected for the resonance's drift the run estimates (the plate's "
                         "warming) where it has a budget: power_w / power_resonance_w as read, corrected"),
    "power_ratio_U": ("1", "expanded uncertainty (k for 95 % under its budget) of Pt / P0: noise, CH2 delay, "
                                "compensation, generator frequency and amplitude (through the piezos' dielectric "
                                "share, which does not follow the resonance), the resonance's drift as the plate warms "
                                "(its estimate's u; a bias bound where the readings alone give it); the gains cancel"),
    "power_ratio_largest_term": ("", "the term of power_ratio_U's budget with the largest standard uncertainty: "
                                     "what to act on to narrow it"),
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
    "median_coverage_of_U": ("1", "median over the points of the probability that +-U holds the value under its budget's own distribution"),
    "error_model": ("", "how the simulated benches' errors were drawn: 'specified' (within the limits, as the budgets assume) or 'world' (normal, a probe lag of known sign, now and then out of specification)"),
    # the measurement model (analysis.measurement_model)
    "measurand": ("", "what exactly the quantity is, where and under which conditions"),
    "model": ("", "the equation the stated value comes from"),
    "input": ("", "one input of the quantity's model (a budget term or a tolerance)"),
    "distribution": ("", "the input's probability distribution as the budget assumes it"),
    "relative_std_uncertainty": ("1", "the input's standard uncertainty over |value| at the run's first stored point"),
    "correction": ("", "whether the input's effect is corrected or only budgeted"),
    "floor_p95_rel": ("1", "p95 relative error the instruments' specified errors leave, whatever the averaging"),
    "budget_floor_p95_rel": ("1", "the uncertainty budgets' floor (p95 relative, noise averaged away) at the campaign points a study point stands for: the floor the report stands by, the study its check"),
    "dominant_term": ("", "largest term of the budget"),
    "point": ("", "the systematics study's point: table3 (Table 3), stress (Fig. 2c), sweep (a Fig. 5 "
                  "plate), search (the resonance search), campaign (the whole paper campaign)"),
    "benches": ("1", "simulated benches, each with its own draw of the instruments' errors"),
    "calibrated_floor_p95_rel": ("1", "floor_p95_rel after the deskew calibration"),
    "calibrated_averages": ("1", "scope averages where the calibrated floor is reached"),
    "calibrated_bench_time_s": ("s", "bench time per trial there, the calibration's included"),
    "covered_fraction": ("1", "values whose expanded uncertainty covers the truth, over all benches"),
    "benches_fully_covered": ("1", "benches on which every value is covered"),
    "benches_beyond_specification": ("1", "benches with an instrument erring beyond the limit its budgets claim "
                                          "(outside what the specifications claim; the world model's, now and then)"),
    "covered_fraction_within_specification": ("1", "covered_fraction over the benches whose instruments are all "
                                                   "within specification"),
    "coverage_interval_low": ("1", "95 % interval of covered_fraction, benches as trials (study.coverage_interval): low end"),
    "coverage_interval_high": ("1", "95 % interval of covered_fraction, benches as trials (study.coverage_interval): high end"),
    "median_rel_expanded_u": ("1", "median relative expanded uncertainty of the points (k for 95 % under each budget)"),
    "p95_error_over_u": ("1", "95th percentile of |error| / U over the benches' values: below 1, U over-covers by "
                              "that factor"),
    "lifted_by": ("", "what would lower the dominant term"),
    "power_w_U": ("W", "expanded uncertainty (k for 95 % under its budget) of power_w"),
    "power_w_dominant": ("", "dominant term of power_w's budget"),
    "velocity_pp_mps_U": ("m/s pp", "expanded uncertainty (k for 95 % under its budget) of velocity_pp_mps"),
    "velocity_pp_mps_dominant": ("", "dominant term of velocity_pp_mps's budget"),
    "piezo_voltage_vpp": ("V pp", "piezo voltage measured in the record"),
    "piezo_voltage_vpp_U": ("V pp", "expanded uncertainty (k for 95 % under its budget) of piezo_voltage_vpp"),
    "piezo_voltage_vpp_dominant": ("", "dominant term of piezo_voltage_vpp's budget"),
    "frequency_hz_U": ("Hz", "expanded uncertainty (k for 95 % under its budget's distribution) of frequency_hz"),
    "frequency_hz_dominant": ("", "dominant term of frequency_hz's budget"),
    **{f"{quantity}_U_coverage": ("1", f"probability that +-U holds {quantity} under its budget's own distribution "
                                       "as the specifications state it (specification terms rectangular, the rest "
                                       "normal); k holds 95 % under the world's reading of the limits too")
       for quantity in ("power_w", "velocity_pp_mps", "piezo_voltage_vpp", "frequency_hz")},
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
    # what the plate model predicts (plates.predicted_plates)
    "predicted_frequency_hz": ("Hz", "working (n, 0) mode's frequency predicted by the plate model from geometry and materials"),
    "predicted_frequency_u_hz": ("Hz", "expanded uncertainty (k = 2) of the prediction from the stated tolerances (sheet, alloy, bond, placement, a cut plate's length)"),
    "printed_frequency_hz": ("Hz", "resonance frequency printed in the paper"),
    "frequency_deviation": ("1", "predicted / printed - 1"),
    "predicted_antinodes": ("1", "interior antinodes of the predicted working mode"),
    "printed_antinodes": ("1", "antinodes printed in the paper"),
    "predicted_half_wavelength_mm": ("mm", "mean spacing of the predicted mode's interior nodal lines"),
    "printed_half_wavelength_mm": ("mm", "half-wavelength stated in the paper (empty: not stated)"),
    "predicted_velocity_pp_mps": ("m/s pp", "velocity at the plate centre at resonance at the printed voltage, predicted (shared q_mech)"),
    "predicted_velocity_u_pp_mps": ("m/s pp", "expanded uncertainty (k = 2) of the predicted velocity: d31, damping spread, material, thickness, bond and placement tolerances, and the drive's model-form term (force factor and Q) sized on one build (plates.predicted_plates.drive_model_form)"),
    "printed_velocity_pp_mps": ("m/s pp", "velocity printed in the paper (empty: not printed)"),
    "predicted_mechanical_power_w": ("W", "mechanical power at resonance at the printed voltage, predicted (shared q_mech)"),
    "predicted_dielectric_power_w": ("W", "the powered piezos' dielectric loss at the printed voltage (NCE 41 low-field tan delta)"),
    "predicted_power_w": ("W", "electrical input power at resonance at the printed voltage, predicted: mechanical plus dielectric"),
    "predicted_power_u_w": ("W", "expanded uncertainty (k = 2) of the predicted power: d31, damping spread, material, thickness, bond and placement tolerances, and the drive's model-form term (force factor squared and Q) sized on one build (plates.predicted_plates.drive_model_form)"),
    "predicted_power_at_printed_velocity_w": ("W", "electrical input power at resonance at the printed velocity (the large plate: 1 um read as pp), predicted: mechanical w M v0^2 / (2 q_mech) plus dielectric; no force factor in it"),
    "predicted_power_at_printed_velocity_u_w": ("W", "expanded uncertainty (k = 2) of the power at the printed velocity: damping spread, w M and placement tolerances, and the drive's model-form term's Q part sized on one build"),
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
