"""The design page: the answer first, then the mode, the power curve, the layouts, the budget.

Written by `squeezebench design` as DIR/index.html beside design.json and the CSV tables;
the run report's page and style (`report.page`), readable on a laptop and a phone.
"""
from __future__ import annotations

import html
import json
import math
from dataclasses import replace
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from squeezebench.report import presentation  # noqa: E402
from squeezebench.designing.answer import DesignAnswer  # noqa: E402
from squeezebench.designing.design import COVERAGE_FACTOR, INPUTS, mean_edge_gap_mm  # noqa: E402
from squeezebench.designing.workflow import HISTORY_FILE, record_measurement  # noqa: E402
from squeezebench.plates import predicted_plates  # noqa: E402
from squeezebench.plates.plate_modes import crossings  # noqa: E402
from squeezebench.report.figures import PAPER_STYLE, save_figure  # noqa: E402
from squeezebench.report import page as html_page  # noqa: E402
from squeezebench.report.section import cell_text, html_table  # noqa: E402

FILES = {"page": "index.html", "json": "design.json", "budget": "budget.csv", "comparison": "comparison.csv",
         "layouts": "layouts.csv", "mode": "mode.png", "power": "power_voltage.png", "pareto": "layouts.png",
         "placement": "placement.csv", "placement_figure": "placement.png"}
#: The outputs the budget section shows, in the order a designer asks for them.
BUDGET_OUTPUTS = ("voltage_vpp", "power_w", "frequency_hz", "current_pp_a", "weakest_antinode_ratio")


def _target_words(answer: DesignAnswer) -> str:
    t = answer.design.target
    where = "at the centre" if t.at == "centre" else "averaged over the touch area"
    if t.amplitude_pp_m is not None:
        return f"{t.amplitude_pp_m * 1e6:.3g} µm pp {where}"
    return f"{t.velocity_pp_mps:.3g} m/s pp {where}"


def _pm(answer: DesignAnswer, quantity: str, digits: int = 2) -> str:
    return _pm_of(answer.physics, quantity, digits)


def headline(answer: DesignAnswer) -> list[str]:
    """What a person reads first: a few sentences, every number with its U (k = 2)."""
    v, d = answer.physics.nominal.values, answer.design
    verdict = answer.judged()
    lines = [f"Verdict: {verdict.status}" + (f" ({'; '.join(verdict.reasons)})" if verdict.reasons else "")
             + (f". Nearest feasible change: {'; or '.join(verdict.changes)}" if verdict.changes else "") + ".",
             f"{d.name} needs {_pm(answer, 'voltage_vpp')} Vpp and {_pm(answer, 'power_w')} W for "
             f"{_target_words(answer)}, from physics (working mode {_pm(answer, 'frequency_hz', 2)} Hz, "
             f"{v['interior_antinodes']} antinodes; {_q_words(answer)})."]
    act = _act_on(answer.physics)
    if act:
        lines.append(act)
    limits = [f"amplifier {v['voltage_vpp'] / d.amplifier.max_output_vpp:.0%} of its {d.amplifier.max_output_vpp:g} Vpp",
              f"piezo field {v['piezo_field_v_per_mm']:.0f} of {d.piezo.max_field_v_per_mm:g} V/mm"]
    if d.amplifier.max_current_app:
        limits.append(f"current {v['current_pp_a'] / d.amplifier.max_current_app:.0%} of its {d.amplifier.max_current_app:g} A pp")
    if d.amplifier.max_power_w:
        limits.append(f"power {v['power_w'] / d.amplifier.max_power_w:.0%} of its {d.amplifier.max_power_w:g} W")
    lines.append("Limits: " + "; ".join(limits) + f". Touch area: weakest antinode {v['weakest_antinode_ratio']:.0%} "
                 "of the strongest.")
    route = answer.paper_route
    if route is not None:
        lines.append(f"The paper's method from {len(route.small_plates)} characterised small plates: "
                     f"{presentation.with_uncertainty_or_range(route.voltage_vpp.nominal_value, COVERAGE_FACTOR * route.voltage_vpp.std_dev, unit='Vpp')} "
                     f"and {presentation.with_uncertainty_or_range(route.power_w.nominal_value, COVERAGE_FACTOR * route.power_w.std_dev, unit='W')}.")
    elif answer.paper_route_problem:
        lines.append(f"The paper's method: no answer ({answer.paper_route_problem}).")
    comparison = answer.comparison()
    against = comparison[comparison["reference"] != ""]
    if not against.empty:
        reference = against["reference"].iloc[0]
        parts = [f"{_source_short(r.source)} {presentation.label(r.quantity).split(' (')[0]} "
                 f"{presentation.percent(r.deviation)} ({'within' if r.within_u else 'outside'} U)"
                 for r in against.itertuples() if r.quantity != "frequency_hz" or r.source.startswith("physics")]
        against_words = ("the paper's printed values" if reference.startswith("printed")
                         else f"the built plate, {reference}")
        lines.append(f"Against {against_words}: " + "; ".join(parts) + ".")
        if answer.measured is not None and answer.measured.origin in ("simulated", "predicted"):
            lines.append("That plate was simulated: a simulated build of a predicted scene follows the same plate "
                         "model, so this checks the chain (scene, instruments, analysis), not the physics.")
    lines.extend(placement_sentences(answer))
    if answer.layouts is not None and not answer.layouts.empty:
        lines.append(_layouts_sentence(answer))
    return lines


def placement_sentences(answer: DesignAnswer) -> list[str]:
    """What the end piezos' place along the length does, in words a designer acts on; with
    the paper's printed values, where on the curve they fall (an inference, labelled)."""
    curve = answer.placement
    if curve is None or curve["voltage_vpp"].notna().sum() < 2:
        return []
    d, v = answer.design, answer.physics.nominal.values
    ok = curve[curve["voltage_vpp"].notna()]
    gap = mean_edge_gap_mm(d)
    best = ok.loc[ok["voltage_vpp"].idxmin()]
    rows = answer.physics.budget[(answer.physics.budget["output"] == "voltage_vpp")
                                 & (answer.physics.budget["input"] == "placement_mm")]
    contribution = float(rows["contribution"].iloc[0]) if len(rows) else 0.0
    share = (contribution / (answer.physics.expanded["voltage_vpp"] / COVERAGE_FACTOR)) ** 2 if contribution else 0.0
    # the budget's contribution is the slope times u = t / sqrt 3: the whole half-width moves it sqrt 3 times as much
    swing = abs(contribution) * np.sqrt(3) / v["voltage_vpp"]
    move = best["edge_gap_mm"] - gap
    lines = [f"Placement: the end piezos sit {gap:.1f} mm from the edges, bonded to ±{d.placement_tolerance_mm:g} mm, "
             f"which moves the voltage by about ±{swing:.0%} ({share:.0%} of its U²). Between {ok['edge_gap_mm'].min():.1f} and "
             f"{ok['edge_gap_mm'].max():.1f} mm from the edges the voltage for the target runs from "
             f"{ok['voltage_vpp'].min():.3g} to {ok['voltage_vpp'].max():.3g} Vpp and the power from "
             f"{ok['power_w'].min():.3g} to {ok['power_w'].max():.3g} W."]
    if abs(move) >= 0.05 and v["voltage_vpp"] / best["voltage_vpp"] > 1.05:
        lines.append(f"Moving them {abs(move):.1f} mm {'inward' if move > 0 else 'outward'} "
                     f"({best['edge_gap_mm']:.1f} mm from the edges) divides the voltage by "
                     f"{v['voltage_vpp'] / best['voltage_vpp']:.2g} (to {best['voltage_vpp']:.3g} Vpp).")
    if answer.printed:
        lines.append(_implied_placement(answer, ok))
    return lines


def _implied_placement(answer: DesignAnswer, curve: pd.DataFrame) -> str:
    """Where the printed voltage and power fall on the placement curve: the crossings, else
    the distances whose U (k = 2) holds the printed voltage. An inference about the paper's
    build, never an input of the prediction."""
    printed = answer.printed

    def where(gaps: list[float]) -> str:
        return " and ".join(f"{g:.1f} mm" for g in gaps) + " from the edges"
    at_voltage = crossings(curve["edge_gap_mm"], curve["voltage_vpp"], printed["voltage_vpp"])
    at_power = crossings(curve["edge_gap_mm"], curve["power_w"], printed["power_w"])
    if at_voltage:
        voltage = f"its {printed['voltage_vpp']:g} Vpp at {where(at_voltage)}"
    else:
        within = edge_gaps_within_u(curve, printed["voltage_vpp"])
        lowest = curve.loc[curve["voltage_vpp"].idxmin()]
        lo, hi = (min(within), max(within)) if within else (None, None)
        span = "" if lo is None else f"; within its U at {lo:.1f} mm" if lo == hi else f"; within U from {lo:.1f} to {hi:.1f} mm"
        voltage = (f"its {printed['voltage_vpp']:g} Vpp nowhere (the least is {lowest['voltage_vpp']:.3g} Vpp at "
                   f"{lowest['edge_gap_mm']:.1f} mm{span})")
    power = f"its {printed['power_w']:g} W at {where(at_power)}" if at_power else f"its {printed['power_w']:g} W nowhere"
    text = (f"Inference, not a prediction: on this curve the paper's build would have {voltage}, {power}; the paper "
            "does not state the placement, and nothing here is chosen from its printed numbers.")
    return text if at_voltage else f"{text} {_what_separates(answer, curve)}"


def edge_gaps_within_u(curve: pd.DataFrame, voltage_vpp: float) -> list[float]:
    """The placement curve's edge gaps whose voltage and U (k = 2) hold `voltage_vpp`: in the
    interval the page shows (`predicted_plates.within_expanded_interval`), the factor one where
    U passes the voltage."""
    held = predicted_plates.within_expanded_interval(voltage_vpp, curve["voltage_vpp"],
                                                     curve["voltage_expanded_uncertainty"])
    return [float(gap) for gap in curve.loc[held, "edge_gap_mm"]]


def _what_separates(answer: DesignAnswer, curve: pd.DataFrame) -> str:
    """Which factor of V_pp = w^2 M x_pp / (Q A) keeps the placement curve's least voltage from
    the printed one, and by how much (the convention of the target's amplitude included)."""
    lowest = curve.loc[curve["voltage_vpp"].idxmin()]
    needed = lowest["voltage_vpp"] / answer.printed["voltage_vpp"]
    physics = lowest["voltage_vpp"] * lowest["mechanical_q"] / lowest["physics_q"]
    return (f"What separates it: at {lowest['edge_gap_mm']:.1f} mm the voltage is ω² M x / (Q A) with M "
            f"{lowest['modal_mass_g']:.3g} g and A {lowest['force_factor_n_per_v']:.3g} N/V at the centre and Q "
            f"{lowest['mechanical_q']:.0f}, the target read as {_target_words(answer)} (read as an amplitude it doubles): "
            f"Q A / M would have to be {needed:.2f} times larger, e.g. Q {lowest['mechanical_q'] * needed:.0f} (the loss "
            f"physics gives {lowest['physics_q']:.0f} there, {physics:.3g} Vpp) or A "
            f"{lowest['force_factor_n_per_v'] * needed:.2g} N/V.")


def _q_words(answer: DesignAnswer) -> str:
    """Where the mechanical Q comes from, and the loss physics' Q beside a stated one."""
    d, v = answer.design, answer.physics.nominal.values
    if d.damping.source == "physics":
        return (f"mechanical Q {_pm(answer, 'mechanical_q', 2)} from the plate's losses (aluminium, ceramic, bond, "
                f"radiation), ± {d.damping.tolerance_rel:.0%} for losses outside that model")
    spread = (f"{answer.physics.expanded['mechanical_q'] / v['mechanical_q']:.0%} (log-normal, as the paper's builds "
              "realise it)" if d.damping.spread == "paper_builds" else f"{d.damping.tolerance_rel:.0%}")
    return (f"mechanical Q {d.damping.mechanical_q:g} ± {spread}, the build's stated figure; "
            f"the loss physics gives {v['physics_q']:.0f} for this plate")


def _source_short(source: str) -> str:
    return "physics" if source.startswith("physics") else "small plates"


def _layouts_sentence(answer: DesignAnswer) -> str:
    frame = answer.layouts
    feasible = frame[frame["feasible"].astype(bool)]
    if feasible.empty:
        return f"None of {len(frame)} layouts meets the target within the limits."
    best = feasible.loc[feasible["power_w"].idxmin()]
    text = (f"Of {len(frame)} layouts, {len(feasible)} meet the target within the limits; the least power: "
            f"{best['power_w']:.2g} W at {best['voltage_vpp']:.0f} Vpp, weakest antinode {best['weakest_antinode_ratio']:.0%} "
            f"(layout {int(best['layout'])}: {_layout_words(best)}).")
    if answer.best_layout is not None:
        b = answer.best_layout
        text += (f" Solved again with its budget: {_pm_of(b, 'voltage_vpp')} Vpp and {_pm_of(b, 'power_w')} W "
                 f"(dominant: {b.dominant('voltage_vpp')}).")
    return text


def _pm_of(physics, quantity: str, digits: int = 2) -> str:
    return presentation.with_uncertainty_or_range(physics.nominal.values[quantity], physics.expanded[quantity], digits)


def _act_on(physics, quantities=("voltage_vpp", "power_w")) -> str | None:
    """Where a quantity's U reaches its value (shown as a range), the input to act on: its
    budget's largest term, in words; None when every one is a value +- U."""
    wide = [q for q in quantities if physics.expanded[q] >= physics.nominal.values[q] > 0]
    if not wide:
        return None
    rows = physics.budget[physics.budget["output"].isin(wide)]
    top = rows.loc[rows["contribution_abs"].idxmax()]
    return (f"The {' and '.join(presentation.label(q).split(' (')[0] for q in wide)} can only be given as a range: "
            f"their U is mostly {top['input_label']}. Act on it: characterise the built plate (its resonance at a "
            "known drive gives its force factor and Q) and give the run to design --measured.")


def _layout_words(row) -> str:
    columns = "columns at both ends" if row["columns"] == "ends" else "columns at both ends and the centre"
    spread = "at the corners" if row["arrangement"] == "corners" else "across the middle"
    return (f"{columns}, their piezos {row['edge_gap_mm']:.1f} mm from the edges, {int(row['piezos_per_column'])} "
            f"piezos per column {spread}, {row['piezo_thickness_mm']:g} mm thick")


# --- figures --------------------------------------------------------------------------------

def mode_figure(answer: DesignAnswer, path: Path) -> Path:
    point = answer.physics.nominal
    modes, k = point.modes, point.mode_index
    fig, ax = plt.subplots(figsize=(7, 4.4))
    image = ax.pcolormesh(modes.x_m * 1e3, modes.y_m * 1e3, modes.shapes[k].T, cmap="RdBu_r", vmin=-1, vmax=1,
                          shading="gouraud")
    for p in point.geometry.patches:
        x0, x1, y0, y1 = (b * 1e3 for b in p.bounds)
        ax.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, fill=p.powered, facecolor="0.3",
                                   edgecolor="k", linewidth=0.8))
    (tx0, tx1), (ty0, ty1) = answer.design.touch_area_mm
    ax.add_patch(plt.Rectangle((tx0, ty0), tx1 - tx0, ty1 - ty0, fill=False, edgecolor="k", linestyle="--"))
    ax.set_aspect("equal")
    ax.set(xlabel="x (mm)", ylabel="y (mm)",
           title=f"predicted working mode, {modes.frequencies_hz[k]:.0f} Hz ({modes.interior_antinodes(k)} antinodes)")
    fig.colorbar(image, ax=ax, label="deflection / largest", shrink=0.8)
    return save_figure(fig, path)


def power_figure(answer: DesignAnswer, path: Path) -> Path:
    v = answer.physics.nominal.values
    top = max(2.0 * v["voltage_vpp"], (answer.printed or {}).get("voltage_vpp", 0) * 1.2)
    voltage = np.linspace(0, top, 81)
    fig, ax = plt.subplots(figsize=(7, 4.4))
    power, band = answer.physics.band(voltage, "power_w")
    ax.plot(voltage, power, color="C0", label="physics (a)")
    ax.fill_between(voltage, power - band, power + band, color="C0", alpha=0.2, label="physics U (k = 2)")
    if answer.paper_route is not None:
        p_b, u_b = answer.paper_route.power_at(voltage, v["frequency_hz"])
        ax.plot(voltage, p_b, color="C1", label="small plates (b)")
        ax.fill_between(voltage, p_b - u_b, p_b + u_b, color="C1", alpha=0.2)
    ax.axvline(v["voltage_vpp"], color="C0", linestyle=":", label=f"target: {_target_words(answer)}")
    if answer.measured is not None:
        m = answer.measured
        ax.errorbar([m.voltage_vpp.nominal_value], [m.power_w.nominal_value], xerr=[2 * m.voltage_vpp.std_dev],
                    yerr=[2 * m.power_w.std_dev], fmt="s", color="k", label=f"measured ({m.plate})")
    if answer.printed:
        ax.plot([answer.printed["voltage_vpp"]], [answer.printed["power_w"]], **PAPER_STYLE, label="printed in the paper")
    ax.set(xlabel="piezo voltage (V pp)", ylabel="electrical power (W)", title="power against voltage at resonance")
    ax.set_ylim(0, None)
    ax.legend(fontsize=8)
    return save_figure(fig, path)


def placement_figure(answer: DesignAnswer, path: Path) -> Path:
    """Voltage (with the other inputs' U) and power for the target against the end piezos'
    distance from the edges; the drawn placement, the sweep's best layout of the same
    pattern and, for one of the paper's plates, its printed values where the curve meets them."""
    curve = answer.placement[answer.placement["voltage_vpp"].notna()]
    v = answer.physics.nominal.values
    fig, ax = plt.subplots(figsize=(7, 4.4))
    gap, volt, band = curve["edge_gap_mm"], curve["voltage_vpp"], curve["voltage_expanded_uncertainty"]
    ax.plot(gap, volt, color="C0", marker="o", label="voltage for the target")
    ax.fill_between(gap, volt - band, volt + band, color="C0", alpha=0.2, label="U (k = 2) of the other inputs")
    drawn = mean_edge_gap_mm(answer.design)
    ax.errorbar([drawn], [v["voltage_vpp"]], xerr=[answer.design.placement_tolerance_mm],
                yerr=[answer.physics.expanded["voltage_vpp"]], fmt="D", color="k", label="as drawn, ± bonding and U")
    power_ax = ax.twinx()
    power_ax.plot(gap, curve["power_w"], color="C3", linestyle="--", label="power for the target")
    if answer.printed:
        for g in crossings(gap, volt, answer.printed["voltage_vpp"]):
            ax.plot([g], [answer.printed["voltage_vpp"]], **PAPER_STYLE)
        ax.axhline(answer.printed["voltage_vpp"], **{**PAPER_STYLE, "marker": None, "linestyle": ":"},
                   label=f"printed {answer.printed['voltage_vpp']:g} Vpp (implied placement: inference)")
        power_ax.axhline(answer.printed["power_w"], color="C3", linestyle=":", linewidth=1,
                         label=f"printed {answer.printed['power_w']:g} W")
    ax.set(xlabel="end piezos' distance from the plate's edges (mm)", ylabel="piezo voltage (V pp, log scale)",
           title="where along the length the end piezos are bonded")
    ax.set_yscale("log")   # near a nodal line of curvature the voltage runs up tenfold: keep the useful range legible
    plain = matplotlib.ticker.FuncFormatter(lambda y, _: f"{y:g}")
    ax.yaxis.set_major_formatter(plain)
    ax.yaxis.set_minor_formatter(plain)
    power_ax.set_ylim(0, None)
    power_ax.set_ylabel("electrical power (W)")
    handles = ax.get_legend_handles_labels()
    more = power_ax.get_legend_handles_labels()
    ax.legend(handles[0] + more[0], handles[1] + more[1], fontsize=8)
    return save_figure(fig, path)


def pareto_figure(answer: DesignAnswer, path: Path) -> Path:
    frame, v = answer.layouts, answer.physics.nominal.values
    fig, ax = plt.subplots(figsize=(7, 4.4))
    ok = frame["feasible"].astype(bool)
    ax.scatter(frame.loc[~ok, "weakest_antinode_ratio"] * 100, frame.loc[~ok, "power_w"], s=10, color="0.75",
               label="beyond a limit")
    sc = ax.scatter(frame.loc[ok, "weakest_antinode_ratio"] * 100, frame.loc[ok, "power_w"], s=14,
                    c=frame.loc[ok, "piezo_thickness_mm"], cmap="viridis", label="within the limits")
    front = frame[frame["pareto"]].sort_values("weakest_antinode_ratio")
    ax.plot(front["weakest_antinode_ratio"] * 100, front["power_w"], color="crimson", marker="o", markerfacecolor="none",
            label="best trade-offs (Pareto)")
    ax.plot([v["weakest_antinode_ratio"] * 100], [v["power_w"]], marker="D", color="k", linestyle="none",
            label=f"{answer.design.name} as drawn")
    fig.colorbar(sc, ax=ax, label="piezo thickness (mm)", shrink=0.8)
    ax.set(xlabel="weakest antinode in the touch area (% of the strongest)", ylabel="power for the target (W)",
           title="where the piezos go: power against homogeneity")
    ax.set_yscale("log")
    ax.legend(fontsize=8)
    return save_figure(fig, path)


# --- tables -------------------------------------------------------------------------------

_VALUE_ROWS = (("frequency_hz", "working mode frequency", "Hz"), ("half_wavelength_mm", "nodal-line spacing λ/2", "mm"),
               ("mechanical_q", "mechanical Q", "1"), ("modal_mass_g", "modal mass at the centre", "g"), ("force_factor_n_per_v", "force factor at the centre", "N/V"),
               ("clamped_capacitance_nf", "clamped capacitance C0 (powered)", "nF"),
               ("k_eff", "effective coupling k_eff", "1"), ("voltage_vpp", "piezo voltage", "V pp"),
               ("piezo_field_v_per_mm", "field amplitude in the piezo", "V/mm"),
               ("mechanical_power_w", "mechanical power", "W"), ("dielectric_power_w", "dielectric power", "W"),
               ("power_w", "electrical power", "W"), ("current_pp_a", "current", "A pp"),
               ("apparent_power_va", "apparent power", "VA"),
               ("weakest_antinode_ratio", "weakest antinode / strongest (touch area)", "1"),
               ("width_uniformity", "width uniformity (touch area)", "1"))


def values_table(answer: DesignAnswer) -> pd.DataFrame:
    v, u = answer.physics.nominal.values, answer.physics.expanded
    return pd.DataFrame([{"quantity": words, "unit": unit, "predicted": presentation.with_uncertainty_or_range(v[key], u[key]),
                          "dominant input": answer.physics.dominant(key) if u[key] > 0 else "none"}
                         for key, words, unit in _VALUE_ROWS])


def budget_table(answer: DesignAnswer, output: str) -> pd.DataFrame:
    rows = answer.physics.budget[answer.physics.budget["output"] == output]
    total = float(np.sqrt((rows["contribution"] ** 2).sum()))
    absolute = rows["tolerance_rel"].isna()   # the placement's, in mm
    return pd.DataFrame({
        "input": rows["input_label"],
        "tolerance (±, rectangular unless the input names another)": [f"{mm:g} mm" if a else presentation.percent(t).lstrip("+")
                                       for a, t, mm in zip(absolute, rows["tolerance_rel"], rows["tolerance_mm"])],
        "u of the input": [f"{mm:.2f} mm" if a else f"{x:.2%}"
                           for a, x, mm in zip(absolute, rows["input_u_rel"], rows["input_u_mm"])],
        "contribution to u": [np.format_float_positional(c, precision=3, unique=False, fractional=False, trim="-",
                                                         sign=True) for c in rows["contribution"]],
        "share of u²": [f"{(c / total) ** 2:.0%}" if total else "0%" for c in rows["contribution"]]})


def comparison_table(answer: DesignAnswer) -> pd.DataFrame:
    frame = answer.comparison()
    return pd.DataFrame({
        "quantity": [presentation.label(q) for q in frame["quantity"]], "route": frame["source"],
        "predicted ± U": [presentation.with_uncertainty_or_range(a, b) for a, b in zip(frame["value"], frame["expanded_uncertainty"])],
        "reference": [f"{_plain(a, b)} ({r})" if r else "none"
                      for a, b, r in zip(frame["reference_value"], frame["reference_expanded_uncertainty"], frame["reference"])],
        "deviation": [presentation.percent(d) if math.isfinite(d) else "" for d in frame["deviation"]],
        "within U": ["" if w is None else ("yes" if w else "no") for w in frame["within_u"]]})


def _plain(value: float, u: float) -> str:
    """A reference value: with its U when it has one, else positional at 4 significant digits."""
    return presentation.with_uncertainty(value, u) if u > 0 else cell_text(value)


def assumptions(answer: DesignAnswer) -> str:
    d = answer.design
    items = [f"<li><b>{html.escape(k)}</b>: {html.escape(v)}</li>" for k, v in d.provenance.items()]
    shape = "" if d.damping.spread == "paper_builds" else " (rectangular)"   # the words name a log-normal one
    items.append(f"<li><b>damping</b>: {html.escape(_q_words(answer))}{shape}: "
                 f"{html.escape(d.damping.origin)}</li>")
    sheet = " (the rolled sheet's, EN 485-4)" if d.tolerances.thickness_m is None else ""
    items.append("<li><b>tolerances</b> (rectangular half-widths): " + ", ".join(
        f"{label} ±{d.tolerance(name):.1%}" + (sheet if name == "thickness_m" else "")
        for name, label, _ in INPUTS
        if name not in ("mechanical_q", "placement_mm", "bond_loss_factor", "build_force_factor")) + "</li>")
    items.append("<li><b>force factor</b>: the model's, spread as the force factor the paper's builds realise "
                 "over it (log-normal, sized on Table 3's plates, judged on the others): measure the built plate's "
                 "to remove it</li>")
    items.append(f"<li><b>placement</b>: each end group within ±{d.placement_tolerance_mm:g} mm along the length "
                 "(rectangular; the bonding tolerance unless a group states its own), all moved together in the "
                 "budget, as one template or jig places them</li>")
    items.append(f"<li><b>piezo loss</b>: tan δ {d.piezo.tan_delta_low_field:g} at low field to "
                 f"{d.piezo.tan_delta_at_max_field:g} at {d.piezo.max_field_v_per_mm:g} V/mm (field amplitude), linear "
                 "between them (NCE 41 datasheet); the field limit is that highest stated point</li>")
    items.append("<li><b>model</b>: Kirchhoff plate with bonded piezo laminate, free edges, scikit-fem Argyris elements "
                 "(plates/plate_modes.py); voltage, power and current from the mode's modal mass and force factor at the "
                 "plate's centre (designing/design.py)</li>")
    if answer.paper_route is not None:
        r = answer.paper_route
        items.append(f"<li><b>route (b)</b>: Q from {html.escape(r.template)} scaled by Eq. 29 to the design's "
                     f"{d.piezo.width_y_mm:g} mm piezo; tan θ′ the mean of {', '.join(r.small_plates)}; Eqs. 27 and 25 "
                     f"under the report's reading '{r.convention.name}', at the frequency and λ/2 physics predicts. "
                     f"{html.escape(d.from_small_plates.origin)}</li>")
    return "<ul>" + "".join(items) + "</ul>"


# --- the page and its files ------------------------------------------------------------------

def payload(answer: DesignAnswer, files: dict[str, str]) -> dict:
    """design.json: what the page says, for scripts (every number with its U, k = 2)."""
    v, u = answer.physics.nominal.values, answer.physics.expanded
    physics = {k: _with_u(float(x), u.get(k)) for k, x in v.items()}
    route = answer.paper_route
    verdict = answer.judged()
    return {
        "command": "design", "design": answer.design.name, "headline": headline(answer),
        "verdict": {"status": verdict.status, "reasons": list(verdict.reasons), "changes": list(verdict.changes)},
        "placement": _placement_payload(answer),
        "best_layout": None if answer.best_layout is None else {
            "edge_gap_mm": mean_edge_gap_mm(answer.best_layout.design),
            **{k: _with_u(answer.best_layout.nominal.values[k], answer.best_layout.expanded[k])
               for k in ("voltage_vpp", "power_w")}},
        "target": answer.design.target.model_dump(), "coverage_factor": COVERAGE_FACTOR,
        "physics": physics,
        "dominant_inputs": {k: answer.physics.dominant(k) for k in BUDGET_OUTPUTS},
        "small_plates": None if route is None else {
            "q": _uf(route.q), "tan_theta": _uf(route.tan_theta), "voltage_vpp": _uf(route.voltage_vpp),
            "power_w": _uf(route.power_w), "template": route.template, "plates": list(route.small_plates),
            "reading": route.convention.name},
        "small_plates_problem": answer.paper_route_problem or None,
        "comparison": json.loads(answer.comparison().to_json(orient="records")),
        "layouts": None if answer.layouts is None else {
            "count": int(len(answer.layouts)), "feasible": int(answer.layouts["feasible"].sum()),
            "solved_by": answer.layouts_note,
            "pareto": json.loads(answer.layouts[answer.layouts["pareto"]].to_json(orient="records"))},
        "files": files,
    }


def _placement_payload(answer: DesignAnswer) -> dict | None:
    curve = answer.placement
    if curve is None:
        return None
    ok = curve[curve["voltage_vpp"].notna()]
    implied = None
    if answer.printed:
        implied = {"inference": True,
                   "voltage_vpp": {"printed": answer.printed["voltage_vpp"], "edge_gap_mm": crossings(
                       ok["edge_gap_mm"], ok["voltage_vpp"], answer.printed["voltage_vpp"]),
                       "within_u_edge_gap_mm": edge_gaps_within_u(ok, answer.printed["voltage_vpp"])},
                   "power_w": {"printed": answer.printed["power_w"], "edge_gap_mm": crossings(
                       ok["edge_gap_mm"], ok["power_w"], answer.printed["power_w"])}}
    least = ok.loc[ok["voltage_vpp"].idxmin()] if len(ok) else None
    return {"edge_gap_mm": mean_edge_gap_mm(answer.design), "tolerance_mm": answer.design.placement_tolerance_mm,
            "least_voltage": None if least is None else {
                "edge_gap_mm": float(least["edge_gap_mm"]), "voltage_vpp": float(least["voltage_vpp"]),
                "expanded_uncertainty": float(least["voltage_expanded_uncertainty"])},
            "sentences": placement_sentences(answer), "curve": json.loads(curve.to_json(orient="records")),
            "implied_by_printed": implied}


def _with_u(value: float, u: float | None) -> dict:
    """A number for scripts: its value, its U (k = 2) and the interval they stand for
    (`predicted_plates.expanded_interval`: the factor interval where U passes the value, as the
    page writes it)."""
    if u is None or not math.isfinite(u):
        return {"value": value, "expanded_uncertainty": u}
    low, high = predicted_plates.expanded_interval(value, u)
    return {"value": value, "expanded_uncertainty": u, "interval": [float(low), float(high)]}


def _uf(value) -> dict:
    return _with_u(value.nominal_value, COVERAGE_FACTOR * value.std_dev)


def write(answer: DesignAnswer, out_dir: Path) -> dict[str, str]:
    """The page, its figures and tables, and design.json in `out_dir`; returns the files."""
    out_dir.mkdir(parents=True, exist_ok=True)
    files = {}
    answer.physics.budget.drop(columns="contribution_abs").to_csv(out_dir / FILES["budget"], index=False)
    answer.comparison().to_csv(out_dir / FILES["comparison"], index=False)
    files["budget"], files["comparison"] = FILES["budget"], FILES["comparison"]
    mode_figure(answer, out_dir / FILES["mode"])
    power_figure(answer, out_dir / FILES["power"])
    files["mode"], files["power"] = FILES["mode"], FILES["power"]
    if answer.placement is not None and answer.placement["voltage_vpp"].notna().sum() >= 2:
        answer.placement.to_csv(out_dir / FILES["placement"], index=False)
        placement_figure(answer, out_dir / FILES["placement_figure"])
        files["placement"], files["placement_figure"] = FILES["placement"], FILES["placement_figure"]
    if answer.layouts is not None:
        answer.layouts.to_csv(out_dir / FILES["layouts"], index=False)
        pareto_figure(answer, out_dir / FILES["pareto"])
        files["layouts"], files["pareto"] = FILES["layouts"], FILES["pareto"]
    files["page"], files["json"] = FILES["page"], FILES["json"]
    (out_dir / FILES["page"]).write_text(page(answer, files), encoding="utf-8")
    (out_dir / FILES["json"]).write_text(json.dumps(payload(answer, files), indent=2, default=str), encoding="utf-8")
    return files


def _history_html(history: pd.DataFrame) -> str:
    """Each design checked against its built plate: the physics route's deviation per
    quantity and whether the measurement fell within U, newest last."""
    rows = history[history["quantity"].isin(["voltage_vpp", "power_w"])]
    table = pd.DataFrame({
        "design": rows["design"], "checked (UTC)": rows["checked_utc"], "route": rows["source"],
        "quantity": [presentation.label(q) for q in rows["quantity"]],
        "deviation": [presentation.percent(d) for d in rows["deviation"]],
        "within U": ["yes" if str(w).lower() == "true" else "no" for w in rows["within_u"]]})
    share = (table["within U"] == "yes").mean()
    return (f"<p>{len(rows['design'].unique())} design(s) checked against the plate built from them; "
            f"{share:.0%} of these predictions held within their U.</p>"
            + html_table(table, "Prediction against the built plate's measurement, from history.csv beside the "
                                "designs' folders"))


def _figure(file: str, alt: str, caption: str) -> str:
    return (f"<figure><img src='{file}' alt='{html.escape(alt)}'>"
            f"<figcaption>{html.escape(caption)}</figcaption></figure>")


def page(answer: DesignAnswer, files: dict[str, str]) -> str:
    d = answer.design
    sections = []
    status = answer.judged().status
    lines = [html.escape(line) for line in headline(answer)]
    lines[0] = f"<span class='verdict'>{lines[0]}</span>"
    answer_html = (f"<div class='banner {status}'>" + "".join(f"<p>{line}</p>" for line in lines)
                   + "</div>" + html_table(comparison_table(answer), "Each route's prediction ± U (k = 2) beside the "
                                           "reference: a measurement of the built plate when given, else the paper's "
                                           "printed value"))
    sections.append(("Answer", answer_html))
    sections.append(("Working mode and what it needs", _figure(
        FILES["mode"], "predicted mode shape", "The working mode as the plate model predicts it: piezos (filled: "
        "powered) and the touch area (dashed).") + html_table(values_table(answer), "Physics route: each value ± U "
                                                              "(k = 2) and the input that dominates its U")))
    sections.append(("Power against voltage", _figure(
        FILES["power"], "power against voltage", "Electrical power at resonance against the piezo voltage: physics "
        "with its band, the paper's method with its band when small plates were given, the target's voltage.")))
    if "placement_figure" in files:
        sections.append(("Where along the length", "".join(f"<p>{html.escape(t)}</p>" for t in
                                                          placement_sentences(answer)) + _figure(
            FILES["placement_figure"], "voltage and power against the piezos' distance from the edge",
            "The voltage and power the target needs with the end piezos at each distance from the plate's edges, on "
            "the design's working mode; the diamond is the design as drawn with its bonding tolerance and U.")))
    if answer.layouts is not None:
        frame = answer.layouts
        front = frame[frame["pareto"]].sort_values("power_w")
        shown = front[["layout", "columns", "edge_gap_mm", "piezos_per_column", "arrangement", "piezo_thickness_mm",
                       "voltage_vpp", "power_w", "weakest_antinode_ratio"]]
        sections.append(("Where the piezos go", f"<p>{html.escape(_layouts_sentence(answer))}</p>" + _figure(
            FILES["pareto"], "power against homogeneity of the layouts",
            "Each layout's power for the target against its weakest antinode; grey: beyond the amplifier or the "
            "piezo's field limit, or no clean working mode.") + html_table(
            shown, "The best trade-offs (no other layout needs less power and is more even)") + presentation.fold(
            f"All {len(frame)} layouts", f"<p>In <a href='{FILES['layouts']}'>{FILES['layouts']}</a>, with the reason "
            "each infeasible layout fails.</p>")))
    if answer.history is not None and not answer.history.empty:
        sections.append(("How the designs fare", _history_html(answer.history)))
    budget_html = "".join(presentation.fold(
        f"{presentation.label(o)}: {_pm(answer, o)}", html_table(budget_table(answer, o), f"Budget of {o}"))
        for o in BUDGET_OUTPUTS)
    sections.append(("Uncertainty budget", "<p>Each input moved by its standard uncertainty, the plate solved "
                     "again where it must be; U = 2 √(Σ contribution²).</p>" + budget_html))
    sections.append(("Assumptions and their origins", assumptions(answer)))
    description = f"<p>{html.escape(d.description)}</p>" if d.description else ""
    return html_page.render(f"squeezebench design: {d.name}",
                            [html_page.PageSection(f"s{i}", t, t, b) for i, (t, b) in enumerate(sections)], description)


def write_design(answer: DesignAnswer, out_dir: str | Path | None = None,
                 measured_run: str | Path | None = None) -> tuple[Path, dict[str, str]]:
    """The page and its files in `out_dir` (default designs/<name>); returns the folder and
    the files. With the built plate's run, its comparison joins the history beside the
    designs' folders (`HISTORY_FILE`), which the page shows."""
    folder = Path(out_dir) if out_dir is not None else Path("designs") / answer.design.name
    if measured_run is not None and answer.measured is not None:
        history = record_measurement(answer, folder.parent / HISTORY_FILE, measured_run)
        answer = replace(answer, history=history)
    return folder, write(answer, folder)
