"""Planning a map: the cheapest grid step and averaging that meet a homogeneity target.

The figure planned is the touch area's coefficient of variation of the velocity amplitude
(`analysis.cartography.homogeneity`), the number a designer reads first. Its relative
error has two parts, each computed:

- sampling: a grid sees the mode only at its points. The plate model's working mode
  (`plates.predicted_plates.working_shape`, geometry and datasheets, as the report
  compares a map with) is evaluated on each candidate grid of the run's area and on a
  0.5 mm grid of the same area, the continuum's stand-in; the difference of their
  coefficients of variation is the sampling error, the largest over four placements of
  the grid along the length (shifted by quarters of its step): where the nodal lines
  fall between grid points is not the lab's to choose, and a coarse grid that meets the
  target at one placement by luck misses it at another. A plate the model does not know
  is refused with that said: its map's sampling error cannot be planned.
- noise: one point's velocity, acquired on the simulated bench at the run's resonance and
  voltage, gives the record fit's relative standard uncertainty at each averaging (seeded
  acquisitions). The scope re-ranges at every point, so the relative noise is taken the
  same at every point; it is carried through the coefficient of variation by seeded Monte
  Carlo (`analysis.cartography.summarise_map`'s own propagation).

A candidate meets the target when |sampling error| + U(noise, k = 2), relative to the
continuum's coefficient of variation, is at most the target. Its bench time is the
stage's moves (`map_bench_time_s`), the settling waits and the acquisitions measured on
the simulated bench; the re-checks of the resonance add about the same to every
candidate and are left out. Only simulated benches can be planned, as for the points.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path
from typing import Any

import numpy as np

from squeezebench.analysis.cartography import coefficients_of_variation, homogeneity
from squeezebench.plates import predicted_plates
from squeezebench.errors import UserError
from squeezebench.protocols.campaign import Run, load_campaign
from squeezebench.protocols.plan_cache import PlanCache
from squeezebench.protocols import cartography
from squeezebench.protocols.cartography import map_moves_s, map_time_s
from squeezebench.protocols.simulated_session import open_simulated, reduce_point
from squeezebench.protocols.variants import MAP_PROTOCOLS
from squeezebench.yamlfiles import dump_yaml, load_strict

AVERAGES = (1, 2, 4, 8, 16, 32)
STEPS_MM = (1.0, 2.0, 3.0, 4.0, 6.0, 8.0)
CONTINUUM_STEP_MM = 0.5
NOISE_REPEATS = 4          # acquisitions per averaging: the fit's own u is averaged over them
NOISE_DRAWS = 200          # Monte Carlo draws of the points' noise


@dataclasses.dataclass(frozen=True)
class MapCandidate:
    step_mm: float
    averages: int
    n_points: int
    coefficient_of_variation: float
    sampling_error_rel: float      # worst (grid CV - continuum CV) / continuum CV over the placements
    noise_expanded_rel: float      # U (k = 2) of the CV from the points' noise, relative
    bench_time_s: float

    @property
    def error_rel(self) -> float:
        return abs(self.sampling_error_rel) + self.noise_expanded_rel


@dataclasses.dataclass
class MapPlan:
    run_name: str
    plate: str
    target_rel_error: float
    continuum_cv: float
    candidates: list[MapCandidate]
    as_written: MapCandidate

    @property
    def chosen(self) -> MapCandidate | None:
        meeting = [c for c in self.candidates if c.error_rel <= self.target_rel_error]
        return min(meeting, key=lambda c: (c.bench_time_s, c.step_mm)) if meeting else None

    def as_dict(self) -> dict[str, Any]:
        chosen = self.chosen
        return {"run": self.run_name, "plate": self.plate, "target_rel_error": self.target_rel_error,
                "continuum_coefficient_of_variation": self.continuum_cv,
                "chosen": None if chosen is None else {**dataclasses.asdict(chosen), "error_rel": chosen.error_rel},
                "as_written": {**dataclasses.asdict(self.as_written), "error_rel": self.as_written.error_rel},
                "candidates": [{**dataclasses.asdict(c), "error_rel": c.error_rel} for c in self.candidates]}

    def table(self) -> str:
        chosen = self.chosen
        lines = [f"map {self.run_name} ({self.plate}): coefficient of variation of the touch area, target "
                 f"{100 * self.target_rel_error:g} % (sampling error + noise U, k = 2)",
                 f"{'step mm':>8} {'averages':>8} {'points':>7} {'CV':>7} {'sampling':>9} {'noise U':>8} "
                 f"{'total':>7} {'bench min':>9}"]
        for c in [self.as_written, *([chosen] if chosen else [])]:
            mark = "as written" if c is self.as_written else "planned"
            sampling = f"{100 * c.sampling_error_rel:+.2f} %"
            lines.append(f"{c.step_mm:8g} {c.averages:8d} {c.n_points:7d} {100 * c.coefficient_of_variation:6.1f}% "
                         f"{sampling:>9} {100 * c.noise_expanded_rel:7.3f}% {100 * c.error_rel:6.2f}% "
                         f"{c.bench_time_s / 60:9.1f}  {mark}")
        if chosen is None:
            lines.append("no grid step and averaging meets the target (the finest grid's sampling error is above it)")
        else:
            lines.append(f"planned: {chosen.step_mm:g} mm step, {chosen.averages} averages: "
                         f"{chosen.bench_time_s / self.as_written.bench_time_s:.2f} x the bench time as written")
        return "\n".join(lines)


def map_runs(campaign_path: Path) -> list[Run]:
    return [run for run in load_campaign(Path(campaign_path)).runs if run.protocol in MAP_PROTOCOLS]


def plan_map(run: Run, target_rel_error: float, seed: int = 0, cache: PlanCache | None = None) -> MapPlan:
    """Every candidate (step, averaging) of `run`'s map, with its error and bench time (read
    from `cache` where an earlier plan of the campaign keeps them)."""
    if not target_rel_error > 0:
        raise UserError(f"target relative error must be positive, got {target_rel_error!r}")
    found = cache.result(map_job(run, cache, seed)) if cache is not None else map_candidates(_plannable(run), seed)
    return MapPlan(run.name, run.plate.name, target_rel_error, *found)


def map_job(run: Run, cache: PlanCache, seed: int = 0) -> functools.partial:
    """`map_candidates` of `run` as a job of `cache` (`plan_map` reads its result), for a
    plan to run beside its other jobs."""
    return cache.job(map_candidates, _plannable(run), seed)


def _plannable(run: Run) -> Run:
    """`run`, refused with the reason if its map cannot be planned."""
    if run.bench.scene is None:
        raise UserError("only simulated benches (bench: {scene: ...}) can be planned")
    if run.plate.name not in predicted_plates.GEOMETRIES:
        raise UserError(f"run {run.name}: no plate model for {run.plate.name!r} (known: "
                        f"{', '.join(predicted_plates.GEOMETRIES)}): a map's sampling error cannot be planned "
                        "without the mode it samples")
    return run


def map_candidates(run: Run, seed: int = 0) -> tuple[float, list[MapCandidate], MapCandidate]:
    """What a map plan is at any target: the continuum's coefficient of variation, every
    candidate, and the candidate as written."""
    params = run.parameters
    noise_rel, acquisition_s, frequency_hz, acceleration_mm_per_s2 = _point_noise(run)
    continuum_cv = homogeneity(np.abs(_touch_shape(run, CONTINUUM_STEP_MM, frequency_hz))).coefficient_of_variation
    rng = np.random.default_rng(seed)

    placements: dict[float, tuple[np.ndarray, float, float, int, float]] = {}

    def sampled(step_mm: float) -> tuple[np.ndarray, float, float, int, float]:
        """The grid as written at `step_mm`: its amplitudes, CV, the worst sampling error, its
        points and the stage's moves between them (the same at every averaging)."""
        if step_mm not in placements:
            shapes = [np.abs(_touch_shape(run, step_mm, frequency_hz, shift_mm=step_mm * q / 4)) for q in range(4)]
            errors = [homogeneity(shape).coefficient_of_variation / continuum_cv - 1.0 for shape in shapes]
            worst = errors[int(np.argmax(np.abs(errors)))]
            points = dataclasses.replace(params.grid, step_mm=step_mm).points_mm()
            placements[step_mm] = (shapes[0], homogeneity(shapes[0]).coefficient_of_variation, worst, len(points),
                                   map_moves_s(points, (0.0, 0.0), params.stage_velocity_mm_per_s,
                                               acceleration_mm_per_s2))
        return placements[step_mm]

    def candidate(step_mm: float, averages: int) -> MapCandidate:
        amplitude, cv, sampling, n_points, moves_s = sampled(step_mm)
        draws = amplitude * (1.0 + noise_rel[averages] * rng.normal(size=(NOISE_DRAWS, amplitude.size)))
        noise = 2.0 * float(np.std(coefficients_of_variation(draws), ddof=1)) / continuum_cv
        bench_s = map_time_s(moves_s, n_points, params.settle_s, acquisition_s[averages])
        return MapCandidate(step_mm, averages, n_points, float(cv), float(sampling), noise, bench_s)

    candidates = [candidate(step, averages) for step in STEPS_MM for averages in AVERAGES]
    as_written = next((c for c in candidates if c.step_mm == params.grid.step_mm
                       and c.averages == run.acquisition.averages), None) \
        or candidate(params.grid.step_mm, _nearest(run.acquisition.averages))
    return float(continuum_cv), candidates, as_written


def _nearest(averages: int) -> int:
    return min(AVERAGES, key=lambda a: abs(np.log2(a) - np.log2(max(averages, 1))))


def _touch_shape(run: Run, step_mm: float, frequency_hz: float, shift_mm: float = 0.0) -> np.ndarray:
    """The model's shape at the touch-area points of the run's grid at `step_mm`, its
    first column moved `shift_mm` along the length."""
    params = run.parameters
    grid = params.grid
    (x0, x1) = grid.x_range_mm
    # the model sampled, not a map to visit (the continuum's 0.5 mm exceeds a map's bound),
    # in the grid's visiting order (each point's noise draw follows it)
    xs = cartography.axis_mm((x0 + shift_mm, x1), step_mm, grid.margin_mm)
    ys = cartography.axis_mm(grid.y_range_mm, step_mm, grid.margin_mm)
    points = np.vstack([np.column_stack([xs[::-1] if grid.serpentine and i % 2 else xs, np.full(len(xs), y)])
                        for i, y in enumerate(ys)])
    inside = np.array([params.in_touch_area(x, y) for x, y in points])
    shape, _ = predicted_plates.working_shape(run.plate.name, frequency_hz, points[inside, 0] * 1e-3,
                                              points[inside, 1] * 1e-3)
    return shape


def _point_noise(run: Run) -> tuple[dict[int, float], dict[int, float], float, float]:
    """Per averaging: the fit's relative u of one point's velocity and the bench time of
    its acquisition, at the run's resonance and voltage on the simulated bench; that
    resonance frequency, and the stage's acceleration (SMC100 UM AC) there."""
    noise, cost = {}, {}
    with open_simulated(run.bench.scene, run.plate.state, run.acquisition.settle_s, run.safety) as session:
        simulated, clock = session.simulated, session.bench.clock
        session.drive.set_piezo_voltage(run.parameters.piezo_voltage_vpp)
        session.go_to_resonance()
        for averages in AVERAGES:
            acquisition = session.acquisition(dataclasses.replace(run.acquisition, averages=averages))
            acquisition.measure(keep_waveforms=False)   # ranges the channels
            relative, spent = [], []
            for repeat in range(NOISE_REPEATS):
                simulated.reseed(1000 * averages + repeat)
                start_s = clock.now_s()
                reduced = reduce_point(acquisition.measure(keep_waveforms=True))
                spent.append(clock.now_s() - start_s)
                relative.append(reduced.velocity_pp_mps.std_uncertainty / reduced.velocity_pp_mps.value)
            noise[averages], cost[averages] = float(np.mean(relative)), float(np.mean(spent))
        return noise, cost, session.drive.frequency_hz, session.bench.stage.acceleration_mm_per_s2("x")


def write_planned_maps(campaign_path: Path, plans: list[MapPlan], out: Path) -> None:
    """Put each map's planned step and averaging into the campaign file at `out`."""
    data = load_strict(Path(out).read_text(encoding="utf-8"))
    chosen = {plan.run_name: plan.chosen for plan in plans if plan.chosen is not None}
    for run in data["runs"]:
        if run["name"] in chosen:
            run["parameters"]["grid"]["step_mm"] = chosen[run["name"]].step_mm
            run.setdefault("acquisition", {})["averages"] = chosen[run["name"]].averages
    Path(out).write_text(dump_yaml(data), encoding="utf-8")
