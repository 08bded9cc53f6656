"""The accuracy study's section (error against bench time, systematics, coverage) and the
hard cases' summary.
"""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import pandas as pd

from squeezebench.analysis import over_coverage, study, uncertainty
from squeezebench.analysis.cartography import TRUTH_CELL_SAMPLES
from squeezebench.report import figures, presentation
from squeezebench.analysis.tables import MissingDataError
from squeezebench.report.section import ReportContext, Section, cell_text, html_table, run_budgets, words_for_missing, words_of


def study_section(context: ReportContext) -> Section | None:
    """Accuracy vs bench time"""
    if not (context.run.run_dir / "study").is_dir():
        context.absent.append("Accuracy vs bench time: no study/ folder ('squeezebench study --out RUN_DIR' writes it)")
        return None
    body = _coverage_part(context) + _over_coverage_part(context)
    found = _study_summary(context)
    if found is None:
        return Section("Accuracy vs bench time", body, "study") if body else None
    n_trials, summary = found
    summary.to_csv(context.out_dir / "study_summary.csv", index=False)
    systematics, noise, heating = _study_parts(summary)
    drawn = study_figures(context)
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


def study_figures(context: ReportContext) -> dict[str, Path]:
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
        f"{words_of(row.quantity)} {100 * row.floor_p95_rel:.2g} % ({row.point}, from {cell_text(row.bench_time_s)} s per trial)"
        f"{_calibrated_words(row)}" for row in floors.itertuples())
    checked = floors.dropna(subset=["budget_floor_p95_rel"])
    reconciled = ("" if checked.empty else
                  "<p><b>One floor per quantity: the budgets'.</b> The floor this report stands by is the "
                  "uncertainty budgets' (the instruments' specified limits with the noise averaged away, "
                  "<a href='#uncertainty-budgets-gum-k-2'>Uncertainty budgets</a>); the simulated benches "
                  "below check it: "
                  + html.escape("; ".join(f"{words_of(row.quantity)} at the {row.point} point, budget "
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
            "search, a finer tolerance) lowers the noise until the bench's own errors (for the search, "
            "the generator's frequency error) are all that is left. Floor (lowest p95 "
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
    the paper campaign over simulated benches: what it found first (`study.coverage_verdict`),
    then each quantity's coverage under each error model (`_coverage_grid`), then how the
    benches erred and what was scored, and the whole table, each one click away."""
    points = study.load_coverage(context.run.run_dir)
    if points is None:
        context.absent.append("Coverage of the uncertainties on erring benches: not run ('squeezebench study "
                              "--out RUN_DIR --resume' adds it: the paper campaign on 40 benches, a few minutes)")
        return ""
    table = study.coverage_table(pd.concat([points, study.design_coverage_points()], ignore_index=True))
    context.tables["study_coverage"] = table
    campaign = str(points["campaign"].iat[0]) if "campaign" in points else "the campaign"
    method = (
        f"{html.escape(campaign)} run on up to {table['benches'].max()} simulated benches (bench k: "
        "errors drawn from seed k), every expanded uncertainty (analysis.uncertainty) the report "
        "prints on a stored point (power, velocity, amplitude), on Fig. 2's Pt/P0, on each resonance "
        "frequency, on each characterised plate's Q and tan theta', on each value of Tables 3 and 4 "
        "(the 'table' rows: an item's value combined from its points as the table combines them, against "
        "the same combination of their truths; a frequency against the cold plate's resonance) and Table "
        "5's estimated tan theta' (the mean over the small plates as thick as the large one), and on each "
        "map's figures "
        "(coefficient of variation, area above the share of the peak, mean and peak velocity; the map at "
        "its campaign's own grid step; the coefficient of variation and the area against the ideal vibration "
        f"over the points' cells, {TRUTH_CELL_SAMPLES} x {TRUTH_CELL_SAMPLES} spots each) "
        "compared with the truth at its setting; each bench reads its own noise, and its plates are drawn "
        "within their geometry's and materials' tolerances (simbench.plate_draws): Q and tan theta' are "
        "scored against the plate as drawn, which the report reads with the nominal inputs. Benches "
        "'within specification' err as the budgets assume (uniformly within each limit); 'as the world "
        "errs' do not (normal errors with half the limit as their spread, so about one in 20 beyond it, "
        "a current probe lagging by about 8 ns, one error in 100 at 1.5 times its limit). Each U's k "
        "holds 95 % under both readings of its specification terms (analysis.budgets: the world's from "
        "plates.specifications.WORLD_READING, its one error in 100 beyond the limit included), so both "
        "are claims a budget can fail. The design's predictions (physics section, U with k = 2) are "
        "scored against the paper's printed measurement of the same plate, a plate for a bench. A "
        "bench's errors are shared by all its values, so a bench is covered almost wholly or hardly at "
        "all: the interval takes benches as its trials (Wilson's, on the number of values the benches "
        "are worth; 40 benches all covered leave 91.2-100 %), and a handful of them decides it.")
    return ("<h3>Coverage of the expanded uncertainties</h3>"
            f"<p>{html.escape(study.coverage_verdict(table, words_of))}</p>"
            + html_table(_coverage_grid(table),
                         "Share of each quantity's values whose ± U holds the truth, with its 95 % interval "
                         "(benches as trials), by how the simulated benches erred. Simulated bench.")
            + presentation.fold("How the benches erred and what was scored", f"<p>{method}</p>")
            + presentation.fold("Coverage per quantity, as a table", html_table(
                table, "Coverage of the expanded uncertainties over simulated benches "
                       "(study_coverage.csv). Simulated bench.")))


def _coverage_grid(table: pd.DataFrame) -> pd.DataFrame:
    """One row per quantity, one column per error model (`study.MODEL_HEADINGS`): its coverage and
    95 % interval on that model's benches ("" where it was not scored so; their number in the
    heading where every quantity had as many, else in each cell), and, beside the
    world's, its coverage on the world's benches whose instruments all err within
    specification (what the budgets promise)."""
    def cell(row, benches_said: bool) -> str:
        return (f"{100 * row.covered_fraction:.1f} % ({100 * row.coverage_interval_low:.1f}-"
                f"{100 * row.coverage_interval_high:.1f} %)" + ("" if benches_said else f", {row.benches} benches"))

    grid = pd.DataFrame(index=pd.Index(list(dict.fromkeys(table["quantity"])), name="quantity"))
    for model, heading in study.MODEL_HEADINGS.items():
        rows = table[table["error_model"] == model].set_index("quantity")
        if rows.empty:
            continue
        one_count = rows["benches"].nunique() == 1   # said once, in the heading
        if one_count:
            heading = f"{heading}, {rows['benches'].iat[0]} benches"
        grid[heading] = [cell(rows.loc[q], one_count) if q in rows.index else "" for q in grid.index]
        if model == "world":
            within = (rows["benches"] - rows["benches_beyond_specification"]).unique()
            heading = "world, instruments within specification" + (f", {within[0]} benches" if len(within) == 1 else "")
            grid[heading] = [f"{100 * rows.at[q, 'covered_fraction_within_specification']:.1f} %"
                             if q in rows.index else "" for q in grid.index]
    grid.index = [words_of(q) for q in grid.index]
    return grid.rename_axis("quantity").reset_index()


def _over_coverage_part(context: ReportContext) -> str:
    """How much narrower the U of each quantity over-covering on the world model's benches
    could be (`analysis.over_coverage`), and where its price in bench time is found."""
    table = context.tables.get("study_coverage")
    lines = [] if table is None else over_coverage.shrink_lines(table, words_of)
    if not lines:
        return ""
    return (f"<p>{html.escape('; '.join(lines))}. A budget of rectangles at their limits is wider than normal "
            "errors with half the limit as their spread need; what a U that much narrower would save in bench time, "
            "its floor being lower, the planner says: 'squeezebench plan CAMPAIGN --coverage RUN_DIR'.</p>")


def _budget_floors(context: ReportContext) -> dict[tuple[str, str], float]:
    """The uncertainty budgets' floor (`uncertainty.systematic_floor`, as the bench is) at the
    campaign points each systematics point of the study stands for: (point, quantity) ->
    p95 relative. stress: the Fig. 2c stress points; table3: the uncut plate of the cutting
    run; campaign: the worst run."""
    points = run_budgets(context).points
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
                  and run_budgets(context).deskew is None else uncertainty.systematic_floor(rows))
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
            words_for_missing(frame, "not available"), f"{path.name} (hardcases/). Simulated bench.")
    for path in sorted(directory.glob("*.png")):
        copy = context.out_dir / f"hardcases_{path.name}"
        copy.write_bytes(path.read_bytes())
        body += context.figure(copy, f"{html.escape(path.name)} from hardcases/ (simulated bench).")
    return Section("Hard cases (hardcases/)", body or "<p class='missing'>hardcases/ is empty.</p>", "hardcases")
