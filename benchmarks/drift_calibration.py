"""Is the nine-column plate's resonance-drift u calibrated? (issue 46; prints figures, not a test)

Fig. 2's Pt/P0 of the nine-column plate is corrected for the resonance's drift while the run
measured (`analysis.resonance_drift._warming_estimates`: an estimate e per point and its u),
and its largest budget term is that u. This runs the paper campaign's `fig2_nine_column`
alone on seeded benches built as the coverage study builds them (`bench_errors.errors_on_bench`:
instrument errors, the plate drawn within its tolerances and warming as drawn,
`variants.plate_warming_effects`, its own noise), records the simulated plate's TRUE drift
while it measures (`simbench.effects.HeatingDrift`'s temperature rise, the one its load
follows, against the bench clock: f alpha T with its drawn alpha, T including the room's
ramp) and compares it at each stored point's bench time with the estimate: (e - true) / u.
A calibrated u gives a spread of about 1 (p95 of |.| 1.96 for a normal error, 1.65 for a
rectangle); much less says u overstates.

Beside it the parts of u (`_warming_estimates`): the scale's, the spread over the time
constants the readings allow (a rectangle) and the room's (a rectangle), RMS over the points;
and the scale the readings fit at the plate's own drawn time constant over its true one.

Seeds 1-40 within specification: e 85 % of the fall (median), (e - true) / u +0.47 +- 0.53,
p95 |.| 1.47, u 4.35 Hz RMS (the scale's 4.32, the time constants' 0.45, the room's 0.19), the
readings' scale 0.84 of the plate's: the re-centrings' walks stopped on the side they came
from. With each reading corrected for its stop's mean (`recentring_stop_moments_hz`): 91 %,
+0.29 +- 0.56, p95 1.07, u 3.35 Hz RMS, the scale 0.91 (docs/coverage.md). About 1 CPU s a bench.

Run: python benchmarks/drift_calibration.py [--benches 20] [--first-seed 1] [--error-model specified]
     [--csv rows.csv]
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from squeezebench import paths
from squeezebench.analysis import resonance_drift
from squeezebench.analysis.rundata import load_run
from squeezebench.analysis.uncertainty import run_uncertainties
from squeezebench.protocols.campaign import run_campaign
from squeezebench.protocols.steps import StepContext
from squeezebench.protocols.variants import (campaign_with_effects, plate_draw_effects, plate_warming_effects,
                                             systematic_effects)
from squeezebench.plates import warming
from squeezebench.simbench import effects as fx
from squeezebench.yamlfiles import dump_yaml, load_strict

RUN = "fig2_nine_column"
DESKEW_RUN = "deskew_calibration"
#: Fig. 2's rows read on the resonance's slope (their drift is an estimate of the plate's fall;
#: a P0 or closing row's is its setting's offset).
SLOPE_PHASES = ("detuned", "regained")
#: The effect's drawn parameters kept beside its truth.
DRAWN = ("frequency_coefficient_per_k", "convection_w_per_m2_k", "specific_heat_j_per_kg_k", "room_drift_k_per_s")


def one_run_campaign(out_dir: Path, run_name: str = RUN) -> Path:
    """The paper campaign with `run_name` its only run besides its deskew calibration (which
    lifts the CH2 delay from Fig. 2's budgets: without it Pt/P0's U is another's)."""
    data = load_strict(paths.paper_campaign().read_text(encoding="utf-8"))
    data["runs"] = [run for run in data["runs"] if run["name"] in (run_name, DESKEW_RUN)]
    target = Path(out_dir) / "campaign.yaml"
    target.write_text(dump_yaml(data), encoding="utf-8")
    return target


class TruthRecorder:
    """Wraps `HeatingDrift._advance` (and `attach`) to record the temperature rise its load
    follows (`state_key`) and its drawn frequency coefficient against the bench clock, and
    `StepContext` to record each step's bench clock and campaign bench time at its start,
    which map the clock onto the stored points' bench time."""

    def __init__(self) -> None:
        self.rows: list[tuple[float, float]] = []
        self.steps: list[tuple[float, float]] = []
        self.drawn: dict[str, float] = {}

    def __enter__(self):
        advance, attach, init = fx.HeatingDrift._advance, fx.HeatingDrift.attach, StepContext.__init__
        rows, steps = self.rows, self.steps

        def recorded_init(ctx, *args, **kwargs) -> None:
            init(ctx, *args, **kwargs)
            steps.append((ctx.clock_start_s, ctx.bench_time_base_s))

        def recorded_advance(effect, start_s: float, duration_s: float) -> None:
            advance(effect, start_s, duration_s)
            rows.append((start_s + duration_s, effect.state_key()))

        def recorded_attach(effect, bench) -> None:
            attach(effect, bench)
            self.drawn = {"time_constant_s": effect.time_constant_s,
                          "thermal_resistance_k_per_w": effect.thermal_resistance_k_per_w,
                          **{key: effect.parameters[key] for key in DRAWN}}
            rows.append((bench.clock.now_s(), effect.state_key()))

        self._saved = advance, attach, init
        fx.HeatingDrift._advance, fx.HeatingDrift.attach, StepContext.__init__ = (recorded_advance, recorded_attach,
                                                                                  recorded_init)
        return self

    def __exit__(self, *exc) -> None:
        fx.HeatingDrift._advance, fx.HeatingDrift.attach, StepContext.__init__ = self._saved

    def frame(self) -> pd.DataFrame:
        """The recorded rise against campaign bench time (the clock mapped through the step
        it fell in: bench time = the step's base + the clock since the step's start)."""
        frame = pd.DataFrame(self.rows, columns=["clock_s", "rise_k"])
        frame = frame.drop_duplicates("clock_s", keep="last").sort_values("clock_s")
        starts = pd.DataFrame(self.steps, columns=["clock_s", "base_s"]).sort_values("clock_s")
        step = np.clip(np.searchsorted(starts["clock_s"], frame["clock_s"], side="right") - 1, 0, len(starts) - 1)
        frame["bench_time_s"] = (starts["base_s"].to_numpy()[step] + frame["clock_s"].to_numpy()
                                 - starts["clock_s"].to_numpy()[step])
        return frame


class FitRecorder:
    """Wraps `resonance_drift.drifts_over_time_constants` to keep what `_warming_estimates`
    chose among (its arguments and fits), for the parts of u and the scale at the plate's
    own time constant."""

    def __init__(self) -> None:
        self.calls: list[tuple[tuple, list]] = []

    def __enter__(self):
        fits_of = self._saved = resonance_drift.drifts_over_time_constants

        def recorded(*args):
            fits = fits_of(*args)
            self.calls.append((args, fits))
            return fits

        resonance_drift.drifts_over_time_constants = recorded
        return self

    def __exit__(self, *exc) -> None:
        resonance_drift.drifts_over_time_constants = self._saved


def u_parts(points: pd.DataFrame, call: tuple[tuple, list], drawn: dict[str, float]) -> pd.DataFrame:
    """Each point's u parts as `_warming_estimates` combines them: the scale's (the largest
    u(k) E over the time constants the readings allow), the spread over those (their range
    as a rectangle) and the room's (a rectangle at `warming.room_drift_bound_hz`); and the
    scale the readings fit at the plate's own drawn time constant over its true one,
    f |alpha| / C (C = tau / R_th)."""
    (times_s, power_w, readings, when_s, scale_range, _), fits = call
    least = min(chi2 for chi2, _, _ in fits)
    allowed = [(drift, drift_u) for chi2, drift, drift_u in fits if chi2 <= least + resonance_drift.CHI2_95_ONE]
    drifts = np.array([drift for drift, _ in allowed])[:, :-1]   # the last: the first reading's time
    elapsed_s = when_s[:-1] - times_s[0]
    tau_s = drawn["time_constant_s"]
    (_, own_drift, _), *_ = resonance_drift.drifts_over_time_constants(times_s, power_w, readings, when_s, scale_range,
                                                                       (tau_s, tau_s))
    own_heat_j = np.interp(when_s, times_s, warming.held_heat_j(times_s, power_w, tau_s))
    true_scale = float(readings["frequency_hz"].iat[0]) * abs(drawn["frequency_coefficient_per_k"]) * drawn[
        "thermal_resistance_k_per_w"] / tau_s
    return pd.DataFrame({
        "u_scale_hz": np.max([drift_u[:-1] for _, drift_u in allowed], axis=0),
        "u_time_constants_hz": np.ptp(drifts, axis=0) / math.sqrt(12.0),
        "u_room_hz": warming.room_drift_bound_hz(points["generator_frequency_hz"].to_numpy(float), elapsed_s)
        / math.sqrt(3.0),
        "time_constants_allowed": len(allowed),
        "scale_at_own_tau_over_true": -own_drift[-2] / own_heat_j[-2] / true_scale if own_heat_j[-2] > 0 else math.nan,
    }, index=points.index)


def bench_rows(seed: int, error_model: str, work_dir: Path) -> pd.DataFrame:
    """Each stored Fig. 2 point of the run on bench `seed`: its drift estimate, u and the
    simulated plate's true drift at its bench time."""
    campaign = one_run_campaign(work_dir)
    effects = (systematic_effects(seed, error_model=error_model) + plate_draw_effects(seed, error_model)
               + plate_warming_effects(seed, error_model))
    erring = campaign_with_effects(campaign, work_dir / "erring", effects, noise_seed=seed)
    with TruthRecorder() as recorder:
        run_dir = run_campaign(erring, out_dir=work_dir / "run", progress=False, durable=False)
    truth = recorder.frame()
    run = load_run(run_dir)
    with FitRecorder() as fitted:
        points = run_uncertainties(run).points
    points = points[(points["run_name"] == RUN) & (points["protocol"] == "detuning")].copy()
    (call,) = fitted.calls   # one run of Fig. 2 points, its plate's warming estimated once
    points = points.join(u_parts(points, call, recorder.drawn))
    rise_k = np.interp(points["bench_time_s"].to_numpy(float), truth["bench_time_s"], truth["rise_k"])
    alpha = recorder.drawn["frequency_coefficient_per_k"]
    cold_hz = float(points["generator_frequency_hz"][points["detuning_phase"] == "resonance"].iloc[0])
    points["true_drift_hz"] = cold_hz * alpha * rise_k
    for key, value in recorder.drawn.items():
        points[key] = value
    points["bench_seed"] = seed
    return points[["bench_seed", "step_id", "detuning_phase", "bench_time_s", "generator_frequency_hz", "power_w",
                   "resonance_drift_hz", "resonance_drift_u_hz", "resonance_drift_bound_hz", "true_drift_hz",
                   "u_scale_hz", "u_time_constants_hz", "u_room_hz", "time_constants_allowed",
                   "scale_at_own_tau_over_true", *recorder.drawn]]


def rms(values: pd.Series) -> float:
    return float(np.sqrt(np.mean(np.square(values))))


def summary(z: np.ndarray) -> str:
    return (f"n {len(z)}  mean {np.mean(z):+.2f}  sd {np.std(z, ddof=1):.2f}  "
            f"p95 |.| {np.quantile(np.abs(z), 0.95):.2f}  max |.| {np.max(np.abs(z)):.2f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--benches", type=int, default=20)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--error-model", default="specified")
    parser.add_argument("--csv", type=Path)
    args = parser.parse_args()
    started = time.process_time()
    frames = []
    for seed in range(args.first_seed, args.first_seed + args.benches):
        with tempfile.TemporaryDirectory() as scratch:
            frames.append(bench_rows(seed, args.error_model, Path(scratch)))
    rows = pd.concat(frames, ignore_index=True)
    if args.csv:
        rows.to_csv(args.csv, index=False)
    slope = rows[rows["detuning_phase"].isin(SLOPE_PHASES)]
    z = ((slope["resonance_drift_hz"] - slope["true_drift_hz"]) / slope["resonance_drift_u_hz"]).to_numpy()
    print(f"{RUN}: {args.benches} benches from seed {args.first_seed} ({args.error_model}), "
          f"{len(slope)} slope points (detuned, regained)")
    print(f"  estimate e {slope['resonance_drift_hz'].median():+.2f} Hz median, true "
          f"{slope['true_drift_hz'].median():+.2f} Hz median, u {slope['resonance_drift_u_hz'].median():.2f} Hz median "
          f"({slope['resonance_drift_u_hz'].max():.2f} max)")
    share = slope["resonance_drift_hz"] / slope["true_drift_hz"]
    print(f"  e / true (the share of the fall estimated): median {share.median():.3f}, "
          f"quartiles {share.quantile(0.25):.3f}-{share.quantile(0.75):.3f}")
    print(f"  (e - true) / u: {summary(z)}  (calibrated: sd ~1, p95 1.65 rectangle to 1.96 normal)")
    for phase, group in slope.groupby("detuning_phase"):
        zz = ((group["resonance_drift_hz"] - group["true_drift_hz"]) / group["resonance_drift_u_hz"]).to_numpy()
        print(f"    {phase:9s} {summary(zz)}")
    print(f"  u's parts, RMS over the points (Hz): the scale's {rms(slope['u_scale_hz']):.2f}, the time constants' "
          f"rectangle {rms(slope['u_time_constants_hz']):.2f}, the room's {rms(slope['u_room_hz']):.2f} "
          f"(u {rms(slope['resonance_drift_u_hz']):.2f}); time constants allowed: "
          f"{slope['time_constants_allowed'].min()}-{slope['time_constants_allowed'].max()} of "
          f"{resonance_drift.TIME_CONSTANT_STEPS}")
    per_bench = slope.groupby("bench_seed").first()
    own = per_bench["scale_at_own_tau_over_true"]
    print(f"  the scale the readings fit at the plate's own time constant over its true f |alpha| / C: median "
          f"{own.median():.3f}, range {own.min():.3f}-{own.max():.3f} ({len(own)} benches)")
    print(f"  CPU {time.process_time() - started:.0f} s")


if __name__ == "__main__":
    main()
