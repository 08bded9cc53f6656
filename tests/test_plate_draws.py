"""The plate drawn within its tolerances (`simbench.plate_draws`) and the coverage machinery
that scores Q and tan theta' against it."""

from __future__ import annotations

import numpy as np
import pytest

from squeezebench.analysis import model
from squeezebench.plates.specifications import sheet_thickness_tolerance
from squeezebench.analysis.budgets import Budget, Term
from squeezebench.analysis.uncertainty import model_budgets, tolerances_for, with_deviations
from squeezebench.instruments.bench import open_bench, sim_bench_config
from squeezebench.protocols.variants import plate_draw_effects, scene_with_effects
from squeezebench.simbench.plate_draws import PERMITTIVITY, PlateTolerances
from squeezebench.simbench.scene import load_scene
from squeezebench.yamlfiles import dump_yaml, load_strict


def _bare_scene(tmp_path, effects, name="small_plate_1.yaml"):
    """A shipped plate with no effect but `effects` (no shunt: the power is the branch's)."""
    from squeezebench import paths

    data = load_strict((paths.scenes_dir() / name).read_text())
    data["effects"] = effects
    folder = tmp_path / ("drawn" if effects else "nominal")
    folder.mkdir(exist_ok=True)
    (folder / name).write_text(dump_yaml(data))
    return folder / name


def _at_resonance(scene_path, amplitude_vpp=1.0):
    scene = load_scene(scene_path)
    with open_bench(sim_bench_config(scene_path)) as bench:
        simulated = bench.resource_manager.visalib.bench
        bench.generator.set_frequency(scene.state(scene.initial_state).resonance_frequency_hz)
        bench.generator.set_amplitude_vpp(amplitude_vpp)
        truth = simulated.truth()
        drawn = simulated.effects.get("plate_tolerances")
        return truth, drawn, scene


def test_a_plate_at_its_tolerances_limits_answers_as_eqs_25_and_27_say(tmp_path):
    """draw 0 puts every input at its limit: at resonance the velocity goes by the paper
    model's amplitude ratio, the power by its power ratio (Eqs. 27 and 25 at the same Q and
    tan theta'), the capacitive current by eps b_p / h_p."""
    nominal, _, scene = _at_resonance(_bare_scene(tmp_path, []))
    drawn, effect, _ = _at_resonance(_bare_scene(tmp_path, [{"plate_tolerances": {"draw": 0}}]))
    limits = {name: t.half_width_rel for name, t in tolerances_for(scene.geometry(scene.state("fig5"))).items()}
    assert effect.deviations_rel == pytest.approx({**limits, PERMITTIVITY: 0.10})
    assert limits["resonator_thickness_m"] == pytest.approx(sheet_thickness_tolerance(2e-3))   # 0.09 mm on 2 mm

    geometry = scene.geometry(scene.state("fig5"))
    shape, reading = with_deviations(geometry, model.PHYSICAL_CONVENTION, limits)
    f = scene.state("fig5").resonance_frequency_hz
    a = model.amplitude_pp_m(1.0, 1.0, shape, reading) / model.amplitude_pp_m(1.0, 1.0, geometry,
                                                                              model.PHYSICAL_CONVENTION)
    b = (model.power_w(1.0, 1.0, 1.0, f, shape, reading)
         / model.power_w(1.0, 1.0, 1.0, f, geometry, model.PHYSICAL_CONVENTION))
    assert abs(a - 1.0) > 1e-3 and abs(b - 1.0) > 0.05   # the limits move the plate (here the power most)
    assert drawn.velocity_pp_mps / nominal.velocity_pp_mps == pytest.approx(a, rel=1e-9)
    assert drawn.power_w / nominal.power_w == pytest.approx(b, rel=1e-6)
    capacitive = abs(drawn.capacitive_current_phasors_a[0]) / abs(nominal.capacitive_current_phasors_a[0])
    assert capacitive == pytest.approx(1.10 * 1.01 / 1.02, rel=1e-9)


def test_plates_on_a_bench_share_their_stocks_draw_and_differ_in_their_own_and_keep_it_across_scenes(tmp_path):
    """Plates 1 and 2 (2 mm) are cut from one sheet and carry piezos of one lot: the sheet's and
    the lot's departures are one draw; their cuts (length, piezo length) are each plate's own.
    Plate 5 (1.2 mm) is cut from another sheet but carries the same piezo lot."""
    from squeezebench.analysis.uncertainty import PIEZO_LOT, PLATE, SHEET
    from squeezebench.simbench.effects import build_pipeline

    def drawn(scene_name, seed, model_name="specified"):
        path = scene_with_effects(scene_name, tmp_path / f"{seed}{model_name}", plate_draw_effects(seed, model_name))
        return build_pipeline(load_scene(path)).get("plate_tolerances").deviations_rel

    def of(values, shared_by):
        return {n: v for n, v in values.items() if PlateTolerances.shared_by[n] == shared_by}

    assert {PlateTolerances.shared_by[n] for n in ("half_wavelength_m", "piezo_length_m")} == {PLATE}
    first = drawn("small_plate_1.yaml", 3)
    assert first == drawn("small_plate_1.yaml", 3)   # the same plate on the same bench: one draw
    second, thinner = drawn("small_plate_2.yaml", 3), drawn("small_plate_5.yaml", 3)
    assert of(second, SHEET) == of(first, SHEET) and of(second, PIEZO_LOT) == of(first, PIEZO_LOT)
    assert all(second[n] != first[n] for n in of(first, PLATE))
    assert of(thinner, PIEZO_LOT) == of(first, PIEZO_LOT)
    assert thinner["resonator_young_pa"] != first["resonator_young_pa"]   # another sheet
    other_bench = drawn("small_plate_1.yaml", 4)
    assert all(other_bench[n] != first[n] for n in first)
    limits = {**{n: t.half_width_rel for n, t in tolerances_for(
        model.PlateGeometry(2e-3, 5e-4, 9e-3, 9.5e-3, 4, 1)).items()}, PERMITTIVITY: 0.10}
    for seed in range(1, 30):
        values = drawn("small_plate_1.yaml", seed)
        assert all(abs(values[n]) <= limits[n] for n in limits)   # as the budgets assume: within each limit
    world = np.array([list(drawn("small_plate_1.yaml", seed, "world").values()) for seed in range(1, 30)])
    assert np.abs(world).max() < 3 * max(limits.values()) and not np.allclose(world, 0.0)


def test_every_drawn_tolerance_of_the_model_is_a_term_of_q_and_tan_thetas_budgets():
    """What the bench draws is what the budgets claim to cover (C0's permittivity is no
    input of Eqs. 25 and 27, so in neither)."""
    geometry = model.PlateGeometry(2e-3, 5e-4, 9e-3, 9.5e-3, 4, 1)
    reading = Budget("a", "m/V", 1e-7, (Term("CH3 gain", "B", 1e-9, "spec"),))
    power = Budget("p", "W/V^2", 1e-4, (Term("CH2 gain", "B", 1e-6, "spec"),))
    q, tan = model_budgets(reading, power, Budget("v", "V", 1.0, ()), 48e3, geometry, model.PHYSICAL_CONVENTION)
    drawn = set(PlateTolerances.errors) - {PERMITTIVITY}
    for budget in (q, tan):
        assert drawn <= {term.name for term in budget.terms}


def test_the_coverage_study_scores_q_and_tan_theta_against_the_plate_as_drawn(tmp_path):
    """One characterised plate on two benches: Q and tan theta' are scored against the drawn
    plate's own, read with its drawn inputs: the same plate whatever the draw (it answers as
    its inputs say), while the report's reading with the nominal inputs moves with the draw."""
    from squeezebench import paths
    from squeezebench.protocols.bench_errors import errors_on_bench

    data = load_strict((paths.campaigns_dir() / "paper.yaml").read_text())
    data["runs"] = [run for run in data["runs"] if run["name"] == "fig5_small_plates"]
    data["runs"][0]["parameters"]["plates"] = data["runs"][0]["parameters"]["plates"][:1]
    data["runs"][0]["parameters"]["voltages_vpp"] = [10, 20, 30]
    data["runs"][0]["parameters"]["search"]["points"] = 31
    data.pop("output_dir", None)
    campaign = tmp_path / "one_plate.yaml"
    campaign.write_text(dump_yaml(data))
    scores = {seed: errors_on_bench(campaign, seed, tmp_path / f"bench{seed}", quantities=("q", "tan_theta"),
                                     draw_plates=True)
              .set_index("quantity") for seed in (1, 2)}
    for frame in scores.values():
        assert set(frame.index) == {"q", "tan_theta"}
        assert (frame["rel_expanded_u"] > 0.05).all()   # the tolerances' terms, not the fits alone
    for quantity in ("q", "tan_theta"):
        # the truths are the ideal readings at each bench's own drive, set where its search's
        # noisy readings put the resonance (a few hertz apart on a Q 300 peak: 0.1-0.2 %)
        assert scores[1].loc[quantity, "true_value"] == pytest.approx(scores[2].loc[quantity, "true_value"], rel=5e-3)
        assert abs(scores[1].loc[quantity, "rel_error"] - scores[2].loc[quantity, "rel_error"]) > 0.01
