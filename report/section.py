"""What every section of the run report shares: the context it reads, the `Section` it
returns, and the words and HTML tables the sections write alike.
"""

from __future__ import annotations

import html
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from squeezebench.analysis import audit, characterisation, model, provenance, uncertainty
from squeezebench.report import headline, presentation
from squeezebench.report.drawing import Drawing
from squeezebench.analysis.model import REPORT_CONVENTION
from squeezebench.analysis.rundata import RunData
from squeezebench.errors import UserError


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

    def plates(self) -> dict[str, characterisation.PlateCharacterisation]:
        """Fig. 5 characterisation, computed once for the sections that share it."""
        if "plates" not in self.cache:
            self.cache["plates"] = characterisation.characterise_plates(self.run, self.convention)
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


def slug(text: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


#: Said on a table whose numbers come from the plate model and print, not from any bench.
PLATE_MODEL_WORDS = "Plate model, no bench:"


def bench_words(context: ReportContext) -> str:
    """Said on every table: where its numbers come from."""
    kind = context.bench()
    return {"simulated": "Dry run: simulated bench.", "real": "Measured on a real bench."}.get(
        kind, f"Bench: {kind}.")


def paper_findings() -> pd.DataFrame:
    return audit.audit_findings()


def signed(value: float) -> str:
    return f"{value:.3g}".replace("-", "−")


def words_of(quantity: str) -> str:
    """A quantity's code name as words, without its unit (`power_w` -> "power")."""
    return presentation.label(quantity).split(" (")[0]


def run_budgets(context: ReportContext) -> uncertainty.RunUncertainties:
    """The run's budgets, computed once for the sections that share them."""
    if "uncertainties" not in context.cache:
        context.cache["uncertainties"] = uncertainty.run_uncertainties(context.run)
    return context.cache["uncertainties"]


def table5_readings(context: ReportContext) -> pd.DataFrame:
    """Table 5 and Fig. 9 under each reading (`audit.table5_under_readings`), computed once for
    the sections that show or cite it; a run that cannot give it raises its UserError each time."""
    if "table5_readings" not in context.cache:
        try:
            context.cache["table5_readings"] = audit.table5_under_readings(context.run)
        except UserError as exc:
            context.cache["table5_readings"] = exc
    found = context.cache["table5_readings"]
    if isinstance(found, UserError):
        raise found
    return found


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


def words_for_missing(frame: pd.DataFrame, word: str) -> pd.DataFrame:
    frame = frame.astype(object)
    return frame.where(frame.notna(), word)
