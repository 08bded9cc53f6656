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
               .agg(n_trials=("rel_error", "size"),
                    median_rel_error=("rel_error", "median"),
                    p95_abs_rel_error=("abs_rel_error", lambda e: float(np.percentile(e, ERROR_PERCENTILE))),
                    bench_time_s=("bench_time_s", "mean"))
               .reset_index())
    summary["on_front"] = False
    for _, group in summary.groupby(["experiment", "quantity"]):
        summary.loc[front_index(group), "on_front"] = True
    return summary


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


def _setting(value) -> str:
    if isinstance(value, (bool, np.bool_)):
        return "on" if value else "off"
    return f"{value:g}" if isinstance(value, (float, np.floating)) else str(value)
