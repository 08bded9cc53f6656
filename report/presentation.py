"""How the report shows a number to a person: display units, the paper's precision plus
one digit, and the paper's table layout (items across, quantities down).

The CSVs keep machine names and SI units (analysis.tables); only the HTML is dressed.
"""

from __future__ import annotations

import html
import math
import re
from dataclasses import dataclass

import pandas as pd

from squeezebench.analysis import provenance
from squeezebench.paper import paper_table, printed_step
from squeezebench.plates.predicted_plates import expanded_interval
from squeezebench.analysis.tables import ROUND_TRIP


@dataclass(frozen=True)
class Display:
    label: str
    unit: str     # as printed in a header ("" for a pure number)
    scale: float  # SI value x scale = displayed value


DISPLAY = {
    "n_antinodes": Display("antinodes", "", 1.0),
    "frequency_hz": Display("resonance frequency", "Hz", 1.0),
    "voltage_vpp": Display("voltage", "Vpp", 1.0),
    "power_w": Display("power", "mW", 1e3),
    "velocity_pp_mps": Display("velocity", "m/s pp", 1.0),
    "amplitude_pp_m": Display("amplitude", "µm pp", 1e6),
    "q": Display("Q", "", 1.0),
    "tan_theta": Display("tan θ′", "", 1.0),
    "tan_theta_mean": Display("mean tan θ′", "", 1.0),
}
#: How a round trip is marked (tables.ROUND_TRIP): a value the run was given came back, which
#: shows the chain, never the paper; not the ✓ of an agreement.
ROUND_TRIP_MARK = "↺ round trip"
#: Significant digits of a number the paper does not print.
UNPRINTED_DIGITS = 4


def header(quantity: str) -> str:
    display = DISPLAY.get(quantity, Display(quantity, "", 1.0))
    return f"{display.label} ({display.unit})" if display.unit else display.label


def decimals(quantity: str, value_text: str | None) -> int | None:
    """Decimals that show the paper's precision plus one digit, in display units (None:
    the paper prints no such number; use significant digits)."""
    if not value_text:
        return None
    if quantity == "n_antinodes":   # a count
        return 0
    step = printed_step(value_text) * DISPLAY[quantity].scale
    return max(0, 1 - math.floor(math.log10(step) + 1e-9))


def number(value: float, quantity: str, places: int | None) -> str:
    """`value` (SI) in display units: fixed decimals, or UNPRINTED_DIGITS significant."""
    if not isinstance(value, (int, float)) or not math.isfinite(value):
        return "–"
    shown = value * DISPLAY.get(quantity, Display("", "", 1.0)).scale
    if places is None:
        magnitude = math.floor(math.log10(abs(shown))) if shown else 0
        places = max(0, UNPRINTED_DIGITS - 1 - magnitude)
    if places < 0:   # U's second figure left of the units: 38414 ± 2273 shows as 38400 ± 2300
        shown, places = round(shown, places), 0
    return f"{shown:.{places}f}".replace("-", "−")


def paper_texts(name: str) -> dict[tuple[str, str], str]:
    """(item, quantity) -> the printed value as typed, for the precision of each row."""
    return {(row.item, row.quantity): row.value_text for row in paper_table(name).itertuples(index=False)}


def cell(row: pd.Series, places: int | None, explain_href: str | None = None) -> str:
    """One cell: "this run ± U" over "paper X, deviation %", with the origin beneath and
    a flag (and a link to what explains it) when the deviation is outside the tolerance."""
    quantity = row["quantity"]
    round_trip = row["status"] == ROUND_TRIP
    if row["status"] != "measured" and not round_trip:
        return f"<td class='na'>{html.escape(str(row['status']))}{_physics(row, quantity, places)}</td>"
    expanded = row.get("expanded_uncertainty")
    has_u = isinstance(expanded, (int, float)) and math.isfinite(expanded) and expanded > 0
    shown_places = places
    if has_u and quantity in DISPLAY:   # the uncertainty sets the figures: two on U, the value to match
        scale = DISPLAY[quantity].scale
        shown_places = 1 - math.floor(math.log10(expanded * scale))
        shown = abs(row["value"]) * scale
        if math.isfinite(shown) and shown > 0 and math.floor(math.log10(shown)) + 1 + shown_places > MAX_FIGURES:
            shown_places -= 1   # one figure on U (GUM 7.2.6: one or two): 37160.0 ± 0.8, not 37160.00 ± 0.77
    run = number(row["value"], quantity, shown_places)
    if has_u:
        run += f" ± {number(expanded, quantity, shown_places)}"
    agrees = row.get("agrees")
    agrees = None if agrees is None or pd.isna(agrees) else bool(agrees)
    parts = [f"<div class='run'>{run}</div>"]
    if isinstance(row.get("paper_value"), (int, float)) and math.isfinite(row["paper_value"]):
        deviation = percent(row["relative_difference"])
        mark = (ROUND_TRIP_MARK if round_trip else "✓" if agrees is True
                else "✗ outside tolerance" if agrees is False else "")
        parts.append(f"<div class='paper'>paper {number(row['paper_value'], quantity, None if places is None else max(0, places - 1))}"
                     f" · <span class='dev'>{deviation}</span> <span class='mark'>{mark}</span></div>")
    parts.append(_physics(row, quantity, places))
    origin = str(row.get("origin") or "")
    calibrated = str(row.get("calibrated_on") or "")
    if calibrated:
        origin = provenance.CALIBRATION_INPUT if origin != provenance.DERIVED else "derived from a calibration input"
    title = f" title='{html.escape(calibrated)}'" if calibrated else ""
    parts.append(f"<div class='origin'{title}>{html.escape(origin)}</div>")
    if agrees is False and explain_href:
        parts.append(f"<div class='why'><a href='{html.escape(explain_href)}'>why?</a></div>")
    classes = ["off" if agrees is False else "ok" if agrees is True else "trip" if round_trip else "",
               "cal" if calibrated else ""]
    return f"<td class='{' '.join(c for c in classes if c)}'>{''.join(parts)}</td>"


def _physics(row: pd.Series, quantity: str, places: int | None) -> str:
    """The plate model's prediction for the paper's plate, ± U to two significant digits (as
    a factor range where U reaches the value, `with_uncertainty_or_range`), and its deviation
    from print; '' where the model predicts nothing for this cell."""
    predicted = row.get("predicted_value")
    if not (isinstance(predicted, (int, float)) and math.isfinite(predicted)):
        return ""
    u = row.get("predicted_expanded_uncertainty")
    if isinstance(u, (int, float)) and math.isfinite(u) and u >= predicted > 0 and quantity in DISPLAY:
        scale = DISPLAY[quantity].scale
        shown = with_uncertainty_or_range(predicted * scale, u * scale).replace("-", "−")
    elif isinstance(u, (int, float)) and math.isfinite(u) and u > 0 and quantity in DISPLAY:
        u_places = 1 - math.floor(math.log10(u * DISPLAY[quantity].scale))
        shown = f"{number(predicted, quantity, u_places)} ± {number(u, quantity, u_places)}"
    else:
        shown = number(predicted, quantity, places)
    deviation = row.get("predicted_difference")
    said = f" · {percent(deviation)}" if isinstance(deviation, float) and math.isfinite(deviation) else ""
    return f"<div class='physics'>physics {shown}{said}</div>"


def paper_layout(frame: pd.DataFrame, paper_name: str | None, item_label, explain: dict[str, str] | None = None,
                 caption: str = "") -> str:
    """The tidy table `frame` (analysis.tables columns) as the paper lays it out: one
    column per item, one row per quantity, units in the row headers. `item_label` maps an
    item to its column header; `explain` maps an item to the link explaining its flags."""
    texts = paper_texts(paper_name) if paper_name else {}
    items = list(dict.fromkeys(frame["item"]))
    quantities = list(dict.fromkeys(frame["quantity"]))
    head = "<th></th>" + "".join(f"<th>{html.escape(item_label(i))}</th>" for i in items)
    body = ""
    for quantity in quantities:
        cells = ""
        for item in items:
            match = frame[(frame["item"] == item) & (frame["quantity"] == quantity)]
            if match.empty:
                cells += "<td class='na'></td>"
                continue
            cells += cell(match.iloc[0], decimals(quantity, texts.get((item, quantity)))
                          if quantity in DISPLAY else None, (explain or {}).get(item))
        body += f"<tr><th>{html.escape(header(quantity))}</th>{cells}</tr>"
    caption_html = f"<caption>{caption}</caption>" if caption else ""
    return f"<table class='paper'>{caption_html}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def calibration_notes(frame: pd.DataFrame, item_label=str) -> str:
    """What the scenes behind the shaded cells were calibrated on: one line per item,
    each scene state once with the printed values it took."""
    notes = frame[frame["calibrated_on"].astype(str) != ""] if "calibrated_on" in frame else frame.iloc[0:0]
    if notes.empty:
        return ""
    lines = []
    for item, group in notes.groupby("item", sort=False):
        by_state: dict[str, list[str]] = {}
        for source in group["calibrated_on"]:
            for part in str(source).split("; "):
                state, _, value = part.rpartition(": ")
                by_state.setdefault(state, [])
                if value not in by_state[state]:
                    by_state[state].append(value)
        text = "; ".join(f"{state}: {', '.join(values)}" for state, values in by_state.items())
        lines.append(f"<li>{html.escape(item_label(str(item)))}: {html.escape(text)}</li>")
    return ("<div class='notes'>" + fold("Shaded cells return a printed value: the simulated scene was "
                                         "calibrated on it or on the values it is computed from (which, per column)",
                                         f"<ul>{''.join(lines)}</ul>") + "</div>")


#: No number is shown with more significant figures than this: an uncertainty below the
#: last of them is said as a bound.
MAX_FIGURES = 6


def with_uncertainty(value: float, u: float, digits: int = 2, unit: str = "") -> str:
    """"value ± u unit" with u to `digits` significant digits and value to the same decimal;
    a value never past MAX_FIGURES figures ("45.2759 (U < 0.0001)" for a U of 3e-14)."""
    unit = f" {unit}" if unit else ""
    if not (math.isfinite(value) and math.isfinite(u)) or u <= 0:
        return f"{value:.4g}{unit}".replace("-", "−")
    places = digits - 1 - math.floor(math.log10(u))
    cap = max(0, MAX_FIGURES - 1 - math.floor(math.log10(abs(value)))) if value else places
    if places > cap:
        return f"{value:.{cap}f}{unit} (U < {10.0 ** -cap:.{cap}f}{unit})".replace("-", "−")
    if places < 0:   # U's figures left of the units: 44593 ± 2471 is 44600 ± 2500
        value, u, places = round(value, places), round(u, places), 0
    return f"{value:.{places}f} ± {u:.{places}f}{unit}".replace("-", "−")


def with_uncertainty_or_range(value: float, u: float, digits: int = 2, unit: str = "") -> str:
    """`with_uncertainty`, or, where U reaches the (positive) value itself, its interval
    (`predicted_plates.expanded_interval`) as "value (×/÷ F: value / F to value F)"."""
    if not (value > 0 and math.isfinite(u) and u >= value):
        return with_uncertainty(value, u, digits, unit)
    low, high = (float(end) for end in expanded_interval(value, u))
    unit = f" {unit}" if unit else ""

    def figures(x: float) -> str:   # `digits` significant figures, never an exponent
        places = digits - 1 - math.floor(math.log10(x))
        return f"{round(x, places):.{max(places, 0)}f}"
    return f"{figures(value)}{unit} (×/÷ {figures(high / value)}: {figures(low)} to {figures(high)}{unit})"


def grid_correction_note(value: float, correction: float) -> str:
    """What a map's homogeneity figure `value` (a fraction) took for where the grid fell on
    the mode (`cartography.grid_bias`), in percentage points, and what the points alone
    read: a reader sees both what is given and by how much it moved."""
    return (f" (corrected by {100 * correction:+.2f} points for where the grid fell on the mode; "
            f"the points alone {100 * (value - correction):.2f} %)").replace("-", "−")


def percent(fraction: float) -> str:
    """A relative difference in %, two significant digits below 1 % (never "+0.0 %"), at
    most three from 1 % on ("+96.0 %", "−1061 %")."""
    value = 100 * fraction
    text = (f"{value:+.0f}" if abs(value) >= 100 else f"{value:+.1f}" if abs(value) >= 1 or value == 0
            else f"{value:+.2g}")
    return f"{text} %".replace("-", "−")


def fold(summary: str, inner_html: str) -> str:
    """Detail one click away: `summary` (plain text) shows, `inner_html` opens beneath it."""
    return f"<details><summary>{html.escape(summary)}</summary>{inner_html}</details>"


#: Unit suffixes of squeezebench's column names, longest first, and how a person reads them.
_UNIT_SUFFIXES = (("_pp_mps", "m/s pp"), ("_mps_per_v", "m/s per V"), ("_w_per_um2", "W per µm pp²"),
                  ("_pa_s_per_m", "Pa s/m"),
                  ("_rel", "relative"),
                  ("_mps", "m/s"), ("_vpp", "V pp"), ("_hz", "Hz"), ("_var", "var"), ("_nf", "nF"),
                  ("_mm", "mm"), ("_rad", "rad"), ("_w", "W"), ("_m", "m"), ("_s", "s"), ("_g", "g"),
                  ("_v", "V"), ("_a", "A"))


def label(name: str) -> str:
    """A column's code name as a table header a person reads: words, and the unit its
    suffix carries in parentheses (`power_w_U` -> "power U, 95 % (W)"). A header that is
    already words (spaces, symbols) is kept."""
    if not re.fullmatch(r"[a-z0-9_]+(_U|_u)?", name):
        return name
    text, spread = name, ""
    if text.endswith("_dominant"):
        return label(text[:-len("_dominant")]).split(" (")[0] + ": dominant term"
    if text.endswith("_U"):
        text, spread = text[:-2], " U, 95 %"
    elif text.endswith("_u"):
        text, spread = text[:-2], " u"
    if text.startswith("n_") and len(text) > 2:
        text = "number of " + text[2:]
    for suffix, unit in _UNIT_SUFFIXES:
        if text.endswith(suffix) and len(text) > len(suffix):
            return _words(text[:-len(suffix)]) + f"{spread} ({unit})"
    return _words(text) + spread


def _words(text: str) -> str:
    return text.replace("_", " ").replace("tan theta", "tan θ′")
