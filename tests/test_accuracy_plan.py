"""The floor a bench's specified errors put under a campaign (quick campaign, simulated)."""

from __future__ import annotations

import math

import pytest

from squeezebench import paths
from squeezebench.analysis.calibration import gain_weight
from squeezebench.analysis.specifications import SPECIFICATIONS
from squeezebench.protocols.accuracy_plan import accuracy_floors

QUICK = paths.campaigns_dir() / "quick.yaml"


@pytest.fixture(scope="module")
def floors():
    return accuracy_floors(QUICK, 0.01)


def test_a_one_percent_target_is_below_the_gain_floor(floors):
    # power carries three gains (CH1, CH2 +-2 %, TCP202 +-3 %): p95 ~ 1.96 x 2.4 % whatever the averaging
    gains = math.sqrt(2 * SPECIFICATIONS["scope_gain"].std_uncertainty**2
                      + SPECIFICATIONS["current_probe_gain"].std_uncertainty**2)
    power = [f for f in floors.floors if f.quantity == "power_w"]
    assert all(f.floor_p95_rel >= 1.96 * gains * 0.999 for f in power)
    # the gain check trades the current path's errors for the voltage path's: g1^(1+a) (g2 gp)^(1-a)
    alpha = gain_weight()
    checked = math.hypot((1 + alpha) * SPECIFICATIONS["scope_gain"].std_uncertainty,
                         (1 - alpha) * math.hypot(SPECIFICATIONS["scope_gain"].std_uncertainty,
                                                  SPECIFICATIONS["current_probe_gain"].std_uncertainty))
    assert checked < 0.9 * gains
    assert all(f.calibrated_floor_p95_rel >= 1.96 * checked * 0.999 for f in power)
    assert {f.calibrated_dominant_term for f in power} == {"CH1 gain (gain-checked)"}
    assert len(floors.below_floor()) == len(floors.floors)
    text = "\n".join(floors.lines())
    assert "below the reachable floor" in text and "voltage reference" in text


def test_the_deskew_calibration_lifts_the_delay_term_at_its_cost(floors):
    assert floors.calibration_bench_time_s > 1.0
    assert floors.deskew_std_uncertainty_s < 1e-9
    assert set(floors.own_bench_time_s) == {"detuning", "cutting"}
    for f in floors.floors:
        assert f.calibrated_floor_p95_rel <= f.floor_p95_rel + 1e-12
    relaxed = accuracy_floors(QUICK, 0.05)
    assert relaxed.below_floor() == []
    for run in relaxed.calibrated_runs():   # the calibration is planned only where it is needed
        assert relaxed.floor(run, calibrated=False) > 0.05 >= relaxed.floor(run, calibrated=True)
    assert all(0 < relaxed.noise_allowance(run) < 0.05 for run in relaxed.own_bench_time_s)
    assert relaxed.as_dict()["calibration"]["runs"] == relaxed.calibrated_runs()
