"""`write_report(run_dir)`: RUN_DIR/report/index.html, figures beside it, table3/4/5.csv.

The report is a list of section builders (`SECTIONS`); each takes the shared
`ReportContext` and returns a `Section`. A builder that lacks its data returns a section
saying what is missing instead of failing, so a partial run still gets a report; optional
folders (RUN_DIR/study/, RUN_DIR/hardcases/) plug in the same way. Output is
deterministic (no clock, sorted inputs, fixed PNG metadata): re-running the report on a
copy of the run gives identical tables.
"""

from __future__ import annotations

import html
import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

import squeezebench
from squeezebench.analysis import audit, figures, model, readings, study, tables, uncertainty
from squeezebench.analysis.rundata import RunData, load_run
from squeezebench.errors import UserError

#: The conventions every derived number of this report uses (the audit shows the others).
REPORT_CONVENTION = model.PAPER_CONVENTION


@dataclass
class ReportContext:
    run: RunData
    out_dir: Path
    convention: model.Convention = REPORT_CONVENTION
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)  # name -> finished CSV table
    cache: dict[str, object] = field(default_factory=dict)

    def plates(self) -> dict[str, tables.PlateCharacterisation]:
        """Fig. 5 characterisation, computed once for the sections that share it."""
        if "plates" not in self.cache:
            self.cache["plates"] = tables.characterise_plates(self.run, self.convention)
        return self.cache["plates"]


@dataclass(frozen=True)
class Section:
    title: str
    body_html: str


SectionBuilder = Callable[[ReportContext], Section]


def write_report(run_dir: Path | str) -> Path:
    """Recompute everything from the stored run; return the path of index.html."""
    run = load_run(run_dir)
    if run.measurements.empty and not (run.run_dir / "study").is_dir():   # a study alone is reportable
        raise UserError(f"{run.run_dir}: the run holds no measurements yet "
                        "(measurements/*/*.parquet); nothing to report")
    out_dir = run.run_dir / "report"
    out_dir.mkdir(exist_ok=True)
    context = ReportContext(run=run, out_dir=out_dir)
    sections = [_guarded(builder, context) for builder in SECTIONS]
    for name, table in context.tables.items():
        table.to_csv(out_dir / f"{name}.csv", index=False)
    index = out_dir / "index.html"
    index.write_text(_page(run, sections))
    return index


def _guarded(builder: SectionBuilder, context: ReportContext) -> Section:
    """A section whose data is missing says so instead of stopping the report."""
    try:
        return builder(context)
    except UserError as exc:
        title = (builder.__doc__ or builder.__name__).strip().splitlines()[0]
        return Section(title, f"<p class='missing'>Not available: {html.escape(str(exc))}</p>")


# --- sections ----------------------------------------------------------------------------

def provenance_section(context: ReportContext) -> Section:
    """Provenance"""
    run = context.run
    manifest = run.manifest
    rows = [("run directory", run.run_dir.name),
            ("report software", f"squeezebench {squeezebench.__version__}"),
            ("run software", json.dumps(manifest.get("software", "not recorded"), sort_keys=True)),
            ("campaign", json.dumps(manifest.get("campaign", "not recorded"), sort_keys=True)),
            ("created (UTC)", str(manifest.get("created_utc", "not recorded"))),
            ("updated (UTC)", str(manifest.get("updated_utc", "not recorded")))]
    recorded = {name: entry.get("sha256") for name, entry in manifest.get("inputs", {}).items()
                if isinstance(entry, dict)}
    for name, digest in run.input_sha256.items():
        state = ("matches manifest" if recorded.get(name) == digest else
                 "NOT the manifest's sha256" if name in recorded else "not in manifest")
        rows.append((f"inputs/{name}", f"sha256 {digest} ({state})"))
    for name, ids in sorted(manifest.get("instruments", {}).items()):
        rows.append((f"instruments, run {name}", json.dumps(ids, sort_keys=True)))
    counts = run.measurements.groupby("protocol").size() if "protocol" in run.measurements else {}
    for protocol, count in sorted(dict(counts).items()):
        rows.append((f"protocol {protocol}", f"{count} measured points"))
    body = "<table>" + "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>"
                               for k, v in rows) + "</table>"
    return Section("Provenance", body)


def conventions_section(context: ReportContext) -> Section:
    """Conventions"""
    c = context.convention
    m = c.materials
    items = [
        f"Convention '{c.name}': V in Eqs. 25/27 is {c.voltage}; A of Eq. 27 is {c.amplitude}; "
        f"neutral plane z0 at the {c.neutral_plane.replace('_', ' ')}; Eq. 28 "
        f"{'with' if c.eq28_with_pi else 'without'} its factor pi; Eq. 29 "
        f"{'as printed (b_large/b_small)' if c.eq29_as_printed else 'with b_small/b_large, as the text describes'}.",
        f"Materials: E_i = {m.resonator_young_pa:.6g} Pa, nu_i = {m.resonator_poisson}, c11 = {m.piezo_c11_pa:.3g} Pa, "
        f"nu_p = {m.piezo_poisson}, d31 = {m.piezo_d31_c_per_n:.3g} C/N.",
        "n_c = powered piezos of the plate (measurement column n_powered_piezos); b_p, h_i, h_p and "
        "lambda/2 from the plate's scene copy in inputs/; lambda = 2 (lambda/2).",
        "Power: mean of v i over the largest integer number of periods after DC removal (the paper's "
        "MATH channel), cross-checked by a sine fit. Velocity pp: twice the fitted sine amplitude. "
        "Amplitude pp = velocity pp / (2 pi f). Uncertainties are standard (k = 1) and cover noise "
        "and scope resolution; the vibrometer scale, probe gains and the plate geometry are taken "
        "as exact.",
        "Q: Eq. 27 with the fitted slope of amplitude pp vs voltage pp. tan theta': Eq. 25 with the "
        "fitted slope of power vs Vpp^2, divided by Q. Table 5 estimate: Q of small_plate_4 through "
        "Eq. 29; tan theta' the mean of the small plates as thick as the large plate.",
    ]
    return Section("Conventions used", "<ul>" + "".join(f"<li>{html.escape(i)}</li>" for i in items) + "</ul>")


def _paper_table_section(context: ReportContext, name: str, title: str,
                         compute: Callable[[RunData], pd.DataFrame], quantities: list[str]) -> Section:
    note = ""
    try:
        frame = compute(context.run)
    except UserError as exc:  # the CSV is written in any case, saying what is missing
        frame = tables.empty_table(name, quantities)
        note = f"<p class='missing'>{html.escape(str(exc))}</p>"
    finished = tables.finish_table(frame)
    context.tables[name] = finished
    return Section(title, note + _html_table(finished) + f"<p>CSV: <a href='{name}.csv'>{name}.csv</a></p>")


def table3_section(context: ReportContext) -> Section:
    """Table 3"""
    return _paper_table_section(context, "table3", "Table 3: cutting the resonator (Sec. 2.3.1)",
                                tables.table3, tables.TABLE3_QUANTITIES)


def table4_section(context: ReportContext) -> Section:
    """Table 4"""
    return _paper_table_section(context, "table4", "Table 4: powered columns (Sec. 2.3.2)",
                                tables.table4, tables.TABLE4_QUANTITIES)


def characterisation_section(context: ReportContext) -> Section:
    """Fig. 5, Table 5, Figs. 8 and 9"""
    title = "Small plates (Fig. 5), Table 5, large plate (Figs. 8, 9)"
    try:
        plates = context.plates()
        table5 = tables.table5(plates, context.convention)
        note = ""
    except UserError as exc:
        plates, table5 = None, tables.empty_table("table5", ["q", "tan_theta"])
        note = f"<p class='missing'>{html.escape(str(exc))}</p>"
    context.tables["table5"] = tables.finish_table(table5)
    body = note + "<h3>Table 5</h3>" + _html_table(context.tables["table5"])
    body += "<p>CSV: <a href='table5.csv'>table5.csv</a></p>"
    if plates:
        body += "<h3>Table 5 under each reading of Table 2's E_i</h3>" + _html_table(
            _table5_by_materials(context))
        context.tables["fig5"] = tables.finish_table(tables.fig5_table(plates))
        body += "<h3>Fig. 5: Q and tan theta' per plate</h3>" + _html_table(context.tables["fig5"])
        body += "<p>CSV: <a href='fig5.csv'>fig5.csv</a></p>"
        body += _img(figures.fig5_q_tan(plates, context.out_dir / "fig5.png"))
        if tables.LARGE_PLATE in plates:
            body += "<h3>Fig. 8</h3>" + _img(figures.fig8_amplitude(plates[tables.LARGE_PLATE],
                                                                    context.out_dir / "fig8.png"))
            try:
                power = tables.estimated_large_plate_power_w(plates, context.convention)
                error = np.mean(np.abs(power["power_estimated_w"] / power["power_measured_w"] - 1.0))
                body += ("<h3>Fig. 9</h3>" + _img(figures.fig9_power(power, context.out_dir / "fig9.png"))
                         + f"<p>Mean relative difference, estimated vs measured power: {error:.3g} "
                         "(the paper reports below 0.10).</p>")
            except UserError as exc:
                body += f"<p class='missing'>Fig. 9 not available: {html.escape(str(exc))}</p>"
    return Section(title, body)


def _table5_by_materials(context: ReportContext) -> pd.DataFrame:
    """Table 5 recomputed from the same fits with E_i as printed and E_i = 67 GPa
    (only a in Eqs. 25/27 changes: Q scales with a, tan theta' does not)."""
    frames = []
    for materials in (model.MATERIALS_AS_PRINTED, model.MATERIALS_PHYSICAL):
        convention = replace(context.convention, name=f"E_i = {materials.resonator_young_pa:.6g} Pa",
                             materials=materials)
        plates = tables.characterise_plates(context.run, convention)
        frame = tables.table5(plates, convention)
        frame.insert(0, "convention", convention.name)
        frames.append(frame)
    return tables.finish_table(pd.concat(frames, ignore_index=True))


def detuning_section(context: ReportContext) -> Section:
    """Fig. 2"""
    summary = tables.detuning_table(context.run)
    body = _html_table(tables.finish_table(summary, value_columns=("power_w", "power_ratio")))
    plotted = summary[summary["status"] == "measured"]
    if not plotted.empty:
        body += _img(figures.fig2_power_ratio(plotted, context.out_dir / "fig2.png"))
    return Section("Fig. 2: frequency detuning (Sec. 2.2)", body)


def resonance_section(context: ReportContext) -> Section:
    """Resonance curves"""
    sweeps = tables.resonance_sweeps(context.run)
    return Section("Resonance curves (Sec. 2.1, 5.3)",
                   _img(figures.resonance_curves(sweeps, context.out_dir / "resonance.png")))


def audit_section(context: ReportContext) -> Section:
    """Audit"""
    findings = audit.audit_findings()
    grid = audit.convention_grid()
    grid.to_csv(context.out_dir / "conventions_grid.csv", index=False)
    body = ("<p>Every number below is computed from the paper's printed values (data/paper/) and its "
            "equations; relative difference = (computed - printed) / |printed|.</p>"
            + _html_table(_words_for_missing(findings, "")))
    body += ("<h3>Which reading reproduces which published number</h3>"
             f"<p>{len(grid)} readings: {html.escape('; '.join(f'{k} in {v}' for k, v in audit.GRID_AXES.items()))}. "
             f"A number is reproduced within {audit.MATCH_REL:.0%}. Full grid: "
             "<a href='conventions_grid.csv'>conventions_grid.csv</a>.</p>"
             + _html_table(audit.grid_summary(grid))
             + "<p>The ten best readings overall (RMS of log10 ratios):</p>"
             + _html_table(grid[grid["defined"]].head(10)))
    return Section("Audit of the paper", body)


def study_section(context: ReportContext) -> Section:
    """Accuracy vs bench time"""
    trials = study.load_trials(context.run.run_dir)
    summary = study.summarise(trials)
    summary.to_csv(context.out_dir / "study_summary.csv", index=False)
    fronts = study.fronts_table(summary)
    fronts.to_csv(context.out_dir / "study_fronts.csv", index=False)
    body = (f"<p>{len(trials)} trial rows (RUN_DIR/study/*.parquet) on the simulated bench, each scored "
            "against the scene's closed-form truth at resonance; the cost is the virtual bench time of "
            f"one trial. Error = {study.ERROR_PERCENTILE:g}th percentile of |relative error| over the "
            "repeats. All configurations: <a href='study_summary.csv'>study_summary.csv</a>.</p>"
            + _img(figures.study_fronts(summary, context.out_dir / "study_fronts.png"))
            + "<h3>Settings on each Pareto front (cheapest first)</h3>" + _html_table(fronts))
    heating = study.heating_table(summary)
    if not heating.empty:
        body += ("<h3>Heating drift: longer averaging at a fixed frequency, and tracking</h3>"
                 "<p>The plate warms while it is measured and its resonance falls; a point held at the "
                 "frequency found cold loses power as the averaging (and so the series) lasts longer. "
                 "Re-centring on the resonance before each point removes that error at the cost of "
                 "the tracking's bench time.</p>"
                 + _img(figures.heating_drift(heating, context.out_dir / "study_heating.png"))
                 + _html_table(heating))
    return Section("Accuracy vs bench time", body)


def hardcases_section(context: ReportContext) -> Section:
    """Hard cases"""
    return _optional_folder(context, "hardcases", "Hard cases (hardcases/)",
                            "python benchmarks/hardcases_summary.py --out RUN_DIR")


def _optional_folder(context: ReportContext, folder: str, title: str, how: str) -> Section:
    """Shows every CSV (as a table) and PNG (copied beside the report) of an optional folder;
    without it, `how` (the command that writes it)."""
    directory = context.run.run_dir / folder
    if not directory.is_dir():
        return Section(title, f"<p class='missing'>Not part of this run (no {folder}/ folder): "
                              f"<code>{html.escape(how)}</code> writes it.</p>")
    body = ""
    for path in sorted(directory.glob("*.csv")):
        frame = pd.read_csv(path)
        body += f"<h3>{html.escape(path.name)}</h3>" + _html_table(_words_for_missing(frame, "not available"))
    for path in sorted(directory.glob("*.png")):
        copy = context.out_dir / f"{folder}_{path.name}"
        copy.write_bytes(path.read_bytes())
        body += _img(copy)
    return Section(title, body or f"<p class='missing'>{folder}/ is empty.</p>")


def uncertainty_section(context: ReportContext) -> Section:
    """Uncertainty budgets (GUM, k = 2)"""
    found = uncertainty.run_uncertainties(context.run)
    if found.points.empty:
        raise UserError("no stored records to budget")
    quantities = list(uncertainty.POINT_BUDGETS)
    summary = pd.DataFrame([
        {"protocol": protocol, "quantity": q, "points": int(rows[f"{q}_U"].notna().sum()),
         "median_expanded_relative": float((rows[f"{q}_U"] / rows[q].abs()).median()),
         "dominant_term": rows[f"{q}_dominant"].mode().iat[0]}
        for protocol, rows in found.points.groupby("protocol", sort=False) for q in quantities])
    context.tables["uncertainty_summary"] = summary
    context.tables["uncertainty_budgets"] = found.budgets
    columns = ["run_name", "step_id", "point_index", "protocol"] + [
        f"{q}{suffix}" for q in quantities for suffix in ("", "_U", "_dominant")]
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
                               "floor_p95_rel": uncertainty.P95_FACTOR * floor.std_uncertainty / abs(floor.value)})
    context.tables["uncertainty_q_tan_theta"] = pd.DataFrame(plates)
    deskew_u_s = None if found.deskew is None else found.deskew.std_uncertainty_s
    context.tables["uncertainty_floors"] = uncertainty.systematic_floor(found.points, deskew_u_s)
    deskew = ("<p>No deskew calibration in this run: the CH2 delay enters at its specified limit.</p>"
              if found.deskew is None else
              f"<p>Power corrected by the deskew calibration: CH2 delay {found.deskew.delay_s * 1e9:.2f} ns "
              f"(u = {found.deskew.std_uncertainty_s * 1e9:.2f} ns).</p>")
    return Section("Uncertainty budgets (GUM, k = 2)",
                   "<p>Expanded uncertainties (k = 2) of every stored point: noise of the record (Type A) "
                   "and the instruments' specifications (Type B). Median relative U and the most frequent "
                   "dominant term per protocol; then the whole budget of one point of each protocol.</p>"
                   + deskew + _html_table(summary) + _html_table(found.budgets)
                   + "<p>Resonance frequencies found by the searches (the generator's setting there), "
                     "expanded (k = 2):</p>" + _html_table(found.searches)
                   + "<p>Q and tan(theta') per plate with the geometry and material tolerances "
                     "(expanded, k = 2; floor: p95 relative error with the fits' noise gone):</p>"
                   + _html_table(context.tables["uncertainty_q_tan_theta"])
                   + "<p>Floor per run: the p95 relative error of power and velocity the instruments' "
                     "specified errors leave at the run's worst point, whatever the averaging:</p>"
                   + _html_table(context.tables["uncertainty_floors"])
                   + "<p>CSV: <a href='uncertainty_points.csv'>uncertainty_points.csv</a>, "
                     "<a href='uncertainty_budgets.csv'>uncertainty_budgets.csv</a></p>")


#: The report, in order. Another package adds a section by appending a builder.
def readings_section(context: ReportContext) -> Section:
    """Q and tan theta' under the text's reading and the inferred one (issue 13)"""
    plates = audit.plates_under_readings(context.run)
    plates.to_csv(context.out_dir / "plates_by_reading.csv", index=False)
    body = ("<p>Every characterised plate of this run (the paper's or your own), Q from Eq. 27 and "
            "tan theta' from Eq. 25 under the text's own reading ('paper') and under the one reading "
            "that reproduces the paper's published numbers at once ('inferred', analysis.readings). "
            "CSV: <a href='plates_by_reading.csv'>plates_by_reading.csv</a></p>"
            + "".join(f"<p>{html.escape(words)}</p>" for words in readings.search_words())
            + _html_table(plates))
    try:
        table5 = audit.table5_under_readings(context.run)
    except UserError as exc:
        return Section("Plates under each reading", body + f"<p class='missing'>Table 5 and Fig. 9 under "
                       f"each reading not available: {html.escape(str(exc))}</p>")
    table5.to_csv(context.out_dir / "table5_by_reading.csv", index=False)
    body += ("<h3>Table 5 and Fig. 9 under each reading</h3>" + _html_table(table5)
             + "".join(f"<p>{html.escape(words)}</p>" for words in audit.table5_verdicts(table5)))
    return Section("Plates under each reading", body)


SECTIONS: list[SectionBuilder] = [
    provenance_section, conventions_section, table3_section, table4_section, detuning_section,
    resonance_section, characterisation_section, readings_section, audit_section, study_section,
    hardcases_section, uncertainty_section,
]


# --- HTML --------------------------------------------------------------------------------

def _format(value) -> str:
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        return f"{value:.4g}" if math.isfinite(value) else "not available"
    return str(value)


def _html_table(frame: pd.DataFrame) -> str:
    head = "".join(f"<th>{html.escape(str(c))}</th>" for c in frame.columns)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(_format(v))}</td>" for v in row) + "</tr>"
                   for row in frame.itertuples(index=False))
    return f"<table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _words_for_missing(frame: pd.DataFrame, word: str) -> pd.DataFrame:
    frame = frame.astype(object)
    return frame.where(frame.notna(), word)


def _img(path: Path) -> str:
    return f"<p><img src='{html.escape(path.name)}' alt='{html.escape(path.stem)}'></p>"


def _page(run: RunData, sections: list[Section]) -> str:
    parts = [f"<section><h2>{html.escape(s.title)}</h2>{s.body_html}</section>" for s in sections]
    return ("<!DOCTYPE html><html><head><meta charset='utf-8'>"
            f"<title>squeezebench report: {html.escape(run.run_dir.name)}</title>"
            "<style>body{font-family:sans-serif;max-width:1200px;margin:auto}"
            "table{border-collapse:collapse;font-size:12px}td,th{border:1px solid #ccc;padding:2px 6px}"
            ".missing{color:#a33}</style></head><body>"
            f"<h1>squeezebench report: {html.escape(run.run_dir.name)}</h1>" + "".join(parts) + "</body></html>")
