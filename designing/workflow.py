"""`squeezebench design PLATE`: what a plate will need, predicted before it is built.

Reads the design file, predicts by physics (`designing.design`), by the paper's method from
characterised small plates when runs are given (`--from`), sets a characterisation of the
built plate beside both (`--measured`), sweeps the piezo layouts on the parallel engine the
study uses (`protocols.parallel`), and records a built plate's comparison in the history.
The page, design.json and the tables are the report's (`report.design_report.write_design`):
this package never imports the report.
"""
from __future__ import annotations

import math
import tempfile
from dataclasses import replace
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Iterable

import pandas as pd

from squeezebench import paths
from squeezebench.yamlfiles import dump_yaml
from squeezebench.designing import design as design_model
from squeezebench.designing import layouts
from squeezebench.designing.answer import DesignAnswer, measured_point
from squeezebench.designing.paper_route import predict_from_small_plates
from squeezebench.designing.verdict import Verdict, cancellation, judge, neighbour_modes
from squeezebench.errors import UserError


def characterised_plates(run_dirs: Iterable[str | Path], convention=None) -> dict:
    """Every plate the runs' characterisation protocol measured (name -> characterisation,
    under `convention`, by default the report's reading); a plate name in two runs is
    refused, not silently merged."""
    from squeezebench.analysis.model import REPORT_CONVENTION
    from squeezebench.analysis.rundata import load_run
    from squeezebench.analysis.characterisation import characterise_plates

    plates: dict = {}
    for run_dir in run_dirs:
        found = characterise_plates(load_run(run_dir), convention or REPORT_CONVENTION)
        if not found:
            raise UserError(f"{run_dir}: no characterisation points (the 'characterisation' protocol) to design from")
        twice = sorted(set(found) & set(plates))
        if twice:
            raise UserError(f"{run_dir}: plate {twice[0]!r} is characterised in two of the runs given; give one")
        plates.update(found)
    return plates


def printed_values(plate: str | None) -> dict[str, float] | None:
    from squeezebench.paper import paper_value

    if plate is None:
        return None
    return {q: paper_value("large_plate", plate, q) for q in ("frequency_hz", "voltage_vpp", "power_w")}


#: The simulated bench's name for each resonator a design may name (both the paper's Table 2).
SCENE_MATERIALS = {"aluminium_table2": "aluminium"}
#: What a predicted build sees on the simulated bench: the shunt and the scope's own limits.
SCENE_EFFECTS = ["shunt", "scope_noise", "quantisation", "averaging", "dc_offset"]


def scene_from_design(spec, seed: int = 1, mechanical_q: float | None = None) -> dict:
    """A predicted scene of the designed plate for the simulated bench: its geometry and
    materials, the build's q_mech, and a state whose resonance and branch the plate model
    gives (`resonance_frequency_hz: predicted`); measured at the plate's centre. A design
    the scene format cannot place (piezos a column does not centre, or a position's two
    groups not at the width's ends) is refused, saying how the scene places them. Its q_mech:
    `mechanical_q` (the design's answer's), else the design's stated Q."""
    from squeezebench.simbench import predicted
    from squeezebench.simbench.scene import load_scene

    material = spec.resonator.material
    if not isinstance(material, str) or material not in SCENE_MATERIALS:
        raise UserError(f"design {spec.name!r}: the simulated bench knows the resonator materials "
                        f"{', '.join(SCENE_MATERIALS)} by name; this design gives its own constants")
    counts = {len(g.y_mm) for g in spec.groups}
    if len(counts) != 1:
        raise UserError(f"design {spec.name!r}: a scene's columns all hold the same number of piezos; "
                        f"the groups hold {sorted(counts)}")
    antinodes = int(predicted_antinodes(spec))
    # a free plate's n antinodes lie between n + 1 nodal lines, the end ones about a quarter
    # wave from the edges: lambda/2 ~ L / (n + 1/2), where the scene's search then centres
    half_wave_mm = spec.resonator.length_mm / (antinodes + 0.5)
    data = {
        "description": f"predicted from design {spec.name}",
        "plate": {"name": spec.name, "material": SCENE_MATERIALS[material], "length_mm": spec.resonator.length_mm,
                  "width_mm": spec.resonator.width_mm, "thickness_mm": spec.resonator.thickness_mm},
        "actuators": {"piezo": {"length_mm": spec.piezo.width_y_mm, "width_mm": spec.piezo.length_x_mm,
                                "thickness_mm": spec.piezo.thickness_mm, "material": "NCE 41"},
                      "piezos_per_column": counts.pop(),
                      "columns": [{"name": g.name, "position_mm": g.x_mm} for g in spec.groups]},
        "mode": {"name": f"{antinodes} antinodes", "half_wavelength_mm": round(half_wave_mm, 6)},
        "states": {"built": {"description": "as designed, every powered group driven",
                             "resonance_frequency_hz": "predicted", "q_mech": mechanical_q or spec.damping.mechanical_q,
                             "powered_columns": [g.name for g in spec.groups if g.powered]}},
        "initial_state": "built",
        "measurement_point": {"x_mm": spec.resonator.length_mm / 2, "y_mm": spec.resonator.width_mm / 2,
                              "signal_level_percent": 80},
        "effects": list(SCENE_EFFECTS), "seed": seed,
        "provenance": {"states.built.resonance_frequency_hz": "predicted by the plate model from the design file",
                       "states.built.q_mech": spec.damping.origin},
    }
    # the scene's placement rule must put every piezo where the design does
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{spec.name}.yaml"
        path.write_text(dump_yaml(data), encoding="utf-8")
        scene = load_scene(path)
    placed = sorted((round(p.x_center_m, 9), round(p.y_center_m, 9))
                    for p in predicted.geometry(scene, scene.state("built")).patches)
    wanted = sorted((round(p.x_center_m, 9), round(p.y_center_m, 9)) for p in spec.geometry().patches)
    if len(placed) != len(wanted) or not all(math.isclose(a, b, abs_tol=1e-6) for pa, pb in zip(placed, wanted)
                                                for a, b in zip(pa, pb)):
        raise UserError(f"design {spec.name!r}: the simulated bench centres a column's piezos on the width, or puts "
                        "two columns at one place at the width's two ends; this design's piezos sit elsewhere")
    return data


def characterisation_campaign(spec, values: dict, scene_file: str) -> dict:
    """The campaign that characterises the built plate (Sec. 5.3's protocol on the designed
    plate): a resonance search over +-3 % of the predicted frequency, fine enough for the
    build's Q, then 25 to 100 % of the voltage the target needs (within the amplifier and a
    100 Vpp safety limit), from the design's nominal working point's `values`
    (`design.OperatingPoint.values`). On a real bench, `bench: {file: ...}` replaces the scene."""
    frequency = values["frequency_hz"]
    top = min(values["voltage_vpp"], spec.amplifier.max_output_vpp, 100.0)
    points = max(31, math.ceil(0.12 * values["mechanical_q"]) + 1)   # steps <= half the bandwidth f/Q
    return {
        "name": f"{spec.name}_characterisation", "output_dir": f"runs/{spec.name}_characterisation",
        "safety": {"max_piezo_voltage_vpp": 100},
        "runs": [{
            "name": "built_plate", "protocol": "characterisation", "bench": {"scene": scene_file},
            "plate": {"n_powered_columns": spec.n_powered_groups, "n_powered_piezos": spec.n_powered_piezos},
            "parameters": {"search": {"start_hz": round(0.97 * frequency), "stop_hz": round(1.03 * frequency),
                                      "points": points},
                           "voltages_vpp": [round(top * share, 1) for share in (0.25, 0.5, 0.75, 1.0)]}}],
    }


def write_build(spec, values: dict, folder: str | Path, seed: int = 1) -> tuple[Path, Path]:
    """The predicted scene of the design `spec` (its noise drawn from `seed`) and the campaign
    characterising it, in `folder`, from its nominal working point's `values` (the answer's
    `physics.nominal.values`: a build needs no budget)."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    scene = folder / f"{spec.name}.yaml"
    data = scene_from_design(spec, seed=seed, mechanical_q=values["mechanical_q"])
    scene.write_text("# Predicted by `squeezebench design` from the design file: nothing measured is read.\n"
                     + dump_yaml(data), encoding="utf-8")
    campaign = folder / f"{spec.name}_characterisation.yaml"
    campaign.write_text(dump_yaml(characterisation_campaign(spec, values, scene.name)),
                        encoding="utf-8")
    return scene, campaign


def predicted_antinodes(spec) -> int:
    """The design's working mode's antinode count (asked for, or found by the plate model)."""
    if spec.mode.interior_antinodes is not None:
        return spec.mode.interior_antinodes
    return int(design_model.operating_point(spec).values["interior_antinodes"])


def run_design(plate: str | Path, from_runs: Iterable[str | Path] = (), measured: str | Path | None = None,
               measured_plate: str | None = None, sweep: bool = True, workers: int | None = None,
               scheduler: Any = None, allow_infeasible: bool = False) -> DesignAnswer:
    """The design's answer; an infeasible one (`verdict.judge`) is refused with the nearest
    feasible change named, unless `allow_infeasible` (then it carries its red verdict). A
    mode the powered piezos cancel on is refused before its budget is solved. The layout
    sweep (`sweep`) is by the reduced model where it passes its check (`sweep_layouts`)."""
    from squeezebench.protocols.parallel import map_unordered
    from squeezebench.workers import default_workers
    from squeezebench.schemas import load_design_file

    from_runs = list(from_runs)
    small_plates = characterised_plates(from_runs) if from_runs else {}
    spec = load_design_file(paths.design_file(plate), characterised=small_plates)
    modal = design_model.modal_part(spec)
    neighbours = []
    if cancellation(spec, modal.modes, modal.mode_index):
        neighbours = neighbour_modes(spec, modal.modes.interior_antinodes(modal.mode_index))
        if not allow_infeasible:
            reason, change = cancellation(spec, modal.modes, modal.mode_index, neighbours)
            _refuse(spec, Verdict("infeasible", (reason,), (change,)))
    physics = design_model.predict_physics(spec, modal=modal)
    placement = None
    if design_model.mean_edge_gap_mm(spec) is not None:
        placement = design_model.placement_curve(physics, mapper=lambda function, items: map_unordered(
            function, items, workers=workers or default_workers(), scheduler=scheduler, description="placements"))
    verdict = judge(physics, placement, neighbours)
    if verdict.status == "infeasible" and not allow_infeasible:
        _refuse(spec, verdict)
    answer = DesignAnswer(physics, printed=printed_values(spec.paper_plate), verdict=verdict,
                                       placement=placement)
    if from_runs:
        try:
            route = predict_from_small_plates(physics, small_plates)
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
        answer = replace(answer, measured=measured_point(physics, plates[name]))
    if sweep:
        values = physics.nominal.values
        frame, note = sweep_layouts(spec, values, workers=workers, scheduler=scheduler)
        answer = replace(answer, layouts=frame, layouts_note=note,
                         best_layout=_best_layout(frame, spec, int(values["interior_antinodes"])))
    return answer


def _refuse(spec, verdict: Verdict):
    raise design_model.DesignError(
        f"design {spec.name!r} is not an answer (infeasible): {'; '.join(verdict.reasons)}. Nearest feasible change: "
        f"{'; or '.join(verdict.changes) or 'none found'}. (--allow-infeasible shows it, marked infeasible)")


def _best_layout(frame: pd.DataFrame, spec, antinodes: int) -> design_model.PhysicsPrediction | None:
    """The Pareto front's least-power layout, solved again with its budget."""
    front = frame[frame["pareto"]]
    if front.empty:
        return None
    best = front.loc[front["power_w"].idxmin()]
    layout = layouts.Layout(best["columns"], float(best["edge_offset_mm"]), int(best["piezos_per_column"]),
                            best["arrangement"], float(best["piezo_thickness_mm"]))
    return design_model.predict_physics(layouts.layout_design(layout, spec, antinodes))


def sweep_layouts(spec, values: dict, workers: int | None = None, scheduler: Any = None, reduced: bool = True,
                  grid: list | None = None) -> tuple[pd.DataFrame, str]:
    """The layout sweep (`layouts.grid` unless `grid` is given) at the design's working mode
    on the parallel engine: by the reduced model with its sample checked against the full
    solve (`designing.layout_sweep`), every layout in full if the check fails or `reduced` is
    false. Returns the table and a sentence saying how it was solved."""
    from squeezebench.designing import layout_sweep
    from squeezebench.protocols.parallel import map_unordered
    from squeezebench.workers import default_workers

    workers = workers or default_workers()
    grid = grid if grid is not None else layouts.grid(values["half_wavelength_mm"], spec.piezo.length_x_mm)
    antinodes = int(values["interior_antinodes"])

    def full(wanted: list) -> list[dict]:
        return [row for _, result in map_unordered(layouts.evaluate_mesh_group, layouts.tasks(wanted, spec, antinodes),
                                                   workers=workers, scheduler=scheduler, description="layouts")
                for row in result]

    if not reduced:
        return layouts.finish(full(grid)), f"{len(grid)} layouts, each by the full solve"
    done = layout_sweep.sweep(grid, spec, antinodes, workers, scheduler=scheduler)
    if not done.check.passed:
        sampled = {result["layout"] for result in done.checked}
        rows = [result["row"] for result in done.checked] + full([layout for layout in grid if layout not in sampled])
        return layouts.finish(rows), (
            f"{len(grid)} layouts, each by the full solve: the reduced model missed its check against it "
            f"({done.check.worst()}; limits {layout_sweep.reduced_layouts.FREQUENCY_TOLERANCE_REL:.1%} and "
            f"{layout_sweep.reduced_layouts.FORCE_TOLERANCE_REL:.0%})")
    extra = f"; {done.fallbacks} did not settle and were solved in full" if done.fallbacks else ""
    return layouts.finish(done.rows), (f"{len(grid)} layouts by the reduced model{extra}; checked against the "
                                       f"full solve on {len(done.checked)} of them: {done.check.worst()}")


#: Beside the designs' folders: every design checked against its built plate, one row per
#: design, measured run, route and quantity (a later check of the same run replaces its rows).
HISTORY_FILE = "history.csv"


def record_measurement(answer: DesignAnswer, history: Path, measured_run: str | Path) -> pd.DataFrame:
    """Append this design's prediction-against-measurement rows to `history` (CSV) and
    return the whole history: how a lab's designs fare against what it then built."""
    rows = answer.comparison()
    rows = rows[rows["reference"].str.startswith("measured")].drop(columns=["reference"])
    rows.insert(0, "design", answer.design.name)
    rows.insert(1, "measured_run", str(Path(measured_run).resolve()))
    rows.insert(2, "checked_utc", datetime.now(timezone.utc).isoformat(timespec="seconds"))
    old = pd.read_csv(history) if history.is_file() else pd.DataFrame(columns=rows.columns)
    keep = ~(old["design"].eq(answer.design.name) & old["measured_run"].eq(rows["measured_run"].iloc[0]))
    frame = pd.concat([old[keep], rows], ignore_index=True) if len(old[keep]) else rows.reset_index(drop=True)
    history.parent.mkdir(parents=True, exist_ok=True)
    frame.to_csv(history, index=False)
    return frame
