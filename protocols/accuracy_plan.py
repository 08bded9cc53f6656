"""The floor a bench's specified errors put under a campaign, and what lifts it.

Averaging, longer records and finer searches only shrink the noise. What stays is the
instruments' specified errors (`plates.specifications`): per run, the p95 relative
error they leave at its worst stored point is the run's floor
(`analysis.uncertainty.systematic_floor`; Q and tan theta' of characterised plates:
`characterisation_floor`, their tolerances mostly). A target below the floor cannot be planned
with scope settings; a calibration protocol may lift the dominant term (the deskew
calibration replaces the CH2 delay by what it measured), at the bench time it costs.

Everything is measured on the simulated bench: the campaign is run once as written,
preceded by the deskew calibration, and its stored points give the floors, the
calibration's own uncertainty and cost, and the campaign's own bench time per run.
"""

from __future__ import annotations

import dataclasses
import math
import tempfile
from pathlib import Path

import pandas as pd

from squeezebench.analysis.rundata import load_run
from squeezebench.analysis.uncertainty import (REFERENCE_FOR, characterisation_floor, deskewed, stored_points,
                                               systematic_floor)
from squeezebench.protocols.bench_errors import bench_time_by_run_s
from squeezebench.protocols.variants import carries_calibration, with_calibration, without_maps
from squeezebench.protocols.campaign import run_campaign
from squeezebench.errors import UserError

CALIBRATION_RUN = "deskew_calibration"
QUANTITIES = ("power_w", "velocity_pp_mps", "q", "tan_theta")


@dataclasses.dataclass(frozen=True)
class RunFloor:
    run_name: str
    quantity: str
    floor_p95_rel: float            # as the bench is
    dominant_term: str
    calibrated_floor_p95_rel: float  # after the deskew calibration
    calibrated_dominant_term: str


@dataclasses.dataclass
class AccuracyFloors:
    target_rel_error: float
    floors: list[RunFloor]
    own_bench_time_s: dict[str, float]   # the campaign as written, per run
    calibration_bench_time_s: float
    deskew_std_uncertainty_s: float
    #: Calibrate although every floor is below the target: a check on simulated benches
    #: found the uncalibrated floors too close to it (they are normal approximations).
    calibration_forced_by: str = ""
    #: The campaign carries its own deskew calibration (the shipped ones do): every plan keeps it.
    own_calibration: bool = False

    def floor(self, run_name: str, calibrated: bool) -> float:
        """The run's floor over its quantities."""
        return max(f.calibrated_floor_p95_rel if calibrated else f.floor_p95_rel
                   for f in self.floors if f.run_name == run_name)

    def calibrated_runs(self) -> list[str]:
        """Runs whose floor is above the target and that the calibration lowers: to the
        target, or, where the target is below even the calibrated floor, as far as it goes
        (the plan's noise allowance there assumes the calibrated floor, so the plan must
        carry the calibration)."""
        return [run for run in self.own_bench_time_s
                if self.floor(run, False) > self.target_rel_error and self.floor(run, True) < self.floor(run, False)]

    def below_floor(self) -> list[RunFloor]:
        """(run, quantity) whose floor, even calibrated, is above the target."""
        return [f for f in self.floors if f.calibrated_floor_p95_rel > self.target_rel_error]

    @property
    def calibrate(self) -> bool:
        """Whether the plan calibrates: once, first, and its correction serves every run."""
        return bool(self.calibrated_runs() or self.calibration_forced_by or self.own_calibration)

    @property
    def own_bench_time_with_calibration_s(self) -> dict[str, float]:
        """The campaign as written, per run, with its own calibration when it carries one."""
        own = {CALIBRATION_RUN: self.calibration_bench_time_s} if self.own_calibration else {}
        return {**own, **self.own_bench_time_s}

    def scaled(self, factors: dict[str, float]) -> "AccuracyFloors":
        """These floors with each quantity's multiplied by `factors[quantity]` (1 where it has
        none), calibrated or not: the floors the specified errors would leave if the budgets
        were that much narrower (`analysis.over_coverage.shrink_factors`: a budget whose U
        over-covers by that factor puts its floor, the same budget's systematic part, that much
        too high)."""
        def scale(f: RunFloor) -> RunFloor:
            factor = factors.get(f.quantity, 1.0)
            return dataclasses.replace(f, floor_p95_rel=f.floor_p95_rel * factor,
                                       calibrated_floor_p95_rel=f.calibrated_floor_p95_rel * factor)
        return dataclasses.replace(self, floors=[scale(f) for f in self.floors])

    def planned_floor(self, run_name: str) -> float:
        return self.floor(run_name, self.calibrate)

    def noise_allowance(self, run_name: str) -> float:
        """The p95 noise error left to the scope settings: errors add in quadrature."""
        return math.sqrt(max(self.target_rel_error**2 - self.planned_floor(run_name)**2, 0.0))

    def lines(self) -> list[str]:
        out = ["accuracy floor: p95 |relative error| the instruments' specified errors (and for Q and tan theta' the "
               "plates' tolerances) leave, noise averaged away",
               f"{'run':<24} {'quantity':<16} {'floor':>7} {'dominant term':<32} {'deskewed':>8} dominant term"]
        for f in self.floors:
            out.append(f"{f.run_name:<24} {f.quantity:<16} {f.floor_p95_rel:>7.2%} {f.dominant_term:<32} "
                       f"{f.calibrated_floor_p95_rel:>8.2%} {f.calibrated_dominant_term}")
        if self.calibrate:
            needed = (", ".join(self.calibrated_runs()) or self.calibration_forced_by
                      or "every run (the campaign carries it)")
            out.append(f"calibration plan: one deskew_calibration step first ({self.calibration_bench_time_s:.1f} s of "
                       f"bench time; CH2 delay then known to {self.deskew_std_uncertainty_s * 1e9:.2f} ns, the "
                       f"current path's gain checked against the voltage path's), needed by {needed}; "
                       "its correction serves every run")
        below = self.below_floor()
        if below:
            worst = max(below, key=lambda f: f.calibrated_floor_p95_rel)
            out.append(f"target {self.target_rel_error:g} is below the reachable floor of {len(below)} "
                       f"(run, quantity) pairs; the lowest floor there is "
                       f"{min(f.calibrated_floor_p95_rel for f in below):.2%}, the highest {worst.calibrated_floor_p95_rel:.2%} "
                       f"({worst.run_name} {worst.quantity}), limited by {worst.calibrated_dominant_term}")
            for term in sorted({f.calibrated_dominant_term for f in below}):
                out.append(f"  {term}: no calibration protocol of this bench lifts it; it needs "
                           f"{REFERENCE_FOR.get(term, 'a reference for this term')}")
        return out

    def as_dict(self) -> dict:
        return {"target_rel_error": self.target_rel_error,
                "floors": [dataclasses.asdict(f) for f in self.floors],
                "calibration": {"protocol": CALIBRATION_RUN, "planned": self.calibrate,
                                "bench_time_s": self.calibration_bench_time_s,
                                "deskew_std_uncertainty_s": self.deskew_std_uncertainty_s,
                                "runs": self.calibrated_runs(), "forced_by": self.calibration_forced_by},
                "below_floor": [dataclasses.asdict(f) for f in self.below_floor()],
                "reference_needed": {f.calibrated_dominant_term: REFERENCE_FOR.get(f.calibrated_dominant_term, "")
                                     for f in self.below_floor()}}


def accuracy_floors(campaign_path: Path, target_rel_error: float,
                    measured: tuple[list[RunFloor], dict[str, float], float, float] | None = None) -> AccuracyFloors:
    """The campaign's floors against `target_rel_error`, from `measure_floors` (`measured`:
    what it returned, e.g. kept by an earlier plan)."""
    return AccuracyFloors(target_rel_error, *(measured or measure_floors(campaign_path)),
                          own_calibration=carries_calibration(campaign_path))


def measure_floors(campaign_path: Path) -> tuple[list[RunFloor], dict[str, float], float, float]:
    """Run the campaign once (simulated, calibration first) and read what its floors are at
    any target: the floors per run and quantity, the bench time per run, the calibration's
    bench time and its deskew's standard uncertainty (s)."""
    with tempfile.TemporaryDirectory(prefix="squeezebench-floor-") as tmp:
        variant = without_maps(with_calibration(Path(campaign_path), Path(tmp) / Path(campaign_path).name))
        run_dir = run_campaign(variant, out_dir=Path(tmp) / "run", progress=False, durable=False)
        run = load_run(run_dir)
        # the powers as the report's budgets correct them; the floors need no budget's
        # expanded uncertainty (`run_uncertainties` convolves a distribution for each)
        stored, deskew = stored_points(run)
        if stored is None:   # no floor without a point to read it at: said here, not as a crash in the budgets
            raise UserError(f"{Path(campaign_path).name}: its run on the simulated bench stored no measured point "
                            "(no step kept its waveforms), so the floors the instruments' specified errors leave "
                            "cannot be read; the planner needs runs that store points")
        points, _ = deskewed(stored, deskew)
        times_s = bench_time_by_run_s(run_dir)
        # Q and tan theta' of the characterised plates: floors of their own (tolerances, mostly)
        plain = pd.concat([systematic_floor(points), characterisation_floor(run)]).set_index(
            ["run_name", "quantity"])
        calibrated = pd.concat([systematic_floor(points, deskew),
                                characterisation_floor(run, deskew)]).set_index(["run_name", "quantity"])
    deskew_u_s = deskew.std_uncertainty_s
    floors = [RunFloor(run, quantity, float(row["floor_p95_rel"]), row["dominant_term"],
                       float(calibrated.loc[(run, quantity), "floor_p95_rel"]),
                       calibrated.loc[(run, quantity), "dominant_term"])
              for (run, quantity), row in plain.iterrows() if quantity in QUANTITIES]
    calibration_s = times_s.pop(CALIBRATION_RUN)
    return floors, times_s, calibration_s, deskew_u_s
