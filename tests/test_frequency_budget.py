"""The thick-plate factor the frequency budget applies (analysis.frequency_budget) against the
exact Mindlin plate-strip dispersion it is the first-order expansion of."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.analysis.frequency_budget import SHEAR_COEFFICIENT, mindlin_factor


def exact_mindlin_over_kirchhoff(kh: float, poisson: float, kappa: float = SHEAR_COEFFICIENT) -> float:
    """The lower (flexural) root of the Mindlin equations for a straight-crested wave of
    wavenumber k, over the Kirchhoff frequency, with h = 1, E = 1, rho = 1:
    (kappa G h k^2 - rho h w^2)(D k^2 + kappa G h - rho h^3 w^2 / 12) = (kappa G h k)^2."""
    h, k = 1.0, kh
    d = 1.0 / (12.0 * (1.0 - poisson**2))
    shear = kappa * h / (2.0 * (1.0 + poisson))
    # a quadratic in w^2: (shear k^2 - h s)(d k^2 + shear - h s / 12) - (shear k)^2 = 0
    a = h * h / 12.0
    b = -(shear * k**2 * h / 12.0 + h * (d * k**2 + shear))
    c = shear * k**2 * (d * k**2 + shear) - (shear * k) ** 2
    s = min(np.roots([a, b, c]).real)
    return math.sqrt(s / (d * k**4 / h))


@settings(max_examples=40, deadline=None)
@given(kh=st.floats(0.01, 0.5), poisson=st.floats(0.2, 0.4))
def test_the_factor_is_the_first_order_expansion_of_mindlins_dispersion(kh, poisson):
    exact = exact_mindlin_over_kirchhoff(kh, poisson)
    first_order = mindlin_factor(kh, math.pi / 1.0, poisson)   # h = kh, k = pi / (pi / 1) = 1
    assert first_order < 1.0 and exact < 1.0
    # the expansion's error is of the next order, (k h)^4
    assert abs(first_order - exact) <= 0.1 * kh**4 + 1e-12   # about 0.05-0.08 (k h)^4 here


def test_a_thicker_plate_or_a_shorter_wave_departs_more_from_kirchhoff():
    assert mindlin_factor(1e-3, 8e-3, 0.34) == pytest.approx(0.970, abs=0.001)   # the 1 mm paper plates: -3 %
    assert mindlin_factor(2e-3, 9e-3, 0.34) < mindlin_factor(1.2e-3, 8e-3, 0.34) < mindlin_factor(1e-3, 8e-3, 0.34)
    assert 1 - mindlin_factor(2e-3, 8e-3, 0.34) == pytest.approx(4 * (1 - mindlin_factor(1e-3, 8e-3, 0.34)))
