"""Where the command line meets the simulated plates (issue 13).

- `scenes_section`: the report's section on the run's simulated plates: for every scene
  copied into RUN_DIR/inputs/, each state's C0, effective coupling, power factor, modal
  mass over plate mass, shunt share and loss per um^2 (`simbench.scene.scenes_table`),
  with the bounds every state was checked against at load. Importing this module appends
  it to `analysis.report.SECTIONS` (the report's documented way to add one), which the
  command line and the API do before writing a report.
- `check_powered_piezos`: a campaign whose plate states another number of powered piezos
  than its scene's state powers is refused before it runs (n_c scales Q and tan theta').

It lives here, not in `analysis` or `protocols`, because both need the simulator's scenes
and neither imports `simbench`.
"""

from __future__ import annotations

import html

from squeezebench.analysis import report
from squeezebench.errors import UserError
from squeezebench.simbench.scene import BOUNDS, load_scene, scenes_table


def scenes_section(context: report.ReportContext) -> report.Section | None:
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
            + report.html_table(table, "The run's simulated plates at resonance. Dry run: simulated bench."))
    return report.Section("Simulated plates: could they exist?", body, appendix=True)


def check_powered_piezos(campaign) -> None:
    """Raise a UserError at the first step whose plate's n_powered_piezos differs from what
    its scene's state powers (a real bench has no scene: nothing to check)."""
    for run in campaign.runs:
        for step in run.steps():
            scene_path = step.plate.scene or run.bench.scene
            if scene_path is None:
                continue
            scene = load_scene(scene_path)
            state = scene.state(step.plate.state or scene.initial_state)
            if state.n_powered_piezos != step.plate.n_powered_piezos:
                raise UserError(
                    f"{campaign.file}: run {run.name!r}, step {step.step_id!r}: plate {step.plate.name!r} says "
                    f"{step.plate.n_powered_piezos} powered piezos, but {scene_path.name} state {state.name!r} "
                    f"powers {len(state.powered_columns)} columns x {scene.actuators.piezos_per_column} = "
                    f"{state.n_powered_piezos} (n_c scales Q and tan theta'): correct n_powered_piezos")
            if len(state.powered_columns) != step.plate.n_powered_columns:   # stored in every row
                raise UserError(
                    f"{campaign.file}: run {run.name!r}, step {step.step_id!r}: plate {step.plate.name!r} says "
                    f"{step.plate.n_powered_columns} powered columns, but {scene_path.name} state {state.name!r} "
                    f"powers {len(state.powered_columns)}: correct n_powered_columns")


if scenes_section not in report.SECTIONS:
    report.SECTIONS.append(scenes_section)
