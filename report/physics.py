"""The physics sections: every plate's characterisation (and what surprises in it), the
detuning and resonance curves, and what the plate model predicts beside the print.
"""

from __future__ import annotations

import html
import math
from dataclasses import replace
from pathlib import Path

import pandas as pd

from squeezebench.analysis import characterisation, model, tables
from squeezebench.analysis.budgets import COVERAGE_FACTOR
from squeezebench.analysis.uncertainty import DRIFT_TERM
from squeezebench.report import figures, presentation
from squeezebench.plates import damping, predicted_plates
from squeezebench.paper import paper_value
from squeezebench.report.section import PLATE_MODEL_WORDS, ReportContext, Section, bench_words, html_table, signed


def characterisation_section(context: ReportContext) -> Section | None:
    """Every plate: Q, tan theta' and their fits"""
    if context.run.protocol("characterisation").empty:
        context.absent.append("Plate characterisation (Figs. 5, 8, 9, Table 5): protocol "
                              "'characterisation' is not in this run")
        return None
    plates = context.plates()
    context.tables["fig5"] = tables.finish_table(characterisation.fig5_table(plates))
    surprising = _surprises(context, plates)
    body = ("<p>Every characterised plate of this run: Q from the slope of amplitude pp against "
            "voltage pp (Eq. 27), tan θ′ from the slope of power against voltage pp squared (Eq. 25) "
            "divided by Q. Both lines are fitted with an intercept, which a plate obeying the model "
            "leaves at zero within its uncertainty; χ²/dof near 1 says the points scatter as their "
            "uncertainties state.</p>"
            + (presentation.fold("What a reader would stop at in these fits (signs, χ²/dof), and why", surprising)
               if surprising else "")
            + presentation.fold(f"Q, tan θ′ and both fits of each of the {len(plates)} plates, as numbers",
                                _plates_table(context, plates)))
    runs = ", ".join(sorted(context.run.protocol("characterisation")["run_name"].unique()))
    body += presentation.fold("The voltage sweeps of every plate, their fitted lines and residuals", context.figure(
        context.draw(figures.plate_fits, plates, context.out_dir / "plate_fits.png"),
        f"Voltage sweeps of every characterised plate (campaign runs {html.escape(runs)}): amplitude pp "
        "against voltage pp (Eq. 27, top of each pair) and power against voltage pp squared (Eq. 25, "
        "bottom), with the fitted lines; the small panels show the residuals in units of each point's "
        "standard uncertainty. " + bench_words(context)))
    body += context.figure(
        context.draw(figures.fig5_q_tan, plates, context.out_dir / "fig5.png"),
        "Fig. 5 of the paper recomputed: Q and tan θ′ per plate with expanded uncertainties (k = 2). "
        "The paper's per-plate points did not survive in its text; it prints Plate 4's Q (2.34, drawn "
        "as ◆) and the mean tan θ′ per thickness (−1.30 at 2 mm, −1.64 at 1.2 mm, dashed). "
        + bench_words(context))
    body += ("<p class='csv'>Per plate: <a href='fig5.csv'>fig5.csv</a>.</p>"
             + presentation.calibration_notes(context.tables["fig5"]))
    return Section("Every plate: Q, tan θ′ and their fits (Sec. 4, Fig. 5)", body, "plates")


#: A fit's χ²/dof above this is explained in words beside the plates' table.
SURPRISING_CHI2 = 3.0


def _surprises(context: ReportContext, plates: dict[str, characterisation.PlateCharacterisation]) -> str:
    """The numbers of the plates' table a reader would stop at, explained from the run:
    negative tan θ′ (d31's sign, and Q's sign through Eq. 12's a under the reading) and a
    χ²/dof well above 1 (what the points scatter by, against what each point states)."""
    lines = []
    negative = [n for n, p in plates.items() if p.tan_theta.value < 0]
    if negative:
        example = plates[negative[0]]
        a_here = model.a_factor(example.geometry, context.convention)
        a_physical = model.a_factor(example.geometry, replace(context.convention, materials=model.MATERIALS_PHYSICAL))
        a_printed = model.a_factor(example.geometry, replace(context.convention, materials=model.MATERIALS_AS_PRINTED))
        q_sign = ""
        if (a_here > 0) != (a_physical > 0):
            q_sign = (f" Q comes out positive here because Eq. 12's a is {signed(a_here)} for {html.escape(negative[0])} "
                      f"with Table 2's E_i as printed ({context.convention.materials.resonator_young_pa:g} Pa); with "
                      f"E_i = 67 GPa, a = {signed(a_physical)} and Q changes sign (Table 5 under each reading, in its "
                      "section).")
        elif (a_here > 0) != (a_printed > 0):
            q_sign = (f" Q comes out negative here: with E_i = {context.convention.materials.resonator_young_pa / 1e9:g} "
                      f"GPa Eq. 12's a is {signed(a_here)} for {html.escape(negative[0])}, and with d31's sign Eq. 27 "
                      "gives a negative amplitude per unit Q; the paper's positive Q needs Table 2's E_i as printed "
                      f"({model.MATERIALS_AS_PRINTED.resonator_young_pa:g} Pa, a = {signed(a_printed)}), a resonator "
                      "without stiffness (Table 5 under each reading, in its section).")
        lines.append(
            f"tan θ′ is negative for {len(negative)} of {len(plates)} plates: Eqs. 25 and 27 carry NCE 41's d31 with "
            f"its sign ({signed(context.convention.materials.piezo_d31_c_per_n * 1e12)} pC/N); the amplitude is odd in "
            "d31 and the power even, so tan θ′ = power / (Q × Eq. 25's factor) takes d31's sign under any reading. "
            f"The paper prints negative values too ({signed(paper_value('small_plates', '2mm', 'tan_theta_mean'))} "
            "at 2 mm), as if it computed so; the loss tangent's size is |tan θ′|." + q_sign)
    fits = [(fit.chi2_per_dof, name, kind, fit) for name, p in plates.items()
            for kind, fit in (("amplitude", p.amplitude_slope), ("power", p.power_slope))
            if math.isfinite(fit.chi2_per_dof)]
    if fits and max(fits)[0] > SURPRISING_CHI2:
        chi2, name, kind, fit = max(fits, key=lambda f: f[0])
        points = plates[name].points
        column = "amplitude_pp_m" if kind == "amplitude" else "power_w"
        x = points["piezo_voltage_vpp"] if kind == "amplitude" else points["piezo_voltage_vpp"] ** 2
        line = fit.slope.value * x + fit.intercept.value
        off = float((abs(points[column] - line) / line).max())
        stated = float((points[f"{column}_u"] / points[column]).median())
        moved = float((points["frequency_hz"] - points["frequency_hz"].mean()).abs().max())
        lines.append(
            f"χ²/dof reaches {chi2:.1f} ({html.escape(name)}, {kind} against voltage): its points lie up to "
            f"{presentation.percent(off).lstrip('+')} off the line, against {presentation.percent(stated).lstrip('+')} "
            f"stated per point (a record's noise). The resonance, found again before each voltage, moved by up to "
            f"{moved:.1f} Hz between points, and a point read off the peak reads low: scatter a point's own "
            f"uncertainty leaves out. The fit widens the slope's uncertainty by √(χ²/dof), so Q and tan θ′ carry it.")
    return "".join(f"<p>{line}</p>" for line in lines)


def _plates_table(context: ReportContext, plates: dict[str, characterisation.PlateCharacterisation]) -> str:
    rows = []
    for name, p in plates.items():
        a, w = p.amplitude_slope, p.power_slope
        rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in (
            html.escape(name), f"{p.geometry.resonator_thickness_m * 1e3:g}", f"{p.frequency_hz:.0f}",
            presentation.with_uncertainty(p.q.value, COVERAGE_FACTOR * p.q.std_uncertainty),
            presentation.with_uncertainty(p.tan_theta.value, COVERAGE_FACTOR * p.tan_theta.std_uncertainty),
            presentation.with_uncertainty(a.slope.value * 1e9, a.slope.std_uncertainty * 1e9),
            presentation.with_uncertainty(a.intercept.value * 1e9, a.intercept.std_uncertainty * 1e9),
            _chi2(a), presentation.with_uncertainty(w.slope.value * 1e6, w.slope.std_uncertainty * 1e6),
            presentation.with_uncertainty(w.intercept.value * 1e3, w.intercept.std_uncertainty * 1e3), _chi2(w),
            html.escape(p.origin + (" (calibrated scene)" if p.calibrated_on else "")))) + "</tr>")
    head = ("<tr><th rowspan=2>plate</th><th rowspan=2>thickness (mm)</th><th rowspan=2>frequency (Hz)</th>"
            "<th rowspan=2>Q ± U</th><th rowspan=2>tan θ′ ± U</th><th colspan=3>amplitude vs voltage</th>"
            "<th colspan=3>power vs voltage²</th><th rowspan=2>origin</th></tr>"
            "<tr><th>slope (nm pp/Vpp)</th><th>intercept (nm pp)</th><th>χ²/dof</th>"
            "<th>slope (µW/Vpp²)</th><th>intercept (mW)</th><th>χ²/dof</th></tr>")
    caption = (f"Characterisation of every plate in this run. {bench_words(context)} U is k = 2 of the "
               "whole budget (the fits, the instruments' specifications, the geometry's and NCE 41's "
               "tolerances); intercepts ± their standard uncertainty.")
    return (f"<table class='plates'><caption>{caption}</caption><thead>{head}</thead>"
            f"<tbody>{''.join(rows)}</tbody></table>")


def _chi2(fit: tables.LineFit) -> str:
    return f"{fit.chi2_per_dof:.2f}" if math.isfinite(fit.chi2_per_dof) else "–"


def detuning_section(context: ReportContext) -> Section | None:
    """Fig. 2"""
    if context.run.protocol("detuning").empty:
        context.absent.append("Fig. 2: protocol 'detuning' is not in this run")
        return None
    summary = tables.detuning_table(context.run)
    context.tables["fig2"] = tables.finish_table(summary, value_columns=("power_w", "power_ratio", "power_ratio_U"))
    plotted = summary[summary["status"] == "measured"]
    runs = ", ".join(sorted(summary["run_name"].unique()))
    body = ("<p>At each velocity level v0 the plate is detuned until its velocity falls to a fraction "
            "of v0, then the voltage is raised until v0 is regained; Pt/P0 is the power then over the "
            "power at resonance. Losses that grow with the voltage (dielectric) raise Pt/P0 above 1.</p>")
    if not plotted.empty:
        body += context.figure(
            context.draw(figures.fig2_power_ratio, plotted, context.out_dir / "fig2.png"),
            f"Fig. 2 recomputed: Pt/P0 against the velocity fraction reached before regaining v0, one "
            f"line per velocity level, one panel per campaign run ({html.escape(runs)}). The paper's "
            "Fig. 2c stress point, 100 mW at resonance rising to 120 mW once v0 is regained at 37560 Hz "
            "(Pt/P0 = 1.2), is drawn as ★ at the printed voltage ratio 37.6/240. " + bench_words(context))
    body += presentation.fold("Fig. 2 as numbers: Pt/P0 of every series", _detuning_grid(summary, bench_words(context)))
    body += "<p class='csv'>Machine-readable: <a href='fig2.csv'>fig2.csv</a>.</p>"
    return Section("Fig. 2: frequency detuning (Sec. 2.2)", body, "fig2")


def _detuning_grid(summary: pd.DataFrame, bench_words: str) -> str:
    """Fig. 2 as a table: one row per series (run, v0), Pt/P0 per velocity fraction."""
    regained = summary[summary["detuning_phase"] != "resonance"]
    columns = sorted(regained["target_velocity_ratio"].unique(), reverse=True)
    head = ("<tr><th>campaign run</th><th>plate</th><th>v0 (m/s pp)</th><th>P0 (mW)</th>"
            + "".join(f"<th>Pt/P0 at {r:.2f} v0</th>" for r in columns) + "<th>largest term of the widest U</th></tr>")
    rows = []
    for (run, plate, level), group in summary.groupby(["run_name", "plate", "velocity_level_pp_mps"], sort=True):
        cells = []
        for ratio in columns:
            match = group[(group["target_velocity_ratio"] == ratio) & (group["detuning_phase"] != "resonance")]
            if match.empty:
                cells.append("<td class='na'></td>")
            elif match["status"].iloc[0] != "measured":
                cells.append(f"<td class='na'>{html.escape(str(match['status'].iloc[0]))}</td>")
            else:
                phase = " (stress)" if match["detuning_phase"].iloc[0] == "stress" else ""
                ratio_u = match["power_ratio_U"].iloc[0]
                spread = f" ± {ratio_u:.3f}" if math.isfinite(ratio_u) else ""
                cells.append(f"<td>{match['power_ratio'].iloc[0]:.3f}{spread}{phase}</td>")
        p0 = group["power_resonance_w"].iloc[0] * 1e3
        widest = group.loc[group["power_ratio_U"].idxmax(), "power_ratio_largest_term"] \
            if group["power_ratio_U"].notna().any() else ""
        rows.append(f"<tr><td>{html.escape(run)}</td><td>{html.escape(plate)}</td><td>{level:g}</td>"
                    f"<td>{p0:.1f}</td>{''.join(cells)}<td>{html.escape(widest)}</td></tr>")
    caption = (f"{bench_words} Fig. 2 as numbers: Pt/P0 ± U (k for 95 %) for each series once v0 is regained "
               "after detuning to the given velocity fraction; the gains cancel in the ratio, the generator's "
               "frequency (P0 on the flat top, Pt on the slope), the resonance's drift, the CH2 delay and the "
               "noise do not; 'not reachable': the safety limit stopped the voltage.")
    act = (f"Where the {DRIFT_TERM} is the largest term, the plate's warming under the drive sets U: it grows "
           "with the heat the plate holds when Pt is read, so a lower level, or a pause for the plate to cool "
           "(its time constant is minutes) before each level, narrows it; more averages do not."
           if (summary["power_ratio_largest_term"] == DRIFT_TERM).any() else "")
    return (f"<table><caption>{html.escape(caption)}</caption><thead>{head}</thead><tbody>{''.join(rows)}</tbody>"
            f"</table>" + (f"<p>{html.escape(act)}</p>" if act else ""))


def resonance_section(context: ReportContext) -> Section | None:
    """Resonance curves"""
    rows = context.run.protocol("resonance_search")
    if rows.empty or "sweep" not in rows:
        return None
    sweeps = tables.resonance_sweeps(context.run)
    n_searches = sweeps.groupby(["run_name", "step_id"]).ngroups if not sweeps.empty else 0
    body = presentation.fold(f"The frequency sweeps of the {n_searches} resonance searches", context.figure(
        context.draw(figures.resonance_curves, sweeps, context.out_dir / "resonance.png"),
        "Velocity pp against frequency during every resonance search, one panel per plate; each line "
        "is one search (campaign run / step, in the legend), before the golden-section refinement. "
        "The paper shows no such curve; it reports the resonance frequencies found (Tables 3, 4). "
        + bench_words(context)))
    return Section("Resonance searches (Sec. 2.1, 5.3)", body, "resonance")


#: The report, in order (the summary goes first, built last). Another package adds a
#: section by appending a builder.
def predicted_section(context: ReportContext) -> Section:
    """What physics predicts (plates.predicted_plates): no run data, no printed result in."""
    frame = predicted_plates.predictions()
    context.tables["predicted"] = frame
    shown = frame.assign(frequency_deviation=frame["frequency_deviation"].map(lambda d: f"{d:+.1%}"))
    body = ("<p>Predicted from geometry, the modes the text states and the datasheets only (free plate on "
            "Argyris elements with Mindlin's thick-plate correction, the piezos as laminate patches on a "
            "compliant epoxy bond; the paper's Table 2 aluminium and NCE 41 for every plate, no parameter "
            "fitted), beside the printed values. U (k = 2) from the sheet's thickness (EN 485-4), the "
            "aluminium alloy family, the bond and the piezos' placement; the velocity's and the power's U "
            f"also carry the drive's model-form term (the force factor and Q the bench realised beyond any "
            f"stated tolerance), sized on {predicted_plates.DRIVE_FIT_ON}'s print and judged on the other "
            "builds below. The power is the electrical input: mechanical plus the piezos' dielectric loss.</p>")
    body += presentation.fold("Predicted beside printed, plate by plate (the physics lines of Tables 3 and 4, and "
                              "the large plate), and the column layouts assumed",
                              "<p>Column layouts: " + "; ".join(html.escape(why) for _, why in
                                                                predicted_plates.LAYOUTS.values()) + ".</p>"
                              + html_table(shown, "predicted (plate model) and printed (paper)"))
    agree = predicted_plates.what_would_agree()
    body += presentation.fold(
        "Where power and velocity miss: which input would have to move", html_table(
            agree, "the force factor and Q the printed power and velocity imply (model-free, and through the "
                   "model's modal mass) over the model's: the factor each would have to move by"))
    body += presentation.fold(
        f"The drive's model-form term: sized on {predicted_plates.DRIVE_FIT_ON}, judged on the other builds",
        html_table(predicted_plates.drive_cross_check(),
                   "the term (standard uncertainties of ln force factor and ln Q, and the power's relative U it "
                   "gives) sized on each build in turn; how many of each build's printed velocities and powers "
                   "the U then holds, and the largest error as a share of the interval's half on its side (above 1 for "
                   "a miss); 'fitted' rows are in-sample, not a test"))
    fit = damping.fit_and_check()
    body += presentation.fold(
        f"Damping from physics: fitted on {damping.FIT_ON}, judged on the other builds", html_table(
            fit, f"{PLATE_MODEL_WORDS} {damping.TABLE_WORDS} ({fit['fitted_cushion_resistance_pa_s_per_m'].iloc[0]:.0f} "
                 f"Pa s/m), the other rows held out")
        + html_table(damping.terms_table(), "each mechanism's loss factor beside the one the print implies")
        + html_table(damping.cross_check(), "the same fit on each build in turn, judged on every build"))
    figure = predicted_plates.large_plate_mode()
    body += presentation.fold("The large plate's predicted working mode", context.figure(
        context.draw(_large_plate_mode_figure, None, context.out_dir / "predicted_mode_large_plate.png"),
        f"Predicted working mode of the large plate (Sec. 5): {figure['interior_antinodes']} interior "
        f"antinodes, nodal-line spacing {figure['half_wavelength_mm']:.2f} mm against the designed 9 mm "
        f"({figure['half_wavelength_mm'] / 9 - 1:+.1%}); rectangles: the piezos. Predicted, not measured."))
    body += "<p class='csv'>Machine-readable: <a href='predicted.csv'>predicted.csv</a>.</p>"
    return Section("What physics predicts (plate model)", body, "predicted")


def _large_plate_mode_figure(_: None, path: Path) -> None:
    """`predicted_plates.large_plate_mode_figure` as a figure function of `report.drawing` (it
    takes no data: the mode is the model's alone), drawn with the run's figures."""
    predicted_plates.large_plate_mode_figure(path)
