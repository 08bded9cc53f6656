"""A search's plate as one thermal body (`plates.warming`: its time constant against the
closed form), and the bias bound a search on a warm plate takes (`analysis.plate_warming`)
against the protocol's own search run on a plate that warms as it is read, its constants
anywhere within their tolerances. Seeded."""

from __future__ import annotations

import dataclasses
import itertools
import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from squeezebench.analysis import plate_warming, tables
from squeezebench.analysis.resonance_searches import SearchSetup
from squeezebench.analysis.uncertainty import search_budgets
from squeezebench.plates import warming
from squeezebench.plates.laminate import ALUMINIUM_TABLE2
from squeezebench.plates.specifications import (HEATING_NOMINAL, HEATING_TOLERANCES, MODEL_TOLERANCES, SPECIFICATIONS,
                                                sheet_thickness_tolerance)
from squeezebench.protocols.resonance import SearchSettings, find_resonance

#: Table 4's two-column plate (76 x 41 x 1.2 mm, its both-columns state: 44.72 kHz, Q 250)
LENGTH_M, WIDTH_M, THICKNESS_M = 0.076, 0.041, 0.0012
F0_HZ, Q = 44720.0, 250.0
SEARCH = SearchSettings(start_hz=42500.0, stop_hz=46000.0, points=36)   # the paper campaign's
SCENES = {"warm.yaml": {"plate": {"length_mm": 76, "width_mm": 41, "thickness_mm": 1.2}}}
READING_S = 0.73   # a search reading's bench time (the paper campaign's sweep: 16 averages)


def test_the_plates_time_constant_is_its_thickness_over_twice_the_convection():
    """tau = rho c h / (2 h_c), whatever the plate's length and width: 150 s at 1.2 mm."""
    tau_s = _body(1.0, 1.0, 1.0, 1.0).time_constant_s
    assert math.isclose(tau_s, 2790.0 * 900.0 * THICKNESS_M / (2 * 10.0), rel_tol=1e-12)


def _body(c: float, rho: float, h: float, convection: float) -> warming.ThermalPlate:
    """The plate as one thermal body, its specific heat, density, thickness and convection
    at these factors of their nominal values."""
    return warming.thermal_plate(LENGTH_M * 1e3, WIDTH_M * 1e3, THICKNESS_M * h * 1e3,
                                 ALUMINIUM_TABLE2.density_kg_m3 * rho, HEATING_NOMINAL["specific_heat_j_per_kg_k"] * c,
                                 HEATING_NOMINAL["convection_w_per_m2_k"] * convection)


def _corners():
    """Every corner of the warming's constants within their tolerances: (alpha, c, rho,
    thickness, convection) as factors of their nominal values."""
    tolerances = (HEATING_TOLERANCES["frequency_coefficient_per_k"].half_width,
                  HEATING_TOLERANCES["specific_heat_j_per_kg_k"].half_width,
                  MODEL_TOLERANCES["density_kg_m3"].half_width, sheet_thickness_tolerance(THICKNESS_M),
                  HEATING_TOLERANCES["convection_w_per_m2_k"].half_width)
    return [tuple(1.0 + s * t for s, t in zip(signs, tolerances)) for signs in itertools.product((-1, 1), repeat=5)]


def _warm_plate_search(factors, previous_w: float, previous_s: float, peak_w: float, generator_rel: float = 0.0,
                       seed: int = 0) -> tuple[pd.DataFrame, float]:
    """The protocol's search (`find_resonance`) of a plate whose resonance falls as it warms
    (F0_HZ cold, times 1 + alpha T), dissipating `peak_w` / (1 + x^2) at each reading, after
    a previous step that dissipated `previous_w` over `previous_s` and ended as the search
    began; T advanced exactly (the first-order step response) over each reading. `factors`:
    the constants' (`_corners`). The rows a run stores (the previous step's reading among
    them) and the cold resonance."""
    alpha, c, rho, h, convection = factors
    body = _body(c, rho, h, convection)
    capacity, tau_s = body.heat_capacity_j_per_k, body.time_constant_s
    rng = np.random.default_rng(seed)
    state = {"t": previous_s, "T": previous_w * tau_s / capacity * (1.0 - math.exp(-previous_s / tau_s))}
    common = {"run_name": "table4", "plate": "warm", "vibrometer_scale_mps_per_v": 1.0, "power_w": math.nan}
    rows = [{**common, "step_id": "previous", "protocol": "powered_columns", "sweep": False,
             "bench_time_s": at_s, "scope_power_w": previous_w}   # read throughout it, as a step's points
            for at_s in np.linspace(0.0, previous_s, math.ceil(previous_s / READING_S) + 1)[1:]]

    def measure_at(setting_hz: float) -> SimpleNamespace:
        f0_hz = F0_HZ * (1.0 + HEATING_NOMINAL["frequency_coefficient_per_k"] * alpha * state["T"])
        ratio = setting_hz * (1.0 + generator_rel) / f0_hz
        x = Q * (ratio - 1.0 / ratio)
        power_w = peak_w / (1.0 + x * x)
        steady_k = power_w * tau_s / capacity
        state["T"] = steady_k + (state["T"] - steady_k) * math.exp(-READING_S / tau_s)
        state["t"] += READING_S
        velocity = (1.0 + 1e-4 * rng.standard_normal()) / math.sqrt(1.0 + x * x)
        rows.append({**common, "step_id": "search", "protocol": "resonance_search", "sweep": True,
                     "generator_frequency_hz": setting_hz, "velocity_pp_mps": math.nan,
                     "scope_velocity_pp_v": velocity, "bench_time_s": state["t"], "scope_power_w": power_w})
        return SimpleNamespace(frequency_hz=setting_hz, velocity_pp_mps=velocity)

    found = find_resonance(measure_at, SEARCH)
    rows = pd.DataFrame(rows).assign(resonance_frequency_hz=found.frequency_hz)
    stored = rows.iloc[-1].to_dict() | {"sweep": False, "generator_frequency_hz": found.frequency_hz,
                                        "velocity_pp_mps": found.velocity_pp_mps, "velocity_pp_mps_u": 1e-6,
                                        "power_w_u": 1e-6, "bench_time_s": state["t"] + READING_S}
    return pd.concat([rows, pd.DataFrame([stored])], ignore_index=True), F0_HZ


def _budget(rows: pd.DataFrame):
    searches = rows[rows["protocol"] == "resonance_search"].reset_index(drop=True)
    ((_, _, budget),) = search_budgets(searches, {"table4": SearchSetup(tolerance_hz=SEARCH.tolerance_hz)},
                                       rows, SCENES)
    return budget


def test_the_warming_correction_leaves_a_residual_its_term_describes_for_constants_within_their_tolerances():
    """Table 4's case, a search a few seconds after a step drove the plate at 0.11 W, and
    a harder one (0.3 W for a minute), on 40 plates each with its constants drawn uniformly
    within their tolerances (seeded): the corrected resonance is off the cold plate's by a
    residual of mean within 0.35 u and spread within 0.75-1.25 u of the term's, every one
    within 1.96 u; the plate's displacement itself is more than the budget without the term
    allows."""
    rng = np.random.default_rng(46)
    low, high = np.array(_corners()[0]), np.array(_corners()[-1])
    for previous_w, previous_s in ((0.11, 45.0), (0.3, 60.0)):
        residuals, displacements_hz, others_hz = [], [], []
        for seed in range(40):
            rows, cold_hz = _warm_plate_search(tuple(rng.uniform(low, high)), previous_w, previous_s, peak_w=0.066,
                                               seed=seed)
            budget = _budget(rows)
            (term,) = [t for t in budget.terms if t.name == plate_warming.TERM]
            assert not term.bias
            residuals.append((cold_hz - budget.value) / term.std_uncertainty)
            displacements_hz.append(cold_hz - rows["resonance_frequency_hz"].iat[-1])
            others_hz.append(budget.coverage_factor * math.sqrt(budget.std_uncertainty**2 - term.std_uncertainty**2))
        assert min(displacements_hz) > 0   # warmer, lower
        assert abs(np.mean(residuals)) < 0.35 and 0.75 < np.std(residuals) < 1.25
        assert max(np.abs(residuals)) <= 1.96
        assert max(displacements_hz) > max(others_hz)


def test_the_bound_is_the_same_whenever_the_run_started_on_the_campaigns_clock():
    """The rows' bench time is the campaign's: a run that starts an hour in is bounded as one
    that starts at once (its plate at rest before its first reading)."""
    rows, _ = _warm_plate_search((1.0,) * 5, 0.11, 45.0, peak_w=0.066)
    late = rows.assign(bench_time_s=rows["bench_time_s"] + 3600.0)
    assert _budget(late).expanded_uncertainty == pytest.approx(_budget(rows).expanded_uncertainty, rel=1e-9)


def test_a_search_on_a_plate_at_rest_reads_only_its_own_warming():
    """Nothing before the search: the correction and its term are the search's own readings'
    warming, a fraction of the generator's term; another plate's powers do not count."""
    rows, cold_hz = _warm_plate_search((1.0,) * 5, 0.0, 1.0, peak_w=0.02)
    other = rows.iloc[[0]].assign(plate="another", scope_power_w=5.0, bench_time_s=0.5)
    budget = _budget(pd.concat([other, rows], ignore_index=True))
    term = next(t for t in budget.terms if t.name == plate_warming.TERM)
    generator = next(t for t in budget.terms if t.name == "generator frequency")
    correction_hz = budget.value - rows["resonance_frequency_hz"].iat[-1]
    assert 0.0 < term.std_uncertainty < correction_hz < generator.std_uncertainty
    assert abs(cold_hz - budget.value) <= budget.expanded_uncertainty


def test_the_warm_searchs_budget_covers_the_cold_plate_with_the_generator_erring_within_its_specification():
    """Table 4's third configuration as the paper campaign runs it, the generator anywhere
    within +-20 ppm (its limits and 9 values between) and the warming's constants at
    random within their tolerances: every U holds the cold plate's resonance."""
    rng = np.random.default_rng(46)
    limit = SPECIFICATIONS["generator_frequency"].half_width
    for generator_rel in np.linspace(-limit, limit, 11):
        factors = tuple(rng.uniform(_corners()[0], _corners()[-1]))
        rows, cold_hz = _warm_plate_search(factors, 0.11, 45.0, peak_w=0.066, generator_rel=generator_rel,
                                           seed=int(rng.integers(1 << 30)))
        budget = _budget(rows)
        assert abs(budget.value - cold_hz) <= budget.expanded_uncertainty


def test_a_tables_frequency_read_where_the_warm_search_set_the_generator_takes_its_correction():
    """Table 4's third configuration's frequency is its points' reading at the search's
    setting: the value the search's budget corrected for the warming (`Budget.correction`),
    whose U no longer holds it as a bias, so the table's row is corrected by the same, each
    point by its own search's, and its U holds the cold plate."""
    rows, cold_hz = _warm_plate_search((1.0,) * 5, 0.11, 45.0, peak_w=0.066)
    budget = _budget(rows)
    stored_hz = rows.loc[rows["protocol"] == "resonance_search", "resonance_frequency_hz"].dropna().iat[-1]
    assert budget.correction == pytest.approx(budget.value - stored_hz, abs=1e-9) and budget.correction > 0.0
    points = pd.DataFrame({"run_name": ["table4"] * 3, "step_id": ["configuration_3", "configuration_3", "other"]})
    searches = {("table4", "configuration_3"): budget,
                ("table4", "other"): dataclasses.replace(budget, correction=0.0)}
    row = {"value": stored_hz, "std_uncertainty": 0.0, "expanded_uncertainty": 0.0}
    corrected = tables._with_search_uncertainty(row, points, searches)
    assert corrected["value"] == pytest.approx(stored_hz + 2.0 / 3.0 * budget.correction, rel=1e-15)
    alone = tables._with_search_uncertainty(row, points.iloc[:2], searches)
    # the reading as stored is off the cold plate by more than that U: uncorrected, it would miss
    assert abs(alone["value"] - cold_hz) <= alone["expanded_uncertainty"] < abs(stored_hz - cold_hz)


def test_a_run_without_stored_powers_or_a_plate_size_gets_no_warming_term():
    rows, _ = _warm_plate_search((1.0,) * 5, 0.11, 45.0, peak_w=0.066)
    searches = rows[rows["protocol"] == "resonance_search"].reset_index(drop=True)
    setups = {"table4": SearchSetup(tolerance_hz=SEARCH.tolerance_hz)}
    for history, scenes in ((rows.drop(columns="scope_power_w"), SCENES), (rows.assign(scope_power_w=math.nan), SCENES),
                            (rows, {"warm.yaml": {}}), (None, None)):
        ((_, _, budget),) = search_budgets(searches, setups, history, scenes)
        assert plate_warming.TERM not in {t.name for t in budget.terms}


def test_a_plate_cut_shorter_warms_at_its_cut_length_and_keeps_its_temperature_through_the_cut():
    """Table 3 cuts one plate from 75 to 28 mm: its heat capacity and convection go with its
    length, its time constant does not. Read at 28 mm from its run's start it warms as the
    28 mm body, 75 / 28 times the 75 mm one's rise; driven at 75 mm for a minute and then
    cut and left undriven, its temperature at the cut decays with tau (a temperature, not a
    heat: the mean of the cut and uncut plates' estimates gave (1 + 75 / 28) / 2 of it)."""
    scene = {"plate": {"length_mm": 75, "width_mm": 41, "thickness_mm": 1.0},
             "states": {"75x41": {"plate_length_mm": 75}, "28x41": {"plate_length_mm": 28}, "other": {}}}
    assert plate_warming.plate_size_m(scene) == (0.075, 0.041, 0.001)
    assert plate_warming.state_lengths_m(scene) == {"75x41": 0.075, "28x41": 0.028}
    times_s = np.arange(2.0, 62.0, 2.0)
    cut = pd.DataFrame({"run_name": "cut", "plate": "p", "bench_time_s": times_s, "scope_power_w": 0.05,
                        "scene_state": "28x41"})
    (cut_k, _), (uncut_k, _) = (plate_warming.warming_estimate_k(history, "p", times_s[-1], 0.075, 0.041, 0.001,
                                                                 state_lengths_m=plate_warming.state_lengths_m(scene))
                                for history in (cut, cut.assign(scene_state="75x41")))
    assert cut_k == pytest.approx(uncut_k * 75 / 28, rel=1e-12)
    body = warming.thermal_plate(28.0, 41.0, 1.0, ALUMINIUM_TABLE2.density_kg_m3,
                                 HEATING_NOMINAL["specific_heat_j_per_kg_k"], HEATING_NOMINAL["convection_w_per_m2_k"])
    assert cut_k == pytest.approx(0.05 * body.time_constant_s / body.heat_capacity_j_per_k
                                  * -math.expm1(-times_s[-1] / body.time_constant_s), rel=1e-9)
    # a minute at 75 mm, the drive off at its last reading, then 20 s undriven at 28 mm
    after_s = np.arange(62.0, 82.0, 2.0)
    powers_w = np.concatenate([np.full(len(times_s) - 1, 0.05), np.zeros(1 + len(after_s))])
    history = pd.DataFrame({"run_name": "cut", "plate": "p", "bench_time_s": np.concatenate([times_s, after_s]),
                            "scope_power_w": powers_w,
                            "scene_state": ["75x41"] * len(times_s) + ["28x41"] * len(after_s)})
    at_cut_k, _ = plate_warming.warming_estimate_k(history, "p", times_s[-1], 0.075, 0.041, 0.001)
    correction_hz, term = plate_warming.search_warming_term(history, "p", scene, 37e3, after_s[-1:], [37e3], [1.0])
    tau_s = body.time_constant_s
    assert correction_hz == pytest.approx(37e3 * 2e-4 * at_cut_k * math.exp(-(after_s[-1] - times_s[-1]) / tau_s),
                                          rel=1e-9)
    assert "cut" not in term.source


def test_a_search_carries_the_rooms_drift_since_its_run_started():
    """The room drifting by up to ROOM_DRIFT_K_PER_S moves the plate's resonance by up to
    f |alpha| r t (alpha at its limit), t from the run's start (its first reading less that
    reading's own time) to the search's top readings: a rectangle about zero of that
    half-width, the same whenever the run started on the campaign's clock."""
    rows, _ = _warm_plate_search((1.0,) * 5, 0.11, 45.0, peak_w=0.066)
    sweep = rows[(rows["protocol"] == "resonance_search") & rows["sweep"].astype(bool)]
    read_s = plate_warming.top_readings_time_s(sweep["bench_time_s"].to_numpy(float),
                                               sweep["scope_velocity_pp_v"].to_numpy(float))
    elapsed_s = read_s - (2 * rows["bench_time_s"].iat[0] - rows["bench_time_s"].iat[1])
    for shift_s in (0.0, 3600.0):
        budget = _budget(rows.assign(bench_time_s=rows["bench_time_s"] + shift_s))
        (room,) = [t for t in budget.terms if t.name == plate_warming.ROOM_TERM]
        alpha = abs(HEATING_NOMINAL["frequency_coefficient_per_k"]) * (
            1 + HEATING_TOLERANCES["frequency_coefficient_per_k"].half_width)
        assert room.is_rectangular and not room.bias
        assert math.sqrt(3.0) * room.std_uncertainty == pytest.approx(
            rows["resonance_frequency_hz"].iat[-1] * alpha * warming.ROOM_DRIFT_K_PER_S * elapsed_s, rel=1e-9)
    assert elapsed_s > 45.0   # the previous step's 45 s and the search's own readings


def test_the_warmings_estimate_is_the_lumped_bodys_step_response_at_the_nominal_constants():
    """A plate read at 0.2 W through a 2 ohm shunt from its run's start (readings every 2 s,
    0.3 A pp): it takes P = 0.2 - 2 x 0.3^2 / 8 W, and the rise is P tau / C (1 - exp(-t /
    tau)) at the nominal constants; the convection's rectangle is half the difference of the
    same at its limits, the heat capacity's likewise, the shunt's that of its loss at +-1 %,
    the powers' none (every reading the same)."""
    times_s = np.arange(2.0, 62.0, 2.0)
    history = pd.DataFrame({"run_name": "r", "plate": "p", "bench_time_s": times_s, "scope_power_w": 0.2,
                            "scope_current_pp_a": 0.3})
    rise_k, (capacity_k, convection_k, power_k, shunt_k) = plate_warming.warming_estimate_k(
        history, "p", times_s[-1], LENGTH_M, WIDTH_M, THICKNESS_M, 2.0)
    shunt_w = 2.0 * 0.3**2 / 8.0

    def closed_form(body, power_w: float = 0.2 - shunt_w) -> float:
        return power_w * body.time_constant_s / body.heat_capacity_j_per_k * -math.expm1(-times_s[-1] / body.time_constant_s)

    assert rise_k == pytest.approx(closed_form(_body(1.0, 1.0, 1.0, 1.0)), rel=1e-9)
    h = HEATING_TOLERANCES["convection_w_per_m2_k"].half_width
    assert convection_k == pytest.approx(0.5 * (closed_form(_body(1, 1, 1, 1 + h)) - closed_form(_body(1, 1, 1, 1 - h))),
                                         rel=1e-9)
    c, rho, t = (HEATING_TOLERANCES["specific_heat_j_per_kg_k"].half_width, MODEL_TOLERANCES["density_kg_m3"].half_width,
                 sheet_thickness_tolerance(THICKNESS_M))
    assert capacity_k == pytest.approx(0.5 * (closed_form(_body(1 + c, 1 + rho, 1 + t, 1))
                                              - closed_form(_body(1 - c, 1 - rho, 1 - t, 1))), rel=1e-9)
    assert shunt_k == pytest.approx(closed_form(_body(1, 1, 1, 1), 0.01 * shunt_w), rel=1e-9)
    assert power_k == 0.0 and 0.0 < abs(convection_k) < rise_k
