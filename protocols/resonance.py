"""Finding and following the plate's resonance (Section 2.1: "the frequency of the
sinusoidal signal was set at the resonance frequency of each tactile plate"; Section 5.3:
"we adjusted the waveform generator to activate the plate at the desired resonance").

The resonance is the frequency of the largest vibration velocity. A coarse sweep finds
the grid point nearest the peak; a golden-section search on the velocity then narrows
the bracket around it, and the resonance is read from all the readings on the peak's
top (`analysis.resonance_searches.peak_of_readings`), not from the largest one alone.
Golden section needs only a single maximum in the bracket, not a smooth or wide one: a
peak a few hertz wide (mechanical Q of 10^4) between two coarse points still has
monotonic flanks, so the largest coarse point brackets it. The search
runs on a scaled variable u in [0, 1] over the bracket, so its tolerance is independent
of the frequency's magnitude.

Tracking re-centres on a resonance that drifts (temperature, amplitude) between the
points of a protocol: walk uphill from the last resonance, then refine the same way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable

from squeezebench.analysis.resonance_searches import RECENTRING_MAX_STEPS, peak_of_readings
from squeezebench.protocols.acquisition import Point
from squeezebench.protocols.steps import Plate, Step, StepContext
from squeezebench.errors import UserError

PROTOCOL = "resonance_search"

GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0  # 0.618...


class ResonanceError(UserError):
    """The velocity maximum is not inside the searched frequency range."""


@dataclass(frozen=True)
class SearchSettings:
    """Campaign `search:` parameters of a resonance search."""

    start_hz: float
    stop_hz: float
    points: int = 41                  # coarse sweep points, both ends included
    tolerance_hz: float = 0.2         # width of the final bracket
    piezo_voltage_vpp: float = 10.0   # drive while searching (well below any limit)
    tracking_step_hz: float = 5.0     # first step when re-centring on a known resonance

    def __post_init__(self) -> None:
        if not 0 < self.start_hz < self.stop_hz:
            raise ValueError(f"need 0 < start_hz < stop_hz, got {self.start_hz!r}, {self.stop_hz!r}")
        if self.points < 3:
            raise ValueError(f"points must be at least 3, got {self.points!r}")
        if not self.tolerance_hz > 0 or not self.tracking_step_hz > 0:
            raise ValueError("tolerance_hz and tracking_step_hz must be positive")


@dataclass
class Resonance:
    frequency_hz: float
    velocity_pp_mps: float
    points: list[Point]   # every point measured, in order (the sweep and the refinement)


class _VelocityProbe:
    """Measures velocity at a frequency once (a repeated frequency is not re-measured)."""

    def __init__(self, measure_at: Callable[[float], Point]):
        self._measure_at = measure_at
        self.points: list[Point] = []
        self._velocity: dict[float, float] = {}

    def __call__(self, frequency_hz: float) -> float:
        if frequency_hz not in self._velocity:
            point = self._measure_at(frequency_hz)
            self.points.append(point)
            self._velocity[frequency_hz] = point.velocity_pp_mps
        return self._velocity[frequency_hz]

    def best(self) -> tuple[float, float]:
        frequency_hz = max(self._velocity, key=self._velocity.__getitem__)
        return frequency_hz, self._velocity[frequency_hz]

    def peak(self) -> tuple[float, float]:
        """The resonance the readings' top puts the peak at (the best reading's frequency where
        they hold no top to fit), and the largest velocity read."""
        best_hz, velocity_pp_mps = self.best()
        fit = peak_of_readings(list(self._velocity), list(self._velocity.values()))
        return (best_hz if fit is None else fit.frequency_hz), velocity_pp_mps


def golden_section_maximum(velocity: Callable[[float], float], low_hz: float, high_hz: float,
                           tolerance_hz: float) -> None:
    """Narrow [low_hz, high_hz] around the maximum of `velocity` to `tolerance_hz`.

    Works on u = (f - low) / (high - low); the caller reads the best point measured.
    """
    span_hz = high_hz - low_hz
    to_hz = lambda u: low_hz + u * span_hz  # noqa: E731 - the scaling, named once
    a, b = 0.0, 1.0
    c, d = b - GOLDEN * (b - a), a + GOLDEN * (b - a)
    vc, vd = velocity(to_hz(c)), velocity(to_hz(d))
    while (b - a) * span_hz > tolerance_hz:
        if vc >= vd:
            b, d, vd = d, c, vc
            c = b - GOLDEN * (b - a)
            vc = velocity(to_hz(c))
        else:
            a, c, vc = c, d, vd
            d = a + GOLDEN * (b - a)
            vd = velocity(to_hz(d))


def find_resonance(measure_at: Callable[[float], Point], search: SearchSettings) -> Resonance:
    """Coarse sweep over [start_hz, stop_hz], then golden section around its maximum; the
    resonance is the vertex of the readings' top (`_VelocityProbe.peak`), the velocity the
    largest read."""
    probe = _VelocityProbe(measure_at)
    step_hz = (search.stop_hz - search.start_hz) / (search.points - 1)
    grid_hz = [search.start_hz + i * step_hz for i in range(search.points)]
    velocities = [probe(f) for f in grid_hz]
    peak = max(range(len(grid_hz)), key=velocities.__getitem__)
    if peak in (0, len(grid_hz) - 1):
        raise ResonanceError(
            f"the velocity maximum is at the edge ({grid_hz[peak]:.1f} Hz) of the search range "
            f"[{search.start_hz:.1f}, {search.stop_hz:.1f}] Hz; widen or move the range")
    golden_section_maximum(probe, grid_hz[peak - 1], grid_hz[peak + 1], search.tolerance_hz)
    frequency_hz, velocity_pp_mps = probe.peak()
    return Resonance(frequency_hz, velocity_pp_mps, probe.points)


def stopped_at(found: Resonance, search: SearchSettings, tolerance_hz: float) -> Resonance:
    """What `search` would have found with the coarser `tolerance_hz`, without measuring:
    the search's path depends only on the velocities it reads, so the coarser search asks
    for the first of `found`'s points in the same order and stops earlier. Its last point
    is where it ends (`clock_s`: its bench time)."""
    if tolerance_hz < search.tolerance_hz:
        raise ValueError(f"a search to {search.tolerance_hz:g} Hz holds no finer one ({tolerance_hz:g} Hz)")
    measured = iter(found.points)
    return find_resonance(lambda frequency_hz: next(measured), replace(search, tolerance_hz=tolerance_hz))


def track_resonance(measure_at: Callable[[float], Point], frequency_hz: float,
                    search: SearchSettings, max_walk_steps: int = RECENTRING_MAX_STEPS) -> Resonance:
    """Re-centre on a resonance last seen at `frequency_hz` that may have drifted."""
    probe = _VelocityProbe(measure_at)
    step_hz = search.tracking_step_hz
    centre_hz = frequency_hz
    for _ in range(max_walk_steps):
        below, centre, above = probe(centre_hz - step_hz), probe(centre_hz), probe(centre_hz + step_hz)
        if centre >= below and centre >= above:
            break
        centre_hz += step_hz if above > below else -step_hz
    else:
        raise ResonanceError(f"lost the resonance: no maximum within {max_walk_steps} steps of "
                             f"{step_hz:g} Hz from {frequency_hz:.1f} Hz")
    golden_section_maximum(probe, centre_hz - step_hz, centre_hz + step_hz, search.tolerance_hz)
    best_hz, velocity_pp_mps = probe.best()
    return Resonance(best_hz, velocity_pp_mps, probe.points)


# -- as a protocol step ------------------------------------------------------------------
@dataclass(frozen=True)
class Parameters:
    search: SearchSettings


def plan(params: Parameters, plate: Plate) -> list[Step]:
    return [Step("resonance", plate, lambda ctx: record_search(ctx, params.search))]


def record_search(ctx: StepContext, search: SearchSettings) -> float:
    """Search at the search voltage; record every point (`sweep=True`) and the resonance.

    Adds `resonance` to the run's context: the frequency and the velocity per volt there,
    from which a protocol sets its first voltage for a velocity target.
    """
    ctx.drive.set_piezo_voltage(search.piezo_voltage_vpp)
    found = find_resonance(ctx.acquisition.measure_at, search)
    for point in found.points:
        ctx.record(point, protocol=PROTOCOL, sweep=True, resonance_frequency_hz=found.frequency_hz)
    ctx.drive.set_frequency(found.frequency_hz)
    point = ctx.acquisition.measure(keep_waveforms=True)
    ctx.record(point, protocol=PROTOCOL, sweep=False, resonance_frequency_hz=found.frequency_hz)
    ctx.updates["resonance"] = {
        "frequency_hz": found.frequency_hz,
        "velocity_pp_mps_per_vpp": point.velocity_pp_mps / point.piezo_voltage_setpoint_vpp}
    return found.frequency_hz


def record_point_at_resonance(ctx: StepContext, search: SearchSettings, piezo_voltage_vpp: float,
                              **columns) -> None:
    """Search the resonance, then record one point there at `piezo_voltage_vpp`."""
    ctx.drive.set_frequency(record_search(ctx, search))
    ctx.drive.set_piezo_voltage(piezo_voltage_vpp)
    ctx.record(ctx.acquisition.measure(keep_waveforms=True), **columns)
