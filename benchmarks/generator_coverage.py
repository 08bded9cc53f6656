"""Fig. 2's Pt/P0 and the searches' resonance frequencies on a stored coverage study: why do
they over-cover within specification? (issue 46; prints figures, not a test)

Both are mostly the generator's frequency error, one +-20 ppm limit. For each value of the
campaign (run, step) across the study's benches:

1. The bench's drawn generator error, rebuilt from its bench seed through the simulator's own
   effect (`world_coverage.drawn_terms`), and the value's relative error fitted on
   it: its sensitivity a (the generator's term is |a| times the limit, a rectangle), the
   offset and the residual's spread (noise, the other instruments, the plate as drawn).
2. The budget such a value would have were every term exactly right: the rectangle |a| 20 ppm
   and the residual as a normal Type A term, with k by the budgets' own rule
   (`Budget.coverage_factor`: the largest of the specified and the world's 95 % factors). The
   stored U over that exact U says whether a term of the stored budget is mis-sized (1: none).
3. The coverage expected of the stored U under the errors as they are (the fitted sensitivity,
   offset and residual; the generator drawn on many benches as the study's error model draws
   it), with the spread of a study of as many benches as the stored one: is the observed
   coverage that, or sampling?
4. What the k rule costs: the same exact budgets with the specified model's own k, their
   expected coverage within specification and under the world's draw, with the fitted
   offsets and without them (were every bias corrected).
   And how often a study of 40 or 120 such benches has its 95 % interval
   (`study.coverage_interval`) reach 95 % (a bench's values covered binomially at its
   expected share: they share its generator error, their residuals taken as independent).
5. With --budgets-of-bench SEED, term by term: the campaign run once on that specified bench
   (some 10 CPU-s) and each value's stored budget, its generator term against the fitted
   sensitivity's, its other terms against the residual.

6. With --clean-bench SEED, where Pt/P0's offsets come from: the campaign run once on that
   bench's plates with no instrument error drawn (its noise its own), each Fig. 2 point's
   power (the integer-period mean the tables use, and the sine fits' cross-check, which has
   no window) and velocity against the truth, by run, phase and target ratio.

Run: python benchmarks/generator_coverage.py STUDY_DIR [--benches 20000] [--budgets-of-bench 1] [--clean-bench 1]
(STUDY_DIR holds coverage/ and/or coverage_world/, e.g. OUT/study after `squeezebench study --out OUT`.)
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.special import ndtr

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from world_coverage import drawn_terms, stored_benches  # noqa: E402

from squeezebench import paths  # noqa: E402
from squeezebench.analysis import uncertainty  # noqa: E402
from squeezebench.analysis.budgets import (COVERAGE_PROBABILITY, SPECIFIED, WORLD, Budget, Term,  # noqa: E402
                                           budget_distribution)
from squeezebench.analysis.rundata import load_run  # noqa: E402
from squeezebench.analysis.study import coverage_interval  # noqa: E402
from squeezebench.analysis.tables import detuning_points  # noqa: E402
from squeezebench.plates.specifications import SPECIFICATIONS  # noqa: E402
from squeezebench.protocols.bench_errors import _truths  # noqa: E402
from squeezebench.protocols.campaign import run_campaign  # noqa: E402
from squeezebench.protocols.variants import (ERROR_MODELS, campaign_with_effects, plate_draw_effects,  # noqa: E402
                                             systematic_effects)

QUANTITIES = ("power_ratio", "resonance_frequency_hz")
GENERATOR = "generator_frequency_error"
LIMIT_REL = SPECIFICATIONS["generator_frequency"].half_width


def generator_errors(error_model: str, seeds) -> pd.Series:
    """Each bench's drawn generator frequency error (relative), as the simulator draws it."""
    return drawn_terms(error_model, seeds, (GENERATOR,))[GENERATOR].rename("generator")


def decomposed(study: pd.DataFrame, generator: pd.Series) -> pd.DataFrame:
    """One row per value of the campaign: its sensitivity to the generator's error, offset,
    residual spread, median stored U (relative), count, and the exact budget's U (both k)."""
    x = study.join(generator, on="bench_seed")
    benches = x["bench_seed"].nunique()
    rows = []
    for (run_name, step_id), value in x.groupby(["run_name", "step_id"]):
        design = np.column_stack([value["generator"], np.ones(len(value))])
        (slope, offset), *_ = np.linalg.lstsq(design, value["rel_error"].to_numpy(), rcond=None)
        residual = float(np.std(value["rel_error"] - design @ (slope, offset), ddof=2))
        exact = Budget("exact", "1", 1.0, (Term("generator", "B", abs(slope) * LIMIT_REL / np.sqrt(3.0), ""),
                                           Term("residual", "A", residual, "")))
        k_specified = budget_distribution(*exact._shape()[:2]).factor(COVERAGE_PROBABILITY)   # no bias bound
        rows.append({"run_name": run_name, "step_id": step_id, "weight": len(value) / benches,
                     "sensitivity": slope, "offset": offset, "residual": residual,
                     "stored_U": float(value["rel_expanded_u"].median()),
                     "exact_U": exact.expanded_uncertainty, "k": exact.coverage_factor,
                     "specified_U": k_specified * exact.std_uncertainty, "k_specified": k_specified,
                     "observed": float(value["covered"].mean())})
    return pd.DataFrame(rows)


def bench_coverage(values: pd.DataFrame, u_column: str, generator: np.ndarray) -> np.ndarray:
    """Each drawn bench's share of `values` whose U (`u_column`) covers its error: the
    generator's term at the bench's draw, the offset, the residual integrated as a normal."""
    share = np.zeros(len(generator))
    for v in values.itertuples():
        error = v.offset + v.sensitivity * generator
        c, noise = getattr(v, u_column), max(v.residual, 1e-12)
        share += v.weight * (ndtr((c - error) / noise) - ndtr((-c - error) / noise))
    return share / values["weight"].sum()


def study_range(per_bench: np.ndarray, benches: int, rng: np.random.Generator) -> tuple[float, float]:
    """The 95 % range of a study of `benches` benches drawn from `per_bench`."""
    studies = per_bench[rng.integers(0, len(per_bench), size=(20_000, benches))].mean(axis=1)
    return tuple(np.percentile(studies, [2.5, 97.5]))


def interval_reaches_95(per_bench: np.ndarray, values: int, benches: int, rng: np.random.Generator,
                        studies: int = 400) -> float:
    """The share of studies of `benches` benches drawn from `per_bench` (`values` values
    each) whose interval (`study.coverage_interval`) holds 95 %."""
    reached = 0
    for _ in range(studies):
        covered = rng.binomial(values, per_bench[rng.integers(0, len(per_bench), size=benches)])
        low, high = coverage_interval(covered, np.full(benches, values), draws=1000, seed=int(rng.integers(2**31)))
        reached += low <= COVERAGE_PROBABILITY <= high
    return reached / studies


def stored_budgets(seed: int) -> pd.DataFrame:
    """The paper campaign on specified bench `seed` (its errors, plates and noise as the
    study draws them): each Pt/P0 and search frequency's budget, relative to its value, split
    into the generator's term and the rest, by (run, step) as the study stores them."""
    with tempfile.TemporaryDirectory(prefix="generator-coverage-") as tmp:
        erring = campaign_with_effects(paths.paper_campaign(), Path(tmp) / "erring",
                                       systematic_effects(seed) + plate_draw_effects(seed), noise_seed=seed)
        run = load_run(run_campaign(erring, out_dir=Path(tmp) / "run", progress=False, durable=False))
        rows = []
        points = detuning_points(run)
        for _, level in points.groupby(["run_name", "velocity_level_pp_mps"]):
            at_resonance = level[level["detuning_phase"] == "resonance"]
            for _, target in level[level["detuning_phase"].isin(("regained", "stress"))].groupby("target_velocity_ratio"):
                rows.append(("power_ratio", target["run_name"].iat[0], target["step_id"].iat[0],
                             uncertainty.power_ratio_budget(target, at_resonance)))
        rows += [("resonance_frequency_hz", run_name, step_id, budget)
                 for run_name, step_id, budget in uncertainty.run_search_budgets(run)]
    return pd.DataFrame([{"quantity": quantity, "run_name": run_name, "step_id": step_id,
                          "claimed_generator": next(t.std_uncertainty for t in b.terms if t.name == "generator frequency")
                          / abs(b.value),
                          "claimed_rest": np.sqrt(sum(t.std_uncertainty ** 2 for t in b.terms
                                                      if t.name != "generator frequency")) / abs(b.value),
                          "claimed_k": b.coverage_factor}
                         for quantity, run_name, step_id, b in rows])


def clean_bench_errors(seed: int) -> pd.DataFrame:
    """Fig. 2's points read on bench `seed`'s plates without any instrument error: their
    power's and velocity's mean relative error against the truth (`bench_errors`' own), and
    their reactive to real power, by run, phase and target ratio."""
    with tempfile.TemporaryDirectory(prefix="generator-coverage-clean-") as tmp:
        plates = plate_draw_effects(seed)
        clean = campaign_with_effects(paths.paper_campaign(), Path(tmp) / "clean", plates, noise_seed=seed)
        campaign_with_effects(paths.paper_campaign(), Path(tmp) / "plain", plates)
        run = load_run(run_campaign(clean, out_dir=Path(tmp) / "run", progress=False, durable=False))
        points = uncertainty.run_uncertainties(run).points
        points = points[points["protocol"] == "detuning"]
        truths = _truths(points, Path(tmp) / "plain")
    errors = points.assign(
        power_error=points["power_w"] / [truths[i]["power_w"] for i in points.index] - 1.0,
        power_fit_error=points["power_fit_w"] / [truths[i]["power_w"] for i in points.index] - 1.0,
        velocity_error=points["velocity_pp_mps"] / [truths[i]["velocity_pp_mps"] for i in points.index] - 1.0,
        reactive_over_real=points["reactive_power_var"] / points["power_w"],
        power_u_rel=points["power_w_u"] / points["power_w"])
    return errors.groupby(["run_name", "detuning_phase", "target_velocity_ratio"])[
        ["power_error", "power_fit_error", "velocity_error", "reactive_over_real", "power_u_rel"]].mean().reset_index()


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study_dir", type=Path)
    parser.add_argument("--benches", type=int, default=20_000, help="drawn benches for the expectations")
    parser.add_argument("--budgets-of-bench", type=int, help="compare the budgets of this specified bench term by term")
    parser.add_argument("--clean-bench", type=int, help="read Fig. 2 on this bench's plates with no instrument error")
    args = parser.parse_args()
    claimed = stored_budgets(args.budgets_of_bench) if args.budgets_of_bench else None
    rng = np.random.default_rng(46)
    drawn = {model: generator_errors(model, range(10_000_001, 10_000_001 + args.benches)).to_numpy()
             for model in ERROR_MODELS}
    for error_model in ERROR_MODELS:
        study = stored_benches(args.study_dir, error_model)
        if study is None:
            continue
        seeds = sorted(study["bench_seed"].unique())
        generator = generator_errors(error_model, seeds)
        print(f"\n== {error_model}: {len(seeds)} benches")
        for quantity in QUANTITIES:
            values = decomposed(study[study["quantity"] == quantity], generator)
            observed = float(study.loc[study["quantity"] == quantity, "covered"].mean())
            expected = bench_coverage(values, "stored_U", drawn[error_model])
            low, high = study_range(expected, len(seeds), rng)
            ratio = values["stored_U"] / values["exact_U"]
            print(f"{quantity}: observed {observed:.2%}; expected of the stored U {expected.mean():.2%}, a "
                  f"{len(seeds)}-bench study within {low:.1%}-{high:.1%}")
            generator_variance = (values["sensitivity"] * LIMIT_REL) ** 2 / 3.0
            share = generator_variance / (generator_variance + values["residual"] ** 2)
            print(f"    stored U / exact budget's U (same k rule): median {ratio.median():.3f}, "
                  f"range {ratio.min():.3f}-{ratio.max():.3f}; generator's share of the exact variance "
                  f"{share.median():.0%} (median); k {values['k'].median():.3f} where the specified model alone "
                  f"takes {values['k_specified'].median():.3f}")
            if error_model == SPECIFIED:
                n = int(round(values["weight"].sum()))
                print(f"    a study's 95 % interval reaches 95 %: on 40 benches "
                      f"{interval_reaches_95(expected, n, 40, rng):.0%} of the time, on 120 "
                      f"{interval_reaches_95(expected, n, 120, rng):.0%}")
                unbiased = values.assign(offset=0.0)
                exact, exact_unbiased, alone, alone_unbiased = (
                    {model: bench_coverage(frame, u_column, drawn[model]).mean() for model in ERROR_MODELS}
                    for frame, u_column in ((values, "exact_U"), (unbiased, "exact_U"), (values, "specified_U"),
                                            (unbiased, "specified_U")))
                print(f"    exact budgets with the k rule: {exact[SPECIFIED]:.2%} within specification, "
                      f"{exact[WORLD]:.2%} as the world errs ({exact_unbiased[SPECIFIED]:.2%} and "
                      f"{exact_unbiased[WORLD]:.2%} without the offsets); with the specified k alone: "
                      f"{alone[SPECIFIED]:.2%} and {alone[WORLD]:.2%} ({alone_unbiased[SPECIFIED]:.2%} and "
                      f"{alone_unbiased[WORLD]:.2%})")
                table = values.assign(stored_over_exact=ratio,
                                      offset_z=values["offset"] / (values["residual"] / np.sqrt(values["weight"] * len(seeds))))
                columns = ["run_name", "step_id", "sensitivity", "offset", "offset_z", "residual", "stored_over_exact",
                           "observed"]
                if claimed is not None:
                    table = table.merge(claimed[claimed["quantity"] == quantity], on=["run_name", "step_id"], how="left")
                    # the generator's term over the one its fitted sensitivity gives; the rest over the residual
                    table["generator_claimed_over_fitted"] = table["claimed_generator"] / (
                        table["sensitivity"].abs() * LIMIT_REL / np.sqrt(3.0))
                    table["rest_claimed_over_residual"] = table["claimed_rest"] / table["residual"]
                    columns += ["generator_claimed_over_fitted", "rest_claimed_over_residual", "claimed_k"]
                print(table.sort_values("observed", ascending=False)[columns].to_string(
                    index=False, float_format=lambda f: f"{f:.4g}"))
    if args.clean_bench:
        print(f"\n== Fig. 2 on bench {args.clean_bench}'s plates, no instrument error: mean relative errors")
        print(clean_bench_errors(args.clean_bench).to_string(index=False, float_format=lambda f: f"{f:.3g}"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
