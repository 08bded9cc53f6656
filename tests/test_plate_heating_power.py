"""The power that warms a plate is the plate's own (`analysis.dielectric.plate_power_w`): the
scope reads the power at the amplifier's output, through the series 2 ohm shunt (Sec. 2.1),
and the shunt's loss warms the shunt. Against the simulator's own plate power on a seeded
point of the nine-column plate, where the shunt takes 8.6 % at resonance, and through both
warming estimates (a search's, `plate_warming`; Fig. 2's drift, `resonance_drift`)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from squeezebench import paths
from squeezebench.analysis import dielectric, plate_warming, resonance_drift
from squeezebench.yamlfiles import load_strict
from test_plate_warming import _nominal, _warming_run, F0_HZ
from test_sim_support import RawBench, scene_file

NINE_COLUMN = "nine_column_1mm.yaml"
RESONANCE_HZ, GENERATOR_VPP = 38000.0, 2.6   # its scene's calibration: 52 Vpp at resonance


@pytest.fixture(scope="module")
def nine_column_point(tmp_path_factory):
    """The nine-column plate read at resonance on its scene's seeded bench (shunt, noise,
    quantisation, averaging, offsets): the scope's power and current pp, and the simulator's
    closed-form steady state."""
    bench = RawBench(scene_file(tmp_path_factory.mktemp("nine"), NINE_COLUMN))
    try:
        bench.drive(RESONANCE_HZ, GENERATOR_VPP)
        bench.configure(RESONANCE_HZ)
        bench.acquire()
        yield bench.measure("MATH", "MEAN"), bench.measure("CH2", "PK2"), bench.sim.truth()
    finally:
        bench.close()


def test_the_heating_power_is_the_simulators_plate_power_on_a_seeded_point(nine_column_point):
    """|P| - R_s I_pp^2 / 8 from the scope's readings is the plate's dissipated power (V_piezo
    x I, which the simulator warms the plate with) within 0.5 %, where the scope's power is
    8.6 % above it; the shunt's loss from the current's pp, R_s I_pp^2 / 8, is the simulator's
    R_s |I|^2 / 2 within 1 %."""
    power_w, current_pp_a, truth = nine_column_point
    heating_w = float(dielectric.plate_power_w(power_w, current_pp_a, 2.0))
    assert heating_w == pytest.approx(truth.plate_power_w, rel=5e-3)
    assert power_w / truth.plate_power_w - 1.0 > 0.08
    assert power_w - heating_w == pytest.approx(truth.power_w - truth.plate_power_w, rel=1e-2)
    assert float(dielectric.plate_power_w(-power_w, math.nan, 2.0)) == power_w   # no current stored: the whole power


def test_a_search_on_the_nine_column_plate_is_corrected_for_its_plates_power_alone(nine_column_point):
    """A search read after a minute at that point: its warming correction with the scene's
    2 ohm shunt is the one without it times P_plate / P (energy balance linear in the power,
    8.6 % less), and its u holds the shunt's 1 % as the fourth of the rise's rectangles."""
    power_w, current_pp_a, truth = nine_column_point
    times_s = np.arange(2.0, 62.0, 2.0)
    history = pd.DataFrame({"run_name": "fig2", "plate": "nine_column_1mm", "bench_time_s": times_s,
                            "scope_power_w": power_w, "scope_current_pp_a": current_pp_a})
    scene = load_strict((paths.scenes_dir() / NINE_COLUMN).read_text())
    assert dielectric.shunt_ohm(scene) == 2.0
    unshunted = {**scene, "effects": [e for e in scene["effects"] if e != dielectric.SHUNT_EFFECT]}
    (with_hz, term), (without_hz, _) = (plate_warming.search_warming_term(history, "nine_column_1mm", s, RESONANCE_HZ,
                                                                          times_s[-1:], [RESONANCE_HZ], [1.0])
                                        for s in (scene, unshunted))
    share = 1.0 - float(dielectric.plate_power_w(power_w, current_pp_a, 2.0)) / power_w
    assert with_hz == pytest.approx(without_hz * (1.0 - share), rel=1e-9)
    assert share == pytest.approx(1.0 - truth.plate_power_w / truth.power_w, abs=5e-3)
    assert "less the 2 ohm shunt's loss" in term.source
    length_m, width_m, thickness_m = plate_warming.plate_size_m(scene)
    rise_k, halves = plate_warming.warming_estimate_k(history, "nine_column_1mm", times_s[-1], length_m, width_m,
                                                      thickness_m, 2.0)
    assert halves[3] == pytest.approx(dielectric.SHUNT_TOLERANCE_REL * share / (1.0 - share) * rise_k, rel=1e-9)


def test_fig2s_drift_estimate_on_the_nine_column_plate_drops_by_the_shunts_share():
    """Fig. 2's drift on a plate whose re-centrings resolve nothing (the scale at the
    tolerances' middle, linear in the heat): with a scene naming the 2 ohm shunt and currents
    at which it takes 8.6 % of every stored power, each Pt's estimate is 0.914 of the one
    from the whole stored power."""
    scale = F0_HZ * 2e-4 / _nominal().heat_capacity_j_per_k
    points, scenes, searches, _ = _warming_run(scale, _nominal().time_constant_s, 1e4)
    share = 0.086
    points["scope_current_pp_a"] = np.sqrt(8.0 * share * points["power_w"] / 2.0)
    searches["scope_current_pp_a"] = math.sqrt(8.0 * share * searches["power_w"].iat[0] / 2.0)
    shunted = {name: {**scene, "electronics": {"shunt_ohm": 2}, "actuators": {}, "effects": ["shunt"]}
               for name, scene in scenes.items()}
    whole, plate = (resonance_drift.with_resonance_drift(points, searches, scenes=s)["resonance_drift_hz"].to_numpy()
                    for s in (scenes, shunted))
    pt = (points["detuning_phase"] == "regained").to_numpy()
    assert np.all(whole[pt] < 0)
    np.testing.assert_allclose(plate[pt], (1.0 - share) * whole[pt], rtol=1e-6)
