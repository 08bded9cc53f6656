"""The plate's warming under its drive (`plates.warming`, issue 46's Fig. 2 drift): the lumped
thermal model against its closed form, its tolerance ranges about the nominal plate, and the
drift estimate `analysis.resonance_drift` draws from it and the run's readings: a drift the
model makes within the tolerances recovered within its u, tight where the readings resolve it,
and the readings' scatter drawn on seeded runs covered 95 % of the time."""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.analysis import resonance_drift
from squeezebench.analysis.resonance_searches import SearchSetup, peak_of_readings
from squeezebench.plates import warming
from squeezebench.plates.specifications import HEATING_NOMINAL
from squeezebench.protocols.resonance import SearchSettings, track_resonance

PLATE_MM = (76.0, 41.0, 1.0)
DENSITY_KG_M3 = 2790.0
F0_HZ = 38000.0


def _nominal() -> warming.ThermalPlate:
    return warming.thermal_plate(*PLATE_MM, DENSITY_KG_M3, HEATING_NOMINAL["specific_heat_j_per_kg_k"],
                                 HEATING_NOMINAL["convection_w_per_m2_k"])


def test_a_constant_power_warms_the_plate_as_the_first_order_step_response():
    """From cold under a constant P: T = P / G (1 - exp(-t / tau)), tau = rho c t / (2 h)
    for a plate cooled from both faces."""
    plate = _nominal()
    assert plate.time_constant_s == pytest.approx(DENSITY_KG_M3 * 900.0 * 1e-3 / (2 * 10.0), rel=1e-12)
    times_s = np.linspace(0.0, 600.0, 31)
    rise_k = warming.temperature_rise_k(times_s, np.full(31, 0.5), plate)
    expected = 0.5 / plate.conductance_w_per_k * (1.0 - np.exp(-times_s / plate.time_constant_s))
    np.testing.assert_allclose(rise_k, expected, rtol=1e-12, atol=1e-15)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 2.0), min_size=2, max_size=12), st.floats(20.0, 500.0), st.floats(1.05, 4.0))
def test_the_heat_held_grows_with_tau_and_never_exceeds_the_energy_put_in(power_w, tau_s, longer):
    """E(t) = int P exp(-(t - t') / tau) dt': at most int P dt', and larger for a longer tau
    (the kernel grows with tau), which is why the tolerance's longest tau is the warmest."""
    times_s = np.arange(len(power_w)) * 7.0
    held_j = warming.held_heat_j(times_s, power_w, tau_s)
    energy_j = np.concatenate([[0.0], np.cumsum(np.asarray(power_w[1:]) * 7.0)])
    assert np.all(held_j <= energy_j * (1 + 1e-12) + 1e-15)
    assert np.all(warming.held_heat_j(times_s, power_w, tau_s * longer) >= held_j * (1 - 1e-12) - 1e-15)


def test_the_tolerance_ranges_hold_the_nominal_plate():
    """tau and f |alpha| / C of the nominal plate lie within the ranges the bound searches;
    h +-50 % and c +-5 % put tau within 0.95 / 1.5 and 1.05 / 0.5 of its nominal."""
    shortest, longest = warming.time_constant_range_s(*PLATE_MM, DENSITY_KG_M3)
    low, high = warming.drift_per_joule_range_hz(F0_HZ, *PLATE_MM, DENSITY_KG_M3)
    nominal = _nominal()
    assert shortest == pytest.approx(nominal.time_constant_s * 0.95 / 1.5, rel=1e-12)
    assert longest == pytest.approx(nominal.time_constant_s * 1.05 / 0.5, rel=1e-12)
    per_joule = F0_HZ * 2e-4 / nominal.heat_capacity_j_per_k
    assert low < per_joule < high
    assert high == pytest.approx(per_joule * 1.3 / 0.95, rel=1e-12)


def _warming_run(scale_hz_per_j: float, tau_s: float,
                 reading_u_hz: float) -> tuple[pd.DataFrame, dict, pd.DataFrame, np.ndarray]:
    """A run whose plate warms under three rising levels (a P0 with its re-centring and three
    Pt each), its drift -scale E(t) exactly; its re-centrings read it with `reading_u_hz`.
    The plate at rest at the search, each reading's power held from the reading before it (the
    protocol sets a reading's drive just after the reading before). Returns the points, the
    scene copies, the search and each point's true |drift|."""
    rows, time_s = [{"phase": "search", "time_s": 0.0, "power_w": 0.001}], 0.0
    for level, power_w in ((0.125, 0.06), (0.25, 0.22), (0.375, 0.5)):
        for phase in ("resonance", "regained", "regained", "regained"):
            time_s += 4.0 if phase == "regained" else 12.0
            rows.append({"phase": phase, "time_s": time_s, "power_w": power_w * (1.1 if phase == "regained" else 1.0),
                         "level": level})
    time_s += 12.0
    rows.append({"phase": "closing", "time_s": time_s, "power_w": 0.5, "level": 0.375})
    times, powers = [r["time_s"] for r in rows], [r["power_w"] for r in rows]
    held = warming.held_heat_j(times, powers, tau_s)   # each reading's drive from the reading before it
    drift = scale_hz_per_j * held
    frame = []
    for row, drift_hz in zip(rows[1:], drift[1:]):
        at_resonance = row["phase"] in ("resonance", "closing")
        frame.append({"run_name": "fig2_nine_column", "plate": "nine", "bench_input": "inputs/nine.yaml",
                      "detuning_phase": row["phase"], "velocity_level_pp_mps": row["level"],
                      "target_velocity_ratio": 1.0 if at_resonance else 0.8,
                      "generator_frequency_hz": F0_HZ - drift_hz if at_resonance else F0_HZ + 250.0,
                      "bench_time_s": row["time_s"], "power_w": row["power_w"],
                      "tracked_resonance_bench_time_s": row["time_s"] if at_resonance else math.nan,
                      "tracked_resonance_frequency_hz": F0_HZ - drift_hz if at_resonance else math.nan,
                      "tracked_resonance_frequency_hz_u": reading_u_hz if at_resonance else math.nan})
    searches = pd.DataFrame([{"run_name": "fig2_nine_column", "sweep": False, "bench_time_s": 0.0,
                              "resonance_frequency_hz": F0_HZ, "power_w": 0.001}])
    scenes = {"nine.yaml": {"plate": {"material": "aluminium", "length_mm": PLATE_MM[0], "width_mm": PLATE_MM[1],
                                      "thickness_mm": PLATE_MM[2]}}}
    return pd.DataFrame(frame), scenes, searches, drift[1:]


@pytest.mark.parametrize("tau_factor", [0.7, 1.0, 2.0])
@pytest.mark.parametrize("scale_factor", [0.72, 1.0, 1.35])
def test_the_warming_estimate_recovers_a_drift_the_model_makes_within_the_tolerances(tau_factor, scale_factor):
    """A plate within the heating tolerances (scale and tau anywhere in their ranges) drifts
    as the lumped model says: every Pt's estimate is the true drift (negative: the resonance
    falls) within its u, and where the re-centrings resolve the drift (0.05 Hz) that u is
    under 5 % of the last level's drift; a P0's estimate is its setting's offset."""
    nominal = _nominal()
    scale = scale_factor * F0_HZ * 2e-4 / nominal.heat_capacity_j_per_k
    points, scenes, searches, true_hz = _warming_run(scale, tau_factor * nominal.time_constant_s, 0.05)
    drift = resonance_drift.with_resonance_drift(points, searches, scenes=scenes)
    estimate, u = drift["resonance_drift_hz"].to_numpy(), drift["resonance_drift_u_hz"].to_numpy()
    assert np.all(np.abs(estimate + true_hz) <= u) and (drift["resonance_drift_bound_hz"] == 0).all()
    assert drift["resonance_drift_source"].iat[0].startswith("Type A/B, the plate's warming")
    last_pt = ((points["velocity_level_pp_mps"] == 0.375) & (points["detuning_phase"] == "regained")).to_numpy()
    assert np.all(u[last_pt] <= 0.05 * true_hz[last_pt])
    at_setting = points["detuning_phase"].isin(resonance_drift.AT_SETTING).to_numpy()
    np.testing.assert_allclose(estimate[at_setting], points["generator_frequency_hz"][at_setting] - F0_HZ, rtol=1e-12)


def test_readings_that_resolve_nothing_leave_the_estimate_at_the_tolerances_middle():
    """Re-centrings that cannot tell 10 kHz leave the scale at the tolerances' middle with
    their rectangle's u, and every time constant allowed: the estimate is the middle of
    -k E_tau(t) over the taus, its u the scale's, the taus' and the room's in quadrature."""
    nominal = _nominal()
    points, scenes, searches, _ = _warming_run(F0_HZ * 2e-4 / nominal.heat_capacity_j_per_k,
                                               nominal.time_constant_s, 1e4)
    drift = resonance_drift.with_resonance_drift(points, searches, scenes=scenes)
    low, high = warming.drift_per_joule_range_hz(F0_HZ, *PLATE_MM, DENSITY_KG_M3)
    times_s, power_w = resonance_drift._power_history(points, searches, pd.DataFrame())
    held = np.array([np.interp(points["bench_time_s"], times_s, warming.held_heat_j(times_s, power_w, tau))
                     for tau in np.geomspace(*warming.time_constant_range_s(*PLATE_MM, DENSITY_KG_M3),
                                             resonance_drift.TIME_CONSTANT_STEPS)])
    scale, scale_u = 0.5 * (low + high), (high - low) / math.sqrt(12.0)
    room = warming.room_drift_bound_hz(points["generator_frequency_hz"].to_numpy(), points["bench_time_s"].to_numpy())
    pt = (points["detuning_phase"] == "regained").to_numpy()
    spread = scale * (held.max(axis=0) - held.min(axis=0))
    np.testing.assert_allclose(drift["resonance_drift_hz"].to_numpy()[pt],
                               (-0.5 * scale * (held.max(axis=0) + held.min(axis=0)))[pt], rtol=1e-5)
    np.testing.assert_allclose(drift["resonance_drift_u_hz"].to_numpy()[pt],
                               np.sqrt((scale_u * held.max(axis=0)) ** 2 + spread**2 / 12 + room**2 / 3)[pt], rtol=1e-5)


def test_the_scale_weighs_the_readings_fit_with_the_tolerances_rectangle():
    """k = (k_r I + k_t / u_t^2) / (I + 1 / u_t^2), u(k) = (I + 1 / u_t^2)^-1/2, with k_r the
    weighted least squares of -d on m, I = sum(w m^2) its information over the readings'
    Birge ratio chi^2 / (n - 1) (where above 1), and the tolerances' rectangle's mean k_t and
    u_t; u(k) grows by the two's disagreement |k_r - k_t| / sqrt(1 / I + u_t^2) where above 1.
    The readings' k where they resolve it (beyond the tolerances too), the rectangle's where
    they fit nothing."""
    readings = pd.DataFrame({"time_s": [0.0, 1.0, 2.0, 3.0], "frequency_hz": [F0_HZ, F0_HZ - 1.0, F0_HZ - 2.6,
                                                                               F0_HZ - 2.9],
                             "u_hz": [0.0, 0.1, 0.2, 0.1]})
    held_j = np.array([0.0, 10.0, 20.0, 30.0])
    w, m, d = 1 / np.array([0.1, 0.2, 0.1]) ** 2, held_j[1:], np.array([1.0, 2.6, 2.9])
    fitted = np.sum(w * m * d) / np.sum(w * m**2)
    chi2 = np.sum(w * (d - fitted * m) ** 2)
    information = np.sum(w * m**2) / max(1.0, chi2 / 2)
    for low, high in ((0.0, 1.0), (0.09, 0.1), (0.01, 0.02)):
        prior_k, prior_u = 0.5 * (low + high), (high - low) / math.sqrt(12)
        scale, scale_u, fit_chi2 = resonance_drift._warming_scale(held_j, readings, readings["time_s"].to_numpy(),
                                                                  low, high)
        weight = information + prior_u**-2
        disagreement = abs(fitted - prior_k) / math.sqrt(1 / information + prior_u**2)
        assert scale == pytest.approx((fitted * information + prior_k * prior_u**-2) / weight, rel=1e-9)
        assert scale_u == pytest.approx(max(1.0, disagreement) * weight**-0.5, rel=1e-9)
        assert fit_chi2 == pytest.approx(chi2, rel=1e-9)
    assert chi2 > 2 and disagreement > 1   # both ratios act in this example
    assert scale > high   # the readings resolve a scale beyond the tolerances: theirs is kept
    nothing = readings.assign(u_hz=0.0)
    assert resonance_drift._warming_scale(held_j, nothing, readings["time_s"].to_numpy(), 0.0, 1.0) == \
        pytest.approx((0.5, 1 / math.sqrt(12), 0.0))


def test_seeded_warming_plates_read_with_scatter_are_covered_by_the_estimates_u():
    """Plates drawn within the heating tolerances (seeded: scale and tau uniform over their
    ranges), their re-centrings scattering by 0.5 Hz: the last level's Pt drift is within
    1.96 u of its estimate on 95 % of the plates or more, and the 95th percentile of
    |error| / u is above 1 (a normal's is 1.96; a u read off a stacked bound would put it
    far below)."""
    rng = np.random.default_rng(46)
    low, high = warming.drift_per_joule_range_hz(F0_HZ, *PLATE_MM, DENSITY_KG_M3)
    shortest, longest = warming.time_constant_range_s(*PLATE_MM, DENSITY_KG_M3)
    ratios = []
    for _ in range(40):
        points, scenes, searches, true_hz = _warming_run(rng.uniform(low, high), rng.uniform(shortest, longest), 0.5)
        at_setting = points["detuning_phase"].isin(resonance_drift.AT_SETTING)
        scatter_hz = np.where(at_setting, rng.normal(0.0, 0.5, len(points)), 0.0)
        points = points.assign(tracked_resonance_frequency_hz=points["tracked_resonance_frequency_hz"] + scatter_hz)
        drift = resonance_drift.with_resonance_drift(points, searches, scenes=scenes)
        last = ((points["velocity_level_pp_mps"] == 0.375) & ~at_setting).to_numpy()
        ratios += list(np.abs(drift["resonance_drift_hz"].to_numpy() + true_hz)[last]
                       / drift["resonance_drift_u_hz"].to_numpy()[last])
    assert np.mean(np.array(ratios) <= 1.96) >= 0.95 and np.percentile(ratios, 95) > 1.0


def _walked(points: pd.DataFrame, true_hz: np.ndarray, rng: np.random.Generator, half_width_hz: float,
            scatter_rel: float, step_hz: float) -> pd.DataFrame:
    """`points` with each re-centring walked by `protocols.resonance.track_resonance` on a
    Lorentzian top whose peak has fallen by `true_hz`, read with relative scatter
    `scatter_rel`: a level's from the search's resonance (F0), the closing one from the last
    level's; the rows store what `protocols.detuning` does (the best reading as the setting,
    the vertex of the readings' top with its fit's u)."""
    search = SearchSettings(36000.0, 39000.0, tolerance_hz=0.2, tracking_step_hz=step_hz)
    columns = {name: points[name].to_numpy(float).copy() for name in
               ("generator_frequency_hz", "tracked_resonance_frequency_hz", "tracked_resonance_frequency_hz_u")}
    start_hz = F0_HZ
    for index in np.flatnonzero(points["detuning_phase"].isin(resonance_drift.AT_SETTING).to_numpy()):
        def measure_at(frequency_hz, peak_hz=F0_HZ - true_hz[index]):
            velocity = (1.0 + rng.normal(0.0, scatter_rel)) / math.hypot(1.0, (frequency_hz - peak_hz) / half_width_hz)
            return SimpleNamespace(generator_frequency_hz=frequency_hz, velocity_pp_mps=velocity)
        closing = points["detuning_phase"].iat[index] == "closing"
        found = track_resonance(measure_at, start_hz if closing else F0_HZ, search)
        fit = peak_of_readings([p.generator_frequency_hz for p in found.points], [p.velocity_pp_mps for p in found.points])
        columns["generator_frequency_hz"][index] = found.frequency_hz
        columns["tracked_resonance_frequency_hz"][index] = found.frequency_hz if fit is None else fit.frequency_hz
        columns["tracked_resonance_frequency_hz_u"][index] = math.nan if fit is None else fit.std_uncertainty_hz
        start_hz = found.frequency_hz
    return points.assign(**columns)


def test_recentrings_walked_on_a_broad_top_no_longer_pull_the_estimate_toward_no_drift():
    """On a broad top (Q 56, h 340 Hz) a re-centring walked by 5 Hz steps stops wherever its
    readings' scatter (3e-4) hides one step's rise, up to `recentring_blind_hz` (19 Hz) from
    the peak, on the side it came from. The plate falling by up to 20 Hz, the real walk's
    readings (`_walked`, six seeded runs), each taking its walk's stop (`recentring_stop_u_hz`),
    give the last level's estimates within 15 % of the drift and 0.6 u of it, and weighed
    with their fits' u alone (no search settings: the analysis of two sessions ago) lower
    ones, nearer no drift, on every run; the estimate's source names the walk's blind zone
    (from the scatter the search reads). Each reading corrected for its stop's mean (a walk
    stops on the side it came from, `recentring_stop_moments_hz`), the six runs' estimates
    are 98 % of the drift on average, within 4 % (the mean in u alone: 94 %)."""
    rng = np.random.default_rng(46)
    q, scatter_rel, step_hz = 56.0, 3e-4, 5.0
    nominal = _nominal()
    setups = {"fig2_nine_column": SearchSetup(tolerance_hz=0.2, tracking_step_hz=step_hz)}
    shares = []
    for _ in range(6):
        points, scenes, searches, true_hz = _warming_run(F0_HZ * 2e-4 / nominal.heat_capacity_j_per_k,
                                                         nominal.time_constant_s, 3.0)
        points = _walked(points, true_hz, rng, F0_HZ / (2.0 * q), scatter_rel, step_hz)
        sweep_hz = F0_HZ + np.arange(-300.0, 301.0, 20.0)
        velocity = ((1.0 + rng.normal(0.0, scatter_rel, len(sweep_hz)))
                    / np.sqrt(1.0 + (2.0 * q * (sweep_hz / F0_HZ - 1.0)) ** 2))
        searches = pd.concat([searches, pd.DataFrame({"run_name": "fig2_nine_column", "sweep": True,
                                                      "bench_time_s": 0.0, "generator_frequency_hz": sweep_hz,
                                                      "velocity_pp_mps": velocity})], ignore_index=True)
        last = ((points["velocity_level_pp_mps"] == 0.375) & (points["detuning_phase"] == "regained")).to_numpy()
        (before, after) = (resonance_drift.with_resonance_drift(points, searches, scenes=scenes, setups=given)
                           for given in (None, setups))
        estimate, u = after["resonance_drift_hz"].to_numpy()[last], after["resonance_drift_u_hz"].to_numpy()[last]
        assert np.all(np.abs(estimate + true_hz[last]) <= np.minimum(0.15 * true_hz[last], 0.6 * u))
        assert "5 Hz walk stops, blind within" in after["resonance_drift_source"].iat[0]
        assert "no re-centring's blind zone taken" in before["resonance_drift_source"].iat[0]
        assert np.all(-before["resonance_drift_hz"].to_numpy()[last] < -estimate)
        shares.append(np.mean(-estimate / true_hz[last]))
    assert np.mean(shares) == pytest.approx(1.0, abs=0.04)
