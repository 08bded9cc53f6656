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

import contextlib
import html
from concurrent.futures import Future
from pathlib import Path

import pandas as pd

from squeezebench.analysis import columns, readings
from squeezebench.plates import predicted_plates
from squeezebench.report import drawing, page
from squeezebench.report.drawing import Drawing
from squeezebench.analysis.rundata import load_run
from squeezebench.errors import UserError
from squeezebench.workers import default_workers
from squeezebench.report.appendix import conventions_section, provenance_section
from squeezebench.report.audit import audit_section, readings_section
from squeezebench.report.cartography_report import cartography_section, solve_ahead as solve_map_plates_ahead
from squeezebench.report.paper_tables import table3_section, table4_section, table5_section
from squeezebench.report.physics import characterisation_section, detuning_section, predicted_section, resonance_section
from squeezebench.report.section import ReportContext, Section, SectionBuilder, slug
from squeezebench.report.study import study_figures, hardcases_section, study_section
from squeezebench.report.summary import summary_section
from squeezebench.report.uncertainty import measurement_model_section, uncertainty_section


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
        solve_map_plates_ahead(context)   # the map section waits for it: handed out before the figures
        try:
            study_figures(context)   # the longest to draw: handed out first
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


def solve_ahead(workers: int | None = None) -> Future | None:
    """Start solving the paper's plates for a report to come, on its drawing process (none
    with one worker, or with the disk cache off; `workers` as `write_report`'s). The solves
    are kept in the disk cache (`squeezebench.disk_cache`), where `prepare` in this process
    reads them instead of solving them (most of a report's time). They depend on the
    paper's dimensions and the datasheets only, never on a run, so `reproduce` starts them
    with its campaign."""
    return drawing.beside(workers or default_workers(), solve_paper_plates)


def solve_paper_plates() -> None:
    """The paper's plates solved into the disk cache (`predicted_plates.predictions`), a plate the
    model cannot solve left for the sections (or a coverage bench's table) to say so."""
    with contextlib.suppress(UserError):   # the sections say why, in their place
        predicted_plates.predictions()


def prepare(ahead: Future | None = None) -> None:
    """Compute now what the report reads from the model and the paper alone, never from a
    run (the paper's plates predicted: most of a report's time; the search over readings),
    cached for this process: `reproduce` does it while its study's last trials run. With
    `ahead` (`solve_ahead`'s), the plates another process is solving are waited for and
    read, not solved twice (solved here if that process failed)."""
    with contextlib.suppress(UserError):   # the sections say why, in their place
        readings.search_readings()   # first: the plates solved `ahead` may still be coming
    if ahead is not None:
        with contextlib.suppress(Exception):
            ahead.result()
    with contextlib.suppress(UserError):
        predicted_plates.predictions()


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


SECTIONS: list[SectionBuilder] = [
    table3_section, table4_section, predicted_section, table5_section, detuning_section, cartography_section,
    characterisation_section,
    readings_section, resonance_section, uncertainty_section, measurement_model_section, audit_section,
    study_section,
    hardcases_section, conventions_section, provenance_section,
]


def _page(context: ReportContext, sections: list[Section]) -> str:
    run = context.run
    kind = context.bench()
    what = {"simulated": "dry run on the simulated bench", "real": "measured on a real bench"}.get(
        kind, f"bench {kind}")
    title = f"squeezebench report: {run.run_dir.name} ({what})"
    sections = [s for s in sections if not s.appendix] + [s for s in sections if s.appendix]
    return page.render(title, [page.PageSection(
        anchor=s.anchor or slug(s.title), nav=s.title.split(":")[0], heading=f"{'Appendix: ' if s.appendix else ''}{s.title}",
        body_html=s.body_html, css_class="appendix" if s.appendix else "result") for s in sections])
