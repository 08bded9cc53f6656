"""The report explains the numbers a reader would stop at, from the run's own data:
negative tan theta' (d31's sign; Q's through Eq. 12's a) and a chi^2/dof well above
1 (the points' scatter against their stated uncertainty, and the resonance's moves)."""
from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd

from squeezebench.analysis import characterisation, model
from squeezebench.report import physics

GEOMETRY = model.PlateGeometry(2e-3, 0.5e-3, 9e-3, 9.5e-3, 4, 1)


def plate(scatter_rel: float, frequency_moves_hz: float) -> characterisation.PlateCharacterisation:
    rng = np.random.default_rng(3)
    volts = np.array([10.0, 20.0, 30.0, 40.0])
    amplitude = 2e-8 * volts * (1 + scatter_rel * rng.standard_normal(4))
    points = pd.DataFrame({
        "piezo_voltage_vpp": volts, "amplitude_pp_m": amplitude, "amplitude_pp_m_u": 1e-4 * amplitude,
        "power_w": 1e-5 * volts**2, "power_w_u": 1e-3 * 1e-5 * volts**2,
        "frequency_hz": 45000 + frequency_moves_hz * np.array([-1, 0.2, -0.2, 1.0])})
    return characterisation.characterise_plate("p", points, GEOMETRY, model.PAPER_CONVENTION)


def test_negative_tan_theta_and_a_large_chi2_are_explained():
    context = SimpleNamespace(convention=model.PAPER_CONVENTION)
    text = physics._surprises(context, {"p": plate(scatter_rel=0.01, frequency_moves_hz=5.0)})
    assert "tan θ′ is negative for 1 of 1 plates" in text and "takes d31's sign" in text
    assert "a is −3.06" in text and "Q changes sign" in text
    assert "χ²/dof reaches" in text and "moved by up to 5.0 Hz" in text and "amplitude against voltage" in text


def test_tan_theta_has_d31s_sign_under_both_readings_and_exact_points_raise_no_chi2():
    for convention in (model.PAPER_CONVENTION, model.PHYSICAL_CONVENTION):
        exact = characterisation.characterise_plate("p", plate(0.0, 0.0).points, GEOMETRY, convention)
        assert np.sign(exact.tan_theta.value) == np.sign(convention.materials.piezo_d31_c_per_n)
        assert "χ²/dof" not in physics._surprises(SimpleNamespace(convention=convention), {"p": exact})
