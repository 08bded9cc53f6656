"""Acquisition planning: the cheapest scope settings that meet an accuracy target.

For every distinct plate (scene, state) the campaign's runs measure, on the simulated
bench at its resonance and the run's (smallest) voltage, the relative error of the
power reduced from the stored waveforms (analysis.waveforms.integer_period_mean_power_w,
as the analysis does) against the scene's closed-form truth (`truth().power_w`) is
measured for scope settings, one after the other on one bench per plate: record length
500 or 10000 points x averaging 1 (sample mode), 2, 4, ..., 512, over several
acquisitions (each setting ranges the channels afresh, and each acquisition's noise is
seeded by the scene's seed and what defines it, so the plan is reproducible and the same
on any number of workers, `protocols.parallel`); the 95th percentile of |error| is
compared with the target. A run gets the setting meeting the target on all its plates at the least bench
time per point (the baseline's when none does: every step of a run shares its
acquisition settings). A point's bench time grows with the averaging, so the averagings
are measured in rounds, fewest first, and only as far as a cheaper setting meeting the
target could still be found (`SettingsStudy`): the choice is the one measuring all twenty
gives. The campaign is then run twice on the simulated bench into
temporary directories, with the planned settings and with 512 averages everywhere (the
fixed baseline, at the campaign's record lengths), and the virtual bench time of each run
is read from the journals; a run whose setting is the one the campaign names (which the
floors' run measured, `accuracy_plan`) or the baseline's is not run again.

Only simulated benches (`bench: {scene: ...}`) can be planned: the truth is needed.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
import tempfile
import zlib
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np
import pandas as pd

from squeezebench.analysis.over_coverage import UNPRICED
from squeezebench.analysis.waveforms import integer_period_mean_power_w, sample_interval_s
from squeezebench.protocols.accuracy_plan import CALIBRATION_RUN, AccuracyFloors, accuracy_floors, measure_floors
from squeezebench.protocols.simulated_session import SimulatedSession, open_simulated
from squeezebench.protocols.variants import (CALIBRATION_PROTOCOL, MAP_PROTOCOLS, only_run, planned_campaign,
                                             with_acquisition)
from squeezebench.protocols.bench_errors import (
    bench_time_by_run_s, errors_on_bench, p95_by_run)
from squeezebench.protocols.acquisition import AcquisitionSettings
from squeezebench.protocols.campaign import Run, load_campaign, run_campaign
from squeezebench.protocols.plan_cache import PlanCache
from squeezebench.protocols.safety import SafetyLimits
from squeezebench.errors import UserError

AVERAGES = tuple(2 ** k for k in range(10))   # 1 (sample mode), 2..512: what the TDS3000 offers
RECORD_LENGTHS = (500, 10000)                   # HOR:RECO: what the TDS3000 offers
BASELINE_AVERAGES = 512
CHECK_BENCHES = 20             # simulated benches with drawn errors the plan is checked on (p95 needs >> 8)
MAX_TIGHTENINGS = 3            # checks that may send runs back for less noise
REPEATS = 8                    # acquisitions per setting; p95 of 8 is near the max
ERROR_PERCENTILE = 95.0
DEFAULT_VOLTAGE_VPP = 20.0     # detuning runs set voltage from a velocity level; ~20 Vpp is typical


@dataclasses.dataclass(frozen=True)
class Setting:
    """What the plan chooses per run: the scope's record length and averaging."""

    record_length: int
    averages: int


SETTINGS = tuple(Setting(r, n) for r in RECORD_LENGTHS for n in AVERAGES)
#: The averagings a plate's bench measures together, round after round, at both record
#: lengths. The scope waits for every record it averages, so a point's bench time grows
#: with the averaging (by 3.9 % or more a step on the paper's plates: 0.08 s at 500 points
#: in sample mode, 5.7 s at 512 averages); the rounds go from cheap to dear.
AVERAGING_ROUNDS = ((1,), (2, 4), (8, 16, 32), (64, 128, 256, 512))


@dataclasses.dataclass
class SettingResult:
    setting: Setting
    p95_rel_error: float
    bench_time_per_point_s: float   # virtual bench time of one measured point


@dataclasses.dataclass
class PlateStudy:
    scene: Path
    state: str | None
    voltage_vpp: float
    resonance_hz: float
    results: list[SettingResult]   # the settings measured (`SettingsStudy`: as far as the plan needed)

    def result(self, setting: Setting) -> SettingResult:
        return next(r for r in self.results if r.setting == setting)


def cheapest_setting(studies: list[PlateStudy], target_rel_error: float, fallback: Setting | None
                     ) -> Setting | None:
    """The setting meeting the target on every plate at the least bench time per point
    (summed over the plates); `fallback` when none meets it everywhere."""
    meeting = [r.setting for r in studies[0].results
               if all(s.result(r.setting).p95_rel_error <= target_rel_error for s in studies)]
    if not meeting:
        return fallback
    return min(meeting, key=lambda setting: (bench_time_per_point_s(studies, setting), setting.averages))


def bench_time_per_point_s(studies: list[PlateStudy], setting: Setting) -> float:
    """What a point costs at `setting`, summed over the plates: a run's cost of the setting."""
    return sum(s.result(setting).bench_time_per_point_s for s in studies)


class SettingsStudy:
    """The settings' study of a plan's plates (keys of `measure_settings`), measured only as
    far as the runs' choices need: a round measures the next averagings of
    `AVERAGING_ROUNDS` at both record lengths, on one bench per plate. Since every
    setting not measured yet has more averages, and so costs more per point, than the
    most averaged one measured, a run's cheapest setting is known once one meets its target
    at no more cost than those; `choose` returns what `cheapest_setting` picks among all
    twenty. A setting measures the same whatever ran before it on its bench, so the
    rounds' results are those of one bench measuring all twenty."""

    def __init__(self, cache: PlanCache, keys: Sequence[tuple], repeats: int) -> None:
        self.cache, self.repeats = cache, repeats
        self.rounds = dict.fromkeys(keys, 0)   # rounds measured per plate
        self._results: dict[tuple, list[SettingResult]] = {key: [] for key in keys}
        self._resonance_hz: dict[tuple, float] = {}

    def next_round(self, keys: Sequence[tuple]) -> dict[functools.partial, tuple]:
        """{job: key} measuring each plate's next round."""
        return {self.cache.job(measure_settings, *key, self.repeats,
                               tuple(Setting(r, n) for r in RECORD_LENGTHS for n in AVERAGING_ROUNDS[self.rounds[key]])
                               ): key for key in keys}

    def absorb(self, jobs: dict[functools.partial, tuple], done: dict) -> None:
        for job, key in jobs.items():
            results, self._resonance_hz[key] = done[job]
            self._results[key] += results
            self.rounds[key] += 1

    def study(self, key: tuple, rounds: int | None = None) -> PlateStudy:
        """The plate's measured settings (of its first `rounds` rounds), in `SETTINGS`' order."""
        averages = {n for averagings in AVERAGING_ROUNDS[:rounds] for n in averagings}
        return PlateStudy(key[0], key[1], key[2].voltage_vpp, self._resonance_hz[key],
                          sorted((r for r in self._results[key] if r.setting.averages in averages),
                                 key=lambda r: SETTINGS.index(r.setting)))

    def choose(self, wanted: dict[str, tuple[list[tuple], float, Setting]], workers: int, scheduler: Any
               ) -> dict[str, Setting]:
        """{run: setting} for {run: (its plate keys, noise target, fallback)}, measuring the
        rounds the choices need on `workers`."""
        while True:
            chosen = {name: self._cheapest(*want) for name, want in wanted.items()}
            behind = {key: None for name, (keys, _, _) in wanted.items() if chosen[name] is None
                      for key in keys if self.rounds[key] == min(self.rounds[k] for k in keys)}
            if not behind:
                return chosen
            jobs = self.next_round(list(behind))
            self.absorb(jobs, self.cache.run(list(jobs), workers, scheduler, "scope settings"))

    def _cheapest(self, keys: list[tuple], target: float, fallback: Setting) -> Setting | None:
        """`cheapest_setting` among all twenty, or None while a round not measured on every
        plate of the run could hold a cheaper one."""
        rounds = min(self.rounds[key] for key in keys)
        if not rounds:
            return None
        studies = [self.study(key, rounds) for key in keys]
        best = cheapest_setting(studies, target, fallback=None)
        if rounds == len(AVERAGING_ROUNDS):
            return best or fallback
        if best is None:
            return None
        most = AVERAGING_ROUNDS[rounds - 1][-1]   # every setting not measured costs more than this one
        bound_s = min(bench_time_per_point_s(studies, Setting(r, most)) for r in RECORD_LENGTHS)
        return best if bench_time_per_point_s(studies, best) <= bound_s else None


def _waveform_power_w(point) -> float:
    """Power from the stored waveforms, as the analysis reduces them (DC removed, integer
    periods). The scope's MATH MEAN keeps the channels' DC offsets' product, a bias no
    averaging removes, so it cannot meet a tight target at any averaging count."""
    frame = point.waveforms
    return integer_period_mean_power_w(frame["piezo_voltage_v"].to_numpy(), frame["current_a"].to_numpy(),
                                       sample_interval_s(frame["time_s"].to_numpy()), point.scope_frequency_hz)


def _run_plates(run: Run) -> list[tuple[Path, str | None, Any]]:
    """(scene, state, plate) of every step of `run`, each once."""
    seen: dict[tuple[Path, str | None], Any] = {}
    for step in run.steps():
        scene = step.plate.scene or run.bench.scene
        seen.setdefault((scene, step.plate.state), step.plate)
    return [(scene, state, plate) for (scene, state), plate in seen.items()]


@dataclasses.dataclass(frozen=True)
class OperatingPoint:
    """Where a run measures a plate: at its resonance, or at a fixed frequency with the
    voltage that brings the velocity to a level there (Fig. 2c's stress point)."""

    voltage_vpp: float
    frequency_hz: float | None = None
    velocity_level_pp_mps: float | None = None


def _run_points(run: Run, plate: Any) -> list[OperatingPoint]:
    """The points of the run hardest to measure: the resonance at the smallest voltage the
    run drives the plate at and, for a stress point, that point (power factor ~0.02: the
    power is a small difference of large products there, and its noise is larger)."""
    voltage_vpp = None
    for source in (plate, run.parameters):
        voltage_vpp = voltage_vpp or getattr(source, "piezo_voltage_vpp", None)
    voltages = getattr(run.parameters, "voltages_vpp", None)
    voltage_vpp = float(voltage_vpp or (min(voltages) if voltages else DEFAULT_VOLTAGE_VPP))
    points = [OperatingPoint(voltage_vpp)]
    stress_hz = getattr(run.parameters, "stress_frequency_hz", None)
    if stress_hz:
        points.append(OperatingPoint(voltage_vpp, float(stress_hz),
                                     float(run.parameters.stress_velocity_level_pp_mps)))
    return points


def _trial_seed(scene_seed: int, state: str | None, point: OperatingPoint, setting: Setting,
                trial: int | str) -> int:
    """The noise of one acquisition of the plan: from what defines it, never from what ran
    before, so any order, partition or number of workers draws the same."""
    where = f"{point.voltage_vpp:.9g}" + ("" if point.frequency_hz is None else
                                          f"@{point.frequency_hz:.9g}:{point.velocity_level_pp_mps:.9g}")
    parts = (state, where, setting.record_length, setting.averages, trial)
    entropy = [scene_seed, *(zlib.crc32(str(part).encode()) for part in parts)]
    return int(np.random.SeedSequence(entropy).generate_state(1)[0])


def measure_settings(scene: Path, state: str | None, point: OperatingPoint, acquisition: AcquisitionSettings,
                     limits: SafetyLimits, repeats: int = REPEATS, settings: Sequence[Setting] = SETTINGS
                     ) -> tuple[list[SettingResult], float]:
    """Error and bench cost of each setting on one plate at one operating point, and the
    frequency driven. One bench serves them all, as on a real bench: the plate is driven
    there once, and each setting ranges the channels afresh and draws from its own seeds
    (`_trial_seed`), so it measures the same whatever was measured before it."""
    with open_simulated(scene, state, acquisition.settle_s, limits) as session:
        simulated = session.simulated
        session.drive.set_piezo_voltage(point.voltage_vpp)
        if point.frequency_hz is None:
            session.go_to_resonance()   # the closed-form resonance, not a measured search
        else:   # the plate is linear in the drive: scale the voltage to the level
            session.drive.set_frequency(point.frequency_hz)
            scale = point.velocity_level_pp_mps / simulated.truth().velocity_pp_mps
            session.drive.set_piezo_voltage(min(point.voltage_vpp * scale, session.drive.max_piezo_voltage_vpp))
        truth_power_w = simulated.truth().power_w
        scene_seed = simulated.scene.seed
        return ([_measure_setting(session, acquisition, setting, truth_power_w, repeats,
                                  functools.partial(_trial_seed, scene_seed, state, point, setting))
                 for setting in settings], session.drive.frequency_hz)


def _measure_setting(session: SimulatedSession, acquisition: AcquisitionSettings, setting: Setting,
                     truth_power_w: float, repeats: int, seed: Callable[[int | str], int]) -> SettingResult:
    """One setting at the present drive: ranged once, then `repeats` acquisitions, each
    from the ranged state and its own seed (`seed(trial)`)."""
    simulated, clock = session.simulated, session.bench.clock
    simulated.reseed(seed("setup"))
    ranged = session.acquisition(dataclasses.replace(
        acquisition, record_length=setting.record_length, averages=setting.averages))
    ranged.measure(keep_waveforms=False)   # ranges the channels once
    errors, costs_s = [], []
    for repeat in range(repeats):
        simulated.reseed(seed(repeat))
        start_s = clock.now_s()
        measured = copy.copy(ranged).measure(keep_waveforms=True)   # each from the ranged state
        costs_s.append(clock.now_s() - start_s)
        errors.append(abs(_waveform_power_w(measured) / truth_power_w - 1.0))
    return SettingResult(setting, float(np.percentile(errors, ERROR_PERCENTILE)), float(np.mean(costs_s)))


def simulate_run_bench_time_s(campaign_path: Path, run_name: str, acquisition: dict) -> float:
    """Bench time of run `run_name` of the campaign with these acquisition settings, run
    alone on the simulated bench: a run opens a bench of its own, so alone it takes what it
    does within the campaign (`variants.only_run`), and the runs are timed on as many workers."""
    with tempfile.TemporaryDirectory(prefix="squeezebench-plan-") as tmp:
        variant = only_run(with_acquisition(campaign_path, {run_name: acquisition}, Path(tmp) / campaign_path.name),
                           run_name)
        return bench_time_by_run_s(run_campaign(variant, out_dir=Path(tmp) / "run", progress=False,
                                                 durable=False))[run_name]


def bench_time_jobs(cache: PlanCache, campaign_path: Path, acquisition_by_run: dict[str, dict]
                    ) -> dict[functools.partial, str]:
    """{job: run name} timing every run of `acquisition_by_run`; each run's job depends on
    its own settings only, so a plan at another target reads the runs whose setting it keeps."""
    return {cache.job(simulate_run_bench_time_s, campaign_path, name, acquisition): name
            for name, acquisition in acquisition_by_run.items()}


@dataclasses.dataclass
class Plan:
    target_rel_error: float
    studies: dict[str, list[PlateStudy]]
    settings_by_run: dict[str, Setting]
    error_by_run: dict[str, float]
    planned_s: dict[str, float]
    baseline_s: dict[str, float]
    repeats: int = REPEATS   # acquisitions per setting in the study
    floors: AccuracyFloors | None = None   # what the instruments' specified errors leave
    own_s: dict[str, float] = dataclasses.field(default_factory=dict)   # the campaign as written
    check: pd.DataFrame | None = None   # p95 |error| per run over simulated benches with errors
    check_benches: int = 0
    #: runs a check sent back: the fraction of the floor's headroom their noise may take
    noise_scale: dict[str, float] = dataclasses.field(default_factory=dict)
    measurements: str = ""   # where the numbers came from (`PlanCache.words`)
    cache: dict = dataclasses.field(default_factory=dict)   # `PlanCache.as_dict`
    over_coverage: "OverCoverageCost | None" = None   # what the budgets' surplus costs (`make_plan`)

    @property
    def calibrate(self) -> bool:
        return bool(self.floors and self.floors.calibrate)

    @property
    def reachable(self) -> bool:
        """Whether every run's planned floor is at or below the target."""
        return not (self.floors and self.floors.below_floor())

    def expected_p95_rel_error(self, run_name: str) -> float:
        """The run's total expected p95 error: its planned floor and its noise in quadrature
        (the convention of `AccuracyFloors.noise_allowance`)."""
        floor = self.floors.planned_floor(run_name) if self.floors else 0.0
        return math.hypot(floor, self.error_by_run[run_name])

    @property
    def planned_total_s(self) -> float:
        return sum(self.planned_s.values())

    @property
    def baseline_total_s(self) -> float:
        return sum(self.baseline_s.values())

    @property
    def meets_check(self) -> bool:
        return self.check is not None and not self.missed_runs()

    def missed_runs(self) -> list[str]:
        """Runs whose p95 |error| over the check's benches is above the target."""
        if self.check is None:
            return []
        missed = self.check[self.check["p95_abs_rel_error"] > self.target_rel_error]
        return list(dict.fromkeys(missed["run_name"]))

    @property
    def own_total_s(self) -> float:
        return sum(self.own_s.values())

    def table(self) -> str:
        # one unit style in the table: every relative error in %, as the floors are
        lines = [f"target relative error (p95, power and velocity; Q and tan theta' floors too): "
                 f"{self.target_rel_error:g} ({100 * self.target_rel_error:g} %); noise p95 of "
                 f"{self.repeats} acquisitions per setting; floor: the instruments' specified errors",
                 f"{'run':<24} {'record':>6} {'averages':>8} {'noise p95':>10} {'floor':>7} {'planned s':>10} "
                 f"{'own s':>8} {'ratio':>6} {'512-avg s':>10}"]
        for name, setting in self.settings_by_run.items():
            planned_s, own_s = self.planned_s.get(name, 0.0), self.own_s.get(name, math.nan)
            floor = self.floors.planned_floor(name) if self.floors else math.nan
            lines.append(f"{name:<24} {setting.record_length:>6d} {setting.averages:>8d} "
                         f"{self.error_by_run[name]:>10.3%} {floor:>7.2%} {planned_s:>10.1f} {own_s:>8.1f} "
                         f"{planned_s / own_s:>6.2f} {self.baseline_s.get(name, 0.0):>10.1f}")
        for name in set(self.planned_s) - set(self.settings_by_run):   # the calibration the plan adds
            lines.append(f"{name:<24} {'':>6} {'':>8} {'':>10} {'':>7} {self.planned_s[name]:>10.1f} "
                         f"{self.own_s.get(name, 0.0):>8.1f} "
                         f"{'':>6} {'':>10}")
        ratio = self.planned_total_s / self.own_total_s if self.own_total_s else math.nan
        lines.append(f"{'total':<24} {'':>6} {'':>8} {max(self.error_by_run.values()):>10.3%} {'':>7} "
                     f"{self.planned_total_s:>10.1f} {self.own_total_s:>8.1f} {ratio:>6.2f} "
                     f"{self.baseline_total_s:>10.1f}")
        if self.own_total_s and self.planned_total_s > self.own_total_s:
            lines.append(f"the plan is dearer than the campaign's own settings: {self.planned_total_s:.1f} s of bench "
                         f"time against {self.own_total_s:.1f} s ({ratio:.2f} times): the cheapest settings whose "
                         "noise fits the target cost more than those the campaign names")
        if self.floors:
            lines += self.floors.lines()
        if self.measurements:
            lines.append(self.measurements)
        if self.check is not None:
            worst = self.check.groupby("quantity")["p95_abs_rel_error"].max()
            meets = self.meets_check
            lines.append(f"check on {self.check_benches} simulated benches with errors drawn within specification"
                         f"{' (deskew calibration first)' if self.calibrate else ''}: worst run p95 |error| "
                         + ", ".join(f"{q} {v:.2%}" for q, v in worst.items())
                         + f" -> {'meets' if meets else 'misses'} the target {self.target_rel_error:g}")
            for name, scale in self.noise_scale.items():
                lines.append(f"  {name}: an earlier check missed; its noise may take {scale:g} of the floor's headroom")
            if not meets:
                lines.append(f"  missed by {', '.join(self.missed_runs())} after {MAX_TIGHTENINGS} tightenings")
        if self.over_coverage is not None:
            lines += self.over_coverage.lines(self)
        return "\n".join(lines)

    def as_dict(self) -> dict:
        """The plan as plain data (`squeezebench plan --json`): the numbers of `table()`."""
        return {"target_rel_error": self.target_rel_error, "repeats": self.repeats,
                "runs": [{"run": name, **dataclasses.asdict(setting),
                          "p95_rel_error": self.expected_p95_rel_error(name),
                          "noise_p95_rel_error": self.error_by_run[name],
                          "planned_bench_time_s": self.planned_s.get(name, 0.0),
                          "baseline_bench_time_s": self.baseline_s.get(name, 0.0)}
                         for name, setting in self.settings_by_run.items()],
                "reachable": self.reachable,
                "planned_bench_time_s": self.planned_total_s,
                "own_bench_time_s": self.own_total_s,
                "own_bench_time_by_run_s": self.own_s,
                "baseline_bench_time_s": self.baseline_total_s,
                "baseline_averages": BASELINE_AVERAGES,
                "calibration_bench_time_s": {k: v for k, v in self.planned_s.items() if k not in self.settings_by_run},
                "floors": self.floors.as_dict() if self.floors else None,
                "cache": self.cache,
                "over_coverage": None if self.over_coverage is None else self.over_coverage.as_dict(self),
                "check": None if self.check is None else {
                    "benches": self.check_benches, "meets_target": self.meets_check,
                    "missed_runs": self.missed_runs(), "noise_scale": self.noise_scale,
                    "p95_abs_rel_error": self.check.to_dict(orient="records")}}


@dataclasses.dataclass
class OverCoverageCost:
    """What the budgets' over-coverage on the world model costs a plan: the same choice
    (`_choose`, the same noise measurements and check tightenings) with each over-covering
    quantity's floors multiplied by its shrink factor (`AccuracyFloors.scaled`), so that more
    of the target is left to the noise and cheaper settings meet it. The narrower plan is an
    estimate: it is timed like any plan, not checked on erring benches."""

    shrink_factors: dict[str, float]   # {quantity: p95 |error| / U}, `analysis.over_coverage.shrink_factors`
    source: str                        # where they were read (a coverage study's run directory)
    narrower: "Plan | None"            # None: no quantity over-covers

    def saved_s(self, plan: "Plan") -> float:
        """Bench time the narrower budgets would save on `plan` (what the surplus costs)."""
        return plan.planned_total_s - self.narrower.planned_total_s if self.narrower else 0.0

    def lines(self, plan: "Plan") -> list[str]:
        where = f" (coverage study in {self.source})" if self.source else ""
        if not self.narrower:
            return [f"over-coverage on the world model{where}: no quantity over-covers; nothing to save"]
        planned = {f.quantity for f in plan.floors.floors} if plan.floors else set()
        unplanned = {q: f" ({UNPRICED.get(q, 'no floor in this plan')})" for q in self.shrink_factors if q not in planned}
        factors = ", ".join(f"{q} {factor:.2f}{unplanned.get(q, '')}" for q, factor in self.shrink_factors.items())
        saved_s = self.saved_s(plan)
        out = [f"over-coverage on the world model{where}: U could be this fraction of itself and still cover "
               f"95 %: {factors}; with floors that much lower the plan would take "
               f"{self.narrower.planned_total_s:.1f} s of bench time instead of {plan.planned_total_s:.1f} s: "
               f"the over-coverage costs {saved_s:.1f} s ({saved_s / plan.planned_total_s:.1%})"
               + ("" if self.narrower.reachable == plan.reachable else
                  f"; the target would be {'reachable' if self.narrower.reachable else 'out of reach'}")]
        if not self.narrower.reachable:
            out.append("  the target is below a floor with the narrower budgets too: these times keep the noise "
                       "under a third of each floor, they do not price the surplus")
        if plan.calibrate and not self.narrower.calibrate:
            out.append(f"  {CALIBRATION_RUN}: {plan.planned_s.get(CALIBRATION_RUN, 0.0):.1f} s no longer needed")
        for name, setting in plan.settings_by_run.items():
            narrower = self.narrower.settings_by_run[name]
            if narrower != setting:
                out.append(f"  {name}: floor {plan.floors.planned_floor(name):.2%} -> "
                           f"{self.narrower.floors.planned_floor(name):.2%}, {setting.record_length} points x "
                           f"{setting.averages} averages -> {narrower.record_length} x {narrower.averages}, "
                           f"{plan.planned_s[name]:.1f} s -> {self.narrower.planned_s[name]:.1f} s")
        return out

    def as_dict(self, plan: "Plan") -> dict:
        narrower = self.narrower
        return {"shrink_factors": self.shrink_factors, "source": self.source,
                "saved_bench_time_s": self.saved_s(plan),
                "planned_bench_time_s": narrower.planned_total_s if narrower else plan.planned_total_s,
                "reachable": narrower.reachable if narrower else plan.reachable,
                "runs": [] if not narrower else [
                    {"run": name, **dataclasses.asdict(setting), "floor_p95_rel": narrower.floors.planned_floor(name),
                     "planned_bench_time_s": narrower.planned_s.get(name, 0.0)}
                    for name, setting in narrower.settings_by_run.items()]}


def make_plan(campaign_path: Path, target_rel_error: float, repeats: int = REPEATS,
              workers: int = 1, scheduler: Any = None, check_benches: int = CHECK_BENCHES,
              cache: PlanCache | None = None, alongside: Sequence[functools.partial] = (),
              shrink_factors: dict[str, float] | None = None, shrink_source: str = "") -> Plan:
    """Measure the settings the plates' runs need (`SettingsStudy`), pick each run's, and
    time the campaign with the plan and with the baseline, on `workers` local processes or
    the Dask cluster at `scheduler` (the plan is the same either way). The floors the
    instruments' specified errors leave decide what the noise may take and whether to
    calibrate; the plan is then checked on `check_benches` simulated benches with drawn
    errors (0: no check; none when the target is below the floor). What an earlier plan of
    the campaign measured is read from `cache` (default: the campaign's `plan_cache`); the
    `alongside` jobs of `cache` (a caller's map plans) run in the same batch as the floors.
    With `shrink_factors` ({quantity: factor}, `analysis.over_coverage.shrink_factors`, read
    from `shrink_source`) the plan also says what the budgets' over-coverage costs it
    (`OverCoverageCost`)."""
    if not target_rel_error > 0:
        raise UserError(f"target relative error must be positive, got {target_rel_error!r}")
    campaign_path = Path(campaign_path)
    campaign = load_campaign(campaign_path)
    if any(run.bench.scene is None for run in campaign.runs):
        raise UserError("only simulated benches (bench: {scene: ...}) can be planned")
    # a map's settings answer to its homogeneity figures: `map_planning` plans those runs
    # (and a calibration the campaign carries is kept as written: the floors measure it)
    campaign = dataclasses.replace(campaign, runs=tuple(r for r in campaign.runs if r.protocol not in MAP_PROTOCOLS
                                                        and r.protocol != CALIBRATION_PROTOCOL))
    if not campaign.runs:
        raise UserError(f"{campaign_path.name} has only maps: nothing for the point planner")
    plates = {}   # one study per plate, voltage and acquisition, shared by the runs measuring it
    plates_by_run: dict[str, list[tuple]] = {}
    for run in campaign.runs:
        keys = [(scene, state, point, run.acquisition, run.safety)
                for scene, state, plate in _run_plates(run) for point in _run_points(run, plate)]
        plates.update(dict.fromkeys(keys))
        plates_by_run[run.name] = keys
    # None of this depends on the target: an earlier plan of the same campaign may hold it.
    # The floors and the 512-average baseline do not depend on the settings' study either:
    # they run beside its first round, as do the `alongside` jobs (the caller's map plans).
    cache = cache or campaign_cache(campaign_path)
    # a run written at 512 averages is the baseline as it stands: the floors' run times it
    baseline = bench_time_jobs(cache, campaign_path, {run.name: {"averages": BASELINE_AVERAGES}
                                                      for run in campaign.runs
                                                      if run.acquisition.averages != BASELINE_AVERAGES})
    floors_job = cache.job(measure_floors, campaign_path)
    # the settings' first round too: no choice can be made before the floors are known
    settings = SettingsStudy(cache, list(plates), repeats)
    first_round = settings.next_round(list(plates))
    done = cache.run([floors_job, *alongside, *baseline, *first_round], workers, scheduler, "plan")   # longest first
    settings.absorb(first_round, done)
    floors = accuracy_floors(campaign_path, target_rel_error, done[floors_job])
    at_512_s = {name: done[job] for job, name in baseline.items()}
    baseline_s = {run.name: at_512_s.get(run.name, floors.own_bench_time_s[run.name]) for run in campaign.runs}
    noise_scale = {run.name: 1.0 for run in campaign.runs}

    def choose() -> Plan:
        return _choose(campaign, campaign_path, target_rel_error, repeats, settings, plates_by_run, floors,
                       baseline_s, noise_scale, cache, workers, scheduler)

    plan = choose()
    checks = MAX_TIGHTENINGS + 1 if check_benches and not floors.below_floor() else 0   # none: nothing reaches it
    for tightenings in range(checks):
        plan.check, plan.check_benches = check_plan(campaign_path, plan, check_benches, workers,
                                                    scheduler, cache=cache), check_benches
        missed = plan.missed_runs()
        if not missed or tightenings == MAX_TIGHTENINGS:   # the plan returned is always the one checked
            plan.measurements, plan.cache = cache.words(), cache.as_dict()   # the checks' benches counted too
            break
        # The floors and noise add as normal approximations; the check on erring benches is
        # the arbiter. Calibrate first (a bench in the floor's tail may miss), then halve the
        # noise the missing runs may take, and check again.
        if not floors.calibrate:
            floors.calibration_forced_by = f"the check on {check_benches} benches without it"
        else:
            noise_scale.update({name: noise_scale[name] / 2.0 for name in missed})
        plan = choose()
    if shrink_factors is not None:   # the same choice with the narrower budgets' floors (not checked)
        narrower = None if not shrink_factors else _choose(
            campaign, campaign_path, target_rel_error, repeats, settings, plates_by_run,
            floors.scaled(shrink_factors), baseline_s, noise_scale, cache, workers, scheduler)
        plan.over_coverage = OverCoverageCost(dict(shrink_factors), shrink_source, narrower)
        plan.measurements, plan.cache = cache.words(), cache.as_dict()
    return plan


def campaign_cache(campaign_path: Path) -> PlanCache:
    """The plan cache of a campaign: keyed by its file and every file its runs name."""
    runs = load_campaign(Path(campaign_path)).runs
    return PlanCache([Path(campaign_path), *dict.fromkeys(f for run in runs for f in run.input_files())])


def _choose(campaign, campaign_path: Path, target_rel_error: float, repeats: int, settings: SettingsStudy,
            plates_by_run: dict[str, list[tuple]], floors: AccuracyFloors, baseline_s: dict[str, float],
            noise_scale: dict[str, float], cache: PlanCache, workers: int, scheduler: Any) -> Plan:
    """Per run the cheapest setting whose noise fits in what the floor leaves of the
    target (errors add in quadrature; times the run's `noise_scale`, lowered where a check
    missed); where the floor is above the target, the cheapest
    whose noise stays a third of the floor (it then adds under 6 %)."""
    unreachable = {f.run_name for f in floors.below_floor()}
    settings_by_run = settings.choose(
        {run.name: (plates_by_run[run.name],
                    floors.floor(run.name, calibrated=True) / 3.0 if run.name in unreachable
                    else floors.noise_allowance(run.name) * noise_scale[run.name],
                    Setting(run.acquisition.record_length, BASELINE_AVERAGES)) for run in campaign.runs},
        workers, scheduler)
    studies_by_run = {name: [settings.study(key) for key in keys] for name, keys in plates_by_run.items()}
    error_by_run = {name: max(s.result(setting).p95_rel_error for s in studies_by_run[name])
                    for name, setting in settings_by_run.items()}
    # A run opens a bench of its own, so it takes the bench time it took where it already ran
    # at the setting chosen: in the floors' run (the campaign as written) or in the baseline.
    timed_s = {run.name: {Setting(run.acquisition.record_length, BASELINE_AVERAGES): baseline_s[run.name],
                          Setting(run.acquisition.record_length, run.acquisition.averages):
                              floors.own_bench_time_s[run.name]} for run in campaign.runs}
    timing = bench_time_jobs(cache, campaign_path, {name: dataclasses.asdict(setting)
                                                    for name, setting in settings_by_run.items()
                                                    if setting not in timed_s[name]})
    # longest first, the runs' own bench time a proxy for their simulation's: the workers end together
    done = cache.run(sorted(timing, key=lambda job: -floors.own_bench_time_s[timing[job]]), workers, scheduler,
                     "planned bench time")
    for job, seconds in done.items():
        timed_s[timing[job]][settings_by_run[timing[job]]] = seconds
    # The calibration a calibrated plan starts with is the floors' own, for the same reason.
    planned_s = {**({CALIBRATION_RUN: floors.calibration_bench_time_s} if floors.calibrate else {}),
                 **{name: timed_s[name][setting] for name, setting in settings_by_run.items()}}
    return Plan(target_rel_error, studies_by_run, settings_by_run, error_by_run, planned_s, baseline_s,
                repeats=repeats, floors=floors, own_s=floors.own_bench_time_with_calibration_s,
                noise_scale={name: scale for name, scale in noise_scale.items() if scale != 1.0},
                measurements=cache.words(), cache=cache.as_dict())


def check_plan(campaign_path: Path, plan: Plan, benches: int, workers: int = 1,
               scheduler: Any = None, cache: PlanCache | None = None) -> pd.DataFrame:
    """p95 |relative error| per run and quantity of the planned campaign over `benches`
    simulated benches whose instruments err within specification (`bench_errors`); a
    bench an earlier plan checked with the same settings is read from `cache` (default:
    the campaign's)."""
    cache = cache or campaign_cache(campaign_path)
    jobs = {cache.job(errors_on_planned_bench, campaign_path, _settings(plan), plan.calibrate, seed): seed
            for seed in range(1, benches + 1)}
    done = cache.run(list(jobs), workers, scheduler, "simulated benches")
    return p95_by_run(pd.concat([done[job] for job in jobs], ignore_index=True))


def errors_on_planned_bench(campaign_path: Path, acquisition_by_run: dict[str, dict], calibrate: bool,
                            bench_seed: int) -> pd.DataFrame:
    """`errors_on_bench` of the campaign with these settings, on bench `bench_seed`."""
    with tempfile.TemporaryDirectory(prefix="squeezebench-check-") as tmp:
        planned = planned_campaign(campaign_path, acquisition_by_run, calibrate, Path(tmp) / campaign_path.name)
        return errors_on_bench(planned, bench_seed, Path(tmp) / "bench")


def _settings(plan: Plan) -> dict[str, dict]:
    return {name: dataclasses.asdict(setting) for name, setting in plan.settings_by_run.items()}


def plan_campaign(campaign_path: Path, target_rel_error: float = 0.01, write: Path | None = None,
                  workers: int = 1, scheduler: Any = None) -> str:
    """The `squeezebench plan` table: per run the setting, error and bench times; with
    `write`, also the campaign file with the planned settings, ready to run."""
    plan = make_plan(Path(campaign_path), target_rel_error, workers=workers, scheduler=scheduler)
    return plan_text(plan, write_planned_campaign(Path(campaign_path), plan, Path(write)) if write else None)


def plan_text(plan: Plan, written: Path | None) -> str:
    """The plan's table, and where its campaign file was written (with the calibration it carries)."""
    if written is None:
        return plan.table()
    carries = f" (with the {CALIBRATION_RUN} it assumes first)" if plan.calibrate else ""
    return plan.table() + f"\nplanned campaign written to {written}{carries}"


def write_planned_campaign(campaign_path: Path, plan: Plan, out: Path) -> Path:
    """The campaign file with the plan's acquisition settings, ready for `squeezebench run`."""
    return planned_campaign(campaign_path, _settings(plan), plan.calibrate, out)
