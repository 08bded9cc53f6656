"""The report's section on the run's simulated plates (issue 13): for every scene copied
into RUN_DIR/inputs/, each state's C0, effective coupling, power factor, modal mass over
plate mass, shunt share and loss per um^2 (`simbench.scene.scenes_table`), with the
bounds every state was checked against at load.

It lives here, not in `analysis`, because the figures need the simulator's physics and
`analysis` never imports `simbench`; importing this module appends the section to
`analysis.report.SECTIONS` (the report's documented way to add one), which the command
line does before writing a report.
"""

from __future__ import annotations

import html

from squeezebench.analysis import report
from squeezebench.errors import UserError
from squeezebench.simbench.scene import BOUNDS, scenes_table


def scenes_section(context: report.ReportContext) -> report.Section:
    """Simulated plates: could they exist?"""
    inputs = context.run.run_dir / "inputs"
    files = sorted(inputs / name for name, data in context.run.scenes.items()
                   if isinstance(data, dict) and "states" in data)
    if not files:
        raise UserError(f"no scene in {inputs}: the run used a real bench")
    table = scenes_table(files)
    table.to_csv(context.out_dir / "scenes.csv", index=False)
    body = ("<p>The simulated plates of this run (SIMULATED: every measured number above comes from "
            "these scenes), at resonance on the scene's bench. Each state was checked at load against: "
            + html.escape("; ".join(BOUNDS.values())) + ". CSV: <a href='scenes.csv'>scenes.csv</a></p>"
            + table.to_html(index=False, float_format=lambda v: f"{v:.4g}", border=0))
    return report.Section("Simulated plates: could they exist?", body)


if scenes_section not in report.SECTIONS:
    report.SECTIONS.append(scenes_section)
