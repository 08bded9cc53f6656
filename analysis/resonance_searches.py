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
    """Where the search's readings put the resonance, the standard uncertainty of that from
    their own scatter (Type A), and what the fit's covariance misses of it
    (`lack_of_fit_hz`, Type A: see `peak_of_readings`)."""

    frequency_hz: float
    std_uncertainty_hz: float
    lack_of_fit_hz: float = 0.0


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
    covariance scaled by its residuals (first-order propagation, GUM 5.1.2).

    That u assumes every reading errs alike and independently. One reading off by more than
    the rest moves a vertex fitted on a few readings far more than the residuals' mean
    square says, the more so at the window's edge (its leverage): on small plate 6 (Q 40) the
    search's second golden reading comes out 0.25 % low on every bench, noise-free instruments
    too (its piezo voltage with it), and moves the vertex 2-3 Hz against a u of 0.5 Hz. The
    delete-one jackknife of the vertex (Efron & Stein; consistent with the covariance when
    the readings err alike) sees that: `lack_of_fit_hz` is what its standard deviation adds
    to the covariance's in quadrature, sqrt(max(u_jk^2 - u^2, 0)), so undistorted readings
    add about nothing. None with fewer than five readings (two degrees of freedom), no
    minimum, or a minimum outside the fitted readings (no top to fit: the caller keeps the
    largest reading)."""
    fitted = _fitted_top(frequency_hz, velocity)
    if fitted is None:
        return None
    frequency_hz, velocity, (peak_hz, u_hz) = fitted
    vertices_hz = _delete_one_vertices(frequency_hz, velocity)
    n = len(vertices_hz)
    jackknife_hz = math.sqrt((n - 1) / n * np.sum((vertices_hz - vertices_hz.mean()) ** 2))
    return PeakFit(peak_hz, u_hz, math.sqrt(max(jackknife_hz**2 - u_hz**2, 0.0)))


def resonance_of_readings(frequency_hz, velocity) -> float | None:
    """Where `peak_of_readings` puts the resonance, without its uncertainties (all a search
    needs: its jackknife is most of the fit's cost); None where that is None."""
    fitted = _fitted_top(frequency_hz, velocity)
    return None if fitted is None else fitted[2][0]


def _fitted_top(frequency_hz, velocity) -> tuple[np.ndarray, np.ndarray, tuple[float, float]] | None:
    """The readings on the top (frequencies, velocities) and their vertex with its u
    (`_vertex_of_top`); None where `peak_of_readings` says so."""
    frequency_hz, velocity = np.asarray(frequency_hz, dtype=float), np.asarray(velocity, dtype=float)
    finite = np.isfinite(velocity) & (velocity > 0)
    frequency_hz, velocity = frequency_hz[finite], velocity[finite]
    if len(velocity) == 0:
        return None
    top = velocity >= PEAK_FIT_SHARE * velocity.max()
    if np.unique(frequency_hz[top]).size < 5:
        return None
    frequency_hz, velocity = frequency_hz[top], velocity[top]
    fit = _vertex_of_top(frequency_hz, velocity)
    if fit is None or not frequency_hz.min() <= fit[0] <= frequency_hz.max():
        return None
    return frequency_hz, velocity, fit


def _weighted_system(frequency_hz: np.ndarray, velocity: np.ndarray, centre_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The weighted least-squares system (design, target) of 1/v^2 = a + b f^2 + c / f^2 in
    u = (f / centre)^2, which conditions it (u within a few per cent of 1); weighted for
    readings of equal relative scatter (sigma(1/v^2) = 2 s / v^2, up to a constant)."""
    u = (frequency_hz / centre_hz) ** 2
    weight = velocity**2
    return np.column_stack([np.ones_like(u), u - 1.0, 1.0 / u - 1.0]) * weight[:, None], velocity**-2.0 * weight


def _delete_one_vertices(frequency_hz: np.ndarray, velocity: np.ndarray) -> np.ndarray:
    """The vertex of each fit leaving one reading out (those with a minimum), solved together:
    a reading left out is a row of zeros (it weighs nothing), and the vertex does not depend
    on the centre the fit is written about, so every fit shares the whole top's. The top
    holds five frequencies or more, so each fit keeps four."""
    centre_hz = frequency_hz.mean()
    design, target = _weighted_system(frequency_hz, velocity, centre_hz)
    kept = 1.0 - np.eye(len(target))
    q, r = np.linalg.qr(design[None, :, :] * kept[:, :, None])
    coefficients = np.linalg.solve(r, np.einsum("kij,ki->kj", q, target[None, :] * kept)[:, :, None])[:, :, 0]
    b, c = coefficients[:, 1], coefficients[:, 2]
    minimum = (b > 0) & (c > 0)
    return centre_hz * (c[minimum] / b[minimum]) ** 0.25


def _vertex_of_top(frequency_hz: np.ndarray, velocity: np.ndarray) -> tuple[float, float] | None:
    """The vertex of 1/v^2 = a + b f^2 + c / f^2 fitted to readings already on the top, and
    its u from the residual-scaled covariance (`peak_of_readings`); None with fewer than
    four readings or no minimum."""
    if np.unique(frequency_hz).size < 4:
        return None
    centre_hz = frequency_hz.mean()
    design, target = _weighted_system(frequency_hz, velocity, centre_hz)
    coefficients, *_ = np.linalg.lstsq(design, target, rcond=None)
    residuals = target - design @ coefficients
    covariance = np.linalg.inv(design.T @ design) * (residuals @ residuals) / (len(target) - 3)
    _, b, c = coefficients
    if not (b > 0 and c > 0):
        return None
    peak_hz = centre_hz * (c / b) ** 0.25
    gradient = np.array([0.0, -peak_hz / (4.0 * b), peak_hz / (4.0 * c)])
    return float(peak_hz), float(math.sqrt(max(gradient @ covariance @ gradient, 0.0)))


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
