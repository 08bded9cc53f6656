"""The paper's Tables 3, 4 and 5 in the paper's layout: each cell this run +- U, the printed
value, the deviation and its origin, and why a printed number is not returned.
"""

from __future__ import annotations

import html
import math
from dataclasses import replace
from typing import Callable

import numpy as np
import pandas as pd

from squeezebench.analysis import audit, characterisation, model, provenance, tables
from squeezebench.report import figures, headline, presentation
from squeezebench.plates import predicted_plates
from squeezebench.paper import paper_value
from squeezebench.analysis.rundata import RunData
from squeezebench.errors import UserError
from squeezebench.report.section import (ReportContext, Section, bench_words, paper_findings, html_table, signed, slug,
                                         table5_readings)


def _explanation(context: ReportContext, table: str, item: str, quantity: str,
                 value: float) -> tuple[str, str, str] | None:
    """What explains a disagreement of this run's `value` (table, item, quantity) with the
    paper: the anchor to link, a sentence built from computed numbers and the same in a
    few words for the opening, or None. An explanation counts only when it reproduces this
    run's value (within MATCH_REL): the audit's number from printed values alone, or this
    run under the inferred reading."""
    findings = paper_findings()

    def matches(number: float) -> bool:
        return math.isfinite(value) and abs(value - number) <= audit.MATCH_REL * abs(number)

    if (table, item, quantity) == ("table5", "estimated", "q"):
        carried = _finding(findings, "Eq. 29 inverted", "Q_large with")
        needed = _finding(findings, "Eq. 29 inverted", "Q_small")
        if matches(carried["computed"]):
            return ("audit-" + slug(carried["topic"]),
                    f"Eq. 29 carries Plate 4's printed Q = {needed['printed']:.3g} to {carried['computed']:.4g}; "
                    f"the printed {carried['printed']:.3g} needs Q = {needed['computed']:.4g}: the paper "
                    "computed it from Plate 4's Q before rounding",
                    f"the paper's own Eq. 29 carries Plate 4's printed Q to {carried['computed']:.4g}: it was "
                    "computed before rounding")
    if (table, item, quantity) == ("table5", "measured", "tan_theta"):
        row = _finding(findings, "Table 5 under E_i", "tan theta'")
        if matches(row["computed"]):
            return ("audit-" + slug(row["topic"]),
                    f"the paper's own Eq. 25 with its printed Q turns its printed 1.3 W at 32 Vpp into "
                    f"tan θ′ = {signed(row['computed'])} (E_i as printed), not the printed {signed(row['printed'])}: "
                    "under the text's definitions the printed power and loss tangent cannot both hold, and a "
                    "plate that returns the 1.3 W misses the printed tan θ′ under either E_i (with Q read from "
                    "the same plate's amplitude, E_i cancels from tan θ′)",
                    f"the paper's own Eq. 25 turns its printed 1.3 W into tan θ′ = {signed(row['computed'])}: "
                    "the printed power and loss tangent cannot both hold")
    return _inferred_reading_explanation(context, table, item, quantity)


def _reading_words(name: str) -> str:
    """A reading of Eqs. 25/27 (a Convention's name) named for a reader."""
    return {model.PHYSICAL_CONVENTION.name: "the physical reading (E_i = 67 GPa, the text's definitions)",
            model.PAPER_CONVENTION.name: "the text's reading (E_i as printed)"}.get(
        name, f"the {html.escape(name)} reading")


def _finding(findings: pd.DataFrame, topic: str, quantity_prefix: str) -> pd.Series:
    """The first audit finding of `topic` whose quantity starts with `quantity_prefix`."""
    return findings[(findings["topic"] == topic) & findings["quantity"].str.startswith(quantity_prefix)].iloc[0]


def _inferred_reading_explanation(context: ReportContext, table: str, item: str,
                                  quantity: str) -> tuple[str, str, str] | None:
    """Table 5 and Fig. 9 under the inferred reading (analysis.readings): when this run
    agrees with the paper there, the report's reading is what disagrees."""
    frame = _table5_under_readings(context)
    if frame is None or table not in ("table5", "fig9"):
        return None
    key = ("fig9", "mean_power_difference") if table == "fig9" else (item, quantity)
    others = frame[(frame["reading"] != context.convention.name) & (frame["item"] == key[0])
                   & (frame["quantity"] == key[1])]
    built_under = _scene_readings(context)
    for row in others.itertuples(index=False):
        agrees = (abs(row.value) <= audit.MATCH_REL if table == "fig9"
                  else abs(row.relative_difference) <= audit.MATCH_REL)
        if agrees:
            shown = (f"the estimate is within {100 * abs(row.value):.1f} % of the measured power"
                     if table == "fig9" else
                     f"this run gives {signed(row.value)} against the printed {signed(row.printed)} "
                     f"({presentation.percent(row.relative_difference)})")
            reading, used = _reading_words(str(row.reading)), _reading_words(context.convention.name)
            there = (f"{100 * abs(row.value):.1f} %" if table == "fig9" else
                     f"{signed(row.value)}, {presentation.percent(row.relative_difference)}")
            short = _reading_words(str(row.reading)).split(" (")[0]
            if row.reading in built_under:   # the run's own mix of readings, not the paper, makes the miss
                return ("readings", f"this run's Fig. 5 scenes were built from the paper's summaries under "
                        f"{reading}, and under it {shown}; analysed under {used}, used in this table, they "
                        "cannot return the printed numbers: the miss comes from mixing two readings in this "
                        "run, not from the paper",
                        f"this run's scenes were built under {short} ({there} there): the run mixes two "
                        "readings, the paper holds")
            return ("readings", f"under {reading} of the paper's open conventions, {shown}: {used}, used in "
                    "this table, is what disagrees with the paper's own numbers",
                    f"it holds only under {short} ({there} there), not under {used.split(', the text')[0]})")
    return None


def _scene_readings(context: ReportContext) -> set[str]:
    """The readings of Eqs. 25/27 the run's scenes were calibrated through (a state's
    `calibration.paper_model.convention`): a simulated plate built under one reading returns
    the printed numbers under that reading only."""
    found = set()
    for scene in context.run.scenes.values():
        for state in provenance.scene_states(scene).values():
            calibration = state.get("calibration")
            paper_model = calibration.get("paper_model") if isinstance(calibration, dict) else None
            if isinstance(paper_model, dict) and paper_model.get("convention"):
                found.add(str(paper_model["convention"]))
    return found


def _table5_under_readings(context: ReportContext) -> pd.DataFrame | None:
    try:
        return table5_readings(context)
    except UserError:
        return None


def _flag(context: ReportContext, title: str, anchor: str, frame: pd.DataFrame) -> dict[str, str]:
    """Records every cell outside its tolerance for the summary, with the sentence that
    explains it; returns item -> the link the cell shows."""
    links: dict[str, str] = {}
    for row in frame[frame["agrees"].map(lambda a: a is not None and not pd.isna(a) and not a)].itertuples(index=False):
        label = presentation.header(row.quantity)
        sentence = (f"{html.escape(str(row.item))}, {html.escape(label)}: this run "
                    f"{presentation.percent(row.relative_difference)} from the printed value")
        explanation = _explanation(context, str(row.table), str(row.item), str(row.quantity), row.value)
        if explanation:
            link, why, short = explanation
            sentence += f"; {why}. <a href='#{link}'>{'Audit' if link.startswith('audit') else 'Readings'}</a>."
            links[str(row.item)] = f"#{link}"
        else:
            link, short = anchor, "no audit finding explains it"
            sentence += "; no audit finding explains it."
            links.setdefault(str(row.item), f"#{anchor}")
        context.reasons[(str(row.table), str(row.item), str(row.quantity))] = headline.miss_line(
            pd.Series({**row._asdict(), "table": headline.PAPER_TABLES.get(str(row.table), title)}), short, f"#{link}")
        context.flagged.append((title, sentence, anchor))
    return links


def _paper_table_section(context: ReportContext, name: str, title: str, protocol: str,
                         compute: Callable[[RunData], pd.DataFrame], quantities: list[str],
                         item_label: Callable[[str], str], intro: str) -> Section | None:
    if context.run.protocol(protocol).empty:   # the CSV says "not measured" in every row
        context.tables[name] = tables.finish_table(tables.empty_table(name, quantities))
        context.absent.append(f"{title}: protocol '{protocol}' is not in this run")
        return None
    context.tables[name] = tables.finish_table(compute(context.run))   # the CSV's rows are the HTML's cells
    return Section(title, _paper_table_html(context, name, title, context.tables[name], item_label, intro), name)


def _paper_table_html(context: ReportContext, name: str, title: str, frame: pd.DataFrame,
                      item_label: Callable[[str], str], intro: str) -> str:
    explain = _flag(context, title, name, frame)
    budget = ("the fits, instrument specifications, geometry and NCE 41 tolerances" if name == "table5"
              else "noise and instrument specifications")
    physics = ("physics: what the plate model predicts for the paper's plate from geometry and datasheets "
               "± U (k = 2) and its deviation from print (no printed result in; see What physics predicts); "
               if "predicted_value" in frame and frame["predicted_value"].notna().any() else "")
    k_words = "k = 2" if name == "table5" else "k for 95 % under each budget's limits read as rectangles and as the world reads them"
    caption = (f"{html.escape(title)}. {bench_words(context)} Each cell: this run ± U ({k_words}, {budget}), "
               "the printed value and the deviation; ✓ within, ✗ outside "
               f"U plus half the printed last digit, {presentation.ROUND_TRIP_MARK}: a printed value the run was "
               f"given came back (the chain, not the paper); {physics}beneath, the origin of the number.")
    return (f"<p>{intro}</p>" + presentation.paper_layout(frame, name, item_label, explain, caption)
            + presentation.calibration_notes(frame, item_label)
            + f"<p class='csv'>Machine-readable: <a href='{name}.csv'>{name}.csv</a> "
              "(columns in <a href='columns.csv'>columns.csv</a>).</p>")


def table3_section(context: ReportContext) -> Section | None:
    """Table 3"""
    return _paper_table_section(
        context, "table3", "Table 3: cutting the resonator (Sec. 2.3.1)", "resonator_cutting", tables.table3,
        tables.TABLE3_QUANTITIES, lambda item: f"{item} × 41 mm",
        "The one-column plate at 20 Vpp, cut to shorter lengths: if the resonator's own losses "
        "mattered, the power at a given velocity would change with its length.")


def table4_section(context: ReportContext) -> Section | None:
    """Table 4"""
    return _paper_table_section(
        context, "table4", "Table 4: powered columns (Sec. 2.3.2)", "powered_columns", tables.table4,
        tables.TABLE4_QUANTITIES, str,
        "One- and two-column plates (76 × 41 × 1.2 mm), one or both columns powered.")


def table5_section(context: ReportContext) -> Section | None:
    """Table 5, Figs. 8 and 9 (the figures alone when the run has the large plate but not
    the small plate Table 5 estimates from)"""
    context.tables["table5"] = tables.finish_table(tables.empty_table("table5", ["q", "tan_theta"]))
    if context.run.protocol("characterisation").empty:
        return None   # characterisation_section says so
    plates = context.plates()
    if characterisation.LARGE_PLATE not in plates:
        context.absent.append(f"Table 5 and Figs. 8-9: the run has no characterisation of {characterisation.LARGE_PLATE}")
        return None
    estimated = characterisation.TEMPLATE_SMALL_PLATE in plates
    large = plates[characterisation.LARGE_PLATE]
    response = predicted_plates.large_plate_response()
    printed_vpp = paper_value("large_plate", "large_plate", "voltage_vpp")
    physics_amplitude = (response["amplitude_pp_m_per_vpp"] * printed_vpp * 1e6,
                         response["amplitude_rel_U"] * response["amplitude_pp_m_per_vpp"] * printed_vpp * 1e6)
    physics_power = (response["power_w_per_vpp2"] * printed_vpp**2,
                     response["power_rel_U"] * response["power_w_per_vpp2"] * printed_vpp**2)
    fig8 = context.figure(
        context.draw(figures.fig8_amplitude, large, context.out_dir / "fig8.png",
                     (response["amplitude_pp_m_per_vpp"], response["amplitude_rel_U"])),
        "Fig. 8 recomputed: amplitude pp of the large plate against voltage pp, with the fitted line "
        f"(intercept kept) and residuals. The paper reports about {paper_value('large_plate', 'large_plate', 'amplitude_m') * 1e6:g} µm "
        f"at {printed_vpp:g} Vpp (★). Physics (the plate model, no printed result in; green, U "
        f"k = 2) predicts {presentation.with_uncertainty_or_range(*physics_amplitude, unit='µm pp')} at the plate's centre "
        f"there. " + bench_words(context))
    if estimated:
        title = "Table 5: the large plate estimated from the small ones (Sec. 5.3)"
        context.tables["table5"] = table5 = tables.finish_table(characterisation.table5(plates, context.convention))
        body = _paper_table_html(
            context, "table5", title, table5, lambda item: f"{item} ({'Eq. 29 from small_plate_4' if item == 'estimated' else 'large_plate'})",
            "Estimated: Q of small_plate_4 carried to the large plate by Eq. 29, tan θ′ the mean of "
            "the small plates as thick as the large one. Measured: the large plate's own voltage sweep.")
        body += presentation.fold("Table 5 under each reading of Table 2's E_i, and Fig. 8", html_table(
            _table5_by_materials(context), "Table 5 recomputed from the same fits under both readings of E_i "
            "(only a of Eqs. 25/27 changes). " + bench_words(context)) + fig8)
    else:
        context.absent.append(f"Table 5: the run has no characterisation of {characterisation.TEMPLATE_SMALL_PLATE} "
                              "to estimate the large plate from")
        title = "Figs. 8 and 9: the large plate (Sec. 5.3)"
        body = ("<p>The large plate's own voltage sweep; Table 5's estimate needs the small plates, which "
                "this run did not characterise.</p>" + fig8)
    power = characterisation.estimated_large_plate_power_w(plates, context.convention)
    body += context.figure(
        context.draw(figures.fig9_power, power, context.out_dir / "fig9.png"),
        "Fig. 9 recomputed: power of the large plate against voltage pp squared, from its own sweep "
        + ("(●) and estimated from the small plates through Eqs. 25 and 29 with Table 5's estimate (■). "
           if estimated else "(●). ")
        + f"The paper reports {paper_value('large_plate', 'large_plate', 'power_w'):g} W at "
        f"{printed_vpp:g} Vpp (★) and an estimate within "
        f"10 % of the measurement. Physics (green, U k = 2, one damping figure shared by every plate) "
        f"predicts {presentation.with_uncertainty_or_range(*physics_power, unit='W')} there. " + bench_words(context))
    if not estimated:
        return Section(title, body, "table5")
    error = float(np.mean(np.abs(power["power_estimated_w"] / power["power_measured_w"] - 1.0)))
    verdict = "within" if error < audit.MATCH_REL else "outside"
    sentence = (f"Mean relative difference, estimated vs measured power: {100 * error:.1f} %, {verdict} "
                f"the paper's 10 %.")
    if error >= audit.MATCH_REL:
        explanation = _explanation(context, "fig9", "", "power_w", error)
        opening = (f"Fig. 9: the power estimated from the small plates is {100 * error:.1f} % from the measured "
                   "power on average, outside the paper's 10 %")
        if explanation:
            anchor, why, short = explanation
            sentence += f" Why: {why}. <a href='#{anchor}'>Readings</a>."
            context.extra_misses.append(headline.Line(f"{opening}; {short}.", f"#{anchor}", "miss"))
        else:
            sentence += " No audit finding or reading explains it."
            context.extra_misses.append(headline.Line(f"{opening}; no audit finding or reading explains it.",
                                                      "#table5", "miss"))
        context.flagged.append(("Fig. 9", sentence, "table5"))
    body += f"<p class='{'explain' if error >= audit.MATCH_REL else ''}'>{sentence}</p>"
    return Section(title, body, "table5")


def _table5_by_materials(context: ReportContext) -> pd.DataFrame:
    """Table 5 recomputed from the same fits with E_i as printed and E_i = 67 GPa
    (only a in Eqs. 25/27 changes: Q scales with a, tan theta' does not)."""
    frames = []
    for materials in (model.MATERIALS_AS_PRINTED, model.MATERIALS_PHYSICAL):
        name = ("E_i as printed (67109 Pa)" if materials is model.MATERIALS_AS_PRINTED
                else f"E_i = {materials.resonator_young_pa / 1e9:g} GPa")
        convention = replace(context.convention, name=name, materials=materials)
        frame = characterisation.table5(characterisation.characterise_plates(context.run, convention), convention)
        frames.append(pd.DataFrame({"reading": convention.name, "item": frame["item"],
                                    "quantity": frame["quantity"].map(presentation.header),
                                    "this run": frame["value"].map(lambda v: f"{v:.3f}"),
                                    "printed": frame["paper_value"].map(lambda v: f"{v:.2f}"),
                                    "deviation (%)": frame["relative_difference"].map(
                                        lambda v: presentation.percent(v).removesuffix(" %"))}))
    return pd.concat(frames, ignore_index=True)
