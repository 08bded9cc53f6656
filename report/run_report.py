"""`write_report(run_dir)`: RUN_DIR/report/index.html, figures beside it, table3/4/5.csv
and columns.csv (the column dictionary).

The report reads like a results section with its audit trail: a summary in words, the
paper's tables in the paper's layout (each cell: this run +- U, the printed value, the
deviation, the origin), captioned figures with the published points drawn, every plate's
characterisation, the audit's conclusions, and the provenance in an appendix.

The report is a list of section builders (`SECTIONS`); each takes the shared
`ReportContext` and returns a `Section`, or None when the run holds nothing for it (the
summary lists what is not in the run, so no section is empty). A builder whose data is
broken returns a section saying what is missing instead of failing. Output is
deterministic (no clock, sorted inputs, fixed PNG metadata): re-running the report on a
copy of the run gives identical tables.
"""

from __future__ import annotations

import html
import json
import math
import re
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

import squeezebench
from squeezebench.analysis import (audit, columns, measurement_model,
                                   model, provenance, readings, study, tables,
                                   uncertainty)
from squeezebench.report import cartography_report, figures, headline, page, presentation
from squeezebench.plates import damping, predicted_plates
from squeezebench.report.drawing import Drawing
from squeezebench.analysis.model import REPORT_CONVENTION
from squeezebench.analysis.tables import MissingDataError
from squeezebench.paper import paper_value
from squeezebench.analysis.rundata import RunData, load_run
from squeezebench.errors import UserError
from squeezebench.workers import default_workers



@dataclass
class ReportContext:
    run: RunData
    out_dir: Path
    convention: model.Convention = REPORT_CONVENTION
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)  # name -> finished CSV table
    cache: dict[str, object] = field(default_factory=dict)
    absent: list[str] = field(default_factory=list)   # what the run does not hold, for the summary
    flagged: list[tuple[str, str, str]] = field(default_factory=list)  # (where, sentence, audit anchor)
    # each disagreement's line in the opening: (table, item, quantity) -> headline.Line
    reasons: dict[tuple[str, str, str], headline.Line] = field(default_factory=dict)
    extra_misses: list[headline.Line] = field(default_factory=list)   # beyond Tables 3-5 (Fig. 9)
    figure_count: int = 0
    draw: Drawing = field(default_factory=lambda: Drawing(1))   # figure functions, maybe on other processes

    def plates(self) -> dict[str, tables.PlateCharacterisation]:
        """Fig. 5 characterisation, computed once for the sections that share it."""
        if "plates" not in self.cache:
            self.cache["plates"] = tables.characterise_plates(self.run, self.convention)
        return self.cache["plates"]

    def bench(self) -> str:
        return provenance.bench_kind(self.run.measurements, self.run.manifest)

    def figure(self, path: Path, caption: str) -> str:
        """A numbered, captioned figure (caption: what is drawn, from which runs, what the
        paper shows)."""
        self.figure_count += 1
        return (f"<figure id='figure-{self.figure_count}'><a href='{html.escape(path.name)}'>"
                f"<img src='{html.escape(path.name)}' alt='{html.escape(path.stem)}'></a><figcaption><b>Report figure {self.figure_count}.</b> "
                f"{caption}</figcaption></figure>")


@dataclass(frozen=True)
class Section:
    title: str
    body_html: str
    anchor: str = ""
    appendix: bool = False   # reference material: after every result, titled "Appendix: ..."


SectionBuilder = Callable[[ReportContext], "Section | None"]


#: The report's first lines as plain text, which the commands print when they finish.
HEADLINE_FILE = "headline.txt"


def write_report(run_dir: Path | str, workers: int | None = None, left_out: list[str] = ()) -> Path:
    """Recompute everything from the stored run; return the path of index.html. Figures are
    drawn on `workers - 1` other processes meanwhile (default: `squeezebench.workers`).
    `left_out`: what the run's checks found missing or unverified and the report was told
    to go on without; the page and its headline open with it."""
    run = load_run(run_dir)
    if run.measurements.empty and not (run.run_dir / "study").is_dir():   # a study alone is reportable
        raise UserError(f"{run.run_dir}: the run holds no measurements yet "
                        "(measurements/*/*.parquet); nothing to report")
    out_dir = run.run_dir / "report"
    out_dir.mkdir(exist_ok=True)
    context = ReportContext(run=run, out_dir=out_dir, draw=Drawing(workers or default_workers()))
    builders = [b for b in SECTIONS if b is not provenance_section] + [provenance_section]   # appendix last
    try:
        try:
            _study_figures(context)   # the longest to draw: handed out first
        except UserError:
            pass   # the study's section says why, in its place
        sections = [section for builder in builders if (section := _guarded(builder, context)) is not None]
        sections.insert(0, summary_section(context))   # last: it sums up what the others found
        if left_out:
            sections.insert(0, _left_out_section(left_out))
            context.cache["headline"].insert(0, f"LEFT OUT of this report ({len(left_out)}): " + "; ".join(left_out))
        context.draw.finish()   # no page points at a figure not yet drawn
    finally:
        context.draw.cancel()
    (out_dir / HEADLINE_FILE).write_text("\n".join(context.cache["headline"]) + "\n")
    for name, table in context.tables.items():
        table.to_csv(out_dir / f"{name}.csv", index=False)
    written = [_header(p) for p in sorted(out_dir.glob("*.csv")) if p.name != "columns.csv"]
    columns.write(out_dir / "columns.csv", [run.measurements, *written])
    index = out_dir / "index.html"
    index.write_text(_page(context, sections))
    return index


def _left_out_section(left_out: list[str]) -> Section:
    """What the report was told to go on without (`--allow-missing`, `--allow-unverified`)."""
    items = "".join(f"<li>{html.escape(item)}</li>" for item in left_out)
    return Section("Left out of this report", f"<p class='banner'>The run's checks found these missing or not what "
                   f"made the run; the report was asked to go on without them:</p><ul>{items}</ul>", "left-out")


def _header(path: Path) -> pd.DataFrame:
    """The columns of a written CSV (none for an empty table)."""
    try:
        return pd.read_csv(path, nrows=0)
    except pd.errors.EmptyDataError:
        return pd.DataFrame()


def _guarded(builder: SectionBuilder, context: ReportContext) -> Section | None:
    """A section whose data is missing says so instead of stopping the report."""
    try:
        return builder(context)
    except UserError as exc:
        title = (builder.__doc__ or builder.__name__).strip().splitlines()[0]
        return Section(title, f"<p class='missing'>Not available: {html.escape(str(exc))}</p>")


def _slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


# --- sections ----------------------------------------------------------------------------

#: Said on a table whose numbers come from the plate model and print, not from any bench.
PLATE_MODEL_WORDS = "Plate model, no bench:"


def _bench_words(context: ReportContext) -> str:
    """Said on every table: where its numbers come from."""
    kind = context.bench()
    return {"simulated": "Dry run: simulated bench.", "real": "Measured on a real bench."}.get(
        kind, f"Bench: {kind}.")


def summary_section(context: ReportContext) -> Section:
    """Summary"""
    run = context.run
    kind = context.bench()
    benches = run.manifest.get("benches", {})
    inputs = (sorted(run.measurements["bench_input"].dropna().unique()) if "bench_input" in run.measurements
              else sorted({b.get("bench_input", "") for b in benches.values()} - {""}))
    if kind == "simulated":
        replays = sum(isinstance(scene, dict) and isinstance(scene.get("replay"), dict)
                      for scene in run.scenes.values())
        predicted = sum(any(state.get("resonance_frequency_hz") == "predicted"
                            for state in provenance.scene_states(scene).values()) for scene in run.scenes.values())
        said = ("" if not replays else ", a declared replay of published points the plate model does not predict"
                if replays == len(run.scenes) == 1 else
                f", {'all' if replays == len(run.scenes) else replays} of them declared replays of published "
                "points the plate model does not predict")
        if predicted:
            said += (f"; {'all' if predicted == len(run.scenes) else predicted} predicted by the plate model from "
                     "geometry and datasheets, no printed result in (cells labelled <i>predicted</i>: what a "
                     "lab would measure if the model is right)")
        lead = ("<p class='banner'><b>Dry run on the simulated bench.</b> No plate was measured: the "
                f"instruments answered from the physics of {len(inputs)} scene{'s' if len(inputs) != 1 else ''}{said} "
                f"(<a href='#provenance'>listed in the appendix</a>, with why). {presentation.ROUND_TRIP_MARK}: "
                "a printed value the run was given came back (the chain, not the paper).</p>")
    elif kind == "real":
        ids = sorted({json.dumps(v, sort_keys=True) for v in run.manifest.get("instruments", {}).values()})
        lead = ("<p class='banner real'><b>Measured on a real bench</b> (instruments: "
                + html.escape("; ".join(ids)) + ").</p>")
    else:
        lead = (f"<p class='banner'><b>Bench {html.escape(kind)}</b>: this run predates provenance "
                "columns; its values are not labelled measured or simulated.</p>")
    measurements = run.measurements
    said = (kind, len(measurements), measurements["run_name"].nunique() if not measurements.empty else 0,
            context.tables, _needs_deskew_count(context), context.reasons, context.extra_misses)
    context.cache["headline"] = headline.headline(*said)
    body = _opening_html(headline.opening(*said)) + lead
    verdicts = _verdict_table(context)
    if verdicts:
        body += presentation.fold("Against the paper, table by table, with each disagreement's full reason", verdicts)
    if not measurements.empty:
        plates = sorted(measurements["plate"].dropna().unique())
        protocols = measurements.groupby("protocol")["run_name"].nunique()
        n_runs = measurements["run_name"].nunique()
        body += presentation.fold(
            f"What ran: {n_runs} campaign run{'s' if n_runs != 1 else ''} on {len(plates)} "
            f"plate{'s' if len(plates) != 1 else ''}",
            "<p>" + f"{len(measurements)} stored points from {n_runs} campaign run{'s' if n_runs != 1 else ''} ("
            + html.escape(", ".join(f"{p}: {n}" for p, n in protocols.items()))
            + f") on {len(plates)} plates: " + html.escape(", ".join(plates)) + ".</p>")
    if context.absent:
        body += presentation.fold(f"Not in this run: {len(context.absent)} section{'s' if len(context.absent) != 1 else ''} "
                                  "left out", "<ul>" + "".join(f"<li>{html.escape(a)}</li>" for a in context.absent) + "</ul>")
    return Section("Summary", body, "summary")


def _opening_html(lines: list[headline.Line]) -> str:
    """The opening's sentences, each linked to where the report shows why; the printed
    numbers the run does not return as a list."""
    def sentence(line: headline.Line) -> str:
        link = f" <a href='{html.escape(line.href)}'>Why</a>" if line.href and line.kind == "miss" else (
            f" <a href='{html.escape(line.href)}'>More</a>" if line.href else "")
        return html.escape(line.text) + link

    out, misses = [], []
    for line in lines + [headline.Line("")]:   # the sentinel closes a list still open
        if line.kind == "miss":
            misses.append(f"<li>{sentence(line)}</li>")
            continue
        if misses:
            out.append(f"<ul class='misses'>{''.join(misses)}</ul>")
            misses = []
        if line.text:
            out.append(f"<p class='headline {html.escape(line.kind)}'>{sentence(line)}</p>")
    return "<div class='opening'>" + "".join(out) + "</div>"


def _verdict_table(context: ReportContext) -> str:
    """Per paper table (and Fig. 9): how many compared values agree, come back as round
    trips of what the run was given, or disagree, and why each disagreement, linked."""
    cells = headline.verdicts(context.tables)
    rows = []
    for title, anchor in (("Table 3", "table3"), ("Table 4", "table4"), ("Table 5", "table5")):
        mine = cells[cells["table"] == title]
        if mine.empty:
            continue
        counts = mine["verdict"].value_counts()
        why = [sentence for where, sentence, _ in context.flagged if where.startswith(title)]
        rows.append((f"<a href='#{anchor}'>{title}</a>", str(counts.get("agrees", 0)),
                     str(counts.get("round trip", 0)), str(counts.get("disagrees", 0)),
                     "<br>".join(why) or "–"))
    fig9 = [sentence for where, sentence, _ in context.flagged if where == "Fig. 9"]
    if "table5" in context.tables and not context.tables["table5"]["value"].isna().all():
        rows.append(("<a href='#table5'>Fig. 9</a>", "0" if fig9 else "1", "0", "1" if fig9 else "0",
                     "<br>".join(fig9) or "–"))
    if not rows:
        return ""
    head = "".join(f"<th>{h}</th>" for h in ("", "agree", "round trip", "disagree", "why it disagrees"))
    body = "".join("<tr>" + "".join(f"<td>{cell}</td>" for cell in row) + "</tr>" for row in rows)
    return ("<table class='verdicts'><caption>Against the paper: a round trip is a printed value the run "
            "was given or calibrated on coming back (it shows the chain, not the paper); a disagreement is "
            "outside this run's expanded uncertainty plus half the printed last digit. "
            f"{_bench_words(context)}</caption><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")


def _explanation(context: ReportContext, table: str, item: str, quantity: str,
                 value: float) -> tuple[str, str, str] | None:
    """What explains a disagreement of this run's `value` (table, item, quantity) with the
    paper: the anchor to link, a sentence built from computed numbers and the same in a
    few words for the opening, or None. An explanation counts only when it reproduces this
    run's value (within MATCH_REL): the audit's number from printed values alone, or this
    run under the inferred reading."""
    findings = _findings()

    def matches(number: float) -> bool:
        return math.isfinite(value) and abs(value - number) <= audit.MATCH_REL * abs(number)

    if (table, item, quantity) == ("table5", "estimated", "q"):
        carried = _finding(findings, "Eq. 29 inverted", "Q_large with")
        needed = _finding(findings, "Eq. 29 inverted", "Q_small")
        if matches(carried["computed"]):
            return ("audit-" + _slug(carried["topic"]),
                    f"Eq. 29 carries Plate 4's printed Q = {needed['printed']:.3g} to {carried['computed']:.4g}; "
                    f"the printed {carried['printed']:.3g} needs Q = {needed['computed']:.4g}: the paper "
                    "computed it from Plate 4's Q before rounding",
                    f"the paper's own Eq. 29 carries Plate 4's printed Q to {carried['computed']:.4g}: it was "
                    "computed before rounding")
    if (table, item, quantity) == ("table5", "measured", "tan_theta"):
        row = _finding(findings, "Table 5 under E_i", "tan theta'")
        if matches(row["computed"]):
            return ("audit-" + _slug(row["topic"]),
                    f"the paper's own Eq. 25 with its printed Q turns its printed 1.3 W at 32 Vpp into "
                    f"tan θ′ = {_signed(row['computed'])} (E_i as printed), not the printed {_signed(row['printed'])}: "
                    "under the text's definitions the printed power and loss tangent cannot both hold, and a "
                    "plate that returns the 1.3 W misses the printed tan θ′ under either E_i (with Q read from "
                    "the same plate's amplitude, E_i cancels from tan θ′)",
                    f"the paper's own Eq. 25 turns its printed 1.3 W into tan θ′ = {_signed(row['computed'])}: "
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
                     f"this run gives {_signed(row.value)} against the printed {_signed(row.printed)} "
                     f"({presentation.percent(row.relative_difference)})")
            reading, used = _reading_words(str(row.reading)), _reading_words(context.convention.name)
            there = (f"{100 * abs(row.value):.1f} %" if table == "fig9" else
                     f"{_signed(row.value)}, {presentation.percent(row.relative_difference)}")
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
    if "table5_readings" not in context.cache:
        try:
            context.cache["table5_readings"] = audit.table5_under_readings(context.run)
        except UserError:
            context.cache["table5_readings"] = None
    return context.cache["table5_readings"]


def _findings() -> pd.DataFrame:
    return audit.audit_findings()


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
    caption = (f"{html.escape(title)}. {_bench_words(context)} Each cell: this run ± U (k = 2, {budget}), "
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


def characterisation_section(context: ReportContext) -> Section | None:
    """Every plate: Q, tan theta' and their fits"""
    if context.run.protocol("characterisation").empty:
        context.absent.append("Plate characterisation (Figs. 5, 8, 9, Table 5): protocol "
                              "'characterisation' is not in this run")
        return None
    plates = context.plates()
    context.tables["fig5"] = tables.finish_table(tables.fig5_table(plates))
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
        "standard uncertainty. " + _bench_words(context)))
    body += context.figure(
        context.draw(figures.fig5_q_tan, plates, context.out_dir / "fig5.png"),
        "Fig. 5 of the paper recomputed: Q and tan θ′ per plate with expanded uncertainties (k = 2). "
        "The paper's per-plate points did not survive in its text; it prints Plate 4's Q (2.34, drawn "
        "as ◆) and the mean tan θ′ per thickness (−1.30 at 2 mm, −1.64 at 1.2 mm, dashed). "
        + _bench_words(context))
    body += ("<p class='csv'>Per plate: <a href='fig5.csv'>fig5.csv</a>.</p>"
             + presentation.calibration_notes(context.tables["fig5"]))
    return Section("Every plate: Q, tan θ′ and their fits (Sec. 4, Fig. 5)", body, "plates")


#: A fit's χ²/dof above this is explained in words beside the plates' table.
SURPRISING_CHI2 = 3.0


def _surprises(context: ReportContext, plates: dict[str, tables.PlateCharacterisation]) -> str:
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
            q_sign = (f" Q comes out positive here because Eq. 12's a is {_signed(a_here)} for {html.escape(negative[0])} "
                      f"with Table 2's E_i as printed ({context.convention.materials.resonator_young_pa:g} Pa); with "
                      f"E_i = 67 GPa, a = {_signed(a_physical)} and Q changes sign (Table 5 under each reading, in its "
                      "section).")
        elif (a_here > 0) != (a_printed > 0):
            q_sign = (f" Q comes out negative here: with E_i = {context.convention.materials.resonator_young_pa / 1e9:g} "
                      f"GPa Eq. 12's a is {_signed(a_here)} for {html.escape(negative[0])}, and with d31's sign Eq. 27 "
                      "gives a negative amplitude per unit Q; the paper's positive Q needs Table 2's E_i as printed "
                      f"({model.MATERIALS_AS_PRINTED.resonator_young_pa:g} Pa, a = {_signed(a_printed)}), a resonator "
                      "without stiffness (Table 5 under each reading, in its section).")
        lines.append(
            f"tan θ′ is negative for {len(negative)} of {len(plates)} plates: Eqs. 25 and 27 carry NCE 41's d31 with "
            f"its sign ({_signed(context.convention.materials.piezo_d31_c_per_n * 1e12)} pC/N); the amplitude is odd in "
            "d31 and the power even, so tan θ′ = power / (Q × Eq. 25's factor) takes d31's sign under any reading. "
            f"The paper prints negative values too ({_signed(paper_value('small_plates', '2mm', 'tan_theta_mean'))} "
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


def _signed(value: float) -> str:
    return f"{value:.3g}".replace("-", "−")


def _plates_table(context: ReportContext, plates: dict[str, tables.PlateCharacterisation]) -> str:
    rows = []
    for name, p in plates.items():
        a, w = p.amplitude_slope, p.power_slope
        rows.append("<tr>" + "".join(f"<td>{c}</td>" for c in (
            html.escape(name), f"{p.geometry.resonator_thickness_m * 1e3:g}", f"{p.frequency_hz:.0f}",
            presentation.with_uncertainty(p.q.value, uncertainty.COVERAGE_FACTOR * p.q.std_uncertainty),
            presentation.with_uncertainty(p.tan_theta.value, uncertainty.COVERAGE_FACTOR * p.tan_theta.std_uncertainty),
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
    caption = (f"Characterisation of every plate in this run. {_bench_words(context)} U is k = 2 of the "
               "whole budget (the fits, the instruments' specifications, the geometry's and NCE 41's "
               "tolerances); intercepts ± their standard uncertainty.")
    return (f"<table class='plates'><caption>{caption}</caption><thead>{head}</thead>"
            f"<tbody>{''.join(rows)}</tbody></table>")


def _chi2(fit: tables.LineFit) -> str:
    return f"{fit.chi2_per_dof:.2f}" if math.isfinite(fit.chi2_per_dof) else "–"


def table5_section(context: ReportContext) -> Section | None:
    """Table 5, Figs. 8 and 9 (the figures alone when the run has the large plate but not
    the small plate Table 5 estimates from)"""
    context.tables["table5"] = tables.finish_table(tables.empty_table("table5", ["q", "tan_theta"]))
    if context.run.protocol("characterisation").empty:
        return None   # characterisation_section says so
    plates = context.plates()
    if tables.LARGE_PLATE not in plates:
        context.absent.append(f"Table 5 and Figs. 8-9: the run has no characterisation of {tables.LARGE_PLATE}")
        return None
    estimated = tables.TEMPLATE_SMALL_PLATE in plates
    large = plates[tables.LARGE_PLATE]
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
        f"at {printed_vpp:g} Vpp (★). Physics (the plate model, no printed result in; green, ± U "
        f"k = 2) predicts {physics_amplitude[0]:.2f} ± {physics_amplitude[1]:.2f} µm pp at the plate's centre "
        f"there. " + _bench_words(context))
    if estimated:
        title = "Table 5: the large plate estimated from the small ones (Sec. 5.3)"
        context.tables["table5"] = table5 = tables.finish_table(tables.table5(plates, context.convention))
        body = _paper_table_html(
            context, "table5", title, table5, lambda item: f"{item} ({'Eq. 29 from small_plate_4' if item == 'estimated' else 'large_plate'})",
            "Estimated: Q of small_plate_4 carried to the large plate by Eq. 29, tan θ′ the mean of "
            "the small plates as thick as the large one. Measured: the large plate's own voltage sweep.")
        body += presentation.fold("Table 5 under each reading of Table 2's E_i, and Fig. 8", html_table(
            _table5_by_materials(context), "Table 5 recomputed from the same fits under both readings of E_i "
            "(only a of Eqs. 25/27 changes). " + _bench_words(context)) + fig8)
    else:
        context.absent.append(f"Table 5: the run has no characterisation of {tables.TEMPLATE_SMALL_PLATE} "
                              "to estimate the large plate from")
        title = "Figs. 8 and 9: the large plate (Sec. 5.3)"
        body = ("<p>The large plate's own voltage sweep; Table 5's estimate needs the small plates, which "
                "this run did not characterise.</p>" + fig8)
    power = tables.estimated_large_plate_power_w(plates, context.convention)
    body += context.figure(
        context.draw(figures.fig9_power, power, context.out_dir / "fig9.png"),
        "Fig. 9 recomputed: power of the large plate against voltage pp squared, from its own sweep "
        + ("(●) and estimated from the small plates through Eqs. 25 and 29 with Table 5's estimate (■). "
           if estimated else "(●). ")
        + f"The paper reports {paper_value('large_plate', 'large_plate', 'power_w'):g} W at "
        f"{printed_vpp:g} Vpp (★) and an estimate within "
        f"10 % of the measurement. Physics (green, ± U k = 2, one damping figure shared by every plate) "
        f"predicts {physics_power[0]:.2f} ± {physics_power[1]:.2f} W there. " + _bench_words(context))
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
        frame = tables.table5(tables.characterise_plates(context.run, convention), convention)
        frames.append(pd.DataFrame({"reading": convention.name, "item": frame["item"],
                                    "quantity": frame["quantity"].map(presentation.header),
                                    "this run": frame["value"].map(lambda v: f"{v:.3f}"),
                                    "printed": frame["paper_value"].map(lambda v: f"{v:.2f}"),
                                    "deviation (%)": frame["relative_difference"].map(
                                        lambda v: presentation.percent(v).removesuffix(" %"))}))
    return pd.concat(frames, ignore_index=True)


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
            "(Pt/P0 = 1.2), is drawn as ★ at the printed voltage ratio 37.6/240. " + _bench_words(context))
    body += presentation.fold("Fig. 2 as numbers: Pt/P0 of every series", _detuning_grid(summary, _bench_words(context)))
    body += "<p class='csv'>Machine-readable: <a href='fig2.csv'>fig2.csv</a>.</p>"
    return Section("Fig. 2: frequency detuning (Sec. 2.2)", body, "fig2")


def _detuning_grid(summary: pd.DataFrame, bench_words: str) -> str:
    """Fig. 2 as a table: one row per series (run, v0), Pt/P0 per velocity fraction."""
    regained = summary[summary["detuning_phase"] != "resonance"]
    columns = sorted(regained["target_velocity_ratio"].unique(), reverse=True)
    head = ("<tr><th>campaign run</th><th>plate</th><th>v0 (m/s pp)</th><th>P0 (mW)</th>"
            + "".join(f"<th>Pt/P0 at {r:.2f} v0</th>" for r in columns) + "</tr>")
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
        rows.append(f"<tr><td>{html.escape(run)}</td><td>{html.escape(plate)}</td><td>{level:g}</td>"
                    f"<td>{p0:.1f}</td>{''.join(cells)}</tr>")
    caption = (f"{bench_words} Fig. 2 as numbers: Pt/P0 ± U (k = 2) for each series once v0 is regained "
               "after detuning to the given velocity fraction; the gains cancel in the ratio, the CH2 delay and the "
               "noise do not; 'not reachable': the safety limit stopped the voltage.")
    return f"<table><caption>{html.escape(caption)}</caption><thead>{head}</thead><tbody>{''.join(rows)}</tbody></table>"


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
        + _bench_words(context)))
    return Section("Resonance searches (Sec. 2.1, 5.3)", body, "resonance")


def audit_section(context: ReportContext) -> Section:
    """Audit"""
    findings = _findings()
    grid = audit.convention_grid()
    grid.to_csv(context.out_dir / "conventions_grid.csv", index=False)
    conclusions = []
    for topic, group in findings.groupby("topic", sort=False):
        compared = group[group["printed"].notna()]
        worst = compared.loc[compared["relative_difference"].abs().idxmax()] if len(compared) else group.iloc[0]
        numbers = (f" (worst: {html.escape(worst['quantity'])}, computed {cell_text(worst['computed'])} vs printed "
                   f"{cell_text(worst['printed'])}, {100 * worst['relative_difference']:+.1f} %)"
                   if pd.notna(worst["printed"]) else f" ({html.escape(worst['quantity'])} = {cell_text(worst['computed'])})")
        conclusions.append(f"<li><a href='#audit-{_slug(topic)}'><b>{html.escape(topic)}</b></a>: "
                           f"{html.escape(str(worst['comment']))}{numbers}.</li>")
    explained = [f"{html.escape(where)}, {why}" for where, why, _ in context.flagged if "</a>." in why]
    body = ""
    if explained:   # the summary opens with each in a line: here in full, one click away
        body += presentation.fold(f"This run's {len(explained)} disagreements with the paper, and what explains them",
                                  "<ul>" + "".join(f"<li>{why}</li>" for why in explained) + "</ul>")
    body += ("<p>What the paper's printed numbers and equations say about each other, computed from "
             "its printed values alone (data/paper/), independently of any run. Conclusions, one per "
             "finding (its largest difference from a printed value):</p>"
             f"<ul class='conclusions'>{''.join(conclusions)}</ul>")
    body += presentation.fold(
        "Every finding, and which reading of the paper reproduces which published number",
        "<h3>The findings</h3><p>Relative difference = (computed − printed) / |printed|.</p>"
        + _findings_table(findings)
        + "<h3>Which reading reproduces which published number</h3>"
        f"<p>{len(grid)} readings: {html.escape('; '.join(f'{k} in {v}' for k, v in audit.GRID_AXES.items()))}. "
        f"A number is reproduced within {audit.MATCH_REL:.0%}. Full grid: "
        "<a href='conventions_grid.csv'>conventions_grid.csv</a>.</p>"
        + html_table(audit.grid_summary(grid), "Readings that reproduce each published number.")
        + "<p>The ten best readings overall (RMS of log10 ratios):</p>"
        + html_table(_best_readings(grid), "The ten best readings: computed / printed for each "
                     "published number (1 = reproduced)."))
    return Section("Audit of the paper", body, "audit")


def _best_readings(grid: pd.DataFrame, n: int = 10) -> pd.DataFrame:
    """The best readings, each as one line of its choices, with its ratios to the paper."""
    best = grid[grid["defined"]].head(n)
    reading = best[list(audit.GRID_AXES)].apply(
        lambda row: ", ".join(f"{k}={v}" for k, v in row.items()), axis=1)
    return pd.DataFrame({"reading": reading, "A / printed": best["amplitude_ratio"],
                         "tan θ′ / printed": best["tan_theta_ratio"],
                         "Table 4 tan θ′ / printed": best["table4_tan_ratio"],
                         "RMS log10 misfit": best["log_misfit"]})


def _findings_table(findings: pd.DataFrame) -> str:
    seen: set[str] = set()
    rows = []
    for row in findings.itertuples(index=False):
        anchor = "" if row.topic in seen else f" id='audit-{_slug(row.topic)}'"
        seen.add(row.topic)
        printed = cell_text(row.printed) if pd.notna(row.printed) else "–"
        rel = f"{100 * row.relative_difference:+.1f}" if pd.notna(row.relative_difference) else "–"
        rows.append(f"<tr{anchor}>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in (
            row.topic, row.quantity, cell_text(row.computed), printed, rel, row.source, row.comment)) + "</tr>")
    head = "".join(f"<th>{h}</th>" for h in ("topic", "quantity", "computed", "printed", "difference (%)",
                                              "source", "comment"))
    return (f"<table class='audit'><caption>The audit's findings (printed values only; no run).</caption>"
            f"<thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>")


def study_section(context: ReportContext) -> Section | None:
    """Accuracy vs bench time"""
    if not (context.run.run_dir / "study").is_dir():
        context.absent.append("Accuracy vs bench time: no study/ folder ('squeezebench study --out RUN_DIR' writes it)")
        return None
    body = _coverage_part(context)
    found = _study_summary(context)
    if found is None:
        return Section("Accuracy vs bench time", body, "study") if body else None
    n_trials, summary = found
    summary.to_csv(context.out_dir / "study_summary.csv", index=False)
    systematics, noise, heating = _study_parts(summary)
    drawn = _study_figures(context)
    body = (f"<p>{n_trials} trial rows (RUN_DIR/study/*.parquet) on the simulated bench, each scored "
            "against the scene's closed-form truth; the cost is the virtual bench time of "
            f"one trial. Error = {study.ERROR_PERCENTILE:g}th percentile of |relative error| over the "
            "repeats. All configurations: <a href='study_summary.csv'>study_summary.csv</a>.</p>") + body
    if not noise.empty:
        fronts = study.fronts_table(noise)
        fronts.to_csv(context.out_dir / "study_fronts.csv", index=False)
        body += presentation.fold(
            "Error against bench time on an ideal bench, and the settings on each Pareto front",
            context.figure(drawn["study_fronts"],
                           "Error against bench time per trial on an ideal bench (noise, settling, "
                           "search and heating only), one panel per quantity: every configuration as a "
                           "dot, each experiment's Pareto front as a line. Simulated bench; the paper "
                           "has no such study.")
            + "<h3>Settings on each Pareto front (cheapest first)</h3>"
            + html_table(fronts, "Settings on each Pareto front. Simulated bench."))
    if not systematics.empty:
        body += _systematics_part(context, systematics, drawn["study_systematics"])
    if not heating.empty:
        body += presentation.fold(
            "Heating drift: longer averaging at a fixed frequency, and tracking",
            "<p>The plate warms while it is measured and its resonance falls; a point held at the "
            "frequency found cold loses power as the averaging (and so the series) lasts longer. "
            "Re-centring on the resonance before each point removes that error at the cost of "
            "the tracking's bench time.</p>"
            + context.figure(drawn["study_heating"],
                             "Power error against scope averaging on a heating plate, at the "
                             "frequency found cold and with the resonance tracked. Simulated bench.")
            + html_table(heating, "Heating drift. Simulated bench."))
    return Section("Accuracy vs bench time", body, "study")


def _study_summary(context: ReportContext) -> tuple[int, pd.DataFrame] | None:
    """The stored study's number of trial rows and summary (`study.summarise`), computed
    once; None without a study (or without trials)."""
    if "study" not in context.cache:
        try:
            trials = study.load_trials(context.run.run_dir)
        except MissingDataError:
            context.cache["study"] = None
        else:
            context.cache["study"] = len(trials), study.summarise(trials)
    return context.cache["study"]


def _study_parts(summary: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame]:
    """The summary's systematics experiments, its noise experiments, and its heating table."""
    is_systematics = summary["experiment"].map(study.is_systematics)
    return summary[is_systematics], summary[~is_systematics], study.heating_table(summary)


def _study_figures(context: ReportContext) -> dict[str, Path]:
    """The study's figures, handed to the drawing processes once ({name: PNG}, those its
    data has). `write_report` hands them out before any section: they are the longest to
    draw, and the study's section comes late on the page."""
    if "study_figures" not in context.cache:
        found = _study_summary(context) if (context.run.run_dir / "study").is_dir() else None
        drawn = {}
        if found is not None:
            systematics, noise, heating = _study_parts(found[1])
            for name, function, data in (("study_fronts", figures.study_fronts, noise),
                                         ("study_systematics", figures.systematics_fronts, systematics),
                                         ("study_heating", figures.heating_drift, heating)):
                if not data.empty:
                    drawn[name] = context.draw(function, data, context.out_dir / f"{name}.png")
        context.cache["study_figures"] = drawn
    return context.cache["study_figures"]


def _systematics_part(context: ReportContext, summary: pd.DataFrame, drawn: Path) -> str:
    """The floors the instruments' specified errors put under averaging, and what the
    deskew calibration buys for its bench time."""
    floors = study.floors_table(summary)
    budget = _budget_floors(context)
    floors.insert(2, "budget_floor_p95_rel", [budget.get((row.point, row.quantity), np.nan)
                                              for row in floors.itertuples()])
    context.tables["study_floors"] = floors
    if "campaign" not in set(floors["point"]):
        context.absent.append("The whole paper campaign on erring benches, per averaging: not run ('squeezebench "
                              "study --out RUN_DIR --resume' adds it, a few minutes)")
    words = "; ".join(
        f"{_words_of(row.quantity)} {100 * row.floor_p95_rel:.2g} % ({row.point}, from {cell_text(row.bench_time_s)} s per trial)"
        f"{_calibrated_words(row)}" for row in floors.itertuples())
    checked = floors.dropna(subset=["budget_floor_p95_rel"])
    reconciled = ("" if checked.empty else
                  "<p><b>One floor per quantity: the budgets'.</b> The floor this report stands by is the "
                  "uncertainty budgets' (the instruments' specified limits with the noise averaged away, "
                  "<a href='#uncertainty-budgets-gum-k-2'>Uncertainty budgets</a>); the simulated benches "
                  "below check it: "
                  + html.escape("; ".join(f"{_words_of(row.quantity)} at the {row.point} point, budget "
                                          f"{100 * row.budget_floor_p95_rel:.2g} %, study {100 * row.floor_p95_rel:.2g} %"
                                          for row in checked.itertuples()))
                  + f". A study's floor is a p95 over {int(floors['benches'].max())} benches at its best "
                    "setting, and scatters by a good part of itself from one set of benches to another: it "
                    "sits below the budget's when no bench drew an error near its limit (a delay near +-10 ns), "
                    "and well above it only if the budget misses an effect.</p>")
    return ("<h3>Floors on benches whose instruments err within specification</h3>"
            + presentation.fold("The budgets' floor each quantity is held to, how the study draws its benches, "
                                "its floors per point, drawn against bench time and as a table",
            reconciled + f"<p>Each trial is another simulated bench: scope gains, current-probe gain and delay, "
            "channel skew, vibrometer scale and generator frequency drawn once within their "
            "specifications (plates.specifications), the noise drawn anew. Averaging (and, for the "
            "search, a finer tolerance) lowers the noise until the bench's own errors, or what the "
            "search cannot resolve on the flat top of the peak, are all that is left. Floor (lowest p95 "
            "|relative error| over the benches at any setting), and the bench time per trial of the cheapest "
            f"setting within {study.AT_FLOOR - 1:.0%} of it: {html.escape(words)}.</p>"
            + context.figure(drawn,
                             "Total error against bench time per trial over simulated benches erring "
                             "within specification, one panel per quantity: each point's series (averaging; "
                             "the search's tolerance) as the bench is (solid) and after the deskew "
                             "calibration (dashed; its bench "
                             "time included). Points: table3 = Table 3's point, stress = Fig. 2c's stress "
                             "point (power factor 0.018), sweep = a Fig. 5 plate's characterisation, search = the "
                             "resonance search on the Table 3 plate, campaign = the whole paper campaign at "
                             "one averaging for all its runs (every stored point; its bench time). "
                             "Simulated bench.")
            + html_table(floors, "Floor per point and quantity, as the bench is and after the deskew "
                                 "calibration, with the averaging and bench time per trial of the cheapest "
                                 f"setting within {study.AT_FLOOR - 1:.0%} of it (study_floors.csv). Simulated bench.")))


def _coverage_part(context: ReportContext) -> str:
    """Whether the expanded uncertainties this report prints cover the truth, checked on
    the paper campaign over simulated benches erring within specification."""
    points = study.load_coverage(context.run.run_dir)
    if points is None:
        context.absent.append("Coverage of the uncertainties on erring benches: not run ('squeezebench study "
                              "--out RUN_DIR --resume' adds it: the paper campaign on 40 benches, a few minutes)")
        return ""
    table = study.coverage_table(points)
    context.tables["study_coverage"] = table
    campaign = str(points["campaign"].iat[0]) if "campaign" in points else "the campaign"
    words = "; ".join(study.coverage_lines(table, _words_of))
    return ("<h3>Coverage of the expanded uncertainties</h3>"
            f"<p>{html.escape(campaign)} run on up to {table['benches'].max()} simulated benches (bench k: "
            "errors drawn from seed k), every expanded uncertainty (k = 2, analysis.uncertainty) the report "
            "prints on a stored point (power, velocity, amplitude), on Fig. 2's Pt/P0 and on each resonance "
            "frequency compared with the truth at its setting. Benches 'within specification' "
            "err as the budgets assume (uniformly within each limit); 'as the world errs' do not (normal "
            "errors, a current probe lagging by about 8 ns, one bench in 13 with an error beyond its "
            f"specification): the test a budget can fail. {html.escape(words)}. A bench's errors are "
            "shared by all its values, so a bench is covered almost wholly or hardly at all: the interval "
            "resamples benches, and a handful of them decides it. Q and tan theta' are not scored: their "
            "budgets are mostly the plates' geometry and material tolerances, which the simulated benches "
            "do not draw.</p>"
            + presentation.fold("Coverage per quantity, as a table", html_table(
                table, "Coverage of the expanded uncertainties (k = 2) over simulated benches "
                       "(study_coverage.csv). Simulated bench.")))


def _words_of(quantity: str) -> str:
    """A quantity's code name as words, without its unit (`power_w` -> "power")."""
    return presentation.label(quantity).split(" (")[0]


def _budget_floors(context: ReportContext) -> dict[tuple[str, str], float]:
    """The uncertainty budgets' floor (`uncertainty.systematic_floor`, as the bench is) at the
    campaign points each systematics point of the study stands for: (point, quantity) ->
    p95 relative. stress: the Fig. 2c stress points; table3: the uncut plate of the cutting
    run; campaign: the worst run."""
    points = _uncertainties(context).points
    if points.empty:
        return {}
    groups = {"campaign": points} if _study_campaign(context) == Path(
        str(context.run.manifest.get("campaign", {}).get("file", ""))).name else {}
    if "detuning_phase" in points:
        groups["stress"] = points[points["detuning_phase"] == "stress"]
    if "plate_length_mm" in points:
        cutting = points[points["protocol"] == "resonator_cutting"]
        groups["table3"] = cutting[cutting["plate_length_mm"] == cutting["plate_length_mm"].max()]
    out = {}
    for point, rows in groups.items():
        if rows.empty:
            continue
        floors = (context.tables["uncertainty_floors"] if point == "campaign" and "uncertainty_floors" in context.tables
                  and _uncertainties(context).deskew is None else uncertainty.systematic_floor(rows))
        for quantity, group in floors.groupby("quantity"):
            out[(point, str(quantity))] = float(group["floor_p95_rel"].max())
    return out


def _study_campaign(context: ReportContext) -> str:
    """The file name of the campaign the study ran on erring benches ('' if unknown)."""
    path = context.run.run_dir / study.STUDY_DIR / "manifest.json"
    try:
        settings = json.loads(path.read_text(encoding="utf-8")).get("settings", {})
    except (OSError, ValueError):
        return ""
    return Path(str(settings.get("systematics", {}).get("campaign", ""))).name


def _calibrated_words(row) -> str:
    if pd.isna(row.calibrated_floor_p95_rel):
        return ""
    return f", {100 * row.calibrated_floor_p95_rel:.2g} % calibrated (from {cell_text(row.calibrated_bench_time_s)} s)"


def hardcases_section(context: ReportContext) -> Section | None:
    """Hard cases"""
    directory = context.run.run_dir / "hardcases"
    if not directory.is_dir():
        return None   # asked for separately (benchmarks/hardcases_summary.py --out RUN_DIR)
    body = ""
    for path in sorted(directory.glob("*.csv")):
        frame = pd.read_csv(path)
        body += f"<h3>{html.escape(path.name)}</h3>" + html_table(
            _words_for_missing(frame, "not available"), f"{path.name} (hardcases/). Simulated bench.")
    for path in sorted(directory.glob("*.png")):
        copy = context.out_dir / f"hardcases_{path.name}"
        copy.write_bytes(path.read_bytes())
        body += context.figure(copy, f"{html.escape(path.name)} from hardcases/ (simulated bench).")
    return Section("Hard cases (hardcases/)", body or "<p class='missing'>hardcases/ is empty.</p>", "hardcases")


def conventions_section(context: ReportContext) -> Section:
    """Conventions"""
    c = context.convention
    m = c.materials
    items = [
        f"Convention '{c.name}': V in Eqs. 25/27 is {c.voltage}; A of Eq. 27 is {c.amplitude}; "
        f"neutral plane z0 at the {c.neutral_plane.replace('_', ' ')}; Eq. 28 "
        f"{'with' if c.eq28_with_pi else 'without'} its factor pi; Eq. 29 "
        f"{'as printed (b_large/b_small)' if c.eq29_as_printed else 'with b_small/b_large, as the text describes'}.",
        f"Materials: E_i = {np.format_float_positional(m.resonator_young_pa, trim='-')} Pa, nu_i = {m.resonator_poisson}, "
        f"c11 = {cell_text(m.piezo_c11_pa / 1e9)} GPa, nu_p = {m.piezo_poisson}, d31 = {cell_text(m.piezo_d31_c_per_n * 1e12)} pC/N.",
        "n_c = powered piezos of the plate (measurement column n_powered_piezos); b_p, h_i, h_p and "
        "lambda/2 from the plate's scene copy in inputs/; lambda = 2 (lambda/2).",
        "Power: mean of v i over the largest integer number of periods after DC removal (the paper's "
        "MATH channel), cross-checked by a sine fit. Velocity pp: twice the fitted sine amplitude. "
        "Amplitude pp = velocity pp / (2 pi f).",
        "Uncertainties: U is the expanded uncertainty (k = 2) of the whole budget of each point "
        "(record noise and the instruments' specifications, analysis.uncertainty); Q and tan theta' "
        "add their fits' uncertainty and the geometry's and NCE 41's tolerances (the systematic parts are "
        "shared by the plates of one bench and do not average down in a mean over plates). A cell agrees "
        "with the paper when the difference is "
        "within U plus half the printed value's last digit.",
        "Q: Eq. 27 with the fitted slope of amplitude pp vs voltage pp. tan theta': Eq. 25 with the "
        "fitted slope of power vs Vpp^2, divided by Q. Table 5 estimate: Q of small_plate_4 through "
        "Eq. 29; tan theta' the mean of the small plates as thick as the large plate.",
        "Origins: measured (real bench), simulated (simulated bench), predicted (simulated bench on a "
        "scene the plate model predicted from geometry and datasheets, no printed result in), calibration input (simulated, "
        "and the scene was calibrated on this printed value: a round trip), derived (computed from "
        "other values), campaign setting (typed into the campaign).",
    ]
    return Section("Conventions used", "<ul>" + "".join(f"<li>{html.escape(i)}</li>" for i in items) + "</ul>",
                   "conventions", appendix=True)


def provenance_section(context: ReportContext) -> Section:
    """Provenance"""
    run = context.run
    manifest = run.manifest
    rows = [("run directory", run.run_dir.name),
            ("bench", context.bench()),
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
    for name, bench in sorted(manifest.get("benches", {}).items()):
        rows.append((f"bench, run {name}", f"{bench.get('bench')} ({bench.get('bench_input')})"))
    for name, scene in sorted(run.scenes.items()):
        replay = scene.get("replay") if isinstance(scene, dict) else None
        rows.append((f"scene {name}", f"replay: {replay.get('reason')}" if isinstance(replay, dict) else
                     "not a replay: within the plate model's bounds, or predicted by it"))
    for name, ids in sorted(manifest.get("instruments", {}).items()):
        rows.append((f"instruments, run {name}", json.dumps(ids, sort_keys=True)))
    counts = run.measurements.groupby("protocol").size() if "protocol" in run.measurements else {}
    for protocol, count in sorted(dict(counts).items()):
        rows.append((f"protocol {protocol}", f"{count} stored points"))
    body = ("<table class='provenance'><caption>Files, digests and instruments of this run.</caption>"
            + "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in rows)
            + "</table><p>Column dictionary of the measurements and CSVs: "
              "<a href='columns.csv'>columns.csv</a> (name, unit, meaning).</p>")
    return Section("Provenance", body, "provenance", appendix=True)


def _percent_range(fractions: pd.Series) -> str:
    """"95.6 to 98.3 %", or one number when they all round alike."""
    low, high = (f"{100 * float(v):.1f}" for v in (fractions.min(), fractions.max()))
    return f"{low} %" if low == high else f"{low} to {high} %"


def _uncertainties(context: ReportContext) -> uncertainty.RunUncertainties:
    """The run's budgets, computed once for the sections that share them."""
    if "uncertainties" not in context.cache:
        context.cache["uncertainties"] = uncertainty.run_uncertainties(context.run)
    return context.cache["uncertainties"]


def uncertainty_section(context: ReportContext) -> Section | None:
    """Uncertainty budgets (GUM, k = 2)"""
    found = _uncertainties(context)
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
                               "floor_p95_rel": uncertainty.P95_FACTOR * floor.std_uncertainty / abs(floor.value)})
    context.tables["uncertainty_q_tan_theta"] = pd.DataFrame(plates)
    context.tables["uncertainty_floors"] = uncertainty.systematic_floor(found.points, found.deskew)
    deskew = (_delay_flag(found.points) if found.deskew is None else
              f"<p>Power corrected by the deskew calibration: CH2 delay {found.deskew.delay_s * 1e9:.2f} ns "
              f"(u = {found.deskew.std_uncertainty_s * 1e9:.2f} ns), current-to-voltage gain ratio "
              f"{found.deskew.gain_ratio:.4f} (u = {found.deskew.gain_ratio_u:.4f}).</p>")
    detail = (html_table(found.budgets[[c for c in ("protocol", "quantity", "term", "type", "relative", "share",
                                                    "source") if c in found.budgets]],
                         "The whole budget of one point of each protocol (relative: the term's standard "
                         "uncertainty over the value; the point: uncertainty_budgets.csv). " + _bench_words(context))
              + "<p>Resonance frequencies found by the searches (the generator's setting there), "
                "expanded (k = 2):</p>" + html_table(found.searches, "Resonance frequencies found, expanded (k = 2). " + _bench_words(context))
              + "<p>Q and tan(theta') per plate with the geometry and material tolerances "
                "(expanded, k = 2; floor: p95 relative error with the fits' noise gone):</p>"
              + html_table(context.tables["uncertainty_q_tan_theta"], "Q and tan θ′ with tolerances. " + _bench_words(context))
              + "<p>Floor per run: the p95 relative error of power and velocity the instruments' "
                "specified errors leave at the run's worst point, whatever the averaging:</p>"
              + html_table(context.tables["uncertainty_floors"], "Floor per run. " + _bench_words(context)))
    overall = "; ".join(
        f"{_words_of(q)} {100 * float((found.points[f'{q}_U'] / found.points[q].abs()).median()):.2g} % "
        f"(mostly {found.points[f'{q}_dominant'].mode().iat[0]})" for q in quantities if f"{q}_U" in found.points)
    coverage = "; ".join(f"{_words_of(q)} {_percent_range(found.points[f'{q}_U_coverage'])}"
                         for q in quantities if found.points[f"{q}_U_coverage"].notna().any())
    return Section("Uncertainty budgets (GUM, k = 2)",
                   "<p>Expanded uncertainties (k = 2) of every stored point: noise of the record (Type A) "
                   f"and the instruments' specifications (Type B). Median relative U over the run: {html.escape(overall)}. "
                   "k = 2 is the convention; under each budget's own distribution (its largest specification "
                   "term rectangular, the rest normal) +-U holds the value with a probability of "
                   f"{html.escape(coverage)}: above 95 % where one rectangular term dominates.</p>"
                   + deskew
                   + presentation.fold("Median relative U and dominant term per protocol",
                                       html_table(summary, "Median relative U and dominant term per protocol. " + _bench_words(context)))
                   + presentation.fold("Every term of one point's budget per protocol, the resonance frequencies, "
                                       "Q and tan θ′ with their tolerances, and the floor per run", detail)
                   + "<p>CSV: <a href='uncertainty_points.csv'>uncertainty_points.csv</a>, "
                     "<a href='uncertainty_budgets.csv'>uncertainty_budgets.csv</a></p>")



def _needs_deskew_count(context: ReportContext) -> int:
    """How many stored powers need a deskew the run did not make; 0 where the budgets cannot
    be made (their own section says why), so the headline is always written."""
    try:
        found = _uncertainties(context)
    except UserError:
        return 0
    return 0 if found.deskew is not None else len(uncertainty.needs_deskew(found.points))


def _delay_flag(points: pd.DataFrame) -> str:
    """Without a deskew run: which points' U is mostly the CH2 delay's bias bound (the
    current probe's lag of known sign, `uncertainty.delay_std_uncertainty_s`): covered, but
    a deskew calibration would measure the lag and shrink them."""
    text = "<p>No deskew calibration in this run: the CH2 delay enters at its bound.</p>"
    flagged = uncertainty.needs_deskew(points)
    if flagged.empty:
        return text
    where = ", ".join(sorted({f"{run} / {step}" for run, step in zip(flagged["run_name"], flagged["step_id"])}))
    bound_ns = uncertainty.COVERAGE_FACTOR * uncertainty.delay_std_uncertainty_s() * 1e9
    return (f"<p class='banner'><b>Needs a deskew calibration:</b> {len(flagged)} point(s) ({html.escape(where)}) "
            f"have a power whose U (above {uncertainty.DELAY_FLAG_U_REL:.0%}) is mostly the CH2 delay, budgeted as "
            f"a bias bound of {bound_ns:.0f} ns: a current probe lags its voltage probe by a fixed delay of known "
            "sign (about 8 ns in Tektronix's deskew example) that nothing here measured. A deskew_calibration run "
            "(squeezebench plan --write adds one) measures it and shrinks these U.</p>")


def measurement_model_section(context: ReportContext) -> Section | None:
    """Measurement model: measurand, equation and inputs of every quantity (issue 28)"""
    found = _uncertainties(context)
    stored = [row for _, row in found.points.iterrows() if pd.notna(row.get("power_w_u"))]
    if not stored:
        return None
    table = measurement_model.model_table(stored[0].to_dict(), found.deskew)
    context.tables["measurement_model"] = table
    blocks = []
    for quantity, rows in table.groupby("quantity", sort=False):
        first = rows.iloc[0]
        inputs = rows[["input", "type", "distribution", "relative_std_uncertainty", "correction", "source"]]
        described = (f"<p><b>Measurand.</b> {html.escape(first['measurand'])}</p>"
                     f"<p><b>Model.</b> {html.escape(first['model'])}</p>") if first["measurand"] else ""
        blocks.append(presentation.fold(f"{_words_of(quantity)} ({quantity})",
                                        described + html_table(inputs, f"Inputs of {quantity}, at the run's "
                                                               f"first stored point. " + _bench_words(context))))
    return Section("Measurement model",
                   "<p>What each stated quantity is, the equation it comes from and every input with its "
                   "distribution, standard uncertainty, source and whether it is corrected or only budgeted, "
                   "as a calibration certificate lists them (relative standard uncertainty at the run's first "
                   "stored point). Inputs known to matter that no budget holds yet are listed as such. "
                   "CSV: <a href='measurement_model.csv'>measurement_model.csv</a></p>" + "".join(blocks),
                   "measurement-model", appendix=True)


def readings_section(context: ReportContext) -> Section | None:
    """Q and tan theta' under the physical reading, the text's and the inferred one (issue 13)"""
    if context.run.protocol("characterisation").empty:
        return None   # characterisation_section says so
    plates = audit.plates_under_readings(context.run)
    plates.to_csv(context.out_dir / "plates_by_reading.csv", index=False)
    body = ("<p>Every characterised plate of this run (the paper's or your own), Q from Eq. 27 and "
            "tan theta' from Eq. 25 under the physical reading the report's tables use ('physical': "
            "E_i = 67 GPa and the text's definitions), under the text's own reading with E_i as printed "
            "('paper') and under the one reading that reproduces the paper's published numbers at once "
            "('inferred', analysis.readings, a hypothesis about what the authors computed). "
            "CSV: <a href='plates_by_reading.csv'>plates_by_reading.csv</a></p>"
            + presentation.fold("How the readings were searched, and Q and tan θ′ of every plate under each",
                                "".join(f"<p>{html.escape(words)}</p>" for words in readings.search_words())
                                + html_table(plates, f"Q and tan θ′ of every plate under each reading. {_bench_words(context)}")))
    try:
        table5 = audit.table5_under_readings(context.run)
    except UserError as exc:
        return Section("Plates under each reading", body + f"<p>Table 5 and Fig. 9 under each reading: "
                       f"{html.escape(str(exc))}.</p>", "readings", appendix=True)
    table5.to_csv(context.out_dir / "table5_by_reading.csv", index=False)
    body += ("<h3>Table 5 and Fig. 9 under each reading</h3>"
             + "".join(f"<p>{html.escape(words)}</p>" for words in audit.table5_verdicts(table5))
             + presentation.fold("Table 5 and Fig. 9 under each reading, as numbers",
                                 html_table(table5, f"Table 5 and Fig. 9 under each reading. {_bench_words(context)}")))
    return Section("Plates under each reading", body, "readings", appendix=True)


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
            "aluminium alloy family, the bond and the piezos' placement.</p>")
    body += presentation.fold("Predicted beside printed, plate by plate (the physics lines of Tables 3 and 4, and "
                              "the large plate), and the column layouts assumed",
                              "<p>Column layouts: " + "; ".join(html.escape(why) for _, why in
                                                                predicted_plates.LAYOUTS.values()) + ".</p>"
                              + html_table(shown, "predicted (plate model) and printed (paper)"))
    agree = predicted_plates.what_would_agree(infer_placement=False)
    body += presentation.fold(
        "Where power and velocity miss: which input would have to move", html_table(
            agree, "the force factor and Q the printed power and velocity imply (model-free, and through the "
                   "model's modal mass) over the model's: the factor each would have to move by"))
    fit = damping.fit_and_check()
    body += presentation.fold(
        "Damping from physics: fitted on Table 3, judged on Table 4 and the large plate", html_table(
            fit, f"{PLATE_MODEL_WORDS} Q from the aluminium's, the ceramic's (Qm) and the bond's losses weighted by their strain "
                 f"energy, and radiation into air; the bond's loss factor fitted on Table 3 "
                 f"({fit['fitted_bond_loss_factor'].iloc[0]:.3g}), the other rows held out"))
    figure = predicted_plates.large_plate_mode_figure(context.out_dir / "predicted_mode_large_plate.png")
    body += presentation.fold("The large plate's predicted working mode", context.figure(
        context.out_dir / "predicted_mode_large_plate.png",
        f"Predicted working mode of the large plate (Sec. 5): {figure['interior_antinodes']} interior "
        f"antinodes, nodal-line spacing {figure['half_wavelength_mm']:.2f} mm against the designed 9 mm "
        f"({figure['half_wavelength_mm'] / 9 - 1:+.1%}); rectangles: the piezos. Predicted, not measured."))
    body += "<p class='csv'>Machine-readable: <a href='predicted.csv'>predicted.csv</a>.</p>"
    return Section("What physics predicts (plate model)", body, "predicted")


def cartography_section(context: ReportContext) -> Section | None:
    """Vibration map (Fig. 7)"""
    if context.run.protocol("cartography").empty:
        return None
    body, summary, points = cartography_report.section_html(context.run, context.out_dir, context.figure, html_table,
                                                             context.draw)
    if context.bench() == "simulated":
        body = ("<p class='banner'>On the simulated bench the map is drawn from the same plate model it is "
                "compared with: a modal assurance criterion near 1 shows the chain (stage, acquisition, phase) "
                "keeps the shape, not that the model is right. A real plate's map is the test.</p>") + body
    context.tables["map_summary"], context.tables["map_points"] = summary, points
    body += ("<p class='csv'>Machine-readable: <a href='map_summary.csv'>map_summary.csv</a>, "
             "<a href='map_points.csv'>map_points.csv</a> (every point, reduced from its record).</p>")
    return Section("Vibration map (Fig. 7)", body, "map")


SECTIONS: list[SectionBuilder] = [
    table3_section, table4_section, predicted_section, table5_section, detuning_section, cartography_section,
    characterisation_section,
    readings_section, resonance_section, uncertainty_section, measurement_model_section, audit_section,
    study_section,
    hardcases_section, conventions_section, provenance_section,
]


# --- HTML --------------------------------------------------------------------------------

def cell_text(value) -> str:
    if value is pd.NA:   # a missing entry of an integer column
        return "not available"
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if isinstance(value, (float, np.floating)):
        if not math.isfinite(value):
            return "not available"
        # 4 significant digits, positional (0.0001234, 52400): a person reads no 1.234e-04
        return np.format_float_positional(value, precision=4, unique=False, fractional=False, trim="-")
    return str(value)


def html_table(frame: pd.DataFrame, caption: str = "") -> str:
    """A plain table for a section builder: headers a person reads (`presentation.label`),
    numbers at four significant digits and never in scientific notation, an optional caption
    (the browser test wants one on every table); a table wider than the page scrolls inside
    its own box."""
    head = "".join(f"<th>{html.escape(presentation.label(str(c)))}</th>" for c in frame.columns)
    body = "".join("<tr>" + "".join(f"<td>{html.escape(cell_text(v))}</td>" for v in row) + "</tr>"
                   for row in frame.itertuples(index=False))
    caption_html = f"<caption>{html.escape(caption)}</caption>" if caption else ""
    return f"<table>{caption_html}<thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _words_for_missing(frame: pd.DataFrame, word: str) -> pd.DataFrame:
    frame = frame.astype(object)
    return frame.where(frame.notna(), word)




def _page(context: ReportContext, sections: list[Section]) -> str:
    run = context.run
    kind = context.bench()
    what = {"simulated": "dry run on the simulated bench", "real": "measured on a real bench"}.get(
        kind, f"bench {kind}")
    title = f"squeezebench report: {run.run_dir.name} ({what})"
    sections = [s for s in sections if not s.appendix] + [s for s in sections if s.appendix]
    return page.render(title, [page.PageSection(
        anchor=s.anchor or _slug(s.title), nav=s.title.split(":")[0], heading=f"{'Appendix: ' if s.appendix else ''}{s.title}",
        body_html=s.body_html, css_class="appendix" if s.appendix else "result") for s in sections])
