"""Where the command line meets the simulated plates (issue 13).

- `scenes_section`: the report's section on the run's simulated plates: for every scene
  copied into RUN_DIR/inputs/, each state's C0, effective coupling, power factor, modal
  mass over plate mass, shunt share and loss per um^2 (`simbench.scene.scenes_table`),
  with the bounds every state was checked against at load. Importing this module appends
  it to `report.run_report.SECTIONS` (the report's documented way to add one), which the
  command line and the API do before writing a report.
- `physics_section`: what the plate model predicts each characterised plate's Q and
  tan theta' read as (Fig. 5 and the large plate), from its stored scene's geometry and
  datasheets (`simbench.predicted`), beside what the run measured; inserted after the
  report's characterisation section.

It lives here, not in `analysis` or `protocols`, because both need the simulator's scenes
and neither imports `simbench`.
"""

from __future__ import annotations

import html
import math

import pandas as pd

from squeezebench.plates import predicted_plates
from squeezebench.report import presentation, run_report as report
from squeezebench.report.section import ReportContext, Section, html_table
from squeezebench.analysis import characterisation
from squeezebench.simbench import predicted
from squeezebench.simbench.scene import load_scene, scenes_table
from squeezebench.simbench.scene_bounds import BOUNDS


def scenes_section(context: ReportContext) -> Section | None:
    """Simulated plates: could they exist?"""
    inputs = context.run.run_dir / "inputs"
    files = sorted(inputs / name for name, data in context.run.scenes.items()
                   if isinstance(data, dict) and "states" in data)
    if not files:
        return None   # a real bench: nothing simulated to show
    table = scenes_table(files)
    table.to_csv(context.out_dir / "scenes.csv", index=False)
    body = ("<p>The simulated plates of this run (SIMULATED: every measured number above comes from "
            "these scenes), at resonance on the scene's bench. Each state was checked at load against: "
            + html.escape("; ".join(BOUNDS.values())) + ". CSV: <a href='scenes.csv'>scenes.csv</a></p>"
            + html_table(table, "The run's simulated plates at resonance. Dry run: simulated bench."))
    return Section("Simulated plates: could they exist?", body, appendix=True)


PHYSICS_FILE = "fig5_predicted.csv"


def physics_rows(context: ReportContext) -> pd.DataFrame:
    """One row per (characterised plate, quantity): the measured Q or tan theta' with its U
    (k = 2) and origin, what the plate model predicts with its U, their ratio and whether the
    two agree within their combined U (columns as in report/columns.csv). The prediction
    takes the plate's stored scene's geometry, piezos and datasheets and nothing it replays
    (`simbench.predicted.predict`, referred to the scene's measurement point), the build's
    one mechanical Q (`predicted_plates.MECHANICAL_Q`) and the report's reading of Eqs. 25/27.
    A plate the model cannot predict is left out, with why, in `frame.attrs["not_predicted"]`."""
    inputs = context.run.run_dir / "inputs"
    steps = context.run.protocol("characterisation")
    if "scene_file" not in steps:
        return pd.DataFrame()   # rows from before scenes were recorded: nothing to predict from
    rows, not_predicted = [], {}
    for name, plate in context.plates().items():
        first = steps[steps["plate"] == name].iloc[0]
        path = inputs / str(first["scene_file"])
        if not path.is_file():
            continue   # a real bench's plate: no geometry to predict from
        scene = load_scene(path)
        state = scene.state(first["scene_state"] or scene.initial_state)
        try:
            prediction = predicted.predict(scene, state)
            response = predicted_plates.response_per_volt(prediction.frequency_hz, prediction.modal_mass_g * 1e-3,
                                                          prediction.force_factor_n_per_v)
            expected = characterisation.predicted_q_tan(response, plate.geometry, context.convention)
        except ValueError as exc:   # no (n, 0) mode near the state's resonance; no force left (model.ModelGeometryError)
            not_predicted[name] = str(exc)
            continue
        for quantity, measured in (("q", plate.q), ("tan_theta", plate.tan_theta)):
            value, u_predicted = expected[quantity]
            u_measured = 2 * measured.std_uncertainty
            rows.append({"plate": name, "scene_file": path.name, "scene_state": state.name,
                         "scene_kind": "predicted" if state.predicted else "replay", "quantity": quantity,
                         "unit": "1", "value": measured.value, "expanded_uncertainty": u_measured,
                         "origin": plate.origin, "predicted_value": value, "predicted_expanded_uncertainty": u_predicted,
                         "value_over_predicted": measured.value / value if value else math.nan,
                         "agrees_with_prediction": predicted_plates.within_expanded_interval(
                             measured.value, value, math.hypot(u_measured, u_predicted))})
    frame = pd.DataFrame(rows)
    frame.attrs["not_predicted"] = not_predicted
    return frame


def _by_plate(frame: pd.DataFrame) -> pd.DataFrame:
    """One row per plate for a person: each quantity's run and physics values ± U, the ratio."""
    out = []
    for plate, rows in frame.groupby("plate", sort=False):
        row = {"plate": plate, "scene": f"{rows['scene_file'].iloc[0]} ({rows['scene_state'].iloc[0]})"}
        for quantity, name in (("q", "Q"), ("tan_theta", "tan θ′")):
            r = rows[rows["quantity"] == quantity].iloc[0]
            row[f"{name}: this run"] = presentation.with_uncertainty(r["value"], r["expanded_uncertainty"])
            row[f"{name}: physics"] = presentation.with_uncertainty_or_range(r["predicted_value"],
                                                                             r["predicted_expanded_uncertainty"])
            row[f"{name}: run / physics"] = r["value_over_predicted"]
        row["both within U"] = "✓" if rows["agrees_with_prediction"].all() else "✗"
        out.append(row)
    return pd.DataFrame(out)


def physics_section(context: ReportContext) -> Section | None:
    """What physics predicts for the characterised plates"""
    if not context.run.scenes or context.run.protocol("characterisation").empty:
        return None
    frame = physics_rows(context)
    missed = "".join(f"<p>{html.escape(name)}: not predicted ({html.escape(why)}).</p>"
                     for name, why in frame.attrs.get("not_predicted", {}).items())
    if frame.empty:
        return _section(missed) if missed else None
    frame.to_csv(context.out_dir / PHYSICS_FILE, index=False)
    replays = sorted(frame.loc[frame["scene_kind"] == "replay", "plate"].unique())
    agree = frame.groupby("plate", sort=False)["agrees_with_prediction"].all()
    body = ("<p>Each characterised plate as the plate model predicts it from its scene's geometry, piezos "
            "and datasheets alone: the working mode's frequency, modal mass and force factor, the build's "
            f"one mechanical Q ({predicted_plates.MECHANICAL_Q:g}), then the same Eqs. 27 and 25 and the same "
            "reading as the measured plate (so their ratio does not depend on the reading: Q goes as the "
            "amplitude per volt, tan θ′ as the power over Q, under every reading). "
            f"<b>{int(agree.sum())} of {len(agree)} plates agree with the prediction within the combined U "
            "(k = 2) on both Q and tan θ′.</b>")
    if replays:
        body += (f" {len(replays)} of them ({html.escape(', '.join(replays))}) are replay scenes, calibrated to "
                 "the paper's printed or summarised numbers: where they depart, the departure is that "
                 "calibration's distance from the plate as described (Fig. 5's layouts are assumed: the paper's "
                 "text does not give them).")
    body += ("</p>" + html_table(_by_plate(frame), "Q and tan θ′ of each plate: this run against the "
                                        "plate model's prediction, each ± U (k = 2).")
             + f"<p class='csv'>CSV, one row per plate and quantity: <a href='{PHYSICS_FILE}'>{PHYSICS_FILE}</a></p>"
             + missed)
    return _section(body)


def _section(body: str) -> Section:
    # detail of Fig. 5's plates, plate by plate: reference, after the results
    return Section("What physics predicts for the characterised plates (Fig. 5)", body, "plates-physics",
                          appendix=True)


if scenes_section not in report.SECTIONS:
    report.SECTIONS.append(scenes_section)
if physics_section not in report.SECTIONS:
    report.SECTIONS.insert(report.SECTIONS.index(report.characterisation_section) + 1, physics_section)
