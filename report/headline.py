"""The few lines a person reads first: what ran, on which bench, whether the chain returns
what it was given, what physics predicts against print, and which printed numbers cannot
hold and why; said the same way at the end of `reproduce`/`report` and atop the HTML report.

A compared cell is counted by what it can show. One the run was given (a scene calibrated
on the printed value, a campaign setting such as the antinode count), or derived only from
what it was given, and that comes back within its tolerance is a round trip
(`tables.ROUND_TRIP`): it verifies the chain, never the paper, so it is one sentence, not a
count of agreements. A cell that misses its tolerance disagrees, whatever its origin; the
report hands each its one-line reason (`Line`), which links where the report shows why.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd

from squeezebench.analysis import provenance
from squeezebench.report.presentation import DISPLAY, grid_correction_note, header, percent, with_uncertainty
from squeezebench.analysis.tables import INPUT_ORIGINS, ROUND_TRIP, is_put_in
from squeezebench.plates.predicted_plates import within_expanded_interval

#: The paper's tables a headline counts, in the order it names them.
PAPER_TABLES = {"table3": "Table 3", "table4": "Table 4", "table5": "Table 5"}
#: Disagreements said one per line; more are counted on one line (the report lists them all).
MAX_MISS_LINES = 5


@dataclass(frozen=True)
class Line:
    """One sentence of the opening; `href` is where the report shows why (HTML only), and
    `kind` groups lines ('miss': a printed number this run does not return)."""

    text: str
    href: str = ""
    kind: str = ""


def verdicts(tables: Mapping[str, pd.DataFrame]) -> pd.DataFrame:
    """One row per compared cell of Tables 3-5: table, item, quantity, verdict (round trip,
    agrees or disagrees), relative_difference, whether the run was given it (`put_in`),
    value, U and the printed value."""
    columns = ["table", "table_name", "item", "quantity", "verdict", "relative_difference", "origin", "put_in",
               "value", "expanded_uncertainty", "paper_value"]
    rows = []
    for name, title in PAPER_TABLES.items():
        frame = tables.get(name)
        if frame is None or frame.empty or "agrees" not in frame:
            continue
        trip = frame["status"] == ROUND_TRIP if "status" in frame else pd.Series(False, index=frame.index)
        # a table the run does not hold says "not compared" in `agrees`: only a verdict counts
        judged = frame["agrees"].map(lambda v: isinstance(v, (bool, np.bool_)))
        compared = frame[frame["paper_value"].notna() & (judged | trip)]
        put_in = is_put_in(compared)
        for (_, row), given, round_trip in zip(compared.iterrows(), put_in, trip[compared.index]):
            verdict = "round trip" if round_trip else "agrees" if bool(row["agrees"]) else "disagrees"
            rows.append({"table": title, "table_name": name, "item": row["item"], "quantity": row["quantity"],
                         "verdict": verdict, "relative_difference": row["relative_difference"],
                         "origin": row["origin"], "put_in": bool(given), "value": row["value"],
                         "expanded_uncertainty": row.get("expanded_uncertainty", np.nan),
                         "paper_value": row["paper_value"]})
    return pd.DataFrame(rows, columns=columns)


def shown(value: float, u: float, quantity: str) -> str:
    """A table value in the report's display units, U to two significant digits."""
    display = DISPLAY.get(quantity)
    scale, unit = (display.scale, display.unit) if display else (1.0, "")
    text = with_uncertainty(value * scale, u * scale if np.isfinite(u) else np.nan)
    return f"{text} {unit}".strip()


def miss_line(cell: pd.Series, reason: str = "", href: str = "") -> Line:
    """"Table 5 measured Q: printed 1.48, this run −14.2 ± 2.0 (−1060.7 %, the opposite sign);
    <reason>." The deviation is rounded as the table rounds it."""
    sign = ", the opposite sign" if cell["relative_difference"] < -1 else ""   # value / printed < 0
    quantity = cell["quantity"]
    display = DISPLAY.get(quantity)
    printed = f"{cell['paper_value'] * (display.scale if display else 1):g}".replace("-", "−")
    text = (f"{cell['table']} {cell['item']} {header(quantity)}: printed {printed}, this run "
            f"{shown(cell['value'], cell['expanded_uncertainty'], quantity).removesuffix(' ' + (display.unit if display else ''))} "
            f"({percent(cell['relative_difference'])}{sign})")
    return Line(f"{text}; {reason}." if reason else f"{text}.", href, "miss")


def _noun(count: int, one: str, many: str) -> str:
    return f"{count} {one if count == 1 else many}"


def opening(bench_kind: str, n_points: int, n_runs: int, tables: Mapping[str, pd.DataFrame],
            needs_deskew: int = 0, reasons: Mapping[tuple[str, str, str], Line] | None = None,
            extra_misses: Sequence[Line] = ()) -> list[Line]:
    """The opening: what ran; the chain verified (round trips, one sentence); agreements;
    what physics predicts against print (frequency, velocity at the printed voltage, power:
    within U or not); each printed number this run does not return, with the reason the
    report found (`reasons`, keyed by (table name, item, quantity); `extra_misses` for
    misses outside Tables 3-5, e.g. Fig. 9); a power resting on an unmeasured probe delay;
    a vibration map's numbers."""
    bench = {"simulated": "Dry run on the simulated bench", "real": "Measured on a real bench"}.get(
        bench_kind, f"Bench {bench_kind}")
    lines = [Line(f"{bench}: {_noun(n_points, 'stored point', 'stored points')} from "
                  f"{_noun(n_runs, 'campaign run', 'campaign runs')}.", kind="ran")]
    cells = verdicts(tables)
    reasons = reasons or {}
    if not cells.empty:
        trips = int((cells["verdict"] == "round trip").sum())
        # a printed value the run was given that misses breaks the chain; one derived from
        # inputs that misses (Table 5 from Fig. 5's scenes) is a finding, said below
        lost = cells[(cells["verdict"] == "disagrees") & cells["origin"].isin(INPUT_ORIGINS)]
        if trips and lost.empty:
            lines.append(Line(f"The chain is verified: every printed value this run was given comes back within "
                              f"its U ({_noun(trips, 'round trip', 'round trips')}: they show the chain, not the "
                              "paper).", kind="chain"))
        elif trips:
            lines.append(Line(f"The chain returns {trips} of the {trips + len(lost)} printed values this run was "
                              "given within U; the others are below.", kind="chain"))
        agree = cells[cells["verdict"] == "agrees"]
        if len(agree):
            on_predicted = int((agree["origin"] == provenance.PREDICTED).sum())
            said = f", {on_predicted} of them on plates the model predicted (nothing printed in)" if on_predicted else ""
            lines.append(Line(f"{_noun(len(agree), 'value', 'values')} this run measured "
                              f"{'agrees' if len(agree) == 1 else 'agree'} with print within U{said}.",
                              kind="agree"))
    # the plate model against the paper's plates: said where the run measured them
    physics = None if cells.empty else _physics_line(tables.get("predicted"))
    if physics:
        lines.append(physics)
    misses = [reasons.get((row["table_name"], row["item"], row["quantity"])) or miss_line(row)
              for _, row in cells[cells["verdict"] == "disagrees"].sort_values(
                  "relative_difference", key=abs, ascending=False).iterrows()] + list(extra_misses)
    if misses:
        lines.append(Line(f"{_noun(len(misses), 'printed number', 'printed numbers')} this run does not return:",
                          kind="misses"))
        lines.extend(misses[:MAX_MISS_LINES])
        if len(misses) > MAX_MISS_LINES:
            lines.append(Line(f"and {len(misses) - MAX_MISS_LINES} more (the summary's table lists them).", kind="miss"))
    if needs_deskew:
        lines.append(Line(f"{needs_deskew} stored power{'s have a U' if needs_deskew > 1 else ' has a U'} mostly the "
                          "current probe's delay bound (no deskew calibration in this run): a deskew run shrinks "
                          f"{'them' if needs_deskew > 1 else 'it'}; squeezebench plan CAMPAIGN --target-rel-error X "
                          "--write FILE adds the run.", kind="deskew"))
    lines.extend(map_lines(tables.get("map_summary")))
    return lines


def headline(bench_kind: str, n_points: int, n_runs: int, tables: Mapping[str, pd.DataFrame],
             needs_deskew: int = 0, reasons: Mapping[tuple[str, str, str], Line] | None = None,
             extra_misses: Sequence[Line] = ()) -> list[str]:
    """The opening as plain lines (headline.txt, the commands' last words); a line of a
    printed number the run does not return starts with "- "."""
    return [("- " if line.kind == "miss" else "") + line.text
            for line in opening(bench_kind, n_points, n_runs, tables, needs_deskew, reasons, extra_misses)]


def _within(predicted: pd.DataFrame, name: str, printed: str) -> tuple[int, int, pd.Series]:
    """How many printed values of one quantity the model puts within its U, of how many,
    and the model / print ratios."""
    rows = predicted[predicted[printed].notna() & predicted[f"predicted_{name}"].notna()]
    within = within_expanded_interval(rows[printed], rows[f"predicted_{name}"], rows[_u_column(name)])
    return int(within.sum()), len(rows), rows[f"predicted_{name}"] / rows[printed]


def _u_column(name: str) -> str:
    """predicted.csv names U after the quantity, before its unit: frequency_hz -> frequency_u_hz,
    velocity_pp_mps -> velocity_u_pp_mps, power_at_printed_velocity_w -> ..._velocity_u_w."""
    quantity, _, unit = name.rpartition("_")
    if quantity.endswith("_pp"):   # pp belongs to the unit
        quantity, unit = quantity.removesuffix("_pp"), f"pp_{unit}"
    return f"predicted_{quantity}_u_{unit}"


def _physics_line(predicted: pd.DataFrame | None) -> Line | None:
    """What the plate model (geometry and datasheets; the drive's model-form term in the
    velocity's and power's U sized on one build's print) predicts against print: resonance
    frequency, velocity at the printed voltage, power at the printed voltage and at the printed
    velocity; within U or not, the worst miss and the widest U, so a U that holds every plate
    only by being wide says so."""
    if predicted is None or predicted.empty:
        return None
    said = []
    for name, printed, words in (("frequency_hz", "printed_frequency_hz", "resonance frequency"),
                                 ("velocity_pp_mps", "printed_velocity_pp_mps", "velocity at the printed voltage"),
                                 ("power_w", "printed_power_w", "power"),
                                 ("power_at_printed_velocity_w", "printed_power_w", "power at the printed velocity")):
        if f"predicted_{name}" not in predicted or printed not in predicted:
            continue
        within, total, ratio = _within(predicted, name, printed)
        if total:
            worst = ratio.iloc[int(np.argmax(np.abs(np.log(ratio.to_numpy()))))]
            scored = predicted[predicted[printed].notna()]
            widest = (scored[_u_column(name)] / scored[f"predicted_{name}"]).abs().max()
            said.append(f"{words} {within} of {total}{' plates' if not said else ''} "
                        f"(worst {percent(worst - 1)}, U up to {percent(widest).lstrip('+')})")
    if not said:
        return None
    return Line("Physics against print (the plate model from geometry and datasheets; within its U, k = 2, "
                "the velocity's and power's U with the drive term sized on Table 3's print): " + "; ".join(said)
                + ".", "#predicted", "physics")


def map_lines(maps: pd.DataFrame | None) -> list[Line]:
    """A vibration map's numbers: velocity, and the amplitude it means in µm pp against the
    haptics criterion (with the voltage that reaches it), its spread and uniformity."""
    if maps is None or maps.empty:
        return []
    row = maps.iloc[0]
    more = f" ({len(maps) - 1} more maps in the report)" if len(maps) > 1 else ""
    amplitude = ""
    if "mean_amplitude_pp_m" in row and np.isfinite(row["mean_amplitude_pp_m"]):
        criterion = row["criterion_amplitude_pp_m"] * 1e6
        verdict = "above" if row["mean_amplitude_pp_m"] * 1e6 >= criterion else "below"
        amplitude = (f", that is {with_uncertainty(1e6 * row['mean_amplitude_pp_m'], 1e6 * row['mean_amplitude_pp_m_U'])}"
                     f" µm pp at {row['piezo_voltage_vpp']:g} V pp, {verdict} the {criterion:g} µm pp a fingertip needs "
                     f"(about {row['voltage_for_criterion_vpp']:.0f} V pp reaches it)")
    return [Line(f"Vibration map {row['run_name']}: {row['n_touch_points']} points over the touch area, velocity "
                 f"{with_uncertainty(row['mean_velocity_pp_mps'], row['mean_velocity_pp_mps_U'])} m/s pp on "
                 f"average{amplitude}; coefficient of variation "
                 f"{with_uncertainty(100 * row['coefficient_of_variation'], 100 * row['coefficient_of_variation_U'], unit='%')}"
                 f"{grid_correction_note(row['coefficient_of_variation'], row['coefficient_of_variation_grid_correction'])}, "
                 f"{row['width_uniformity']:.1%} uniform across the width{more}.", "#map", "map")]
