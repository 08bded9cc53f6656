"""Velocity, amplitude, a map's mean velocity and the resonance frequency on a stored coverage
study: are their misses sampling, or an error their budget lacks? (issue 46; prints figures,
not a test)

For each error model the study holds (`squeezebench study --coverage-errors ...`):

1. Each bench's drawn instrument errors, rebuilt from its bench seed through the simulator's
   own effects (the draw is the seed's: nothing else is needed).
2. Each stored value's error decomposed into them: (1 + CH3 gain)(1 + decoder scale)(1 - s
   generator) - 1 (a resonance frequency: no gains), s the value's sensitivity to the
   generator's frequency error (fitted across the benches: the resonance's slope at a detuned
   point; -1 for a search, from physics: `SENSITIVITY`). What is left is the noise and a bias the drawn terms do not give
   (a warm plate's lower resonance); a term the budget lacks would show here as a residual beyond it.
3. The expected coverage: the same terms drawn on many benches by the simulator's effects (no
   bench simulation), each stored value's U (relative to its reading, as the budget
   sizes it) and noise; the spread of a study of as many benches as the stored one (values on
   one bench share its draw, so benches, not values, are the trials), and how often such a
   study reads at most the observed coverage. Beside it, what the study's own benches' drawn
   terms give through the same decomposition (it matching the observed says the bench
   simulation adds nothing the terms miss: a shortfall is then its seeds' draw), and with
   --predict-benches N what the study's seeds 1..N will read, from their draws alone: a study
   always takes seeds 1..N, so its table reads those benches' luck, before any is simulated.
4. What the budgets claim: `Budget.coverage_probability` of the velocity's budget at its k;
   and what a margin for the study's size would cost: the k at which a study of that many
   benches reads 95 % or more 19 times in 20 (a bench's values all covered or all missed, as
   they nearly are: at most 5 % of the benches may miss), its U against today's and its
   coverage within specification.

Run: python benchmarks/world_coverage.py STUDY_DIR [--benches 100000] [--predict-benches 240]
(STUDY_DIR holds coverage/ and/or coverage_world/, e.g. OUT/study after `squeezebench study --out OUT`.)
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import optimize
from scipy.special import ndtr
from scipy.stats import binom

from squeezebench import paths
from squeezebench.analysis.budgets import SPECIFIED, WORLD, Budget
from squeezebench.analysis.study import coverage_dir
from squeezebench.analysis.uncertainty import velocity_budget
from squeezebench.protocols.variants import ERROR_MODELS
from squeezebench.simbench import effects as fx
from squeezebench.simbench.scene import load_scene

QUANTITIES = ("velocity_pp_mps", "amplitude_pp_m", "map_mean_velocity_pp_mps", "map_max_velocity_pp_mps",
              "resonance_frequency_hz")
#: Up to this many values of a quantity in the campaign, each value's expected coverage is printed.
PER_VALUE_MAX = 20
#: The drawn gains a quantity reads through (a search's frequency is the generator's setting alone).
GAINS = dict.fromkeys(QUANTITIES, ("scope_gain_error", "vibrometer_scale_error")) | {"resonance_frequency_hz": ()}
#: A sensitivity to the generator's error known from physics, not fitted across benches (whose
#: fit would take the values' noise for part of it): a search finds the setting f0 / (1 + e).
SENSITIVITY = {"resonance_frequency_hz": -1.0}
#: The simulated errors a velocity carries (effect: its error parameter), as its budget's terms.
TERMS = {"scope_gain_error": "ch3_rel", "vibrometer_scale_error": "scale_rel",
         "generator_frequency_error": "frequency_rel"}


def drawn_terms(error_model: str, seeds, names=tuple(TERMS)) -> pd.DataFrame:
    """Each bench's drawn errors of the effects `names` (columns; a velocity's by default), as
    the simulator draws them."""
    scene = load_scene(paths.scenes_dir() / "one_column_1mm.yaml")
    draw = ERROR_MODELS[error_model]
    return pd.DataFrame({name: [fx.EFFECTS[name](scene, draw=draw, bench_seed=int(seed)).values[TERMS[name]]
                                for seed in seeds] for name in names}, index=pd.Index(seeds, name="bench_seed"))


def stored_benches(study_dir: Path, error_model: str) -> pd.DataFrame | None:
    """The coverage study's rows under `error_model`, bench by bench (None: it ran none)."""
    files = sorted((study_dir / coverage_dir(error_model)).glob("bench_*.parquet"))
    return pd.concat([pd.read_parquet(f) for f in files], ignore_index=True) if files else None


def decomposed(study: pd.DataFrame, terms: pd.DataFrame, gains: tuple[str, ...],
               sensitivity: float | None = None) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The study's values with their error's residual after the drawn terms (`gains` and the
    generator), and one row per value of the campaign (run, step, point): its U relative to
    its reading, its sensitivity to the generator's error, the residual's mean (a bias the
    drawn terms do not give) and spread (its noise)."""
    x = study.join(terms, on="bench_seed")
    instruments = pd.Series(np.prod([1 + x[name] for name in gains], axis=0) - 1, index=x.index)
    rows = []
    for key, value in x.groupby(["run_name", "step_id", "point_index"]):
        left = (1 + value["rel_error"]) / (1 + instruments.loc[value.index]) - 1
        generator = value["generator_frequency_error"]
        slope = sensitivity if sensitivity is not None else (
            float(np.polyfit(generator, left, 1)[0]) if generator.std() > 0 else 0.0)
        residual = left - slope * generator
        rows.append({"run_name": key[0], "step_id": key[1],
                     "c": float((value["rel_expanded_u"] / (1 + value["rel_error"])).median()), "sensitivity": slope,
                     "bias": float(np.mean(residual)), "noise": float(np.std(residual)), "worst_residual_over_u": float(np.max(np.abs(residual)) /
                                                                                      value["rel_expanded_u"].min())})
    return x, pd.DataFrame(rows)


def bench_coverage(values: pd.DataFrame, terms: pd.DataFrame, gains: tuple[str, ...]) -> np.ndarray:
    """Each drawn bench's share of `values` whose U covers its error (the noise integrated)."""
    instruments = np.prod([1 + terms[name].to_numpy() for name in gains], axis=0)
    generator = terms["generator_frequency_error"].to_numpy()
    share = np.zeros(len(terms))
    for v in values.itertuples():
        error = instruments * (1 + v.sensitivity * generator) - 1 + v.bias
        # |m - t| <= U with U = c m: the error e = m / t - 1 lies in [-c / (1 + c), c / (1 - c)]
        high, low = v.c / (1 - v.c), -v.c / (1 + v.c)
        noise = max(v.noise, 1e-12)
        share += ndtr((high - error) / noise) - ndtr((low - error) / noise)
    return share / len(values)


def margin_k(budget: Budget, benches: int, confidence: float = 0.95) -> float:
    """The k at which a study of `benches` world benches, each missing with the probability
    the budget's world model gives, has at most 5 % of them missed with `confidence`."""
    allowed = int(np.floor(0.05 * benches))
    miss = optimize.brentq(lambda p: binom.cdf(allowed, benches, p) - confidence, 1e-6, 0.5)
    return optimize.brentq(lambda k: budget.coverage_probability(k, WORLD) - (1.0 - miss), 1.0, 4.0)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study_dir", type=Path)
    parser.add_argument("--benches", type=int, default=100_000, help="drawn benches for the expectation")
    parser.add_argument("--predict-benches", type=int, default=0, metavar="N",
                        help="also give what a study of seeds 1..N reads, from their drawn terms alone")
    args = parser.parse_args()
    claim = velocity_budget({"velocity_pp_mps": 1.0, "velocity_pp_mps_u": 1e-3, "frequency_hz": 40e3})
    print(f"velocity budget (CH3 gain, decoder scale, noise 0.1 %): k {claim.coverage_factor:.3f}, "
          f"U {claim.expanded_uncertainty:.2%}")
    rng = np.random.default_rng(46)
    for error_model in ERROR_MODELS:
        study = stored_benches(args.study_dir, error_model)
        if study is None:
            continue
        seeds = sorted(study["bench_seed"].unique())
        started = time.process_time()
        many = drawn_terms(error_model, range(10_000_001, 10_000_001 + args.benches))
        terms = drawn_terms(error_model, seeds)
        ahead = drawn_terms(error_model, range(1, args.predict_benches + 1)) if args.predict_benches else None
        print(f"\n== {error_model}: {len(seeds)} benches in the study; {args.benches} benches drawn "
              f"({time.process_time() - started:.0f} CPU-s); the budget claims "
              f"{claim.coverage_probability(claim.coverage_factor, error_model):.2%}")
        for quantity in QUANTITIES:
            values, template = decomposed(study[study["quantity"] == quantity], terms, GAINS[quantity],
                                          SENSITIVITY.get(quantity))
            if template.empty:
                continue
            per_bench = bench_coverage(template, many, GAINS[quantity])
            studies = per_bench[rng.integers(0, len(per_bench), size=(100_000, len(seeds)))].mean(axis=1)
            observed = float(values["covered"].mean())
            low, high = np.percentile(studies, [2.5, 97.5])
            print(f"{quantity}: observed {observed:.2%}, expected {per_bench.mean():.2%} "
                  f"(Monte Carlo u {per_bench.std() / np.sqrt(len(per_bench)):.2%}); a {len(seeds)}-bench study: "
                  f"95 % within {low:.1%}-{high:.1%}, P(<= observed) {np.mean(studies <= observed + 1e-12):.2f}, "
                  f"P(< 95 %) {np.mean(studies < 0.95 - 1e-12):.2f}; noise left after the drawn terms "
                  f"{template['noise'].median():.3%} (median), worst residual / U {template['worst_residual_over_u'].max():.2f}")
            observed_by_bench = values.groupby("bench_seed")["covered"].mean().reindex(seeds).to_numpy()
            own = bench_coverage(template, terms, GAINS[quantity])
            print(f"    the study's own benches' drawn terms give {own.mean():.2%} (a bench's share within "
                  f"{np.max(np.abs(own - observed_by_bench)):.1%} of its observed one)"
                  + (f"; seeds 1-{args.predict_benches}: {bench_coverage(template, ahead, GAINS[quantity]).mean():.2%}"
                     if ahead is not None else ""))
            if error_model == WORLD and quantity == QUANTITIES[0]:
                k = margin_k(claim, len(seeds))
                print(f"    a margin for {len(seeds)} benches: k {k:.3f} covering {claim.coverage_probability(k, WORLD):.1%} "
                      f"of the world's errors, U {k / claim.coverage_factor - 1:+.1%}, within specification "
                      f"{claim.coverage_probability(k, SPECIFIED):.1%}")
            if len(template) <= PER_VALUE_MAX:   # a few values (a campaign's searches): each its own expectation
                observed_by_value = values.groupby(["run_name", "step_id", "point_index"], sort=False)["covered"].mean()
                for v, seen in zip(template.itertuples(), observed_by_value):
                    print(f"    {v.run_name} {v.step_id}: observed {seen:.1%}, expected "
                          f"{bench_coverage(template[template.index == v.Index], many, GAINS[quantity]).mean():.2%}; "
                          f"bias left {v.bias / v.c:+.2f} U, noise {v.noise / v.c:.2f} U")
            missed = values.groupby("bench_seed")["covered"].mean()
            for seed in missed[missed < 1].index:
                t = terms.loc[seed]
                print(f"    bench {seed}: covered {missed[seed]:.0%}; CH3 gain {t['scope_gain_error']:+.2%}, decoder scale "
                      f"{t['vibrometer_scale_error']:+.2%}, generator {t['generator_frequency_error'] * 1e6:+.1f} ppm")
    return 0


if __name__ == "__main__":
    sys.exit(main())
