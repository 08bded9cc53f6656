"""The uncertainty sections: the run's budgets (GUM, k for 95 %) and the measurement model of
every stated quantity.
"""

from __future__ import annotations

import html

import pandas as pd

from squeezebench.analysis import measurement_model, uncertainty
from squeezebench.analysis.budgets import P95_FACTOR
from squeezebench.report import presentation
from squeezebench.report.section import ReportContext, Section, bench_words, html_table, run_budgets, words_of


def _percent_range(fractions: pd.Series) -> str:
    """"95.6 to 98.3 %", or one number when they all round alike."""
    low, high = (f"{100 * float(v):.1f}" for v in (fractions.min(), fractions.max()))
    return f"{low} %" if low == high else f"{low} to {high} %"


def uncertainty_section(context: ReportContext) -> Section | None:
    """Uncertainty budgets (GUM, k for 95 %)"""
    found = run_budgets(context)
    if found.points.empty:
        return None   # no stored records to budget (a study-only directory)
    quantities = list(uncertainty.POINT_BUDGETS)
    summary = pd.DataFrame([
        {"protocol": protocol, "quantity": q, "points": int(rows[f"{q}_U"].notna().sum()),
         "median_expanded_relative": float((rows[f"{q}_U"] / rows[q].abs()).median()),
         "median_coverage_of_U": float(rows[f"{q}_U_coverage"].median()),
         "dominant_term": rows[f"{q}_dominant"].mode().iat[0]}
        for protocol, rows in found.points.groupby("protocol", sort=False) for q in quantities])
    context.tables["uncertainty_summary"] = summary
    context.tables["uncertainty_budgets"] = found.budgets
    columns = ["run_name", "step_id", "point_index", "protocol"] + [
        f"{q}{suffix}" for q in quantities for suffix in ("", "_U", "_U_coverage", "_dominant")]
    context.tables["uncertainty_points"] = found.points[[c for c in columns if c in found.points]]
    context.tables["uncertainty_resonances"] = found.searches
    plates = []
    if not context.run.protocol("characterisation").empty:
        for name, plate in context.plates().items():
            budgets = uncertainty.characterisation_budgets(plate, context.convention, found.deskew)
            floors = uncertainty.characterisation_budgets(plate, context.convention, found.deskew, with_fit=False)
            for budget, floor in zip(budgets, floors):
                plates.append({"plate": name, "quantity": budget.quantity, "value": budget.value,
                               "expanded_uncertainty": budget.expanded_uncertainty,
                               "dominant_term": budget.dominant.name,
                               "floor_p95_rel": floor.p95_bound / abs(floor.value)})
    context.tables["uncertainty_q_tan_theta"] = pd.DataFrame(plates)
    context.tables["uncertainty_floors"] = uncertainty.systematic_floor(found.points, found.deskew)
    deskew = (_delay_flag(found.points) if found.deskew is None else
              f"<p>Power corrected by the deskew calibration: CH2 delay {found.deskew.delay_s * 1e9:.2f} ns "
              f"(u = {found.deskew.std_uncertainty_s * 1e9:.2f} ns), current-to-voltage gain ratio "
              f"{found.deskew.gain_ratio:.4f} (u = {found.deskew.gain_ratio_u:.4f}).</p>")
    detail = (html_table(found.budgets[[c for c in ("protocol", "quantity", "term", "type", "relative", "share",
                                                    "source") if c in found.budgets]],
                         "The whole budget of one point of each protocol (relative: the term's standard "
                         "uncertainty over the value; the point: uncertainty_budgets.csv). " + bench_words(context))
              + "<p>Resonance frequencies found by the searches (the generator's setting there), "
                "expanded (k for 95 % under each budget):</p>" + html_table(found.searches, "Resonance frequencies found, expanded (k for 95 % under each budget). " + bench_words(context))
              + "<p>Q and tan(theta') per plate with the geometry and material tolerances "
                "(expanded, k for 95 % under each budget; floor: p95 relative error with the fits' noise gone):</p>"
              + html_table(context.tables["uncertainty_q_tan_theta"], "Q and tan θ′ with tolerances. " + bench_words(context))
              + "<p>Floor per run: the p95 relative error of power and velocity the instruments' "
                "specified errors leave at the run's worst point, whatever the averaging:</p>"
              + html_table(context.tables["uncertainty_floors"], "Floor per run. " + bench_words(context)))
    overall = "; ".join(
        f"{words_of(q)} {100 * float((found.points[f'{q}_U'] / found.points[q].abs()).median()):.2g} % "
        f"(mostly {found.points[f'{q}_dominant'].mode().iat[0]})" for q in quantities if f"{q}_U" in found.points)
    coverage = "; ".join(f"{words_of(q)} {_percent_range(found.points[f'{q}_U_coverage'])}"
                         for q in quantities if found.points[f"{q}_U_coverage"].notna().any())
    return Section("Uncertainty budgets (GUM, k for 95 %)",
                   "<p>Expanded uncertainties of every stored point: noise of the record (Type A) "
                   f"and the instruments' specifications (Type B). Median relative U over the run: {html.escape(overall)}. "
                   "k is each budget's own, the smallest that holds 95 % under both error models it claims "
                   "to cover: its specification terms rectangular as stated, and as the world reads a limit "
                   "(normal with half the limit as spread, one in 100 at 1.5 times it), the rest normal, "
                   "convolved. Under the specifications +-U holds the value with a probability of "
                   f"{html.escape(coverage)}; k runs from 1.78 (one rectangle, where the specifications' own "
                   "1.65 covers 93.3 % of the world's errors) to 1.96 (a normal).</p>"
                   + deskew
                   + presentation.fold("Median relative U and dominant term per protocol",
                                       html_table(summary, "Median relative U and dominant term per protocol. " + bench_words(context)))
                   + presentation.fold("Every term of one point's budget per protocol, the resonance frequencies, "
                                       "Q and tan θ′ with their tolerances, and the floor per run", detail)
                   + "<p>CSV: <a href='uncertainty_points.csv'>uncertainty_points.csv</a>, "
                     "<a href='uncertainty_budgets.csv'>uncertainty_budgets.csv</a></p>")


def _delay_flag(points: pd.DataFrame) -> str:
    """Without a deskew run: which points' U is mostly the CH2 delay's bias bound (the
    current probe's lag of known sign, `uncertainty.delay_std_uncertainty_s`): covered, but
    a deskew calibration would measure the lag and shrink them."""
    text = "<p>No deskew calibration in this run: the CH2 delay enters at its bound.</p>"
    flagged = uncertainty.needs_deskew(points)
    if flagged.empty:
        return text
    where = ", ".join(sorted({f"{run} / {step}" for run, step in zip(flagged["run_name"], flagged["step_id"])}))
    bound_ns = P95_FACTOR * uncertainty.delay_std_uncertainty_s() * 1e9
    return (f"<p class='banner'><b>Needs a deskew calibration:</b> {len(flagged)} point(s) ({html.escape(where)}) "
            f"have a power whose U (above {uncertainty.DELAY_FLAG_U_REL:.0%}) is mostly the CH2 delay, budgeted as "
            f"a bias bound of {bound_ns:.0f} ns: a current probe lags its voltage probe by a fixed delay of known "
            "sign (about 8 ns in Tektronix's deskew example) that nothing here measured. A deskew_calibration run "
            "(squeezebench plan --write adds one) measures it and shrinks these U.</p>")


def measurement_model_section(context: ReportContext) -> Section | None:
    """Measurement model: measurand, equation and inputs of every quantity (issue 28)"""
    found = run_budgets(context)
    stored = found.points[found.points["power_w_u"].notna()] if "power_w_u" in found.points else found.points.iloc[0:0]
    if stored.empty:
        return None
    table = measurement_model.model_table(stored.iloc[0].to_dict(), found.deskew)
    context.tables["measurement_model"] = table
    blocks = []
    for quantity, rows in table.groupby("quantity", sort=False):
        first = rows.iloc[0]
        inputs = rows[["input", "type", "distribution", "relative_std_uncertainty", "correction", "source"]]
        described = (f"<p><b>Measurand.</b> {html.escape(first['measurand'])}</p>"
                     f"<p><b>Model.</b> {html.escape(first['model'])}</p>") if first["measurand"] else ""
        blocks.append(presentation.fold(f"{words_of(quantity)} ({quantity})",
                                        described + html_table(inputs, f"Inputs of {quantity}, at the run's "
                                                               f"first stored point. " + bench_words(context))))
    return Section("Measurement model",
                   "<p>What each stated quantity is, the equation it comes from and every input with its "
                   "distribution, standard uncertainty, source and whether it is corrected or only budgeted, "
                   "as a calibration certificate lists them (relative standard uncertainty at the run's first "
                   "stored point). Inputs known to matter that no budget holds yet are listed as such. "
                   "CSV: <a href='measurement_model.csv'>measurement_model.csv</a></p>" + "".join(blocks),
                   "measurement-model", appendix=True)
