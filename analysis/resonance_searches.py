"""A stored run's resonance searches as the uncertainty budgets read them: how each was
set (RUN_DIR/settings/<run>.json), how sharp the resonance its sweep shows is and how
much its readings scatter on the top (`analysis.uncertainty.search_budgets`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from squeezebench.analysis.rundata import RunData


def mechanical_q_from_sweep(frequency_hz: float, sweep: pd.DataFrame) -> float | None:
    """The resonance's sharpness from the search's points around it (sweep and refinement).

    On v = v0 / sqrt(1 + k^2 d^2) (d = f - f0, k = 2 Q / f0), 1/v^2 is a straight line
    in d^2 with slope/intercept k^2: fitted on the points above a third of the peak
    (where one mode dominates). None with fewer than three such points or no rise."""
    near = sweep[sweep["velocity_pp_mps"] > sweep["velocity_pp_mps"].max() / 3.0]
    if len(near) < 3:
        return None
    d2 = (near["generator_frequency_hz"].to_numpy() - frequency_hz) ** 2
    slope, intercept = np.polyfit(d2, near["velocity_pp_mps"].to_numpy() ** -2.0, 1)
    if not (slope > 0 and intercept > 0):
        return None
    return math.sqrt(slope / intercept) * frequency_hz / 2.0


#: The top on which the search's readings are compared with a parabola, as a fraction of
#: the largest reading: there the curve's quartic term (3 x^4 / 8 of v0) stays below 1e-4.
TOP = 0.98
#: Spread of where the golden-section search (`protocols.resonance.find_resonance`) stops,
#: in x = 2 Q (f - f0) / f0 per square root of the readings' relative scatter: near normal
#: with this standard deviation (p95 1.96 of it), the same for any width of the peak, since
#: near the top v/v0 = 1 - x^2/2 turns a scatter s into |x| ~ sqrt(s). Measured by running
#: that search on Lorentzians with seeded scatter (tests/test_resonance_search_budget.py
#: re-measures it and fails if the search changes).
SEARCH_STOP_SPREAD = 0.82


def reading_scatter_rel(sweep: pd.DataFrame) -> float | None:
    """Relative standard deviation of the velocities the search compared (the scope's
    peak-to-peak: its noise, the ADC's step, where the samples fall on the crest) about a
    parabola in f fitted through the readings on the top (above TOP of the largest; vertex
    free, so where the search stopped does not bias it). Type A, from the search's own
    readings; None with fewer than five such readings (two degrees of freedom)."""
    top = sweep[sweep["velocity_pp_mps"] >= TOP * sweep["velocity_pp_mps"].max()]
    if len(top) < 5:
        return None
    frequency_hz = top["generator_frequency_hz"].to_numpy()
    velocity = top["velocity_pp_mps"].to_numpy()
    centre_hz = frequency_hz.mean()   # conditions the fit at 10^4 Hz
    coefficients = np.polyfit(frequency_hz - centre_hz, velocity, 2)
    residuals = velocity / np.polyval(coefficients, frequency_hz - centre_hz) - 1.0
    return float(np.sqrt(np.sum(residuals**2) / (len(residuals) - 3)))


@dataclass(frozen=True)
class SearchSetup:
    """What a run's resonance search was set to (RUN_DIR/settings/<run>.json)."""

    tolerance_hz: float


def search_setups(run: RunData) -> dict[str, SearchSetup]:
    """The search settings of every run of `run` that searched a resonance."""
    setups = {}
    for path in sorted((run.run_dir / "settings").glob("*.json")):
        settings = json.loads(path.read_text(encoding="utf-8"))
        search = settings.get("parameters", {}).get("search")
        if search:
            setups[settings["run"]] = SearchSetup(float(search["tolerance_hz"]))
    return setups
