"""Section 2.2, Fig. 2: are dielectric losses significant? Detune, regain, compare power.

The paper's procedure, per velocity level v0 (0.125, 0.25, 0.375 m/s pp):
  "we record the vibration velocity at resonance as v0 and the corresponding power as P0.
   Then we slightly changed the frequency [...]. As a consequence, the vibration velocity
   decreased. Then, we applied a higher voltage to regain the vibration velocity v0 and
   record the power needed at this state as Pt."
and the frequency is raised until the velocity is 80 %, 60 % and 50 % of v0. When the
voltage limit comes before v0 (the nine-column plate at 0.375 m/s), the point measured at
the limit is recorded with `reachable=False` and the protocol goes on.

Fig. 2c, the stress point: the one-column plate driven at 37560 Hz instead of 37180 Hz,
where regaining v0 took 240 V instead of 37.6 V. It is the same "regain" with a fixed
frequency, and only runs whose `safety` section allows such a voltage can do it.

Steps: `resonance` (search), then per level `level_<v>` (re-centre on the resonance at the
level's voltage, record v0/P0) and `level_<v>_ratio_<r>` (detune, regain), then `stress`,
then `closing`: one more re-centring at the last level's voltage, so that every Fig. 2 point
lies between two dated readings of the resonance (the next level's re-centring follows every
other level's points), and the resonance's drift at it is bounded by readings rather than
extrapolated (`analysis.resonance_drift`). It records no power: one row, the re-centring's
best reading (`detuning_phase` 'closing', no waveforms), with the re-centring's reading in
the `tracked_resonance_*` columns as on a P0 row.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from squeezebench.analysis.resonance_searches import peak_of_readings
from squeezebench.protocols import resonance as resonance_protocol
from squeezebench.protocols.resonance import Resonance, SearchSettings, track_resonance
from squeezebench.protocols.steps import Plate, Step, StepContext

PROTOCOL = "detuning"


@dataclass(frozen=True)
class Parameters:
    search: SearchSettings
    velocity_levels_pp_mps: tuple[float, ...] = (0.125, 0.25, 0.375)
    velocity_ratios: tuple[float, ...] = (0.8, 0.6, 0.5)
    stress_frequency_hz: float | None = None          # Fig. 2c: 37560 Hz
    stress_velocity_level_pp_mps: float | None = None  # which v0 the stress point regains
    velocity_rel_tolerance: float = 0.01   # |v / target - 1| accepted
    first_detuning_hz: float = 10.0        # first frequency step above resonance
    max_iterations: int = 12

    def __post_init__(self) -> None:
        if any(not 0 < r < 1 for r in self.velocity_ratios):
            raise ValueError(f"velocity_ratios must lie in (0, 1), got {list(self.velocity_ratios)}")
        if any(not v > 0 for v in self.velocity_levels_pp_mps):
            raise ValueError("velocity_levels_pp_mps must be positive")
        if (self.stress_frequency_hz is None) != (self.stress_velocity_level_pp_mps is None):
            raise ValueError("stress_frequency_hz and stress_velocity_level_pp_mps go together")


def _level_key(velocity_pp_mps: float) -> str:
    return f"level_{velocity_pp_mps:g}".replace(".", "p")


def plan(params: Parameters, plate: Plate) -> list[Step]:
    steps = [Step("resonance", plate, lambda ctx: resonance_protocol.record_search(ctx, params.search))]
    for level in params.velocity_levels_pp_mps:
        key = _level_key(level)
        steps.append(Step(key, plate, lambda ctx, level=level: _at_resonance(ctx, params, level)))
        previous_key = key
        for ratio in params.velocity_ratios:
            ratio_key = f"{key}_ratio_{ratio:g}".replace(".", "p")
            steps.append(Step(ratio_key, plate, lambda ctx, level=level, ratio=ratio, prev=previous_key:
                              _detune_and_regain(ctx, params, level, ratio, prev)))
            previous_key = ratio_key
    if params.stress_frequency_hz is not None:
        steps.append(Step("stress", plate, lambda ctx: _stress(ctx, params)))
    if params.velocity_levels_pp_mps:
        steps.append(Step("closing", plate, lambda ctx: _closing(ctx, params, params.velocity_levels_pp_mps[-1])))
    return steps


# -- the procedure ----------------------------------------------------------------------
def _at_resonance(ctx: StepContext, params: Parameters, level_pp_mps: float) -> None:
    """Re-centre on the resonance at the voltage giving v0, record v0 and P0."""
    found = ctx.context["resonance"]
    frequency_hz = found["frequency_hz"]
    # Velocity is proportional to voltage at resonance: start from the search's ratio.
    voltage_vpp = level_pp_mps / found["velocity_pp_mps_per_vpp"]
    for _ in range(3):  # the resonance may shift with drive level: re-centre, re-adjust
        ctx.drive.set_frequency(frequency_hz)
        voltage_vpp = _regain(ctx, params, voltage_vpp, level_pp_mps).piezo_voltage_setpoint_vpp
        tracked = track_resonance(ctx.acquisition.measure_at, frequency_hz, params.search)
        shift_hz = tracked.frequency_hz - frequency_hz
        frequency_hz += shift_hz
        if abs(shift_hz) <= params.search.tolerance_hz:
            break
    ctx.drive.set_frequency(frequency_hz)
    point = _regain(ctx, params, voltage_vpp, level_pp_mps)
    ctx.record(point, velocity_level_pp_mps=level_pp_mps, target_velocity_ratio=1.0,
               detuning_phase="resonance", reachable=_within(point.velocity_pp_mps, level_pp_mps, params),
               **_tracked_reading(ctx, tracked))
    ctx.updates[_level_key(level_pp_mps)] = {
        "resonance_frequency_hz": frequency_hz, "piezo_voltage_vpp": point.piezo_voltage_setpoint_vpp,
        "v0_pp_mps": point.velocity_pp_mps, "p0_w": point.scope_power_w}


def _closing(ctx: StepContext, params: Parameters, level_pp_mps: float) -> None:
    """Re-centre on the resonance after the plate's last Fig. 2 point, from the last level's
    resonance and at its P0 voltage (the tracking its re-centring did, once), and record the
    best reading with the re-centring as a dated reading of the resonance (`_tracked_reading`)."""
    at_resonance = ctx.context[_level_key(level_pp_mps)]
    ctx.drive.set_frequency(at_resonance["resonance_frequency_hz"])
    ctx.drive.set_piezo_voltage(at_resonance["piezo_voltage_vpp"])
    tracked = track_resonance(ctx.acquisition.measure_at, at_resonance["resonance_frequency_hz"], params.search)
    best = next(p for p in reversed(tracked.points) if p.generator_frequency_hz == tracked.frequency_hz)
    ctx.record(best, velocity_level_pp_mps=level_pp_mps, target_velocity_ratio=math.nan, detuning_phase="closing",
               reachable=True, **_tracked_reading(ctx, tracked))


def _tracked_reading(ctx: StepContext, tracked: Resonance) -> dict[str, float]:
    """A re-centring as a dated reading of the resonance, for the drift between P0 and
    Pt (`analysis.resonance_drift`): the vertex its readings' top puts the peak at, with that
    fit's u (the best reading, which P0 is set at, scatters several times more on a flat
    top), dated by its readings' mean time (the plate drifts under them). NaN u where they
    hold no top to fit."""
    fit = peak_of_readings([p.generator_frequency_hz for p in tracked.points],
                           [p.velocity_pp_mps for p in tracked.points])
    return {"tracked_resonance_frequency_hz": tracked.frequency_hz if fit is None else fit.frequency_hz,
            "tracked_resonance_frequency_hz_u": math.nan if fit is None else fit.std_uncertainty_hz,
            "tracked_resonance_bench_time_s": float(np.mean([ctx.bench_time_s(p.clock_s) for p in tracked.points]))}


def _detune_and_regain(ctx: StepContext, params: Parameters, level_pp_mps: float, ratio: float,
                       previous_key: str) -> None:
    """Raise the frequency until v = ratio * v0 at the v0 voltage, then regain v0."""
    at_resonance = ctx.context[_level_key(level_pp_mps)]
    previous = ctx.context[previous_key]
    v0_pp_mps, f0_hz = at_resonance["v0_pp_mps"], at_resonance["resonance_frequency_hz"]
    ctx.drive.set_frequency(previous.get("detuned_frequency_hz", f0_hz + params.first_detuning_hz))
    ctx.drive.set_piezo_voltage(at_resonance["piezo_voltage_vpp"])
    detuned = _detune(ctx, params, f0_hz, v0_pp_mps, ratio)
    ctx.record(detuned, velocity_level_pp_mps=level_pp_mps, target_velocity_ratio=ratio,
               detuning_phase="detuned", reachable=True)
    regained = _regain(ctx, params, detuned.piezo_voltage_setpoint_vpp * v0_pp_mps / detuned.velocity_pp_mps,
                       v0_pp_mps)
    ctx.record(regained, velocity_level_pp_mps=level_pp_mps, target_velocity_ratio=ratio,
               detuning_phase="regained", reachable=_within(regained.velocity_pp_mps, v0_pp_mps, params))
    ctx.updates[ctx.step.step_id] = {"detuned_frequency_hz": detuned.generator_frequency_hz}


def _stress(ctx: StepContext, params: Parameters) -> None:
    """Fig. 2c: regain v0 at a fixed, far detuned frequency with a raised voltage limit."""
    at_resonance = ctx.context[_level_key(params.stress_velocity_level_pp_mps)]
    v0_pp_mps = at_resonance["v0_pp_mps"]
    ctx.drive.set_frequency(params.stress_frequency_hz)
    ctx.drive.set_piezo_voltage(at_resonance["piezo_voltage_vpp"])
    detuned = ctx.acquisition.measure(keep_waveforms=False)
    regained = _regain(ctx, params, detuned.piezo_voltage_setpoint_vpp * v0_pp_mps / detuned.velocity_pp_mps,
                       v0_pp_mps)
    ctx.record(regained, velocity_level_pp_mps=params.stress_velocity_level_pp_mps,
               target_velocity_ratio=detuned.velocity_pp_mps / v0_pp_mps, detuning_phase="stress",
               reachable=_within(regained.velocity_pp_mps, v0_pp_mps, params))


# -- the two searches -------------------------------------------------------------------
def _within(velocity_pp_mps: float, target_pp_mps: float, params: Parameters) -> bool:
    return abs(velocity_pp_mps / target_pp_mps - 1.0) <= params.velocity_rel_tolerance


def _regain(ctx: StepContext, params: Parameters, voltage_vpp: float, target_pp_mps: float):
    """Set the voltage that gives `target_pp_mps` at the present frequency.

    Velocity is proportional to voltage (Eq. 1, A ∝ n_c V), so each iteration scales the
    voltage by target / measured. Above the limit, measure at the limit and stop there.
    """
    limit_vpp = ctx.drive.max_piezo_voltage_vpp
    for _ in range(params.max_iterations):
        ctx.drive.set_piezo_voltage(min(voltage_vpp, limit_vpp))
        point = ctx.acquisition.measure(keep_waveforms=True)
        if _within(point.velocity_pp_mps, target_pp_mps, params) or voltage_vpp >= limit_vpp:
            return point
        voltage_vpp = point.piezo_voltage_setpoint_vpp * target_pp_mps / point.velocity_pp_mps
    return point


def _detune(ctx: StepContext, params: Parameters, f0_hz: float, v0_pp_mps: float, ratio: float):
    """Raise the frequency above f0 until the velocity is `ratio` * v0.

    Above a resonance (v0/v)^2 - 1 grows as (f - f0)^2, so u = sqrt((v0/v)^2 - 1) is
    nearly linear in f - f0: a secant on u converges in a few points even for a narrow peak.
    """
    target_u = math.sqrt(1.0 / ratio ** 2 - 1.0)
    frequency_hz = ctx.drive.frequency_hz
    for _ in range(params.max_iterations):
        point = ctx.acquisition.measure(keep_waveforms=True)
        if _within(point.velocity_pp_mps, ratio * v0_pp_mps, params):
            return point
        u = math.sqrt(max((v0_pp_mps / point.velocity_pp_mps) ** 2 - 1.0, 0.0))
        offset_hz = frequency_hz - f0_hz
        # u ≈ 0 means still on the peak's top: double the offset instead of dividing by ~0.
        new_offset_hz = 2.0 * offset_hz if u < 1e-3 else offset_hz * target_u / u
        frequency_hz = f0_hz + min(max(new_offset_hz, 0.25 * offset_hz), 4.0 * offset_hz)
        ctx.drive.set_frequency(frequency_hz)
    return point
