"""The audit's sections: the paper's inconsistencies computed, the best readings of its
equations, and the plates under each reading.
"""

from __future__ import annotations

import functools
import html

import pandas as pd

from squeezebench.analysis import audit, readings
from squeezebench.report import presentation
from squeezebench.errors import UserError
from squeezebench.report.section import (ReportContext, Section, bench_words, cell_text, paper_findings, html_table, slug,
                                         table5_readings)


def audit_section(context: ReportContext) -> Section:
    """Audit"""
    findings = paper_findings()
    grid = audit.convention_grid()
    (context.out_dir / "conventions_grid.csv").write_bytes(_grid_csv())
    conclusions = []
    for topic, group in findings.groupby("topic", sort=False):
        compared = group[group["printed"].notna()]
        worst = compared.loc[compared["relative_difference"].abs().idxmax()] if len(compared) else group.iloc[0]
        numbers = (f" (worst: {html.escape(worst['quantity'])}, computed {cell_text(worst['computed'])} vs printed "
                   f"{cell_text(worst['printed'])}, {100 * worst['relative_difference']:+.1f} %)"
                   if pd.notna(worst["printed"]) else f" ({html.escape(worst['quantity'])} = {cell_text(worst['computed'])})")
        conclusions.append(f"<li><a href='#audit-{slug(topic)}'><b>{html.escape(topic)}</b></a>: "
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


@functools.cache
def _grid_csv() -> bytes:
    """conventions_grid.csv: the paper's alone, so written out once per process (3.4 MB of
    text, 0.2 CPU-s a report; a test session writes dozens of reports)."""
    return audit.convention_grid().to_csv(index=False).encode()


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
        anchor = "" if row.topic in seen else f" id='audit-{slug(row.topic)}'"
        seen.add(row.topic)
        printed = cell_text(row.printed) if pd.notna(row.printed) else "–"
        rel = f"{100 * row.relative_difference:+.1f}" if pd.notna(row.relative_difference) else "–"
        rows.append(f"<tr{anchor}>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in (
            row.topic, row.quantity, cell_text(row.computed), printed, rel, row.source, row.comment)) + "</tr>")
    head = "".join(f"<th>{h}</th>" for h in ("topic", "quantity", "computed", "printed", "difference (%)",
                                              "source", "comment"))
    return (f"<table class='audit'><caption>The audit's findings (printed values only; no run).</caption>"
            f"<thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>")


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
                                + html_table(plates, f"Q and tan θ′ of every plate under each reading. {bench_words(context)}")))
    try:
        table5 = table5_readings(context)
    except UserError as exc:
        return Section("Plates under each reading", body + f"<p>Table 5 and Fig. 9 under each reading: "
                       f"{html.escape(str(exc))}.</p>", "readings", appendix=True)
    table5.to_csv(context.out_dir / "table5_by_reading.csv", index=False)
    body += ("<h3>Table 5 and Fig. 9 under each reading</h3>"
             + "".join(f"<p>{html.escape(words)}</p>" for words in audit.table5_verdicts(table5))
             + presentation.fold("Table 5 and Fig. 9 under each reading, as numbers",
                                 html_table(table5, f"Table 5 and Fig. 9 under each reading. {bench_words(context)}")))
    return Section("Plates under each reading", body, "readings", appendix=True)
