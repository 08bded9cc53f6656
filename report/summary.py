"""The report's opening section: the run in words, its verdicts, what it does not hold.
"""

from __future__ import annotations

import html
import json

from squeezebench.analysis import provenance, uncertainty
from squeezebench.report import headline, presentation
from squeezebench.errors import UserError
from squeezebench.report.section import ReportContext, Section, bench_words, run_budgets


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
            f"{bench_words(context)}</caption><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>")


def _needs_deskew_count(context: ReportContext) -> int:
    """How many stored powers need a deskew the run did not make; 0 where the budgets cannot
    be made (their own section says why), so the headline is always written."""
    try:
        found = run_budgets(context)
    except UserError:
        return 0
    return 0 if found.deskew is not None else len(uncertainty.needs_deskew(found.points))
