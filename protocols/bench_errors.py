"""Total error of a campaign across simulated benches whose instruments err within spec.

One simulated bench has one unknown set of systematic errors (`variants.systematic_effects`,
drawn from its `bench_seed`) and its own reading noise (its scenes seeded with it). Running the campaign on several such benches and scoring
every stored point against the scene's closed-form truth shows what a real bench can
promise: noise averages away, the specified errors do not. A campaign that starts with
the deskew calibration (`variants.with_calibration`) has its correction applied by the
analysis and its bench time counted, as a real campaign would.

The truth of a point is the reading ideal instruments give at its recorded setting
(`analysis.uncertainty`): the scene without the systematic effects, driven at the
point's generator frequency and amplitude, read through the open bench's simulator.
"""

from __future__ import annotations

import functools
import json
import shutil
import tempfile
from pathlib import Path
from typing import Any, Callable

import numpy as np
import pandas as pd
from scipy import optimize

from squeezebench import paths
from squeezebench.analysis import model
from squeezebench.analysis.model import REPORT_CONVENTION
from squeezebench.analysis.rundata import load_run
from squeezebench.analysis.study import COVERAGE_FILE, STUDY_DIR, coverage_dir
from squeezebench.analysis.cartography import (TRUTH_CELL_SAMPLES, cell_offsets, homogeneity, map_points,
                                               map_resonance_q, summarise_map)
from squeezebench.analysis.characterisation import (LARGE_PLATE, TEMPLATE_SMALL_PLATE, as_thick_as_large,
                                                    characterise_plates, estimate_large_from_small)
from squeezebench.analysis.tables import POINT_TABLES, detuning_table, fit_line, reachable_points
from squeezebench.analysis.budgets import COVERAGE_FACTOR
from squeezebench.analysis.uncertainty import run_uncertainties, with_deviations
from squeezebench.instruments.bench import open_bench, sim_bench_config
from squeezebench.plates.specifications import SPECIFICATIONS
from squeezebench.protocols.campaign import run_campaign
from squeezebench.protocols.parallel import map_unordered
from squeezebench.protocols.storage import sha256_file, write_frame_atomic
from squeezebench.protocols.variants import (MAP_PROTOCOLS, PLATE_DRAW_EFFECT, SYSTEMATIC_EFFECTS, campaign_with_effects,
                                             coarser_maps, plate_draw_effects, plate_warming_effects,
                                             systematic_effects)

QUANTITIES = ("power_w", "velocity_pp_mps")
#: What the coverage study scores: every stored point's QUANTITIES and amplitude (Table 4; the
#: velocity's relative budget), and the values the report derives with a U of their own:
#: Fig. 2's Pt/P0, each search's resonance frequency, and each characterised plate's Q and
#: tan theta' (Fig. 5, Table 5), against the plate as drawn within its tolerances.
#: A map's figures with a U (Fig. 7's table: coefficient of variation, area above the share
#: of the peak, mean and peak velocity) against the same figures of the ideal readings at the
#: map's points (the area and the coefficient of variation against the ideal vibration over
#: the points' cells); scored when
#: asked for, on the campaign's map runs (`MAP_PROTOCOLS`).
MAP_QUANTITIES = ("map_coefficient_of_variation", "map_fraction_above_share", "map_mean_velocity_pp_mps",
                  "map_max_velocity_pp_mps")
#: Tables 3 and 4's values with a U (`tables.POINT_TABLES`: each item's value combined from its
#: points, the frequency where its searches put the resonance) and Table 5's estimated tan
#: theta' (the mean over the small plates as thick as the large one), each against the same
#: combination of its points' truths: `table_<the table's quantity>`. Table 5's other values
#: are scored already: its measured Q and tan theta' are the large plate's, its estimated Q
#: Plate 4's times a constant of geometry (Eq. 29), the same relative error under the same
#: relative U.
TABLE_QUANTITIES = tuple(f"table_{quantity}" for quantity in
                         ("frequency_hz", "voltage_vpp", "power_w", "velocity_pp_mps", "amplitude_pp_m", "tan_theta"))
COVERAGE_QUANTITIES = (*QUANTITIES, "amplitude_pp_m", "power_ratio", "resonance_frequency_hz", "q", "tan_theta",
                       *MAP_QUANTITIES, *TABLE_QUANTITIES)
#: The coverage study maps at this multiple of each map's grid step: the campaign's own. The
#: grid's correction (`cartography.grid_bias`, the bending reading between the points) holds
#: grids of two points or more per half-wavelength; twice the paper map's 4 mm step puts 1.15 points on the large plate's
#: 9.2 mm half-wavelength, an aliased field the points cannot tell from a smoother one,
#: so a coarser map would score a grid outside the correction's stated use.
MAP_STEP_FACTOR = 1.0
ERROR_PERCENTILE = 95.0


def errors_on_bench(campaign_file: Path, bench_seed: int, work_dir: Path,
                    error_model: str = "specified", quantities: tuple[str, ...] = QUANTITIES,
                    draw_plates: bool = False) -> pd.DataFrame:
    """Every stored point of the campaign run on bench `bench_seed` (its errors drawn under
    `error_model`, `variants.ERROR_MODELS`): relative error of each of `quantities` (of
    COVERAGE_QUANTITIES) against the truth, with its expanded uncertainty; and the bench
    time. With `draw_plates` the plates too are drawn within their tolerances, erring and
    ideal benches alike (the coverage study; the accuracy study and the planner keep the
    nominal plates their figures are about), and they warm under drive as a real plate does
    (`variants.plate_warming_effects`, drawn likewise), their resonances drifting while a run
    measures; the truth is the plate cold, as mounted, at the point's setting: the drift is
    an error the budgets claim to cover (`uncertainty.drift_term`). The erring bench reads its own noise too (its
    scenes' seed is `bench_seed`): benches that shared one realisation of the noise would
    score the same readings again, not independent ones. `work_dir` is scratch: the run
    there is not kept, so it is not made durable."""
    plates = plate_draw_effects(bench_seed, error_model) if draw_plates else []
    warming = plate_warming_effects(bench_seed, error_model) if draw_plates else []
    maps = bool(set(MAP_QUANTITIES) & set(quantities))
    erring = campaign_with_effects(campaign_file, work_dir / "erring",
                                   systematic_effects(bench_seed, error_model=error_model) + plates + warming,
                                   noise_seed=bench_seed, keep_maps=maps)
    if maps:
        coarser_maps(erring, MAP_STEP_FACTOR)
    campaign_with_effects(campaign_file, work_dir / "plain", plates)   # the same plates, cold, without the errors
    run_dir = run_campaign(erring, out_dir=work_dir / "run", progress=False, durable=False)
    run = load_run(run_dir)
    found = run_uncertainties(run)
    # a map's points and its centre's search are read where the stage put the spot, which the
    # truth at the scene's measurement point does not describe: its homogeneity is scored instead
    maps_run = set(run.protocol(MAP_PROTOCOLS[0])["run_name"]) if maps else set()
    points = found.points[~found.points["run_name"].isin(maps_run)]
    searches = found.searches[~found.searches["run_name"].isin(maps_run)] if len(found.searches) else found.searches
    truths = _truths(points, work_dir / "plain")
    rows = [_scored(point, quantity, point[quantity], truths[index][quantity], point[f"{quantity}_U"])
            for index, point in points.iterrows() for quantity in QUANTITIES if quantity in quantities]
    if "amplitude_pp_m" in quantities:
        rows += [_scored(point, "amplitude_pp_m", point["amplitude_pp_m"], truths[index]["amplitude_pp_m"],
                         abs(point["amplitude_pp_m"]) * point["velocity_pp_mps_U"] / abs(point["velocity_pp_mps"]))
                 for index, point in points.iterrows() if np.isfinite(point["amplitude_pp_m"])]
    if "power_ratio" in quantities:
        rows += _power_ratios(run, points, truths)
    if "resonance_frequency_hz" in quantities:
        rows += _resonance_frequencies(run, searches, work_dir / "plain")
    if {"q", "tan_theta", "table_tan_theta"} & set(quantities):
        rows += [row for row in _characterisations(run, points, truths, work_dir / "plain")
                 if row["quantity"] in quantities]
    if set(TABLE_QUANTITIES) & set(quantities):
        rows += [row for row in _table_values(run, points, truths, work_dir / "plain") if row["quantity"] in quantities]
    if maps:
        rows += [row for row in _map_homogeneities(run, work_dir / "plain") if row["quantity"] in quantities]
    frame = pd.DataFrame(rows).assign(error_model=error_model, bench_seed=bench_seed,
                                      beyond_specification=_beyond_specification(erring))
    frame.attrs["bench_time_s"] = sum(bench_time_by_run_s(run_dir).values())
    return frame


#: Where a budget bounds an error by more than the limit its draw is scaled to: without a
#: deskew run the CH2 lag is carried up to `current_probe_lag` (`uncertainty.delay_term`), of
#: known sign, not the current probe's +-10 ns (with one it is measured).
CLAIMED_LIMIT = {"current_probe_delay": {"delay_s": SPECIFICATIONS["current_probe_lag"].half_width}}


def _beyond_specification(erring_campaign: Path) -> bool:
    """Whether an instrument of this bench errs beyond the limit its budgets claim for it
    (its specification, or `CLAIMED_LIMIT`): outside what the specifications claim, which no
    budget built on them promises to cover. Benches within specification never do; the
    world's do now and then (`simbench.systematic_effects.world_draw`: normal with half the
    limit as its spread, and one error in 100 at 1.5 times it). The plates' tolerances are
    left out: a campaign of 17 plates has nearly always one input beyond its tolerance
    somewhere, and only Q and tan theta' of that one plate could feel it."""
    # every scene of the bench shares its instruments' draw: one of them tells
    scene = next(path for path in sorted(erring_campaign.parent.glob("*.yaml")) if path != erring_campaign)
    with open_bench(sim_bench_config(scene)) as bench:
        effects = bench.resource_manager.visalib.bench.effects
        for effect in filter(None, map(effects.get, SYSTEMATIC_EFFECTS)):
            limits = {key: abs(effect.parameters[key]) for key in effect.values} | CLAIMED_LIMIT.get(effect.name, {})
            if effect.parameters["draw"] and any(abs(value) > limits[key] for key, value in effect.values.items()):
                return True
    return False


def _scored(point, quantity: str, measured: float, true: float, expanded_u: float) -> dict:
    """One scored value: its error against the truth and whether its U covers it."""
    return {"run_name": point["run_name"], "step_id": point["step_id"], "point_index": point["point_index"],
            "quantity": quantity, "measured_value": measured, "true_value": true,
            "rel_error": measured / true - 1.0, "rel_expanded_u": expanded_u / abs(true),
            "covered": abs(measured - true) <= expanded_u}


def _power_ratios(run, points: pd.DataFrame, truths: dict) -> list[dict]:
    """Fig. 2's Pt/P0 as the report gives it (`tables.detuning_table`), each scored against
    the ratio of the truths of the points it is made of (the resonance's own 1 is left out)."""
    if "detuning_phase" not in points:
        return []
    table = detuning_table(run)
    detuning = points[points["protocol"] == "detuning"]
    rows = []
    for row in table[(table["detuning_phase"] != "resonance") & table["power_ratio_U"].notna()].itertuples():
        same_level = detuning[(detuning["run_name"] == row.run_name)
                              & (detuning["velocity_level_pp_mps"] == row.velocity_level_pp_mps)]
        target = same_level[(same_level["detuning_phase"] == row.detuning_phase)
                            & (same_level["target_velocity_ratio"] == row.target_velocity_ratio)]
        resonance = same_level[same_level["detuning_phase"] == "resonance"]
        true = (np.mean([truths[i]["power_w"] for i in target.index])
                / np.mean([truths[i]["power_w"] for i in resonance.index]))
        rows.append(_scored(target.iloc[0], "power_ratio", row.power_ratio, float(true), row.power_ratio_U))
    return rows


def _truths(points: pd.DataFrame, plain_dir: Path) -> dict:
    """Point index -> the closed-form reading at its setting, on the plate without the errors."""
    truths: dict = {}
    for (plate, state), group in points.groupby(["plate", "scene_state"], dropna=False, sort=False):
        scene = plain_dir / f"{plate}.yaml"
        with open_bench(sim_bench_config(scene)) as bench:
            simulated = bench.resource_manager.visalib.bench
            if isinstance(state, str):
                simulated.set_state(state)
            for index, point in group.iterrows():
                bench.generator.set_frequency(float(point["generator_frequency_hz"]))
                bench.generator.set_amplitude_vpp(float(point["generator_amplitude_vpp"]))
                truth = simulated.truth()
                truths[index] = {"power_w": truth.power_w, "velocity_pp_mps": truth.velocity_pp_mps,
                                 "amplitude_pp_m": truth.velocity_pp_mps / (2.0 * np.pi * truth.frequency_hz),
                                 "piezo_voltage_vpp": truth.output_voltage_pp_v, "frequency_hz": truth.frequency_hz}
    return truths


def _characterisations(run, points: pd.DataFrame, truths: dict, plain_dir: Path) -> list[dict]:
    """Each characterised plate's Q and tan theta' as the report gives them
    (`characterisation.characterise_plates` in the report's reading, U = k times the whole standard
    uncertainty: fits, instruments, tolerances) scored against what the plate as drawn
    really is: the same line fits on the ideal instruments' readings at the points'
    settings (`truths` of `points`), read through Eqs. 27 and 25 with the plate's drawn geometry and
    materials (`uncertainty.with_deviations`), where the report reads them with the nominal."""
    if run.protocol("characterisation").empty:
        return []
    index_of = _index_of(points)
    rows, true_tan_theta = [], {}
    plates = characterise_plates(run, REPORT_CONVENTION)
    for name, plate in plates.items():
        points = plate.points
        truth = pd.DataFrame(_truths_of(points, truths, index_of), index=points.index)
        geometry, convention = with_deviations(plate.geometry, REPORT_CONVENTION, _drawn_deviations(plain_dir, name))
        amplitude = fit_line(truth["piezo_voltage_vpp"], truth["amplitude_pp_m"], points["amplitude_pp_m_u"],
                             what=f"{name}: true amplitude vs voltage").slope.value
        power = fit_line(truth["piezo_voltage_vpp"] ** 2, truth["power_w"], points["power_w_u"],
                         what=f"{name}: true power vs voltage squared").slope.value
        q = model.q_from_amplitude(amplitude, 1.0, geometry, convention)
        tan_theta = model.tan_theta_from_power(power, 1.0, q, float(truth["frequency_hz"].mean()), geometry, convention)
        first = points.iloc[0]
        true_tan_theta[name] = tan_theta
        for quantity, true in (("q", q), ("tan_theta", tan_theta)):
            estimate = getattr(plate, quantity)
            rows.append(_scored(first, quantity, estimate.value, true, COVERAGE_FACTOR * estimate.std_uncertainty))
    same = as_thick_as_large(plates) if LARGE_PLATE in plates else []
    if TEMPLATE_SMALL_PLATE in plates and same:
        # Table 5's estimate as `characterisation.table5` prints it (U = k u, `_derived_row`)
        estimate = estimate_large_from_small(plates, REPORT_CONVENTION).tan_theta
        rows.append(_scored(plates[same[0]].points.iloc[0], "table_tan_theta", estimate.value,
                            float(np.mean([true_tan_theta[name] for name in same])),
                            COVERAGE_FACTOR * estimate.std_uncertainty))
    return rows


def _index_of(points: pd.DataFrame) -> dict[tuple, Any]:
    """(run, step, point) -> the index of that point in `points` (`_truths`' keys)."""
    keys = points[["run_name", "step_id", "point_index"]].itertuples(index=False)
    return {tuple(key): index for key, index in zip(keys, points.index)}


def _truths_of(points: pd.DataFrame, truths: dict, index_of: dict[tuple, Any]) -> list[dict]:
    """The truths (`_truths`) of `points` read anew (another frame of the same stored points)."""
    return [truths[index_of[tuple(key)]] for key in points[["run_name", "step_id", "point_index"]].itertuples(index=False)]


#: The truth (`_truths`' key) of each quantity a table averages over its points.
TABLE_TRUTHS = {"voltage_vpp": "piezo_voltage_vpp", "power_w": "power_w", "velocity_pp_mps": "velocity_pp_mps",
                "amplitude_pp_m": "amplitude_pp_m"}


def _table_values(run, points: pd.DataFrame, truths: dict, plain_dir: Path) -> list[dict]:
    """Each value Tables 3 and 4 print with a U (`tables.POINT_TABLES`), scored as
    `table_<quantity>` against the same mean of its points' truths (`_truths`: the ideal
    readings at each point's setting); a frequency, where its searches set the generator,
    against the mean of the resonances of the plate as drawn, cold, at each point's drive
    (`_true_resonance_hz`), the plate the searches' correction states."""
    index_of = _index_of(points)
    rows = []
    for protocol, table, items_of in POINT_TABLES.values():
        if run.protocol(protocol).empty:
            continue
        items = items_of(run)
        frame = table(run)
        for row in frame[(frame["status"] == "measured") & (frame["expanded_uncertainty"] > 0)].itertuples():
            used = reachable_points(items[row.item])
            if row.quantity == "frequency_hz":
                reach_hz = max(3.0 * row.expanded_uncertainty, 20.0)
                true = np.mean([_true_resonance_hz(plain_dir, point, point["frequency_hz"], reach_hz)
                                for _, point in used.iterrows()])
            else:
                true = np.mean([truth[TABLE_TRUTHS[row.quantity]] for truth in _truths_of(used, truths, index_of)])
            rows.append(_scored(used.iloc[0], f"table_{row.quantity}", row.value, float(true),
                                row.expanded_uncertainty))
    return rows


def _map_homogeneities(run, plain_dir: Path) -> list[dict]:
    """Each map's homogeneity figures as the report gives them (`cartography_report.map_summaries`:
    `cartography.summarise_map`, each with the U of its budget) scored against
    the same figures of what ideal instruments read at each mapped point: the plate without
    the errors driven at the point's generator setting, the spot where the stage put it on
    the plate as this bench placed it (`variants.plate_draw_effects`: the grid lands on the
    mode where the mounting put it, the error the grid's term claims to cover).
    The area above the share of the peak and the coefficient of variation are what the
    report says they are, the vibration's over the touch area: the ideal vibration over each
    point's cell (TRUTH_CELL_SAMPLES^2 spots at that point's setting); the area against the share
    of the ideal readings' peak at the mapped points."""
    rows_of = run.protocol(MAP_PROTOCOLS[0])
    if rows_of.empty:
        return []
    truths, cells = {}, {}
    for plate, group in rows_of.groupby("plate", sort=False):
        step_m = {axis: np.diff(np.unique(np.round(group[axis].to_numpy(), 9))).min(initial=np.inf)
                  for axis in ("x_m", "y_m")}
        # a map of one row or one column has no cell to sample across
        offsets = cell_offsets(TRUTH_CELL_SAMPLES) if np.isfinite(step_m["x_m"] + step_m["y_m"]) else np.array([])
        with open_bench(sim_bench_config(plain_dir / f"{plate}.yaml")) as bench:
            simulated = bench.resource_manager.visalib.bench
            bench.stage.home()
            for row in group.itertuples():
                if isinstance(row.scene_state, str):
                    simulated.set_state(row.scene_state)
                bench.generator.set_frequency(float(row.generator_frequency_hz))
                bench.generator.set_amplitude_vpp(float(row.generator_amplitude_vpp))
                velocity = simulated.truth().velocity_pp_mps

                def at(x_m: float, y_m: float) -> float:
                    bench.stage.move_to_mm(1e3 * x_m, 1e3 * y_m)
                    return velocity * abs(simulated.stage.spot_gain())

                key = (row.run_name, row.x_m, row.y_m)
                truths[key] = at(row.x_m, row.y_m)
                if row.in_touch_area:   # the cell's spots at once, approached as the point was
                    x_m, y_m = np.meshgrid(row.x_m + offsets * step_m["x_m"], row.y_m + offsets * step_m["y_m"],
                                           indexing="ij")
                    cells[key] = velocity * np.abs(simulated.stage.spot_gains(1e3 * x_m.ravel(), 1e3 * y_m.ravel()))
    scored = []
    for run_name, points in map_points(run).groupby("run_name", sort=False):
        points = points.reset_index(drop=True)
        measured = summarise_map(points, resonance_q=map_resonance_q(run, run_name))
        touch = [(run_name, x, y)
                 for x, y in points.loc[points["in_touch_area"], ["x_m", "y_m"]].itertuples(index=False)]
        true = homogeneity(np.array([truths[key] for key in touch]), measured["share_of_peak"])
        cell_values = np.concatenate([cells[key] for key in touch])
        over_cells = homogeneity(cell_values, true.share_of_peak) if cell_values.size else true
        true_area = (float(np.mean(cell_values >= true.share_of_peak * true.maximum)) if cell_values.size
                     else true.fraction_above_share)
        where = {"run_name": run_name, "step_id": str(rows_of.loc[rows_of["run_name"] == run_name, "step_id"].iat[0]),
                 "point_index": 0}
        scored += [_scored(where, f"map_{figure}", measured[figure], true_value, measured[f"{figure}_U"])
                   for figure, true_value in (("coefficient_of_variation", over_cells.coefficient_of_variation),
                                              ("fraction_above_share", true_area),
                                              ("mean_velocity_pp_mps", true.mean),
                                              ("max_velocity_pp_mps", true.maximum))]
    return scored


def _drawn_deviations(plain_dir: Path, plate: str) -> dict[str, float]:
    """How far the plate's inputs depart from nominal on this bench (none: not drawn)."""
    with open_bench(sim_bench_config(plain_dir / f"{plate}.yaml")) as bench:
        drawn = bench.resource_manager.visalib.bench.effects.get(PLATE_DRAW_EFFECT)
        return {} if drawn is None else dict(drawn.deviations_rel)


def _resonance_frequencies(run, searches: pd.DataFrame, plain_dir: Path) -> list[dict]:
    """Each resonance search's frequency (`uncertainty.search_budgets`: the generator setting
    it found) scored against the setting at which an ideal generator gives the most velocity
    on the plate without the errors, at the search's drive (bounded search, 10 mHz)."""
    if searches.empty:
        return []
    found = run.protocol("resonance_search")
    found = found[~found["sweep"].astype(bool)]
    rows = []
    for search in searches.itertuples():
        row = found[(found["run_name"] == search.run_name) & (found["step_id"] == search.step_id)].iloc[0]
        true_hz = _true_resonance_hz(plain_dir, row, search.resonance_frequency_hz,
                                     max(3.0 * search.resonance_frequency_hz_U, 20.0))
        rows.append(_scored({"run_name": search.run_name, "step_id": search.step_id, "point_index": row["point_index"]},
                            "resonance_frequency_hz", search.resonance_frequency_hz, true_hz,
                            search.resonance_frequency_hz_U))
    return rows


def _true_resonance_hz(plain_dir: Path, point, around_hz: float, reach_hz: float) -> float:
    """The setting at which an ideal generator gives the most velocity on `point`'s plate
    without the errors (`plain_dir`), in its state, at its drive (bounded search within
    `reach_hz` of `around_hz`, 10 mHz)."""
    with open_bench(sim_bench_config(plain_dir / f"{point['plate']}.yaml")) as bench:
        simulated = bench.resource_manager.visalib.bench
        if isinstance(point["scene_state"], str):
            simulated.set_state(point["scene_state"])
        bench.generator.set_amplitude_vpp(float(point["generator_amplitude_vpp"]))

        def slower(frequency_hz: float) -> float:
            bench.generator.set_frequency(float(frequency_hz))
            return -simulated.truth().velocity_pp_mps

        peak = optimize.minimize_scalar(slower, bounds=(around_hz - reach_hz, around_hz + reach_hz),
                                        method="bounded", options={"xatol": 1e-2})
    return float(peak.x)


def bench_time_by_run_s(run_dir: Path) -> dict[str, float]:
    """Virtual bench time of each run, from the journal's cumulative campaign time."""
    times_s: dict[str, float] = {}
    previous_s = 0.0
    for line in (run_dir / "journal.jsonl").read_text(encoding="utf-8").splitlines():
        entry = json.loads(line)
        total_s = entry["campaign_bench_time_s"]
        times_s[entry["run"]] = times_s.get(entry["run"], 0.0) + total_s - previous_s
        previous_s = total_s
    return times_s


def _errors_on_fresh_bench(campaign_file: Path, bench_seed: int, error_model: str = "specified",
                           quantities: tuple[str, ...] = QUANTITIES,
                           draw_plates: bool = False) -> tuple[pd.DataFrame, float]:
    """`errors_on_bench` in a temporary directory of its own (a worker shares no files)."""
    with tempfile.TemporaryDirectory(prefix=f"squeezebench-bench-{bench_seed}-") as tmp:
        frame = errors_on_bench(Path(campaign_file), bench_seed, Path(tmp), error_model, quantities, draw_plates)
        return frame, frame.attrs["bench_time_s"]


def errors_on_benches(campaign_file: Path, bench_seeds: range = range(1, 9), workers: int = 1,
                      scheduler: Any = None) -> pd.DataFrame:
    """`errors_on_bench` over several benches, on `workers` local processes or the Dask
    cluster at `scheduler`; rows in bench order; `attrs["bench_time_s"]` per seed."""
    done = dict(map_unordered(functools.partial(_errors_on_fresh_bench, Path(campaign_file)), bench_seeds,
                              workers, scheduler, "simulated benches"))
    errors = pd.concat([done[seed][0] for seed in bench_seeds], ignore_index=True)
    errors.attrs["bench_time_s"] = {seed: done[seed][1] for seed in bench_seeds}
    return errors


def run_coverage_study(out_dir: Path, benches: int, campaign_file: Path | None = None, resume: bool = False,
                       workers: int = 1, scheduler: Any = None,
                       progress: Callable[[str], None] = lambda message: None,
                       error_model: str = "specified", first_seed: int = 1) -> Path:
    """Whether the reported expanded uncertainties cover the truth: the campaign (the
    paper's by default) on `benches` benches, seeds `first_seed`.. (1.. by default; another block of
    benches develops a budget on seeds its reported figure is not scored on), with errors drawn within specification
    (`error_model` "specified", what the budgets assume) or as the world may err ("world":
    normal, a probe lag of known sign, now and then an instrument out of specification),
    each bench's plates drawn within their tolerances under the same model and its noise its
    own, every stored point and each map's homogeneity (`MAP_QUANTITIES`) scored. Each bench's rows go to
    OUT_DIR/study/<coverage_dir(error_model)>/bench_<k>.parquet as it completes (`resume`
    keeps those already there of the same campaign file scored for the same quantities,
    column `scored`: a bench stored before a quantity was scored is run again); all of them to
    points.parquet beside them. Returns that path."""
    campaign_file = Path(campaign_file or paths.paper_campaign())
    directory = Path(out_dir) / STUDY_DIR / coverage_dir(error_model)
    if not resume:
        shutil.rmtree(directory, ignore_errors=True)
    directory.mkdir(parents=True, exist_ok=True)
    seeds = range(first_seed, first_seed + benches)
    digest = sha256_file(campaign_file)

    scored = ",".join(COVERAGE_QUANTITIES)

    def stored(seed: int) -> bool:   # a bench of this very campaign file scored for every quantity (others: redone)
        path = directory / f"bench_{seed}.parquet"
        if not path.exists():
            return False
        frame = pd.read_parquet(path)
        return "scored" in frame and set(zip(frame["campaign_sha256"], frame["scored"])) == {(digest, scored)}

    pending = [seed for seed in seeds if not stored(seed)]
    progress(f"coverage: {campaign_file.name} on {len(pending)} of {benches} simulated benches "
             f"(errors: {error_model})")
    job = functools.partial(_errors_on_fresh_bench, campaign_file, error_model=error_model,
                            quantities=COVERAGE_QUANTITIES, draw_plates=True)
    for seed, (frame, bench_time_s) in map_unordered(job, pending, workers, scheduler, "coverage"):
        write_frame_atomic(directory / f"bench_{seed}.parquet",
                           frame.assign(bench_time_s=bench_time_s, campaign=campaign_file.name, campaign_sha256=digest,
                                        scored=scored))
    points = pd.concat([pd.read_parquet(directory / f"bench_{seed}.parquet") for seed in seeds], ignore_index=True)
    write_frame_atomic(directory / COVERAGE_FILE, points)
    progress(f"coverage: stored in {directory / COVERAGE_FILE}")
    return directory / COVERAGE_FILE


def p95_by_run(errors: pd.DataFrame) -> pd.DataFrame:
    """p95 over benches and points of |relative error|, per run and quantity."""
    return (errors.assign(abs_rel_error=errors["rel_error"].abs())
            .groupby(["run_name", "quantity"], sort=False)["abs_rel_error"]
            .agg(lambda e: float(np.percentile(e, ERROR_PERCENTILE))).rename("p95_abs_rel_error").reset_index())
