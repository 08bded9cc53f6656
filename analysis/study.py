"""The accuracy study's trials (RUN_DIR/study/*.parquet) as error distributions and
Pareto fronts of error against bench time.

A configuration is one experiment's full settings (the knob columns); its error is the
95th percentile of |relative error| over its repeats, its cost the mean bench time of one
trial. A configuration is on its experiment's front for a quantity when no cheaper
configuration of that experiment is as accurate.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from squeezebench.analysis.tables import MissingDataError

STUDY_DIR = "study"
#: The coverage of the reported uncertainties over simulated benches (protocols.bench_errors):
#: RUN_DIR/study/coverage/points.parquet, one row per (bench, stored point, quantity).
COVERAGE_DIR = "coverage"
COVERAGE_FILE = "points.parquet"
#: The settings every trial row carries, varied or not (protocols.accuracy_study writes them).
KNOBS = ("averages", "record_length", "periods_per_record", "search_points", "search_tolerance_hz",
         "settle_s", "n_voltages", "tracking")
ERROR_PERCENTILE = 95.0


def load_trials(run_dir: Path) -> pd.DataFrame:
    """Every stored trial row; an experiment that did not complete has no file."""
    files = sorted((Path(run_dir) / STUDY_DIR).glob("*.parquet"))
    if not files:
        raise MissingDataError(f"{Path(run_dir) / STUDY_DIR}: no study trials (*.parquet)")
    return pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)


def varied_knobs(trials: pd.DataFrame) -> list[str]:
    """The knobs an experiment's trials vary (the others are its fixed settings)."""
    return [k for k in KNOBS if trials[k].nunique() > 1]


def summarise(trials: pd.DataFrame) -> pd.DataFrame:
    """One row per (experiment, configuration, quantity): error percentiles and cost."""
    keys = ["experiment", "scene", "state", *KNOBS, "quantity"]
    summary = (trials.assign(abs_rel_error=trials["rel_error"].abs())
               .groupby(keys, sort=True)
               .agg(n_trials=("rel_error", "size"), n_repeats=("repeat", "nunique"),
                    median_rel_error=("rel_error", "median"),
                    p95_abs_rel_error=("abs_rel_error", lambda e: float(np.percentile(e, ERROR_PERCENTILE))),
                    bench_time_s=("bench_time_s", "mean"))
               .reset_index())
    summary["on_front"] = False
    for _, group in summary.groupby(["experiment", "quantity"]):
        summary.loc[front_index(group), "on_front"] = True
    return summary


#: Bootstrap resamples of a configuration's repeats for the Monte Carlo uncertainty of its p95.
BOOTSTRAP_DRAWS = 2000
FIGURE_KEYS = ["experiment", "scene", "state", *KNOBS, "quantity"]


def p95_standard_error(abs_errors: np.ndarray, draws: int = BOOTSTRAP_DRAWS, seed: int = 0) -> float:
    """The Monte Carlo standard uncertainty of the p95 of `abs_errors` (one per repeat): the
    spread of that percentile over bootstrap resamples of the repeats (seeded). With 8
    repeats it is wide: the p95 then sits between the two largest errors."""
    errors = np.asarray(abs_errors, dtype=float)
    resampled = np.random.default_rng(seed).choice(errors, size=(draws, errors.size), replace=True)
    return float(np.std(np.percentile(resampled, ERROR_PERCENTILE, axis=1), ddof=1))


def figures(trials: pd.DataFrame) -> pd.DataFrame:
    """`summarise`'s p95 and bench time per configuration and quantity, with the p95's Monte
    Carlo standard uncertainty (`p95_mc_u`): what the fronts and floors are drawn from, as
    a study's figures to compare with another run of it (`compare_figures`)."""
    summary = summarise(trials).set_index(FIGURE_KEYS)
    u = (trials.assign(abs_rel_error=trials["rel_error"].abs()).groupby(FIGURE_KEYS)["abs_rel_error"]
         .apply(lambda e: p95_standard_error(e.to_numpy())).rename("p95_mc_u"))
    return summary[["n_repeats", "p95_abs_rel_error", "bench_time_s"]].join(u).reset_index()


def compare_figures(current: pd.DataFrame, reference: pd.DataFrame, coverage: float = 2.0) -> pd.DataFrame:
    """Each figure of `current` beside `reference` (both from `figures`): the p95's change in
    units of their combined Monte Carlo uncertainty (`z`), `within` when |z| <= `coverage`
    (about 95 % of figures when both runs sample the same error distributions), and the
    relative change of the bench time. Figures only one side has are left out (the caller
    counts them)."""
    keys = [k for k in FIGURE_KEYS if k in current and k in reference]
    both = current.merge(reference, on=keys, suffixes=("", "_reference"), validate="one_to_one")
    combined = np.hypot(both["p95_mc_u"], both["p95_mc_u_reference"])
    change = both["p95_abs_rel_error"] - both["p95_abs_rel_error_reference"]
    both["z"] = np.where(combined > 0, change / combined.where(combined > 0, 1.0), np.where(change == 0, 0.0, np.inf))
    both["within"] = both["z"].abs() <= coverage
    both["bench_time_rel_change"] = both["bench_time_s"] / both["bench_time_s_reference"] - 1.0
    return both


def front_index(group: pd.DataFrame) -> list:
    """Index of the configurations no cheaper one beats (ties in time: the more accurate)."""
    ordered = group.sort_values(["bench_time_s", "p95_abs_rel_error"])
    best = np.inf
    index = []
    for label, error in ordered["p95_abs_rel_error"].items():
        if error < best:
            index.append(label)
            best = error
    return index


def fronts_table(summary: pd.DataFrame) -> pd.DataFrame:
    """The settings on each front, cheapest first, with only the knobs each experiment varies."""
    rows = []
    for (experiment, quantity), group in summary[summary["on_front"]].groupby(["experiment", "quantity"]):
        knobs = varied_knobs(summary[summary["experiment"] == experiment])
        for _, row in group.sort_values("bench_time_s").iterrows():
            rows.append({"quantity": quantity, "experiment": experiment,
                         "settings": ", ".join(f"{k}={_setting(row[k])}" for k in knobs),
                         "bench_time_s": row["bench_time_s"], "p95_abs_rel_error": row["p95_abs_rel_error"],
                         "median_rel_error": row["median_rel_error"], "n_trials": row["n_trials"]})
    return pd.DataFrame(rows)


def heating_table(summary: pd.DataFrame) -> pd.DataFrame:
    """Power error against averaging, at the frequency found cold and with tracking."""
    heating = summary[(summary["experiment"] == "heating") & (summary["quantity"] == "power_w")]
    if heating.empty:
        return pd.DataFrame()
    table = heating.pivot_table(index="averages", columns="tracking",
                                values=["p95_abs_rel_error", "bench_time_s"])
    table.columns = [f"{value}_{'tracked' if tracked else 'fixed_frequency'}" for value, tracked in table.columns]
    return table.reset_index()


#: Experiments on benches whose instruments err within spec (protocols.systematics_study):
#: `systematics_<point>` as the bench is, `systematics_<point>_calibrated` after the deskew.
SYSTEMATICS = "systematics_"
CALIBRATED = "_calibrated"


def is_systematics(experiment: str) -> bool:
    return experiment.startswith(SYSTEMATICS)


def systematics_point(experiment: str) -> tuple[str, bool]:
    """(point, calibrated) of a systematics experiment's name."""
    name = experiment.removeprefix(SYSTEMATICS)
    return name.removesuffix(CALIBRATED), name.endswith(CALIBRATED)


#: A setting reaches the floor when its error is within this factor of the lowest: beyond,
#: more bench time buys differences the benches' scatter does not resolve.
AT_FLOOR = 1.05


def floors_table(summary: pd.DataFrame) -> pd.DataFrame:
    """Per point and quantity of the systematics experiments: the floor (the lowest p95
    |relative error| any setting reaches over the benches) as the bench is and after the
    deskew calibration, each with the cheapest setting within `AT_FLOOR` of it and its
    bench time per trial."""
    rows: dict[tuple[str, str], dict] = {}
    for (experiment, quantity), group in summary[summary["experiment"].map(is_systematics)].groupby(
            ["experiment", "quantity"], sort=False):
        point, calibrated = systematics_point(experiment)
        floor = float(group["p95_abs_rel_error"].min())
        cheapest = group[group["p95_abs_rel_error"] <= AT_FLOOR * floor].sort_values("bench_time_s").iloc[0]
        prefix = "calibrated_" if calibrated else ""
        rows.setdefault((point, quantity), {"point": point, "quantity": quantity}).update({
            f"{prefix}floor_p95_rel": floor, f"{prefix}bench_time_s": float(cheapest["bench_time_s"]),
            f"{prefix}averages": int(cheapest["averages"]), "benches": int(cheapest["n_repeats"])})
    columns = ["point", "quantity", "benches", "floor_p95_rel", "averages", "bench_time_s",
               "calibrated_floor_p95_rel", "calibrated_averages", "calibrated_bench_time_s"]
    order = {q: i for i, q in enumerate(("power_w", "velocity_pp_mps", "q", "tan_theta", "resonance_frequency_hz"))}
    frame = pd.DataFrame(list(rows.values())).reindex(columns=columns)
    frame[["averages", "calibrated_averages"]] = frame[["averages", "calibrated_averages"]].astype("Int64")
    return frame.sort_values(["quantity", "point"], key=lambda c: c.map(order) if c.name == "quantity" else c,
                             ignore_index=True)


def coverage_dir(error_model: str) -> str:
    """Where a coverage study under `error_model` is stored, inside the study directory."""
    return COVERAGE_DIR if error_model == "specified" else f"{COVERAGE_DIR}_{error_model}"


def load_coverage(run_dir: Path) -> pd.DataFrame | None:
    """The coverage studies' rows (every error model run, `error_model` column), or None
    when none was run."""
    found = sorted((Path(run_dir) / STUDY_DIR).glob(f"{COVERAGE_DIR}*/{COVERAGE_FILE}"))
    if not found:
        return None
    frames = [pd.read_parquet(path) for path in found]
    return pd.concat([frame if "error_model" in frame else frame.assign(error_model="specified")
                      for frame in frames], ignore_index=True)


#: The design's predictions the report prints with a U (`plates.predicted_plates.predictions`,
#: k = 2) that have a truth independent of the model: the paper's printed measurement of the
#: same plate. Quantity -> (predicted, its U, printed) columns.
DESIGN_PREDICTIONS = {
    "predicted_frequency_hz": ("predicted_frequency_hz", "predicted_frequency_u_hz", "printed_frequency_hz"),
    "predicted_velocity_pp_mps": ("predicted_velocity_pp_mps", "predicted_velocity_u_pp_mps", "printed_velocity_pp_mps"),
    "predicted_power_w": ("predicted_power_w", "predicted_power_u_w", "printed_power_w"),
    "predicted_power_at_printed_velocity_w": ("predicted_power_at_printed_velocity_w",
                                              "predicted_power_at_printed_velocity_u_w", "printed_power_w"),
}
#: The error model of the design's rows: each plate is one unit, as a bench is.
DESIGN_MODEL = "paper"


def design_coverage_points() -> pd.DataFrame:
    """Coverage rows of the design's predictions (`DESIGN_PREDICTIONS`) against the paper's
    printed values, one per plate and quantity (a printed value the paper lacks is left out);
    each plate is its own unit (`bench_seed`), the plate model's inputs being its own."""
    from squeezebench.plates import predicted_plates

    frame = predicted_plates.predictions()
    rows = []
    for unit, plate in enumerate(frame.to_dict("records"), start=1):
        for quantity, (value, expanded, printed) in DESIGN_PREDICTIONS.items():
            true = float(plate[printed])
            if not np.isfinite(true):
                continue
            rows.append({"run_name": f"{plate['table']} {plate['item']}", "quantity": quantity,
                         "measured_value": float(plate[value]), "true_value": true,
                         "rel_error": float(plate[value]) / true - 1.0,
                         "rel_expanded_u": float(plate[expanded]) / abs(true),
                         "covered": predicted_plates.within_expanded_interval(true, float(plate[value]),
                                                                              float(plate[expanded])),
                         "error_model": DESIGN_MODEL, "bench_seed": unit, "beyond_specification": False})
    return pd.DataFrame(rows)


#: Bench-bootstrap resamples of a coverage figure (seeded: a figure reads the same twice).
COVERAGE_BOOTSTRAP_DRAWS = 4000
#: The normal's two-sided 95 % quantile, of the Wilson interval.
Z95 = 1.959963984540054


def coverage_table(points: pd.DataFrame) -> pd.DataFrame:
    """Per error model and quantity: the fraction of values whose expanded uncertainty
    covers the truth, pooled over the benches, with its 95 % interval (`coverage_interval`:
    every value of a bench shares that bench's errors, so the bench is the trial: a bench is
    covered nearly wholly or hardly at all, and few benches leave the fraction uncertain).
    `p95_error_over_u`: the 95th percentile of |error| / U (below 1 where U over-covers: a U
    that factor as wide would still cover 95 %). `benches_beyond_specification`: benches with
    an instrument erring beyond what its specification claims (`bench_errors._beyond_specification`;
    the world's, now and then), and `covered_fraction_within_specification` the fraction over
    the others: what the budgets promise."""
    if "error_model" not in points:
        points = points.assign(error_model="specified")
    if "beyond_specification" not in points:   # stored before benches were told apart
        points = points.assign(beyond_specification=False)
    rows = []
    for (model, quantity), group in points.groupby(["error_model", "quantity"], sort=False):
        within = group[~group["beyond_specification"].astype(bool)]
        by_bench = group.groupby("bench_seed")["covered"].agg(["sum", "size"])
        low, high = coverage_interval(by_bench["sum"].to_numpy(float), by_bench["size"].to_numpy(float))
        rows.append({"error_model": model, "quantity": quantity, "benches": len(by_bench), "points": len(group),
                     "covered_fraction": float(group["covered"].mean()),
                     "coverage_interval_low": low, "coverage_interval_high": high,
                     "benches_fully_covered": int((by_bench["sum"] == by_bench["size"]).sum()),
                     "benches_beyond_specification": len(by_bench) - int(within["bench_seed"].nunique()),
                     "covered_fraction_within_specification": float(within["covered"].mean()) if len(within)
                     else float("nan"),
                     "median_rel_expanded_u": float(group["rel_expanded_u"].median()),
                     "p95_error_over_u": float(np.percentile(group["rel_error"].abs() / group["rel_expanded_u"],
                                                             ERROR_PERCENTILE))})
    return pd.DataFrame(rows)


def coverage_interval(covered: np.ndarray, counts: np.ndarray, draws: int = COVERAGE_BOOTSTRAP_DRAWS,
                      seed: int = 0) -> tuple[float, float]:
    """95 % interval of the pooled fraction sum(covered) / sum(counts) of benches (one entry
    each: values covered, values scored) whose values share their bench's errors: Wilson's
    score interval (Wilson 1927) on the benches' effective number of values (Kish's design
    effect; Korn and Graubard 1998 for a proportion of a clustered sample): n_eff =
    p (1 - p) / V, V the fraction's variance over bench-bootstrap resamples, between the
    number of benches (each bench wholly covered or wholly missed) and of values (none
    sharing a cause). Where every value is covered, or none, V is 0 and says nothing of the
    clustering: n_eff is then the benches' number, the least it can be.

    Not the bootstrap's own percentiles: a fraction near 1 of few benches gives them too
    narrow a range, and all benches covered gives [100 %, 100 %] whatever their number,
    where a U holding 93 % gives 40 of 40 one study in 18 (Wilson: 91.2-100 %). On 40 benches
    whose values share their bench's fate, at a true 95 %, the percentiles held it in 86 % of
    studies, this in 95 % (`tests/test_coverage_interval.py`)."""
    values = float(counts.sum())
    fraction = float(covered.sum()) / values
    if 0.0 < fraction < 1.0:
        variance = float(np.var(bench_bootstrap_fractions(covered, counts, draws, seed), ddof=1))
        effective = values if variance == 0.0 else float(np.clip(fraction * (1.0 - fraction) / variance,
                                                                 len(counts), values))
    else:
        effective = float(len(counts))
    return wilson_interval(fraction, effective)


def bench_bootstrap_fractions(covered: np.ndarray, counts: np.ndarray, draws: int = COVERAGE_BOOTSTRAP_DRAWS,
                              seed: int = 0) -> np.ndarray:
    """sum(covered) / sum(counts) over `draws` resamples of the benches (seeded)."""
    picks = np.random.default_rng(seed).integers(0, len(covered), size=(draws, len(covered)))
    return covered[picks].sum(axis=1) / counts[picks].sum(axis=1)


def wilson_interval(fraction: float, trials: float, z: float = Z95) -> tuple[float, float]:
    """Wilson's score interval of a binomial fraction over `trials` (a real number: an
    effective count; SciPy's `binomtest(...).proportion_ci` takes whole counts only)."""
    scale = 1.0 + z * z / trials
    centre = (fraction + z * z / (2.0 * trials)) / scale
    half = z / scale * np.sqrt(fraction * (1.0 - fraction) / trials + z * z / (4.0 * trials * trials))
    return float(max(centre - half, 0.0)), float(min(centre + half, 1.0))


#: How a coverage study's benches erred, in words (protocols.variants.ERROR_MODELS).
COVERAGE_MODELS = {"specified": "benches within specification (instruments and plate tolerances)",
                   "world": "benches erring as the world errs (instruments and plate tolerances)",
                   DESIGN_MODEL: "the paper's plates, the design's prediction against the printed measurement "
                                 "(a 'bench' is a plate)"}


#: Each error model in a few words, in the order a reader meets them (`coverage_verdict`,
#: the report's coverage table).
MODEL_HEADINGS = {"specified": "within specification", "world": "as the world errs",
                  DESIGN_MODEL: "design vs the paper's print"}


def coverage_verdict(table: pd.DataFrame, quantity_words=str) -> str:
    """What a coverage study found (`coverage_table`), a sentence per error model: how many
    quantities' 95 % intervals hold 95 %, and which lie above it (their U wider than their
    errors need) or below it (their U too narrow), judged on the interval as printed (0.1 %:
    95.0-99.6 % holds 95 %)."""
    def listed(quantities: list[str], change: str) -> str:
        return f"; {', '.join(quantities)} {'cover' if len(quantities) > 1 else 'covers'} {change}"

    sentences = []
    for model, heading in MODEL_HEADINGS.items():
        rows = table[table["error_model"] == model]
        if rows.empty:
            continue
        low, high = (rows[column].round(3) for column in ("coverage_interval_low", "coverage_interval_high"))
        above, below = ([quantity_words(q) for q in rows.loc[beyond, "quantity"]]
                        for beyond in (low > 0.95, high < 0.95))
        sentence = (f"{heading[0].upper()}{heading[1:]} ({rows['benches'].max()} benches): the 95 % interval of "
                    f"{len(rows) - len(above) - len(below)} of {len(rows)} quantities holds 95 %")
        if above:
            sentence += listed(above, "more (U wider than the errors need)")
        if below:
            sentence += listed(below, "less (U too narrow)")
        sentences.append(sentence + ".")
    return " ".join(sentences)


def coverage_lines(table: pd.DataFrame, quantity_words=str) -> list[str]:
    """One line per row of `coverage_table` (what `study` prints and the report says):
    quantity, coverage, its 95 % interval (`coverage_interval`), benches, error model."""
    return [f"{quantity_words(row.quantity)}: {row.covered_fraction:.1%} covered "
            f"(95 % interval {row.coverage_interval_low:.1%} to {row.coverage_interval_high:.1%}, benches as trials), "
            f"p95 |error| / U {row.p95_error_over_u:.2f}, "
            f"{row.points} values on {row.benches} benches, {COVERAGE_MODELS.get(row.error_model, row.error_model)}"
            + _beyond_words(row) for row in table.itertuples()]


def _beyond_words(row) -> str:
    """What the benches whose instruments err beyond their specification take from a row."""
    if not getattr(row, "benches_beyond_specification", 0):
        return ""
    return (f"; {row.covered_fraction_within_specification:.1%} on the "
            f"{row.benches - row.benches_beyond_specification} whose instruments are all within specification "
            f"({row.benches_beyond_specification} have one beyond it, outside what the specifications claim)")


def _setting(value) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "on" if value else "off"
    return f"{value:g}" if isinstance(value, (float, np.floating)) else str(value)
