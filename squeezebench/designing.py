"""`squeezebench design PLATE`: what a plate will need, predicted before it is built.

Reads the design file, predicts by physics (`analysis.design`), by the paper's method from
characterised small plates when runs are given (`--from`), sets a characterisation of the
built plate beside both (`--measured`), sweeps the piezo layouts on the parallel engine the
study uses (`protocols.parallel`), and writes the page, design.json and the tables
(`analysis.design_report`).
"""
from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, Iterable

from squeezebench import paths
from squeezebench.analysis import design as design_model
from squeezebench.analysis import design_report, layouts
from squeezebench.errors import UserError


def characterised_plates(run_dirs: Iterable[str | Path]) -> dict:
    """Every plate the runs' characterisation protocol measured (name -> characterisation,
    under the report's reading); a plate name in two runs is refused, not silently merged."""
    from squeezebench.analysis.report import REPORT_CONVENTION
    from squeezebench.analysis.rundata import load_run
    from squeezebench.analysis.tables import characterise_plates

    plates: dict = {}
    for run_dir in run_dirs:
        found = characterise_plates(load_run(run_dir), REPORT_CONVENTION)
        if not found:
            raise UserError(f"{run_dir}: no characterisation points (the 'characterisation' protocol) to design from")
        twice = sorted(set(found) & set(plates))
        if twice:
            raise UserError(f"{run_dir}: plate {twice[0]!r} is characterised in two of the runs given; give one")
        plates.update(found)
    return plates


def printed_values(plate: str | None) -> dict[str, float] | None:
    from squeezebench.analysis.paper import paper_value

    if plate is None:
        return None
    return {q: paper_value("large_plate", plate, q) for q in ("frequency_hz", "voltage_vpp", "power_w")}


def run_design(plate: str | Path, from_runs: Iterable[str | Path] = (), measured: str | Path | None = None,
               measured_plate: str | None = None, sweep: bool = True, workers: int | None = None,
               scheduler: Any = None) -> design_model.DesignAnswer:
    from squeezebench.protocols.parallel import default_workers, map_unordered
    from squeezebench.schemas import load_design_file

    spec = load_design_file(paths.design_file(plate))
    physics = design_model.predict_physics(spec)
    answer = design_model.DesignAnswer(physics, printed=printed_values(spec.paper_plate))
    from_runs = list(from_runs)
    if from_runs:
        try:
            route = design_model.predict_from_small_plates(physics, characterised_plates(from_runs))
            answer = replace(answer, paper_route=route)
        except design_model.DesignError as exc:
            answer = replace(answer, paper_route_problem=str(exc))
    if measured is not None:
        plates = characterised_plates([measured])
        name = measured_plate or (spec.name if spec.name in plates else None)
        if name is None and len(plates) == 1:
            name = next(iter(plates))
        if name not in plates:
            raise UserError(f"{measured}: say which characterised plate is the built one with --measured-plate "
                            f"(one of: {', '.join(sorted(plates))})")
        answer = replace(answer, measured=design_model.measured_point(physics, plates[name]))
    if sweep:
        values = physics.nominal.values
        grid = layouts.grid(values["half_wavelength_mm"], spec.piezo.length_x_mm)
        rows = []
        for _, result in map_unordered(layouts.evaluate_mesh_group,
                                       layouts.tasks(grid, spec, int(values["interior_antinodes"])),
                                       workers=workers or default_workers(), scheduler=scheduler,
                                       description="layouts"):
            rows.extend(result)
        answer = replace(answer, layouts=layouts.finish(rows))
    return answer


def write_design(answer: design_model.DesignAnswer, out_dir: str | Path | None = None) -> tuple[Path, dict[str, str]]:
    """The page and its files in `out_dir` (default designs/<name>); returns the folder and the files."""
    folder = Path(out_dir) if out_dir is not None else Path("designs") / answer.design.name
    return folder, design_report.write(answer, folder)
