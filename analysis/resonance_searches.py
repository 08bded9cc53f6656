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


#: The resonance's top on which `peak_of_readings` fits the search's readings: above this
#: share of the largest (|x| < 0.75), where one mode dominates the response.
PEAK_FIT_SHARE = 0.8


@dataclass(frozen=True)
class PeakFit:
    """Where the search's readings put the resonance, and the standard uncertainty of that
    from their own scatter (Type A)."""

    frequency_hz: float
    std_uncertainty_hz: float


def peak_of_readings(frequency_hz, velocity) -> PeakFit | None:
    """The resonance frequency as the minimum of the driven mode's 1/v^2 fitted to the
    readings above PEAK_FIT_SHARE of the largest.

    A mode driven by a force of constant amplitude moves with v = v0 / sqrt(1 + x^2),
    x = Q (f / f0 - f0 / f) (its velocity's closed form, exact for one degree of freedom),
    so 1/v^2 = a + b f^2 + c / f^2 is linear in its three coefficients and least at
    f0 = (c / b)^(1/4). Every reading on the top tells where the peak is, where the largest
    single reading only says which of the readings tied on the flat top the search kept: a
    scope's step of 1e-3 of a reading leaves tens of hertz tied on a Q 300 peak, and which
    of them the golden section keeps is fixed by the peak's place among the coarse steps (the
    same plate lands off by the same hertz search after search). A parabola in f instead of
    the closed form misplaces a Q 40 peak by about 1 Hz (its x^3 term). Weighted for readings
    of equal relative scatter (sigma(1/v^2) = 2 s / v^2); the vertex's u from the fit's
    covariance scaled by its residuals (first-order propagation, GUM 5.1.2), so a misfit that
    shows in the residuals widens it.

    That u holds for readings that err alike and independently, as the search's do when each
    is read on a record that finds its crest (`protocols.acquisition.search_record_length`:
    one reading read 0.25 % low for want of a sample near its crest moved small plate 6's
    vertex 2.6 Hz). A delete-one jackknife of the vertex added on top of it (as a lack-of-fit
    term) over-states the variance (Efron & Stein 1981: in expectation it is at least the
    variance), most where a few readings at the top's edge carry the fit, as a golden
    section's readings, crowded where it stopped, leave them: it doubled small plates 3-5's U
    with nothing distorted. None with fewer than five readings (two degrees of freedom), no
    minimum, or a minimum outside the fitted readings (no top to fit: the caller keeps the
    largest reading)."""
    frequency_hz, velocity = np.asarray(frequency_hz, dtype=float), np.asarray(velocity, dtype=float)
    finite = np.isfinite(velocity) & (velocity > 0)
    frequency_hz, velocity = frequency_hz[finite], velocity[finite]
    if len(velocity) == 0:
        return None
    top = velocity >= PEAK_FIT_SHARE * velocity.max()
    if np.unique(frequency_hz[top]).size < 5:
        return None
    frequency_hz, velocity = frequency_hz[top], velocity[top]
    centre_hz = frequency_hz.mean()
    u = (frequency_hz / centre_hz) ** 2   # conditions the fit: u within a few per cent of 1
    weight = velocity**2   # 1 / sigma(1/v^2) up to a constant
    design = np.column_stack([np.ones_like(u), u - 1.0, 1.0 / u - 1.0]) * weight[:, None]
    target = velocity**-2.0 * weight
    coefficients, *_ = np.linalg.lstsq(design, target, rcond=None)
    residuals = target - design @ coefficients
    covariance = np.linalg.inv(design.T @ design) * (residuals @ residuals) / (len(u) - 3)
    _, b, c = coefficients
    if not (b > 0 and c > 0):
        return None
    peak_hz = centre_hz * (c / b) ** 0.25
    if not frequency_hz.min() <= peak_hz <= frequency_hz.max():
        return None
    gradient = np.array([0.0, -peak_hz / (4.0 * b), peak_hz / (4.0 * c)])
    return PeakFit(float(peak_hz), float(math.sqrt(max(gradient @ covariance @ gradient, 0.0))))


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
#: The steps a re-centring's walk takes before it gives the resonance up
#: (`protocols.resonance.track_resonance`; `resonance_drift.recentring_stop_offsets_hz`).
RECENTRING_MAX_STEPS = 20


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
    """What a run's resonance search was set to (RUN_DIR/settings/<run>.json): its final
    bracket and the step its re-centrings walk by (None where the settings hold none)."""

    tolerance_hz: float
    tracking_step_hz: float | None = None


def search_setups(run: RunData) -> dict[str, SearchSetup]:
    """The search settings of every run of `run` that searched a resonance."""
    setups = {}
    for path in sorted((run.run_dir / "settings").glob("*.json")):
        settings = json.loads(path.read_text(encoding="utf-8"))
        search = settings.get("parameters", {}).get("search")
        if search:
            step_hz = search.get("tracking_step_hz")
            setups[settings["run"]] = SearchSetup(float(search["tolerance_hz"]),
                                                  None if step_hz is None else float(step_hz))
    return setups
