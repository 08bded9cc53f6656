"""The few lines a person reads first: what ran, on which bench, and what it found against
the paper, said the same way at the end of `reproduce`/`report` and atop the HTML report.

A compared cell is counted by what it can show. One that agrees but was put in (a scene
calibrated on the printed value, a campaign setting such as the antinode count) or derived
from what was put in (its `calibrated_on` names the inputs) only shows that the chain
returns what went in: a round trip, never an agreement. A cell that misses its tolerance
disagrees, whatever its origin (the report says why beside it). Predicted frequencies (the plate model, no printed number in) are counted
within the issue's 3 %.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pandas as pd

from squeezebench.analysis import provenance
from squeezebench.analysis.presentation import header, with_uncertainty

#: The paper's tables a headline counts, in the order it names them.
PAPER_TABLES = {"table3": "Table 3", "table4": "Table 4", "table5": "Table 5"}
#: A predicted frequency this close to print (relative) counts as predicted well.
PREDICTED_FREQUENCY_REL = 0.03
#: Origins of values that were inputs of the run, not results.
INPUT_ORIGINS = ("calibration input", "campaign setting")


def verdicts(tables: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """One row per compared cell of Tables 3-5: table, item, quantity, verdict (round trip,
    agrees or disagrees), relative_difference."""
    rows = []
    for name, title in PAPER_TABLES.items():
        frame = tables.get(name)
        if frame is None or frame.empty or "agrees" not in frame:
            continue
        # a table the run does not hold says "not compared" in `agrees`: only a verdict counts
        compared = frame[frame["paper_value"].notna() & frame["agrees"].map(lambda v: isinstance(v, (bool, np.bool_)))]
        for row in compared.itertuples(index=False):
            put_in = row.origin in INPUT_ORIGINS or (isinstance(row.calibrated_on, str) and row.calibrated_on)
            verdict = "disagrees" if not bool(row.agrees) else "round trip" if put_in else "agrees"
            rows.append({"table": title, "item": row.item, "quantity": row.quantity, "verdict": verdict,
                         "relative_difference": row.relative_difference, "origin": row.origin})
    return pd.DataFrame(rows, columns=["table", "item", "quantity", "verdict", "relative_difference", "origin"])


def headline(bench_kind: str, n_points: int, n_runs: int, tables: Mapping[str, pd.DataFrame],
             needs_deskew: int = 0) -> list[str]:
    """Two to six lines: what ran, what Tables 3-5 show against the paper, what physics
    predicts (when the report holds the prediction), what a vibration map found, and how many
    powers need a deskew calibration the run did not make (`uncertainty.needs_deskew`)."""
    bench = {"simulated": "Dry run on the simulated bench", "real": "Measured on a real bench"}.get(
        bench_kind, f"Bench {bench_kind}")
    lines = [f"{bench}: {n_points} stored points from {n_runs} campaign runs."]
    cells = verdicts(tables)
    if not cells.empty:
        counts = cells["verdict"].value_counts()
        said = [f"{counts.get('agrees', 0)} agree", f"{counts.get('disagrees', 0)} disagree"]
        if counts.get("round trip", 0):
            said.append(f"{counts['round trip']} are round trips (printed values the run was given or "
                        "calibrated on come back: they show the chain, not the paper)")
        worst = cells[cells["verdict"] == "disagrees"]
        if not worst.empty:
            row = worst.loc[worst["relative_difference"].abs().idxmax()]
            sign = ", the sign opposite to print" if row["relative_difference"] < -1 else ""   # value / printed < 0
            said[1] += f" (largest: {row['table']} {row['item']} {header(row['quantity'])}, " \
                       f"{100 * row['relative_difference']:+.0f} %{sign})"
        predicted_cells = int((cells["origin"] == provenance.PREDICTED).sum())
        if predicted_cells:
            said.append(f"{predicted_cells} of them read on plates the model predicted (nothing printed in)")
        lines.append(f"Against the paper, of {len(cells)} compared values in Tables 3-5: " + "; ".join(said) + ".")
    predicted = tables.get("predicted")
    if predicted is not None and not predicted.empty:
        deviation = predicted["frequency_deviation"].abs()
        within_u = (predicted["predicted_frequency_hz"] - predicted["printed_frequency_hz"]).abs() \
            <= predicted["predicted_frequency_u_hz"]
        lines.append(f"From geometry and datasheets alone, the plate model puts "
                     f"{int((deviation <= PREDICTED_FREQUENCY_REL).sum())} of {len(predicted)} printed "
                     f"resonance frequencies within {100 * PREDICTED_FREQUENCY_REL:.0f} % (worst "
                     f"{100 * predicted.loc[deviation.idxmax(), 'frequency_deviation']:+.1f} %) and "
                     f"{int(within_u.sum())} within their U (k = 2), which the sheets' thickness "
                     f"tolerance dominates.")
    if needs_deskew:
        lines.append(f"{needs_deskew} stored power{'s have a U' if needs_deskew > 1 else ' has a U'} mostly the current "
                     "probe's delay bound (no deskew calibration in this run): a deskew run shrinks "
                     f"{'them' if needs_deskew > 1 else 'it'}, "
                     "`squeezebench plan CAMPAIGN --target-rel-error X --write FILE` adds the run.")
    maps = tables.get("map_summary")
    if maps is not None and not maps.empty:
        row = maps.iloc[0]
        more = f" ({len(maps) - 1} more maps in the report)" if len(maps) > 1 else ""
        lines.append(f"Vibration map {row['run_name']}: {row['n_touch_points']} points over the touch area, velocity "
                     f"{with_uncertainty(row['mean_velocity_pp_mps'], row['mean_velocity_pp_mps_U'])} m/s pp on "
                     f"average, coefficient of variation {row['coefficient_of_variation']:.0%}, "
                     f"{row['width_uniformity']:.0%} uniform across the width{more}.")
    return lines
