"""How far a plate's resonance had moved when each Fig. 2 point was read, from the plate's
warming under the run's own stored powers and the run's readings of its resonance.

A plate's resonance moves while a run measures it: the plate warms under its drive (the
modulus falls, the resonance with its square root: about -2e-4 per kelvin for aluminium) and
with the room. A stored value means the plate as mounted (`analysis.uncertainty`: the reading
at the point's recorded setting), so a point read when the resonance had moved by delta reads
the resonance curve displaced by delta: on its slope (Fig. 2's Pt) that is a generator
frequency error of -delta / f on the part of the power that follows the resonance; P0, set
on the re-centred resonance, is off the mounted plate's by its setting's offset, a change of
(offset / h)^2 only on the flat top, h = f / (2 Q) the half-width
(`uncertainty.power_ratio_budget`).

Where the run's scene gives the plate (`_warming_estimates`), the drift is estimated from the
plate's warming: a lumped thermal model (`plates.warming`) driven by the power the plate took
at every stored reading of the run (the stored power less the series shunt's loss,
`dielectric.plate_power_w`: the scope reads it at the amplifier's output), its time
constant and its hertz per joule held within the heating tolerances, the scale fitted to the
run's dated readings below. The warming's sign is known (the resonance
falls), so the drift is an estimate with a standard uncertainty (the scale's fit, the spread
over the time constants the readings allow, the room's drift), which Fig. 2's ratio is
corrected for (GUM 3.2.4; `uncertainty.power_ratio_budget`), not a bound that U must hold
at its edge: a one-sided 95 % bound carried as a bias bound stacked two 95 % margins, and
Pt/P0 covered 99.2 % of 40 benches. The estimate follows the power the plate took: small at
a low level (the plate barely warms), and it keeps growing under the last level's Pt, which
the readings on a broad top (the nine-column plate's, Q ~ 56) need not see: there a
re-centring's walk of 5 Hz steps stops wherever one step's rise hides in its readings'
scatter, up to about 19 Hz from the peak (`recentring_blind_hz`), and its vertex and best
reading, within a step of the stop, cannot see past it. Its re-centrings start from the
last resonance, so on twelve seeded benches the nine-column plate's closing re-centrings
read 7 Hz of its 21 Hz fall, 2-3 times their fits' u off (the one- and four-column plates'
within their u). Weighed with their fits' u alone they scaled its Pt estimates to 69-71 % of
the simulated plate's drift; with that zone as a rectangle at its 95 % bound on each
reading they were 94-95 % (the one-column plate's 94-96 % to 97-98 %, the four-column's
98-99 % to 100-102 %). Where the walk stops is not uniform out to that bound: each reading
now carries its walk's own stop beyond the golden section's bracket
(`recentring_stop_offsets_hz`, the walk's rule as a chain; `recentring_stop_u_hz`;
`_walk_stops_hz`, its start placed against the peak by the warming the tolerances
predict): on that top 3.3 Hz RMS from a start at the peak, 5.6 Hz from 10 Hz off, 8.6 Hz
from 30 Hz, on a narrow top (the one- and four-column plates') 0-0.2 Hz, where the rectangle
said 11.1 Hz and up to 1.2 Hz from anywhere (the run's re-centring step from its settings).
A walk stops on the side it came from, so a re-centring of a falling resonance reads high:
where the warming places its start, the reading is corrected for its stop's mean
(`recentring_stop_moments_hz`) and keeps its spread about it as u. On 40 seeded specified
benches (`benchmarks/drift_calibration.py`, the simulated plate's own drift recorded) the
nine-column plate's Pt estimates were 85 % of its drift (median) with u 4.4 Hz RMS,
(e - true) / u +0.47 +- 0.53 (p95 |.| 1.47): the bias carried as u; corrected, 91 % with u
3.4 Hz, +0.29 +- 0.56 (p95 1.07). The readings alone (below) bound the drift where no scene gives the plate.

Type A, from the run's dated readings of its resonance (`_drift_bounds`: a bias bound,
`resonance_drift_bound_hz`, and no estimate; the same readings scale the warming): its
search's (the plate as mounted, at the search's low drive: the reference), each Fig. 2
level's re-centring before P0 and the plate's closing re-centring after its last point
(`tracked_resonance_frequency_hz`, the vertex of its readings' top, with that fit's u, at its
readings' mean time; its best reading, where P0 is set, where that strays less, as on a top
far wider than the re-centring's steps). Each reading j gives the drift since the reference,
d_j = f_j - f_ref, with u_j = sqrt(u(f_j)^2 + u(f_ref)^2) (0 at the reference itself). A
point between two readings is bounded by the larger of theirs (a plate that warms under a
rising drive drifts one way between two readings; a line between them lagged the warming on
seeded benches: the later reading is at the next, higher, level): the larger of Q(d_j, u_j)
at its two readings, Q the 95th percentile of |d| for d normal about d_j with u_j
(`folded_quantile`): 1.96 u_j where the readings resolve no drift, their scatter entering
once as u, and |d_j| + 1.645 u_j where they resolve one (the readings' scatter is not added
to a bound it already widens). A P0 or closing row is read at its setting: its drift is its
setting's offset from the reference, Q(offset, u(f_ref)).

A point after the run's last reading (a run stored before the closing re-centring was
recorded) has its drift extrapolated, and its source says so: it goes on at the steepest rate
per watt the readings resolve, times the last reading's power (a plate warms at up to its
power over its heat capacity, fastest just after its drive rose; where no interval resolves
a rate, the best-measured one's), bounded by |d_last| + rate t + 1.96 u with u the last
reading's and the rate's u times the time since in quadrature. A run stored before the
re-centrings were recorded has its P0 settings as readings, dated by P0's end: the best
reading of a golden section on a flat top, scattering by h SEARCH_STOP_SPREAD sqrt(s) (s the
search's readings' relative scatter, Q the search sweep's, `resonance_searches`); the source
says so.

Type B where the run holds no repeated reading of its resonance (a single dated one):
FALLBACK_DRIFT_RATE_REL_PER_S times the time since that reading. A point without a stored
time has no estimate: drift, u and bound 0, and the source says so.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pandas as pd
from scipy.integrate import cumulative_trapezoid, trapezoid
from scipy.special import ndtr, ndtri

from squeezebench.analysis import dielectric, plate_warming, provenance
from squeezebench.analysis.budgets import COVERAGE_PROBABILITY, P95_FACTOR
from squeezebench.analysis.resonance_searches import (RECENTRING_MAX_STEPS, SEARCH_STOP_SPREAD, SearchSetup,
                                                      mechanical_q_from_sweep, peak_of_readings, reading_scatter_rel)
from squeezebench.plates import warming
from squeezebench.plates.laminate import ALUMINIUM_TABLE2

#: Relative resonance drift per second where a run holds a single reading of its resonance:
#: the frequency's temperature coefficient times an assumed warming rate.
FALLBACK_DRIFT_RATE_REL_PER_S = 2e-4 * 1.0 / 60.0
FALLBACK_SOURCE = ("Type B, no repeated reading of the resonance in the run: -2e-4 per K (aluminium's "
                   "modulus falls about 4e-4/K, the resonance with its square root) times an assumed warming "
                   "of up to 1 K per minute under drive, over the time since the run's first reading")
NOT_DATED = "no reading times stored: the resonance's drift is not estimated"
#: A run stored before the re-centrings were recorded.
UNTRACKED = ("; re-centrings read from P0's settings dated by P0's end (a run stored before "
             "tracked_resonance_frequency_hz): best readings on a flat top, a few seconds late")
#: A run stored before the closing re-centring: its last level's points come after its last reading.
EXTRAPOLATED = ("; the last level's points after the last reading (a run stored before the closing "
                "re-centring was recorded) at {rate:.3f} +- {rate_u:.3f} Hz/s, the steepest per watt resolved")
#: The Fig. 2 rows that read the resonance at their own setting (no slope under them).
AT_SETTING = ("resonance", "closing")
#: Each point's drift estimate, its u and a bias bound (Hz; `DRIFT_COLUMNS`), and their source.
DriftColumns = tuple[np.ndarray, np.ndarray, np.ndarray, str]
_COLUMNS = ("tracked_resonance_bench_time_s", "tracked_resonance_frequency_hz", "tracked_resonance_frequency_hz_u")
#: What `with_resonance_drift` gives each point: the drift's estimate, its standard uncertainty
#: and a bias bound on what the estimate leaves (Hz).
DRIFT_COLUMNS = ("resonance_drift_hz", "resonance_drift_u_hz", "resonance_drift_bound_hz")


def with_resonance_drift(points: pd.DataFrame, searches: pd.DataFrame | None = None,
                         closings: pd.DataFrame | None = None, scenes: dict[str, dict] | None = None,
                         setups: dict[str, SearchSetup] | None = None) -> pd.DataFrame:
    """`points` (Fig. 2 points, any runs) with how far the resonance had moved from the run's
    first reading of it when each point was read: `resonance_drift_hz`, its estimate (signed:
    negative where it fell; a P0 or closing row, its setting's offset), `resonance_drift_u_hz`
    that estimate's standard uncertainty (normal), `resonance_drift_bound_hz` a bias bound on
    what the estimate leaves where the run gives no estimate (0 where it does), and
    `resonance_drift_source`. `searches`: the runs'
    resonance_search rows (sweep and found, velocities reduced or the scope's): the reference
    reading, and the scatter and Q of a best reading; without them, the runs' re-centrings
    are the only readings. `closings`: the runs' closing re-centrings where `points` does
    not hold them (they store no power, so a frame of powers leaves them out). `scenes`: the
    run's scene copies (`RunData.scenes`); where one gives the plate, its drift is estimated
    from its warming under the run's own stored powers (`_warming_estimates`), else bounded
    by its readings alone (`_drift_bounds`). `setups`: the runs' search settings
    (`resonance_searches.search_setups`), whose re-centring step widens each re-centring's
    reading by how far from the peak its walk may stop (`recentring_blind_hz`); without them
    the readings keep their fits' u alone."""
    out = points.copy()
    for column in DRIFT_COLUMNS:
        out[column] = 0.0
    out["resonance_drift_source"] = NOT_DATED
    if out.empty or "bench_time_s" not in out or "run_name" not in out:
        return out
    searches = pd.DataFrame(columns=["run_name"]) if searches is None else searches
    closings = pd.DataFrame(columns=["run_name"]) if closings is None else closings
    for run_name, group in out.groupby("run_name", sort=False):
        scene = scenes.get(provenance.scene_files(group.iloc[:1]).iat[0], {}) if scenes else {}
        dimensions = _plate_dimensions(scene)
        setup = (setups or {}).get(run_name)
        step_hz = None if setup is None else setup.tracking_step_hz
        # a scene that names no shunt: the whole stored power heats the plate, a bound
        drift = functools.partial(_drift_bounds, step_hz=step_hz) if dimensions is None else functools.partial(
            _warming_estimates, dimensions=dimensions, shunt_ohm=dielectric.shunt_ohm(scene) or 0.0, step_hz=step_hz)
        *values, source = drift(group, searches[searches["run_name"] == run_name],
                                closings[closings["run_name"] == run_name])
        for column, value in zip(DRIFT_COLUMNS, values):
            out.loc[group.index, column] = value
        out.loc[group.index, "resonance_drift_source"] = source
    return out


def best_reading_scatter_hz(top: tuple[float, float] | None) -> float:
    """How far a golden section's best reading on the flat top strays (Hz): the stop spread
    with the search's readings' scatter and Q (`resonance_searches`), `top` their half-width
    and relative scatter (`_top_of`); NaN where the search holds too few readings to tell."""
    return math.nan if top is None else top[0] * SEARCH_STOP_SPREAD * math.sqrt(top[1])


def _top_of(frequency_hz: float, searches: pd.DataFrame) -> tuple[float, float] | None:
    """The half-width h = f / (2 Q) of the top the search swept (Q its sweep's) and its
    readings' relative scatter s; None where the search holds too few readings to tell."""
    sweep = _sweep(searches)
    scatter = reading_scatter_rel(sweep) if len(sweep) else None
    q = mechanical_q_from_sweep(frequency_hz, sweep) if len(sweep) else None
    if scatter is None or not q:
        return None
    return frequency_hz / (2.0 * q), scatter


def recentring_blind_hz(half_width_hz: float, scatter_rel: float, step_hz: float) -> float:
    """How far from the peak a re-centring's walk (`protocols.resonance.track_resonance`:
    readings a step either side of its centre, moving toward the larger until the centre is
    the largest) may stop for its readings' relative scatter s (Hz): its 95 % bound.

    Near the top v = v0 / sqrt(1 + x^2) ~ v0 (1 - x^2 / 2), x = (f - f0) / h, h = f / (2 Q):
    with the centre at x and the step e = step / h, the reading a step toward the peak exceeds
    the centre's by v0 (|x| e - e^2 / 2). The walk stops where the difference of two readings,
    of scatter sqrt(2) s v0, hides that: |x| e < P95_FACTOR sqrt(2) s (+ e / 2, the step's own
    quantization, which the golden section and the vertex within a step of the stop resolve),
    i.e. within P95_FACTOR sqrt(2) s h^2 / step of the peak: on a broad top (the nine-column
    plate's, Q ~ 56, h ~ 340 Hz) tens of hertz for 5 Hz steps, on a narrow one (Q ~ 300) under
    a hertz. Where in that zone it stops is `recentring_stop_offsets_hz`."""
    return P95_FACTOR * math.sqrt(2.0) * scatter_rel * half_width_hz**2 / step_hz


#: The reading noise's span on each position's grid (standard deviations either side) and the
#: grid's points (`recentring_stop_offsets_hz`): the mass past 8 sd is ~1e-15.
STOP_GRID_SD = 8.0
STOP_GRID_POINTS = 321
#: The probability still walking below which a chain ends: past it every later stop's share is
#: smaller (a narrow top's walks all stop within a few steps; the cut saves most of 19 moves).
STOP_MASS_NEGLIGIBLE = 1e-15


def recentring_stop_offsets_hz(half_width_hz: float, scatter_rel: float, step_hz: float,
                               start_offset_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """Where a re-centring's walk (`protocols.resonance.track_resonance`) stops, as offsets
    from the peak (Hz) and their probabilities, for a walk started `start_offset_hz` from the
    peak (positive: above it) on a Lorentzian top of half-width h read with relative scatter s.

    The walk reads y(x) = L(x) (1 + s z) (L = 1 / sqrt(1 + (x / h)^2), z standard normal, each
    frequency read once: `_VelocityProbe` keeps its readings) at its centre x and a step e
    either side. Its rule, stop where the centre is not below either neighbour, else move to
    the larger neighbour, makes it a chain with one continuous state:
    - from the start x0 it stops there where the centre's reading is the largest of the three,
      P = int f_0(y) F_-(y) F_+(y) dy (f, F: a position's reading's density and distribution),
      and moves to the neighbour whose reading is the largest, taking that reading y along
      with density g_1(y) = f_+-(y) F_0(y) F_-+(y);
    - once moved it never turns (the centre it left is below the one it stands on): at x_k
      holding y it reads the next position ahead once, stops with probability
      int g_k(y) F_k+1(y) dy, and moves on holding the new reading, g_k+1(y') = f_k+1(y')
      int_{y < y'} g_k(y) dy (the readings it kept are the largest so far, so a walk into the
      top stops short of the peak on the side it came from).
    Each g is held on its position's own grid (STOP_GRID_SD sd either side of L, STOP_GRID_POINTS
    points, trapezoids); a walk is cut at RECENTRING_MAX_STEPS - 1 moves, as the protocol's is
    (its lost mass is left out: the probabilities sum to under 1 by it), and where what still
    walks is under STOP_MASS_NEGLIGIBLE. On a Q 56 top (h 340
    Hz, s 3e-4, 5 Hz steps; `recentring_blind_hz` 19 Hz) a walk from the peak stops 4.0 Hz
    from it (RMS), from 10 Hz 6.0 Hz (mean +3.7: on the start's side), from 30 Hz or farther
    8.8 Hz (mean +5.8), where the bound as a rectangle said 11.1 Hz from anywhere."""
    moves = range(1, RECENTRING_MAX_STEPS)

    def level(x_hz: float) -> tuple[float, float]:
        mean = 1.0 / math.hypot(1.0, x_hz / half_width_hz)
        return mean, scatter_rel * mean

    def grid(x_hz: float) -> tuple[np.ndarray, np.ndarray]:
        mean, sd = level(x_hz)
        z = np.linspace(-STOP_GRID_SD, STOP_GRID_SD, STOP_GRID_POINTS)
        return mean + sd * z, np.exp(-0.5 * z**2) / (math.sqrt(2.0 * math.pi) * sd)

    def below(y: np.ndarray, x_hz: float) -> np.ndarray:   # P(the reading at x_hz < y)
        mean, sd = level(x_hz)
        return ndtr((y - mean) / sd)

    y, density = grid(start_offset_hz)
    offsets = [start_offset_hz]
    probabilities = [trapezoid(density * below(y, start_offset_hz - step_hz) * below(y, start_offset_hz + step_hz), y)]
    for direction in (1.0, -1.0):
        x_hz = start_offset_hz + direction * step_hz
        y, density = grid(x_hz)
        held = density * below(y, start_offset_hz) * below(y, start_offset_hz - direction * step_hz)
        for _ in moves:
            ahead_hz = x_hz + direction * step_hz
            offsets.append(x_hz)
            probabilities.append(trapezoid(held * below(y, ahead_hz), y))
            kept = cumulative_trapezoid(held, y, initial=0.0)
            if kept[-1] < STOP_MASS_NEGLIGIBLE:   # what walks on could move no sum it enters
                break
            y_ahead, density = grid(ahead_hz)
            held = density * np.interp(y_ahead, y, kept, left=0.0, right=kept[-1])
            x_hz, y = ahead_hz, y_ahead
    return np.array(offsets), np.array(probabilities)


#: The lattice phases a walk's start is averaged over (`recentring_stop_moments_hz`).
START_PHASES = 8


@functools.lru_cache(maxsize=4096)
def recentring_stop_moments_hz(half_width_hz: float, scatter_rel: float, step_hz: float,
                               start_offset_hz: float) -> tuple[float, float]:
    """The mean and the mean square (Hz, Hz^2) of how far from the peak a re-centring's
    reading sits for where its walk stopped, beyond what the golden section after it
    (`track_resonance`, on the stop c +- a step) and the reading's own u (its vertex's fit, or
    `best_reading_scatter_hz`) already hold, for a walk started `start_offset_hz` from the peak
    (positive: above it; the peak moved the other way since the start was read).

    A stop within a step of the peak has it inside the golden section's bracket, which finds
    it to its own scatter, the reading's u: it enters as 0. A stop farther has the peak
    outside the bracket, and the rule that stopped the walk, a step's rise hidden in the
    readings' scatter, hides the bracket's slope from the golden section too: the reading
    stays about at the stop, off the peak by c. So the moments are sums over the stops
    beyond a step (`recentring_stop_offsets_hz`), sum p_c c and sum p_c c^2 (the lost mass
    of walks cut short left out of both). The start's place on the walk's lattice against
    the peak is not known to a step: both are averaged over START_PHASES starts spread evenly
    over a step about the start (a rectangle), a mixture whose variance is the mean square
    less the mean's square. A walk stops on the side it came from (the readings it kept are
    the largest so far): the mean has the start's sign, 0 from the peak. On the nine-column
    plate's broad top (h 340 Hz, s 3e-4, 5 Hz steps) from starts 0, 5, 10, 20 and 30 Hz above
    it: mean 0.0, +1.4, +3.1, +5.0 and +5.3 Hz, where 300 seeded walks of the real
    `track_resonance` read their peaks off by -0.4, +2.1, +3.5, +4.2 and +4.9 Hz (as dated
    drifts, uncorrected, they under-read a falling resonance's fall:
    `benchmarks/drift_calibration.py`); on a narrow top (h ~ 60 Hz) every stop is within a
    step and both are 0."""
    sign = math.copysign(1.0, start_offset_hz)
    phases = (np.arange(START_PHASES) + 0.5) / START_PHASES - 0.5
    means, mean_squares = [], []
    for phase in phases:
        offsets, probabilities = recentring_stop_offsets_hz(half_width_hz, scatter_rel, step_hz,
                                                            abs(start_offset_hz) + phase * step_hz)
        beyond = np.abs(offsets) > step_hz
        means.append(np.sum(probabilities[beyond] * offsets[beyond]) / np.sum(probabilities))
        mean_squares.append(np.sum(probabilities[beyond] * offsets[beyond] ** 2) / np.sum(probabilities))
    return sign * float(np.mean(means)), float(np.mean(mean_squares))


def recentring_stop_u_hz(half_width_hz: float, scatter_rel: float, step_hz: float, moved_hz: float) -> float:
    """The standard uncertainty (Hz) a re-centring's reading takes from where its walk stopped
    about the peak (the RMS of `recentring_stop_moments_hz`: no correction for its mean), for
    a walk that starts where the resonance was `moved_hz` ago: where the start's side against
    the peak is not known (`_walk_stops_hz` without the warming's drift). A start within the
    blind zone (`recentring_blind_hz`) mostly stops within a step of where it started, so the
    term is bounded by the move since the start; a start beyond it walks in and stops on the
    zone's near side. On a narrow top (the one- and four-column plates', h ~ 60 Hz) every
    stop is within a step of the peak and the term is 0, where the rectangle at the zone's
    bound gave up to 1.3 Hz; on the nine-column plate's broad top the readings of 300 seeded
    walks scatter by 2.9, 5.1 and 7.8 Hz from starts 0, 10 and 30 Hz off, their u with this
    term is 4.7, 6.5 and 9.3 Hz (the term 3.3, 5.6 and 8.6 Hz), with the rectangle
    11.5-11.6 Hz."""
    return math.sqrt(recentring_stop_moments_hz(half_width_hz, scatter_rel, step_hz, abs(moved_hz))[1])


def _sweep(searches: pd.DataFrame) -> pd.DataFrame:
    if "sweep" not in searches or "velocity_pp_mps" not in searches:
        return searches.iloc[0:0]
    return searches[searches["sweep"].astype(bool)]


#: The mean over spread of a folded normal past which its fold is negligible (Phi(-16) ~ 1e-58).
FOLD_NEGLIGIBLE = 8.0


def folded_quantile(offset_hz, u_hz, probability: float = COVERAGE_PROBABILITY) -> np.ndarray:
    """The `probability` quantile of |d| for d normal with mean `offset_hz` and standard
    deviation `u_hz` (the folded normal): P95_FACTOR u at offset 0, |offset| + 1.645 u far
    from it, |offset| where u is 0."""
    offset_hz, u_hz = np.broadcast_arrays(np.abs(np.asarray(offset_hz, dtype=float)), np.asarray(u_hz, dtype=float))
    spread = u_hz > 0
    scale = np.where(spread, u_hz, 1.0)
    with np.errstate(over="ignore"):
        c = offset_hz / scale
    # Past FOLD_NEGLIGIBLE the fold below zero holds under Phi(-2 c) of the mass: the one-sided
    # quantile is exact to it, and scipy's root search fails on an overflowing c.
    far = c > FOLD_NEGLIGIBLE
    from scipy import stats   # here, not at the top: every simulator process imports this module, few call this
    folded = stats.foldnorm.ppf(probability, np.where(far, 0.0, c), scale=scale)
    one_sided = offset_hz + ndtri(probability) * u_hz
    return np.where(spread, np.where(far, one_sided, folded), offset_hz)


#: A run's dated readings of its resonance (`_readings`): walk_u_hz, a re-centring's u from
#: where its walk stopped (NaN: none, or no step stored), is in u_hz already (and frequency_hz
#: corrected for the stop's mean).
READING_COLUMNS = ["time_s", "frequency_hz", "u_hz", "power_w", "walk_u_hz"]


def _readings(points: pd.DataFrame, searches: pd.DataFrame, closings: pd.DataFrame,
              step_hz: float | None = None, drift_at=None) -> tuple[pd.DataFrame, bool, tuple[float, float] | None]:
    """The run's dated readings of its resonance (time_s, frequency_hz, u_hz), in time order,
    whether its re-centrings were recorded as such, and the top its search swept (`_top_of`:
    its half-width and readings' scatter, which give the u of a best reading on it,
    `best_reading_scatter_hz`, and a walk's blind zone). A re-centring walked by `step_hz`
    reads the peak where its walk stopped, for whose mean the reading is corrected and whose
    u it takes in quadrature (`_walk_stops_hz`): a broad top's re-centrings stop near where
    they started, on the side they came from, and as
    dated readings of a drift they would state it near 0 (on twelve seeded benches the
    nine-column plate's closing re-centrings read 7 Hz of the plate's 21 Hz fall, 2-3 times
    their fits' u off; the one- and four-column plates' within theirs). `drift_at`: the
    drift since rest (Hz) the warming predicts at given times, which places each walk's
    start against the peak; None where nothing does."""
    top = _top_of(float(points["generator_frequency_hz"].iloc[0]), searches)
    best_u = best_reading_scatter_hz(top)
    rows = []
    if "sweep" in searches:
        sweep = _sweep(searches)
        fit = peak_of_readings(sweep["generator_frequency_hz"], sweep["velocity_pp_mps"]) if len(sweep) else None
        for found in searches[~searches["sweep"].astype(bool)].itertuples():
            fitted = fit is not None and not np.isin(found.resonance_frequency_hz, sweep["generator_frequency_hz"])
            rows.append((found.bench_time_s, found.resonance_frequency_hz, fit.std_uncertainty_hz if fitted else best_u,
                         getattr(found, "power_w", math.nan)))
    at_resonance = points[points["detuning_phase"].isin(AT_SETTING)] if "detuning_phase" in points else points.iloc[0:0]
    if len(closings):
        at_resonance = pd.concat([at_resonance, closings], ignore_index=True)
    at_setting, tracked = _setting_readings(at_resonance, best_u)
    if step_hz and top is not None and len(at_setting):
        closing = (at_resonance["detuning_phase"] == "closing").to_numpy() if "detuning_phase" in at_resonance else \
            np.zeros(len(at_resonance), bool)
        search_s = min((row[0] for row in rows), default=math.nan)
        offset_hz, at_setting["walk_u_hz"] = _walk_stops_hz(at_setting["time_s"].to_numpy(float), closing, search_s,
                                                            top, step_hz, drift_at)
        at_setting["frequency_hz"] -= offset_hz   # where the walk stops on average: corrected for
        at_setting["u_hz"] = np.hypot(at_setting["u_hz"], at_setting["walk_u_hz"])
    rows = [(*row, math.nan) for row in rows] + list(at_setting.reindex(columns=READING_COLUMNS).itertuples(
        index=False, name=None))
    readings = pd.DataFrame(rows, columns=READING_COLUMNS, dtype=float)
    readings = readings[np.isfinite(readings["time_s"]) & np.isfinite(readings["frequency_hz"])]
    readings["u_hz"] = readings["u_hz"].fillna(0.0)   # a scatter the search cannot tell: the estimate alone
    return readings.sort_values("time_s", kind="stable").reset_index(drop=True), tracked, top


#: How far out, in blind zones (`recentring_blind_hz`) and steps, a walk whose start is not
#: placed against the peak is taken to start: from there or farther it walks into the zone and
#: stops as from anywhere beyond (on a Q 56 top, 8.8 Hz RMS from 30 Hz and from 60 Hz).
FAR_START_ZONES, FAR_START_STEPS = 2.0, 2.0


def _walk_stops_hz(times_s: np.ndarray, closing: np.ndarray, search_s: float, top: tuple[float, float],
                   step_hz: float, drift_at) -> tuple[np.ndarray, np.ndarray]:
    """Each re-centring's expected offset from the peak for where its walk stopped (Hz,
    positive: the reading above its peak) and that offset's standard uncertainty
    (`recentring_stop_moments_hz`), its start placed against the peak by how far `drift_at`
    (the warming's drift since rest, Hz, at given times) says the resonance moved since the
    start was read. A level's re-centring (`protocols.detuning`) starts from the search's
    resonance (read at `search_s`): above a falling peak by the fall since. The closing one
    starts from the last level's reading, off that level's peak by its walk's own offset, and
    the peak has moved on since: its moments are averaged over that start +- the last walk's
    u (two-point Gauss-Hermite: the start's spread as a normal, exact to its variance). The
    reading is corrected for the offset (GUM 3.2.4: a walk stops on the side it came from,
    so uncorrected readings of a falling resonance under-read its fall: on 40 seeded
    benches the nine-column plate's readings scaled its drift to 0.84 of the plate's, median)
    and keeps its u. Where `drift_at` is None or the search is not dated, the start's side
    is not known: no offset, and the RMS about the peak of a start from beyond the zone
    (FAR_START_ZONES, FAR_START_STEPS; `recentring_stop_u_hz`), the largest a walk gives."""
    half_width_hz, scatter_rel = top
    if drift_at is None or not math.isfinite(search_s):
        far_hz = FAR_START_ZONES * recentring_blind_hz(half_width_hz, scatter_rel, step_hz) + FAR_START_STEPS * step_hz
        return (np.zeros(len(times_s)),
                np.full(len(times_s), recentring_stop_u_hz(half_width_hz, scatter_rel, step_hz, far_hz)))
    moments = functools.partial(recentring_stop_moments_hz, half_width_hz, scatter_rel, step_hz)
    drift_hz = drift_at(times_s)
    mean_hz, mean_square_hz2 = np.array([moments(float(start)) for start in drift_at(np.array([search_s]))[0]
                                         - drift_hz]).T
    level_u_hz = np.sqrt(np.maximum(mean_square_hz2 - mean_hz**2, 0.0))
    for index in np.flatnonzero(closing):
        before = np.flatnonzero(~closing & (times_s < times_s[index]))
        if len(before):
            last = before[np.argmax(times_s[before])]
            start_hz = mean_hz[last] - (drift_hz[index] - drift_hz[last])
            mean_hz[index], mean_square_hz2[index] = np.mean(
                [moments(float(start_hz + side * level_u_hz[last])) for side in (-1.0, 1.0)], axis=0)
    return mean_hz, np.sqrt(np.maximum(mean_square_hz2 - mean_hz**2, 0.0))


def _setting_readings(at_resonance: pd.DataFrame, best_u: float) -> tuple[pd.DataFrame, bool]:
    """The readings of the resonance that rows read at their setting (P0, closing) hold, by
    their index: (time_s, frequency_hz, u_hz, power_w), and whether the re-centrings were
    recorded as such. A recorded one gives the vertex its readings' top puts the peak at, with
    that fit's u, or the best reading P0 is set at where that strays less (`best_u`: a broad
    top); an older run, its settings at `best_u`, dated by the row."""
    tracked = all(column in at_resonance for column in _COLUMNS) and bool(
        at_resonance["tracked_resonance_frequency_hz"].notna().all())
    power_w = at_resonance.get("power_w", pd.Series(math.nan, index=at_resonance.index)).to_numpy(float)
    setting_hz = at_resonance["generator_frequency_hz"].to_numpy(float)
    if tracked:
        fit_u = at_resonance[_COLUMNS[2]].fillna(math.inf).to_numpy(float)
        vertex = fit_u <= (best_u if np.isfinite(best_u) else math.inf)
        columns = (at_resonance[_COLUMNS[0]].to_numpy(float),
                   np.where(vertex, at_resonance[_COLUMNS[1]].to_numpy(float), setting_hz),
                   np.where(vertex, fit_u, best_u))
    else:
        columns = (at_resonance["bench_time_s"].to_numpy(float), setting_hz, np.full(len(at_resonance), best_u))
    return pd.DataFrame(dict(zip(("time_s", "frequency_hz", "u_hz", "power_w"), (*columns, power_w))),
                        index=at_resonance.index, dtype=float), tracked


def _rate_after(readings: pd.DataFrame) -> tuple[float, float]:
    """The resonance's rate after the last reading (Hz/s) and its u: a plate warms at up to
    its power over its heat capacity, fastest when cold, so each interval's rate is taken per
    watt of its readings' mean power, and the steepest the readings resolve (|rate| - 1.96 u
    largest) times the last reading's power goes on; where they resolve none, the
    best-measured one (a plate that does not warm: its u alone). Without the readings' powers,
    the rates as they are."""
    times, frequencies, u_hz, power_w = (readings[c].to_numpy() for c in ("time_s", "frequency_hz", "u_hz", "power_w"))
    spans_s = np.maximum(np.diff(times), 1e-9)
    rates, rates_u = np.diff(frequencies) / spans_s, np.hypot(u_hz[1:], u_hz[:-1]) / spans_s
    scale = power_w[-1] / (0.5 * (power_w[1:] + power_w[:-1]))   # the last reading's power over each interval's
    if np.all(np.isfinite(scale) & (scale > 0)):
        rates, rates_u = rates * scale, rates_u * scale
    resolved = np.abs(rates) - P95_FACTOR * rates_u
    chosen = int(np.argmax(resolved)) if np.max(resolved) > 0 else int(np.argmin(rates_u))
    return float(rates[chosen]), float(rates_u[chosen])


def _drift_bounds(points: pd.DataFrame, searches: pd.DataFrame, closings: pd.DataFrame,
                  step_hz: float | None = None) -> DriftColumns:
    """Each point's bound on |drift| (Hz), for one run, from its readings alone: no estimate
    (0, its u 0), the bound `resonance_drift_bound_hz`, and the source of the bounds."""
    readings, tracked, _ = _readings(points, searches, closings, step_hz)
    at_s = points["bench_time_s"].to_numpy(float)
    nothing = np.zeros(len(points))
    if readings.empty or not np.all(np.isfinite(at_s)):
        return nothing, nothing, nothing, NOT_DATED
    times, frequencies, u_hz = (readings[c].to_numpy() for c in ("time_s", "frequency_hz", "u_hz"))
    if len(times) < 2:
        return (nothing, nothing, FALLBACK_DRIFT_RATE_REL_PER_S * frequencies[0] * np.maximum(at_s - times[0], 0.0),
                FALLBACK_SOURCE)
    # each reading's drift since the reference and its u (the reference's own is exact)
    drift_hz = frequencies - frequencies[0]
    drift_u_hz = np.hypot(u_hz[0], u_hz) * (np.arange(len(times)) > 0)
    after = np.clip(np.searchsorted(times, at_s, side="right"), 1, len(times) - 1)   # the reading closing each span
    bound_hz = np.maximum(folded_quantile(drift_hz[after - 1], drift_u_hz[after - 1]),
                          folded_quantile(drift_hz[after], drift_u_hz[after]))
    # P0 (and the closing row) is read at its setting: the mounted plate's resonance is off it by the setting's offset
    at_setting = points["detuning_phase"].isin(AT_SETTING).to_numpy() if "detuning_phase" in points else False
    beyond_s = np.maximum(at_s - times[-1], 0.0)
    extrapolated = (beyond_s > 0) & ~at_setting
    if extrapolated.any():
        rate, rate_u = _rate_after(readings)
        bound_hz = np.where(extrapolated, abs(drift_hz[-1]) + abs(rate) * beyond_s
                            + P95_FACTOR * np.hypot(u_hz[0], np.hypot(u_hz[-1], rate_u * beyond_s)), bound_hz)
    bound_hz = np.where(at_setting, folded_quantile(points["generator_frequency_hz"].to_numpy(float) - frequencies[0],
                                                    u_hz[0]), bound_hz)
    source = (f"Type A, the run's {len(times)} dated readings of its resonance (search, re-centrings), from the "
              f"first (u {u_hz[0]:.2f} Hz): the larger of the bracketing readings' 95 % bounds on |drift| "
              f"(1.96 u where they resolve none), readings' u {np.max(u_hz[1:]):.2f} Hz at most"
              + (EXTRAPOLATED.format(rate=abs(rate), rate_u=rate_u) if extrapolated.any() else "")
              + ("" if tracked else UNTRACKED))
    return nothing, nothing, bound_hz, source


#: The plate materials whose density the warming bound knows (`_plate_dimensions`).
DENSITY_KG_M3 = {"aluminium": ALUMINIUM_TABLE2.density_kg_m3}
#: Time constants tried across the tolerances' range (`_warming_estimates`), log-spaced.
TIME_CONSTANT_STEPS = 13
#: chi^2 with one degree of freedom at 95 %: the time constants the readings do not reject
#: (profile likelihood, its minimum plus this).
CHI2_95_ONE = 3.841
WARMING_SOURCE = ("Type A/B, the plate's warming under the run's {n} dated stored powers (lumped thermal model, "
                  "plates.warming, tau {tau_low:.0f}-{tau_high:.0f} s within the heating tolerances) scaled by "
                  "the run's {readings} dated readings of its resonance (the scale they fit, weighed with the "
                  "tolerances' {low:.3g}-{high:.3g} Hz/J{blind}), estimated and corrected for: its u the scale's, the "
                  "spread over the time constants the readings allow and the room's (up to {room:g} K/h), "
                  "the last two rectangles")
#: What WARMING_SOURCE says of the re-centrings' readings (`_walk_stops_hz`), where the run's
#: search settings give their step and its search the top's width and scatter.
BLIND_ZONE = ("; each re-centring's reading with where its {step:g} Hz walk stops, blind within {blind:.3g} Hz of the peak "
              "(95 %): corrected for the stop's mean, u {low:.2g}-{high:.2g} Hz, its start placed by the warming the "
              "tolerances predict")
BLIND_ZONE_UNKNOWN = "; no re-centring's blind zone taken (no re-centring, its step or the search's readings stored)"


def _plate_dimensions(scene: dict) -> tuple[float, float, float, float] | None:
    """Length, width, thickness (mm) and density (kg/m^3) of the plate of the scene copy the
    run's points ran on; None where the copy is missing or its material's density unknown."""
    density = DENSITY_KG_M3.get(scene.get("plate", {}).get("material"))
    size_m = plate_warming.plate_size_m(scene)
    if density is None or size_m is None:
        return None
    return (*(1e3 * size for size in size_m), density)


def _power_history(*frames: pd.DataFrame, shunt_ohm: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """The run's dated powers on the plate in time order (its stored power, else the scope's,
    less the loss of the `shunt_ohm` shunt it was read through: `dielectric.plate_power_w`),
    each held over the interval that closes at it: the drive between two stored readings is
    mostly the later one's (its re-centring's and its voltage's unstored readings are at its
    level, `protocols.detuning`; `plate_warming`). Against the simulated plate's own
    temperature on six seeded benches the heat this holds at Fig. 2's Pt is 4-8 % over the
    plate's (a step's start and end at the generator's minimum), the larger of the
    interval's ends 14-24 % over, their mean 12-22 % under."""
    rows = []
    for frame in frames:
        if "bench_time_s" not in frame:
            continue
        power = frame["power_w"] if "power_w" in frame else pd.Series(math.nan, index=frame.index)
        if "scope_power_w" in frame:
            power = power.fillna(frame["scope_power_w"])
        current_pp_a = frame["scope_current_pp_a"].to_numpy(float) if "scope_current_pp_a" in frame else math.nan
        rows.append(pd.DataFrame({"time_s": frame["bench_time_s"].to_numpy(float),
                                  "power_w": dielectric.plate_power_w(power.to_numpy(float), current_pp_a, shunt_ohm)}))
    history = pd.concat(rows, ignore_index=True) if rows else pd.DataFrame(columns=["time_s", "power_w"], dtype=float)
    history = history[np.isfinite(history["time_s"]) & np.isfinite(history["power_w"])].sort_values("time_s")
    times_s, power_w = history["time_s"].to_numpy(float), history["power_w"].to_numpy(float)
    return times_s, power_w


def _warming_scale(held_j: np.ndarray, readings: pd.DataFrame, times_s: np.ndarray,
                   low: float, high: float) -> tuple[float, float, float]:
    """k (Hz/J) in drift = -k (E - E_0), E the heat held (`held_heat_j` at `times_s`), its
    standard uncertainty and the readings' chi^2 about their own fit (0 where they fit
    nothing). The readings' drifts since the first, d_j = -k (E_j - E_0) + e_j with
    u_j = sqrt(u(f_j)^2 + u(f_0)^2), fit k by weighted least squares, k_r = sum(w m (-d)) /
    sum(w m^2), u(k_r)^2 = 1 / sum(w m^2) (w = 1 / u_j^2, m = E_j - E_0); the tolerances
    state k within [`low`, `high`], a rectangle of mean k_t = (low + high) / 2 and u_t =
    (high - low) / sqrt(12) (GUM 4.3.7). The two are weighed by their inverse variances (the
    normal approximation of the rectangle: the readings' k where they resolve it, even
    beyond the tolerances, the tolerances' middle where they resolve nothing), and where
    they disagree beyond their u the combined u grows by the Birge ratio (the consistency
    check of a weighted mean): the readings' own, sqrt(chi^2 / (n - 1)), and the two
    sources', |k_r - k_t| / sqrt(u(k_r)^2 + u_t^2), where above 1. A broad top's re-centring
    on the nine-column plate read its vertex 6 Hz off with u 1.3 Hz on a seeded bench, and
    its run's k_r came out at a quarter of the plate's, 3.4 u from the tolerances' middle."""
    prior_k, prior_u = 0.5 * (low + high), (high - low) / math.sqrt(12.0)
    at_j = np.interp(readings["time_s"].to_numpy(float), times_s, held_j)
    model = at_j[1:] - at_j[0]
    drift_hz = readings["frequency_hz"].to_numpy(float)[1:] - readings["frequency_hz"].iat[0]
    u_hz = np.hypot(readings["u_hz"].to_numpy(float)[1:], readings["u_hz"].iat[0])
    usable = (u_hz > 0) & (model > 0)
    if not usable.any():
        return prior_k, prior_u, 0.0
    weight = 1.0 / u_hz[usable] ** 2
    information = float(np.sum(weight * model[usable] ** 2))
    scale = float(np.sum(weight * model[usable] * -drift_hz[usable])) / information
    chi2 = float(np.sum(weight * (drift_hz[usable] + scale * model[usable]) ** 2))
    if usable.sum() > 1:
        information /= max(1.0, chi2 / (usable.sum() - 1))
    combined = information + prior_u**-2
    disagreement = abs(scale - prior_k) / math.sqrt(1.0 / information + prior_u**2)
    return ((scale * information + prior_k * prior_u**-2) / combined, max(1.0, disagreement) / math.sqrt(combined),
            chi2)


def _prior_drift(times_s: np.ndarray, power_w: np.ndarray, points: pd.DataFrame,
                 dimensions: tuple[float, float, float, float]):
    """The drift since rest (Hz) as a function of bench time that the heating tolerances
    alone predict for the run's powers: the middle of their Hz per joule times the heat held
    at the geometric middle of their time constants (`plates.warming`). It places each
    re-centring's start against the peak (`_walk_stops_hz`) before the readings, which that
    weighs, fit the scale."""
    low, high = warming.drift_per_joule_range_hz(float(points["generator_frequency_hz"].iloc[0]), *dimensions)
    held_j = warming.held_heat_j(times_s, power_w, math.sqrt(math.prod(warming.time_constant_range_s(*dimensions))))
    return lambda when_s: -0.5 * (low + high) * np.interp(when_s, times_s, held_j)


def drifts_over_time_constants(times_s: np.ndarray, power_w: np.ndarray, readings: pd.DataFrame, when_s: np.ndarray,
                               scale_range: tuple[float, float], time_constant_range_s: tuple[float, float]
                               ) -> list[tuple[float, np.ndarray, np.ndarray]]:
    """At each of TIME_CONSTANT_STEPS time constants log-spaced over `time_constant_range_s`,
    the readings' chi^2 about the scale they fit (`_warming_scale`, within `scale_range` Hz/J),
    the drift since rest at `when_s`, -k E, and its u from the scale's, u(k) E (Hz), E the heat
    held under the run's powers `power_w` at `times_s` (`warming.held_heat_j`): what
    `_warming_estimates` chooses among (and `benchmarks/drift_calibration.py` takes apart)."""
    fits = []
    for tau_s in np.geomspace(*time_constant_range_s, TIME_CONSTANT_STEPS):
        held_j = warming.held_heat_j(times_s, power_w, tau_s)
        scale, scale_u, chi2 = _warming_scale(held_j, readings, times_s, *scale_range)
        since_rest_j = np.interp(when_s, times_s, held_j)
        fits.append((chi2, -scale * since_rest_j, scale_u * since_rest_j))
    return fits


def _warming_estimates(points: pd.DataFrame, searches: pd.DataFrame, closings: pd.DataFrame,
                       dimensions: tuple[float, float, float, float], shunt_ohm: float = 0.0,
                       step_hz: float | None = None) -> DriftColumns:
    """Each point's drift estimate and its u (Hz) from the plate's warming, for one run.

    The plate warms as one body (`plates.warming`): its resonance has fallen by k E(t), E the
    heat it holds from the powers it took (`_power_history`, cold at the run's first stored
    reading: the stored powers less the `shunt_ohm` shunt's loss, whose 1 % tolerance moves
    the heat by under 0.1 %, far inside the scale's u, and is left out), k = f |alpha| / C.
    Its time constant tau and k lie within the heating tolerances' ranges
    (`warming.time_constant_range_s`, `warming.drift_per_joule_range_hz`);
    the run's dated readings of its resonance (`_readings`) fit k at each tau
    (`_warming_scale`), and the taus they do not reject (chi^2 within CHI2_95_ONE of its
    least) give the drift since the plate was at rest, -k E(t), each its own: the estimate is
    the middle of their range, which enters its u as a rectangle, with the largest of their
    scales' u times E (the warming's sign is known: the estimate is one, not a bound). Since
    rest, not since the first reading (-k (E(t) - E(t_0)), as it was): a stored value states
    the plate as mounted, and the first reading, the search, read a plate its own readings had
    warmed (the nine-column plate's 25 mK, 0.19 Hz; on twelve seeded benches the one-column
    plate's Pt estimates went from 65-93 % of the simulated plate's drift to 94-95 %). The
    room's drift since the run's first stored reading (`warming.room_drift_bound_hz`, sign
    unknown) is a rectangle about 0. A plate whose readings resolve its drift is estimated
    near it; one whose readings resolve nothing, at the tolerances' middle, with their spread.

    A P0 or closing row is read at its setting s on the re-centred resonance, which the
    mounted plate's is off by s - f_0 + d_0 (f_0 the first reading, d_0 the drift's estimate
    at it): its estimate is that offset, its u that of f_0, of d_0 and of the row's own
    reading of the resonance it was set on (the
    setting's offset from that reading in quadrature: P0 is set at the best reading, the
    reading may be its readings' vertex), `uncertainty.power_ratio_budget` takes (offset /
    h)^2."""
    times_s, power_w = _power_history(points, searches, closings, shunt_ohm=shunt_ohm)
    at_s = points["bench_time_s"].to_numpy(float)
    readings, _, top = _readings(points, searches, closings, step_hz,
                                 _prior_drift(times_s, power_w, points, dimensions) if len(times_s) > 1 else None)
    best_u = best_reading_scatter_hz(top)
    walk_u_hz = readings["walk_u_hz"].dropna()
    if len(times_s) < 2 or readings.empty or not np.all(np.isfinite(at_s)):
        return _drift_bounds(points, searches, closings, step_hz)
    frequency_hz, reference_s = float(readings["frequency_hz"].iat[0]), float(readings["time_s"].iat[0])
    low, high = warming.drift_per_joule_range_hz(frequency_hz, *dimensions)
    shortest, longest = warming.time_constant_range_s(*dimensions)
    # the drift since the plate was at rest (before the run's first stored reading: the plate
    # as mounted, which a stored value states), at the points and at the first reading of the
    # resonance, itself read on a plate its own readings had warmed
    when_s = np.append(at_s, reference_s)
    fits = drifts_over_time_constants(times_s, power_w, readings, when_s, (low, high), (shortest, longest))
    least = min(chi2 for chi2, _, _ in fits)
    allowed = [(drift, drift_u) for chi2, drift, drift_u in fits if chi2 <= least + CHI2_95_ONE]
    drifts = np.array([drift for drift, _ in allowed])
    lowest, highest = drifts.min(axis=0), drifts.max(axis=0)
    setting_hz = points["generator_frequency_hz"].to_numpy(float)
    room_hz = warming.room_drift_bound_hz(np.append(setting_hz, frequency_hz), when_s - times_s[0])
    estimate_hz = 0.5 * (lowest + highest)
    u_hz = np.sqrt(np.max([drift_u for _, drift_u in allowed], axis=0) ** 2
                   + ((highest - lowest) ** 2 / 4.0 + room_hz**2) / 3.0)
    (estimate_hz, reference_hz), (u_hz, reference_u_hz) = (estimate_hz[:-1], estimate_hz[-1]), (u_hz[:-1], u_hz[-1])
    at_setting = points["detuning_phase"].isin(AT_SETTING).to_numpy() if "detuning_phase" in points else \
        np.zeros(len(points), bool)
    if at_setting.any():   # the setting's offset from the plate at rest's resonance, f_0 - reference_hz
        own, _ = _setting_readings(points[at_setting], best_u)
        estimate_hz[at_setting] = setting_hz[at_setting] - frequency_hz + reference_hz
        u_hz[at_setting] = np.sqrt(readings["u_hz"].iat[0] ** 2 + reference_u_hz**2 + own["u_hz"].fillna(0.0).to_numpy() ** 2
                                   + (setting_hz[at_setting] - own["frequency_hz"].to_numpy()) ** 2)
    blind = BLIND_ZONE_UNKNOWN if walk_u_hz.empty else BLIND_ZONE.format(
        step=step_hz, blind=recentring_blind_hz(*top, step_hz), low=walk_u_hz.min(), high=walk_u_hz.max())
    return estimate_hz, u_hz, np.zeros(len(points)), WARMING_SOURCE.format(
        n=len(times_s), tau_low=shortest, tau_high=longest, readings=len(readings), blind=blind, low=low, high=high,
        room=3600.0 * warming.ROOM_DRIFT_K_PER_S)
