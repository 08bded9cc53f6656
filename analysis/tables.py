"""Tables 3, 4 and 5 and the per-plate Q / tan(theta') of Fig. 5, recomputed from a run.

Every number comes from the stored waveforms reduced by `analysis.waveforms` (the
scope's on-line numbers are shown beside them as a cross-check) and is set side by side
with the paper's printed value (data/paper/) and the relative difference.

Tables are tidy: one row per (item, quantity). A finished table (`finish_table`) keeps
one dtype per column: a value that could not be obtained is NaN, with the row's `status`
("not measured" / "not reachable") saying why.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
import pandas as pd
from scipy import optimize

from squeezebench.analysis import provenance
from squeezebench.analysis.budgets import COVERAGE_FACTOR, Budget
from squeezebench.paper import paper_table, printed_step
from squeezebench.plates.specifications import SPECIFICATIONS
from squeezebench.analysis.resonance_searches import search_setups
from squeezebench.analysis.rundata import RunData
from squeezebench.analysis.waveforms import Estimate, PointReduction, reduce_record
from squeezebench.errors import UserError


TABLE_COLUMNS = ["table", "item", "quantity", "unit", "value", "std_uncertainty", "expanded_uncertainty",
                 "scope_value", "paper_value", "paper_source", "relative_difference", "tolerance",
                 "agrees", "origin", "calibrated_on", "status"]


NOT_MEASURED = "not measured"


NOT_REACHABLE = "not reachable"


#: `status` of a printed value the run was given (or calibrated on, or derived only from
#: those) that came back within its tolerance: it shows the chain, not the paper, so its
#: `agrees` is left empty, never counted as an agreement.
ROUND_TRIP = "round_trip"


#: Origins of values that were inputs of the run, not results.
INPUT_ORIGINS = (provenance.CALIBRATION_INPUT, provenance.SETTING)


#: A straight line through fewer points has no residual to judge it by.
MIN_FIT_POINTS = 3


UNITS = {"n_antinodes": "1", "frequency_hz": "Hz", "voltage_vpp": "V", "power_w": "W",
         "velocity_pp_mps": "m/s", "amplitude_pp_m": "m", "q": "1", "tan_theta": "1", "tan_theta_mean": "1"}


class FitError(UserError):
    """A curve fit that was refused (too few points, no spread) or failed."""


class MissingDataError(UserError):
    """A run lacks what a table needs; the message says what and where."""


@dataclass(frozen=True)
class LineFit:
    """y = slope x + intercept with standard uncertainties, in the caller's units."""

    slope: Estimate
    intercept: Estimate
    n_points: int
    chi2_per_dof: float = math.nan   # with stated uncertainties; NaN without


def fit_line(x, y, y_std=None, *, what: str) -> LineFit:
    """Weighted straight-line fit with `scipy.optimize.curve_fit` on scaled variables
    (x / max|x|, y / max|y|, so the normal equations are of order one whatever the
    units). With stated uncertainties the covariance is theirs, inflated by the reduced
    chi-square when the points scatter more than stated (never deflated: exact points
    keep their stated uncertainty); without, the residual scatter alone."""
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    keep = np.isfinite(x) & np.isfinite(y)
    x, y = x[keep], y[keep]
    if x.size < MIN_FIT_POINTS:
        raise FitError(f"{what}: a line fit needs at least {MIN_FIT_POINTS} points, got {x.size}")
    x_scale, y_scale = np.max(np.abs(x)), np.max(np.abs(y))
    if x_scale == 0 or np.ptp(x) <= 1e-9 * x_scale:
        raise FitError(f"{what}: all {x.size} points share one abscissa; no slope can be fitted")
    if y_scale == 0:
        y_scale = 1.0
    sigma = None
    if y_std is not None:
        s = np.asarray(y_std, dtype=float)[keep] / y_scale
        sigma = s if np.all(s > 0) and np.all(np.isfinite(s)) else None
    u, v = x / x_scale, y / y_scale
    try:
        params, covariance = optimize.curve_fit(lambda t, m, c: m * t + c, u, v, p0=(1.0, 0.0),
                                                sigma=sigma, absolute_sigma=sigma is not None)
    except (RuntimeError, ValueError) as exc:
        raise FitError(f"{what}: line fit failed ({exc})") from exc
    chi2_per_dof = math.nan
    if sigma is not None:
        chi2_per_dof = float(np.sum(((v - params[0] * u - params[1]) / sigma) ** 2)) / (u.size - 2)
        covariance = covariance * max(chi2_per_dof, 1.0)
    errors = np.sqrt(np.clip(np.diag(covariance), 0.0, None))
    errors = np.where(np.isfinite(errors), errors, 0.0)  # exact data: zero scatter
    return LineFit(slope=Estimate(params[0] * y_scale / x_scale, errors[0] * y_scale / x_scale),
                   intercept=Estimate(params[1] * y_scale, errors[1] * y_scale),
                   n_points=int(x.size), chi2_per_dof=chi2_per_dof)


def mean_estimate(values, uncertainties, shared=None) -> Estimate:
    """Mean of repeated points; uncertainty combines their independent part and `shared`,
    each point's part that is common to all of them (the same instruments' Type B errors:
    fully correlated, so the mean keeps their mean, GUM 5.2.2 with r = 1).

    The independent part has two estimates: the stated `uncertainties` averaged down
    (internal, 1/n in quadrature) and the points' scatter about their mean (external,
    s / sqrt(n), GUM 4.2.3). Both measure the same errors (the scatter is what those
    errors do to the points), so adding them counts the errors twice; the larger is kept
    (the Birge ratio's rule: the stated part unless the points scatter more than it
    allows, which then tells of a variation it leaves out)."""
    values = np.asarray(values, dtype=float)
    uncertainties = np.asarray(uncertainties, dtype=float)
    n = values.size
    stated = math.sqrt(float(np.sum(uncertainties**2))) / n
    scatter = float(np.std(values, ddof=1)) / math.sqrt(n) if n > 1 else 0.0
    common = float(np.mean(np.asarray(shared, dtype=float))) if shared is not None else 0.0
    return Estimate(float(values.mean()), math.hypot(max(stated, scatter), common))


def flag(column: pd.Series, default: bool) -> pd.Series:
    """A boolean column of the concatenated steps; steps that lack it get `default`."""
    return column.map(lambda x: default if pd.isna(x) else bool(x)).astype(bool)


def relative_difference(value: float, reference: float) -> float:
    return (value - reference) / abs(reference) if reference else math.nan


def compare_with_paper(row: dict, printed: pd.DataFrame) -> dict:
    """The printed value beside `row`'s value: relative difference, the tolerance (the
    run's expanded uncertainty plus half the step of the printed last digit) and whether
    the difference is within it."""
    if len(printed):
        row["paper_value"] = float(printed["value"].iloc[0])
        row["paper_source"] = str(printed["source"].iloc[0])
        half_step = 0.5 * printed_step(str(printed["value_text"].iloc[0]))
    else:
        row["paper_value"], row["paper_source"], half_step = math.nan, "", math.nan
    row["relative_difference"] = relative_difference(row["value"], row["paper_value"])
    expanded = row.get("expanded_uncertainty", math.nan)
    row["tolerance"] = (expanded if math.isfinite(expanded) else 0.0) + half_step
    difference = abs(row["value"] - row["paper_value"])
    row["agrees"] = bool(difference <= row["tolerance"]) if math.isfinite(difference) else None
    return row


def reduced_points(run: RunData, rows: pd.DataFrame) -> pd.DataFrame:
    """`rows` with the reduction of each row's waveform file added as columns
    (frequency_hz, piezo_voltage_vpp, power_w, power_fit_w, velocity_pp_mps, ... each
    with `_u`). Reductions are cached on the run, so every table sees the same numbers."""
    cache = run.reductions
    reduced = []
    # the three columns read, not the rows' sixty-odd: a row tuple of all of them cost more than a cached reduction
    read = [rows[c] if c in rows else [None] * len(rows)
            for c in ("waveform_file", "vibrometer_scale_mps_per_v", "generator_frequency_hz")]
    for path, scale, frequency in zip(*read):
        if not isinstance(path, str) or not path:
            reduced.append({})
            continue
        if path not in cache:
            waveform = run.waveform(path)
            try:
                cache[path] = reduce_record(
                    waveform.samples, float(scale),
                    y_increments=waveform.y_increments(), averages=waveform.averages(),
                    frequency_hint_hz=float(frequency)).as_row()
            except (ValueError, KeyError) as exc:
                raise MissingDataError(f"{run.run_dir / path}: cannot reduce this record ({exc})") from exc
        reduced.append(cache[path])
    extra = pd.DataFrame(reduced, index=rows.index).reindex(columns=REDUCTION_COLUMNS)
    # The rows carry the scope's own velocity_pp_mps; the reduction replaces it (the
    # scope's number stays available as scope_velocity_pp_v x vibrometer scale).
    return pd.concat([rows.drop(columns=[c for c in REDUCTION_COLUMNS if c in rows]), extra], axis=1)


def with_scope_fallback(points: pd.DataFrame) -> pd.DataFrame:
    """Points without a stored waveform (e.g. resonance sweep points) take the scope's
    on-line power and velocity instead of the reduction."""
    points = points.copy()
    points["power_w"] = points["power_w"].fillna(points["scope_power_w"])
    points["velocity_pp_mps"] = points["velocity_pp_mps"].fillna(_scope_velocity_pp_mps(points))
    return points


REDUCTION_COLUMNS = [f"{name}{suffix}" for name in PointReduction.__dataclass_fields__
                     for suffix in (("",) if name in ("n_periods", "velocity_raw_pp_mps") else ("", "_u"))]


def _scope_velocity_pp_mps(points: pd.DataFrame) -> pd.Series:
    return points["scope_velocity_pp_v"] * points["vibrometer_scale_mps_per_v"]


def _side_by_side(run: RunData | None, table: str, paper_name: str, items: dict[str, pd.DataFrame],
                  quantities: list[str], constant_columns: dict[str, str]) -> pd.DataFrame:
    """One row per (paper item, quantity): recomputed value with its uncertainties and
    origin, scope value, printed value."""
    paper = paper_table(paper_name)
    searches = _search_budgets(run) if run is not None and "frequency_hz" in quantities else {}
    rows = []
    for item in paper["item"].unique():
        if item == "plate":
            continue
        points = items.get(item)
        calibrated = provenance.calibrated_on(run, points) if run is not None and points is not None else {}
        used = reachable_points(points) if points is not None and len(points) else None
        budgets = functools.cache(functools.partial(_point_budgets, used))   # once for all of the item's quantities
        for quantity in quantities:
            printed = paper[(paper["item"] == item) & (paper["quantity"] == quantity)]
            row = {"table": table, "item": item, "quantity": quantity, "unit": UNITS[quantity],
                   "value": math.nan, "std_uncertainty": math.nan, "expanded_uncertainty": math.nan,
                   "scope_value": math.nan, "origin": "", "calibrated_on": "", "status": NOT_MEASURED}
            if used is not None:
                if used.empty:
                    row["status"] = NOT_REACHABLE
                else:
                    row.update(_quantity_value(used, quantity, constant_columns, budgets))
                    if quantity == "frequency_hz":
                        row.update(_with_search_uncertainty(row, used, searches))
                    row["status"] = "measured"
                    row["origin"] = _origin(used, quantity, calibrated, run, constant_columns)
                    row["calibrated_on"] = calibrated.get(quantity, "")
            rows.append(compare_with_paper(row, printed))
    return pd.DataFrame(rows, columns=TABLE_COLUMNS)


def reachable_points(points: pd.DataFrame) -> pd.DataFrame:
    """The points of a table's item that its value is made of: those that reached their
    setting (all of them where the run does not say)."""
    return points[flag(points["reachable"], default=True)] if "reachable" in points else points


def _origin(points: pd.DataFrame, quantity: str, calibrated: dict[str, str], run: RunData,
            constant_columns: dict[str, str]) -> str:
    if quantity in constant_columns:
        return provenance.SETTING
    if quantity in calibrated:
        return provenance.CALIBRATION_INPUT
    return provenance.point_origin(points, run.manifest, run.scenes)


def _quantity_value(points: pd.DataFrame, quantity: str, constant_columns: dict[str, str],
                    budgets: Callable[[], pd.DataFrame]) -> dict:
    if quantity in constant_columns:
        value = float(points[constant_columns[quantity]].iloc[0])
        return {"value": value, "std_uncertainty": 0.0, "expanded_uncertainty": 0.0}
    column = "piezo_voltage_vpp" if quantity == "voltage_vpp" else quantity
    estimate = mean_estimate(points[column], points[f"{column}_u"])
    scope_frequency = points.get("scope_frequency_hz", points["generator_frequency_hz"])
    scope = {"power_w": points["scope_power_w"],
             "amplitude_pp_m": _scope_velocity_pp_mps(points) / (2 * math.pi * scope_frequency),
             "velocity_pp_mps": _scope_velocity_pp_mps(points),
             "frequency_hz": scope_frequency,
             "voltage_vpp": points.get("scope_piezo_voltage_pp_v", points["piezo_voltage_setpoint_vpp"]),
             }.get(quantity)
    return {"value": estimate.value, "std_uncertainty": estimate.std_uncertainty,
            "expanded_uncertainty": _expanded(points, column, estimate, budgets),
            "scope_value": float(scope.mean()) if scope is not None else math.nan}


def _point_budgets(points: pd.DataFrame) -> pd.DataFrame:
    """The points with their budgets' uncertainties (`uncertainty.with_expanded_uncertainties`)."""
    # analysis.uncertainty reads reduced points through analysis.calibration, which imports
    # this module: imported here, once both are loaded.
    from squeezebench.analysis import uncertainty

    return uncertainty.with_expanded_uncertainties(points)


def _expanded(points: pd.DataFrame, column: str, estimate: Estimate,
              budgets: Callable[[], pd.DataFrame] | None = None) -> float:
    """Expanded uncertainty of a mean of points from their whole budgets
    (analysis.uncertainty: noise and the instruments' specifications); the amplitude
    takes the velocity's relative budget. The noise averages down over the points, the
    specifications' part (the same instruments for every point) does not. k is the points'
    own (`Budget.coverage_factor`, their median); without a budget, 2 times the noise alone.
    `budgets()`: `_point_budgets(points)` (worked out here without it), which holds every
    budgeted quantity's, asked once for all of a table item's quantities (Tables 3 and 4 of
    the paper run: 6 times, where 27)."""
    from squeezebench.analysis import uncertainty   # here, as in `_point_budgets`

    budgeted = "velocity_pp_mps" if column == "amplitude_pp_m" else column
    if budgeted in uncertainty.POINT_BUDGETS and points["power_w_u"].notna().all():
        budgets = _point_budgets(points) if budgets is None else budgets()
        combined = budgets[f"{budgeted}_u_combined"]
        k = float((budgets[f"{budgeted}_U"] / combined).median())
        noise = points[f"{budgeted}_u"]
        if column == "amplitude_pp_m":
            combined, noise = (u / points["velocity_pp_mps"] * points["amplitude_pp_m"] for u in (combined, noise))
        shared = np.sqrt(np.clip(combined**2 - noise**2, 0.0, None))
        return k * mean_estimate(points[column], noise, shared).std_uncertainty
    return COVERAGE_FACTOR * estimate.std_uncertainty


def _search_budgets(run: RunData) -> dict[tuple[str, str], Budget]:
    """{(run, step): the budget of where that step's resonance search put the resonance}
    (`uncertainty.run_search_budgets`: the flat top's sampling and noise, the bracket, the
    generator, the plate's warming)."""
    from squeezebench.analysis import uncertainty   # imports this module, see _expanded

    if run.protocol("resonance_search").empty:
        return {}
    return {(name, step): budget for name, step, budget in uncertainty.run_search_budgets(run)}


def _with_search_uncertainty(row: dict, points: pd.DataFrame, searches: dict[tuple[str, str], Budget]) -> dict:
    """A frequency compared with a printed resonance is where a resonance search set the
    generator: its uncertainty also takes how well the search found the resonance, in
    quadrature, from the widest of the points' searches (`searches`: `_search_budgets`), its
    U the search's own (k from its budget) less the generator's frequency error
    (`_placement`); and its value the searches' correction (a warm plate's,
    `Budget.correction`, each point its own search's), which their U no longer holds as a
    bias: the plate as mounted, at rest, as the search states it."""
    if not {"run_name", "step_id"} <= set(points):
        return {}
    found = [_placement(searches[key]) for key in zip(points["run_name"], points["step_id"]) if key in searches]
    if not found:
        return {}
    widest = max(found, key=lambda budget: budget.expanded_uncertainty)
    return {"value": row["value"] + float(np.mean([budget.correction for budget in found])),
            "std_uncertainty": math.hypot(row["std_uncertainty"], widest.std_uncertainty),
            "expanded_uncertainty": math.hypot(row["expanded_uncertainty"], widest.expanded_uncertainty)}


def _placement(search: Budget) -> Budget:
    """A search's budget as it bears on the drive's frequency read by the scope: without its
    generator-frequency term. An output off its setting by e f moved the setting the search
    found by -e f (so the search's value, a setting, carries it), while the drive, read
    by the scope's fit (`frequency_budget`: the time base, its own reference), still sits on
    the resonance: the generator's error is not in the table's value."""
    generator = SPECIFICATIONS["generator_frequency"].source
    return replace(search, terms=tuple(term for term in search.terms if term.source != generator))


def protocol_points(run: RunData, protocol: str) -> pd.DataFrame:
    """The protocol's stored points, reduced; powers corrected by the run's own deskew
    calibration when it has one (a recognised delay is corrected, not only budgeted)."""
    from squeezebench.analysis.calibration import deskew_of_run   # it reads points through this module

    rows = run.protocol(protocol)
    if rows.empty:
        raise MissingDataError(f"protocol '{protocol}' is not in this run "
                               f"({run.run_dir / 'measurements'})")
    if "sweep" in rows:
        rows = rows[~flag(rows["sweep"], default=False)]
    points = reduced_points(run, rows.reset_index(drop=True))
    deskew = deskew_of_run(run)
    return points if deskew is None else deskew.applied_to(points)


TABLE3_QUANTITIES = ["n_antinodes", "frequency_hz", "voltage_vpp", "power_w", "velocity_pp_mps"]


TABLE4_QUANTITIES = ["frequency_hz", "voltage_vpp", "power_w", "velocity_pp_mps", "amplitude_pp_m"]


def empty_table(name: str, quantities: list[str]) -> pd.DataFrame:
    """The paper's rows of a table with nothing measured (the protocol was not run)."""
    return _side_by_side(None, name, name, {}, quantities, {})


def table3(run: RunData) -> pd.DataFrame:
    """Table 3 (Sec. 2.3.1): the one-column plate cut to shorter lengths, 20 Vpp."""
    return with_prediction(_side_by_side(run, "table3", "table3", table3_items(run), TABLE3_QUANTITIES,
                                         {"n_antinodes": "n_antinodes"}), "Table 3")


def table3_items(run: RunData) -> dict[str, pd.DataFrame]:
    """{Table 3's printed length: the run's points of that cut}."""
    points = protocol_points(run, "resonator_cutting")
    printed_lengths = [float(i) for i in paper_table("table3")["item"].unique() if i != "plate"]
    items: dict[str, pd.DataFrame] = {}
    for length, group in points.groupby("plate_length_mm"):
        # The uncut plate is 76 mm in Fig. 2 but labelled 75 in Table 3: match within 1.5 mm.
        nearest = min(printed_lengths, key=lambda p: abs(p - float(length)))
        if abs(nearest - float(length)) <= 1.5:
            items[f"{nearest:g}"] = group
    return items


def table4(run: RunData) -> pd.DataFrame:
    """Table 4 (Sec. 2.3.2): one- and two-column plates, one or two columns powered."""
    return with_prediction(_side_by_side(run, "table4", "table4", table4_items(run), TABLE4_QUANTITIES, {}),
                           "Table 4")


def table4_items(run: RunData) -> dict[str, pd.DataFrame]:
    """{Table 4's configuration: the run's points of it}."""
    points = protocol_points(run, "powered_columns")
    return {str(name): group for name, group in points.groupby("configuration")}


#: Each paper table of stored points: (the protocol it is measured by, the table, its items).
POINT_TABLES = {"table3": ("resonator_cutting", table3, table3_items),
                "table4": ("powered_columns", table4, table4_items)}


def with_prediction(frame: pd.DataFrame, table: str) -> pd.DataFrame:
    """`frame` with what physics predicts for the paper's plate beside each printed value it
    can predict (plates.predicted_plates: geometry and datasheets, no printed result in):
    predicted_value, predicted_expanded_uncertainty (k = 2) and predicted_difference from print."""
    from squeezebench.plates import predicted_plates   # the plate solver: only where a paper table is drawn

    out = frame.merge(predicted_plates.tidy(table), on=["item", "quantity"], how="left")
    out["predicted_difference"] = [relative_difference(v, p) for v, p in zip(out["predicted_value"],
                                                                              out["paper_value"])]
    return out


def is_put_in(frame: pd.DataFrame) -> pd.Series:
    """Rows whose value the run was given: a campaign setting, a calibration input, or
    derived from calibration inputs (`calibrated_on` names them)."""
    # astype(bool): on no rows pandas 3 keeps the mapped column's string dtype, and `|` of
    # booleans with strings is deprecated there (it will raise)
    calibrated = frame["calibrated_on"].map(lambda c: isinstance(c, str) and c != "").astype(bool)
    return frame["origin"].isin(INPUT_ORIGINS) | calibrated


#: What a paper table's `item` is, as a wide table's first column names it.
ITEM_NAMES = {"table3": "plate_length_mm", "table4": "configuration", "table5": "estimate"}


def wide_table(frame: pd.DataFrame) -> pd.DataFrame:
    """A finished paper table (tidy: one row per item and quantity) as pandas users expect
    it: one row per item, named for what it is (`ITEM_NAMES`: Table 3's plate length in mm),
    and per quantity (its unit in its name) its value, `<quantity>_expanded_u` (U, k = 2),
    `paper_<quantity>` and `<quantity>_status` ('measured', 'round_trip', 'not measured')."""
    name = str(frame["table"].iloc[0]) if len(frame) else ""
    item = ITEM_NAMES.get(name, "item")
    parts = {"": "value", "_expanded_u": "expanded_uncertainty", "paper_": "paper_value", "_status": "status"}
    wide = {}
    for suffix, column in parts.items():
        pivot = frame.pivot(index="item", columns="quantity", values=column)
        for quantity in dict.fromkeys(frame["quantity"]):
            wide[f"{suffix}{quantity}" if suffix == "paper_" else f"{quantity}{suffix}"] = pivot[quantity]
    out = pd.DataFrame(wide)
    order = [c for q in dict.fromkeys(frame["quantity"]) for c in (q, f"{q}_expanded_u", f"paper_{q}", f"{q}_status")]
    out = out[order].reindex(list(dict.fromkeys(frame["item"]))).rename_axis(item).reset_index()
    if item.endswith("_mm"):
        out[item] = out[item].astype(float)
    return out


def finish_table(frame: pd.DataFrame, value_columns=("value", "std_uncertainty", "expanded_uncertainty",
                                                     "scope_value", "paper_value", "relative_difference",
                                                     "tolerance", "predicted_value", "predicted_expanded_uncertainty",
                                                     "predicted_difference")) -> pd.DataFrame:
    """The table as written and read back: one dtype per column whatever the run holds.
    Number columns are floats, a missing number NaN (an empty CSV cell) with the row's
    `status` saying why ('not measured', 'not reachable'); `agrees` is a nullable boolean,
    empty where nothing was compared; a missing printed value has `paper_source` 'not
    printed'. A value the run was given that comes back within its tolerance has status
    'round_trip' and `agrees` empty (`ROUND_TRIP`). Words never stand in a number column, so
    `pd.read_csv` gives floats back."""
    out = frame.copy()
    if "agrees" in out:   # compared only where both numbers exist
        out["agrees"] = out["agrees"].map(lambda a: pd.NA if a is None or pd.isna(a) else bool(a)).astype("boolean")
        if "origin" in out and "calibrated_on" in out:
            came_back = out["agrees"].fillna(False).astype(bool) & is_put_in(out)
            out.loc[came_back, "status"] = ROUND_TRIP
            out.loc[came_back, "agrees"] = pd.NA
    if "paper_source" in out:
        out["paper_source"] = out["paper_source"].where(out["paper_source"].fillna("") != "", "not printed")
    for column in (c for c in value_columns if c in out):
        out[column] = pd.to_numeric(out[column], errors="coerce").astype(float)
        out.loc[~np.isfinite(out[column]), column] = np.nan   # inf is as missing as NaN
    return out


def detuning_table(run: RunData) -> pd.DataFrame:
    """Fig. 2 (Sec. 2.2): Pt / P0 per plate, velocity level and target velocity ratio,
    where P0 is the power at resonance (its own row has ratio 1) and Pt the power once v0
    is regained (or at the stress point), with the ratio's expanded uncertainty
    (`uncertainty.power_ratio_budget`: the gains cancel, the CH2 delay does not; the ratio
    corrected for the resonance's estimated drift where it has a budget, so it is not
    power_w / power_resonance_w, which are as read) and the name of its largest term.
    Unreachable targets stay as rows with status 'not reachable'."""
    from squeezebench.analysis import uncertainty   # see _expanded

    points = detuning_points(run)
    rows = []
    # One campaign run is one series of Fig. 2 (the stress point is a run of its own on
    # the same plate, with its own resonance power).
    for (run_name, plate, level), group in points.groupby(["run_name", "plate", "velocity_level_pp_mps"],
                                                          sort=True):
        at_resonance = group[group["detuning_phase"] == "resonance"]
        p0 = float(at_resonance["power_w"].mean()) if len(at_resonance) else math.nan
        for phase in ("resonance", "regained", "stress"):
            for ratio, target in group[group["detuning_phase"] == phase].groupby("target_velocity_ratio"):
                reachable = bool(flag(target["reachable"], default=True).all()) if "reachable" in target else True
                power = float(target["power_w"].mean())
                budget = uncertainty.power_ratio_budget(target, at_resonance) \
                    if reachable and len(at_resonance) and "reactive_power_var" in target else None
                rows.append({"run_name": run_name, "plate": plate, "velocity_level_pp_mps": float(level),
                             "detuning_phase": phase,
                             "target_velocity_ratio": float(ratio),
                             "frequency_hz": float(target["frequency_hz"].fillna(
                                 target["generator_frequency_hz"]).mean()),
                             "voltage_vpp": float(target["piezo_voltage_setpoint_vpp"].mean()),
                             "power_w": power if reachable else math.nan,
                             "power_resonance_w": p0,
                             "power_ratio": (budget.value if budget is not None else power / p0)
                             if reachable and p0 > 0 else math.nan,
                             "power_ratio_U": math.nan if budget is None else budget.expanded_uncertainty,
                             "power_ratio_largest_term": "" if budget is None else budget.dominant.name,
                             "status": "measured" if reachable else NOT_REACHABLE})
    return pd.DataFrame(rows, columns=["run_name", "plate", "velocity_level_pp_mps", "detuning_phase",
                                       "target_velocity_ratio", "frequency_hz", "voltage_vpp", "power_w",
                                       "power_resonance_w", "power_ratio", "power_ratio_U", "power_ratio_largest_term",
                                       "status"])


def detuning_points(run: RunData) -> pd.DataFrame:
    """Fig. 2's points as their budgets read them: reduced, with each power's parts that do
    not follow the resonance (`dielectric`) and the resonance's drift at each reading
    (`resonance_drift`)."""
    from squeezebench.analysis import dielectric, resonance_drift   # they read points through this module

    points = dielectric.with_dielectric_power(with_scope_fallback(protocol_points(run, "detuning")), run.scenes)
    return resonance_drift.with_resonance_drift(points, resonance_search_points(run), scenes=run.scenes,
                                                setups=search_setups(run))


def resonance_search_points(run: RunData) -> pd.DataFrame | None:
    """Every resonance search's rows (sweep and found), reduced where they kept a record and
    the scope's readings elsewhere; None when the run searched nothing."""
    rows = run.protocol("resonance_search")
    return None if rows.empty else with_scope_fallback(reduced_points(run, rows))


def resonance_sweeps(run: RunData) -> pd.DataFrame:
    """The frequency sweep points of every resonance search (rows with sweep=True)."""
    rows = run.protocol("resonance_search")
    if rows.empty or "sweep" not in rows:
        raise MissingDataError("no resonance sweep points in this run (protocol 'resonance_search', sweep=True)")
    sweeps = rows[flag(rows["sweep"], default=False)].reset_index(drop=True)
    return with_scope_fallback(reduced_points(run, sweeps))
