"""`squeezebench design`: the physics route against closed forms, its budget, the design
file's refusals, the layout sweep's Pareto front and the command's outputs."""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench import cli
from squeezebench.designing import design, layouts
from squeezebench.plates import laminate, plate_modes, predicted_plates
from squeezebench.designing.design_file import DesignFile
from squeezebench.designing.answer import DesignAnswer
from squeezebench.designing.paper_route import predict_from_small_plates
from squeezebench.designing.verdict import judge
from squeezebench.errors import UserError
from squeezebench.schemas import load_design_file
from squeezebench.yamlfiles import dump_yaml

#: Table 3's plate (75 x 41 x 1 mm, one column of four piezos mid-length) as a design.
STRIP = {
    "name": "strip", "resonator": {"length_mm": 75, "width_mm": 41, "thickness_mm": 1},
    "piezo": {"length_x_mm": 5, "width_y_mm": 9, "thickness_mm": 0.5},
    "groups": [{"name": "middle", "x_mm": 38, "y_mm": [7, 16, 25, 34]}],
    "mode": {"interior_antinodes": 9}, "target": {"amplitude_pp_m": 1e-6},
    "damping": {"mechanical_q": 310, "origin": "test"}, "amplifier": {"max_output_vpp": 200},
}


def strip(**changes) -> DesignFile:
    data = json.loads(json.dumps(STRIP))
    for key, value in changes.items():
        data[key] = {**data[key], **value} if isinstance(value, dict) else value
    return DesignFile.model_validate(data)


@pytest.fixture(scope="module")
def strip_prediction() -> design.PhysicsPrediction:
    return design.predict_physics(strip())


# --- the lumped branch against its closed forms ---------------------------------------------

lumped_values = st.builds(
    design.Lumped, frequency_hz=st.floats(1e4, 1e5), modal_mass_kg=st.floats(1e-3, 1.0),
    force_factor_n_per_v=st.floats(1e-3, 1.0), mechanical_q=st.floats(10, 3000),
    clamped_capacitance_f=st.floats(1e-10, 1e-7), piezo_thickness_m=st.floats(2e-4, 2e-3),
    tan_delta_low_field=st.floats(0, 0.01), tan_delta_at_max_field=st.floats(0.01, 0.05),
    max_field_v_per_m=st.floats(1e5, 1e6))


@settings(max_examples=60, deadline=None)
@given(lumped=lumped_values, voltage_vpp=st.floats(0.1, 500))
def test_active_power_is_what_the_admittance_takes(lumped, voltage_vpp):
    """P = (V/2)^2 G / 2 with G the branch's conductance: the power the design reports is the
    power the current it reports carries in phase."""
    r = lumped.resistance_ns_per_m
    g = lumped.force_factor_n_per_v**2 / r + lumped.omega * lumped.clamped_capacitance_f * lumped.tan_delta(voltage_vpp)
    total = lumped.mechanical_power_w(voltage_vpp) + lumped.dielectric_power_w(voltage_vpp)
    assert total == pytest.approx(0.5 * (voltage_vpp / 2) ** 2 * g, rel=1e-12)
    # and the current is never below the capacitive part alone
    assert lumped.current_pp_a(voltage_vpp) >= voltage_vpp * lumped.omega * lumped.clamped_capacitance_f * (1 - 1e-12)


@settings(max_examples=40, deadline=None)
@given(lumped=lumped_values, velocity_pp=st.floats(1e-3, 2.0), scale=st.floats(0.2, 5.0))
def test_mechanical_power_at_a_velocity_does_not_depend_on_the_coupling(lumped, velocity_pp, scale):
    """P_mech = R (v/2)^2 / 2 whatever the force factor: coupling sets the voltage, not the power."""
    stronger = design.Lumped(**{**lumped.__dict__, "force_factor_n_per_v": lumped.force_factor_n_per_v * scale})
    v1, v2 = lumped.voltage_vpp_for(velocity_pp), stronger.voltage_vpp_for(velocity_pp)
    assert v2 == pytest.approx(v1 / scale, rel=1e-12)
    expected = 0.5 * lumped.resistance_ns_per_m * (velocity_pp / 2) ** 2
    assert lumped.mechanical_power_w(v1) == pytest.approx(expected, rel=1e-12)
    assert stronger.mechanical_power_w(v2) == pytest.approx(expected, rel=1e-12)


def test_tan_delta_follows_the_datasheet_between_its_two_points():
    lumped = design.Lumped(40e3, 0.01, 0.1, 300, 1e-8, 5e-4, 0.004, 0.020, 400e3)
    assert lumped.tan_delta(0.0) == pytest.approx(0.004)
    assert lumped.tan_delta(400.0) == pytest.approx(0.020)   # 200 V amplitude over 0.5 mm = 400 V/mm
    assert lumped.tan_delta(200.0) == pytest.approx(0.012)


def test_antinode_ratio_of_an_even_and_an_uneven_profile():
    x = np.linspace(0, 10 * math.pi, 2001)
    assert design.antinode_ratio(x, np.sin(x)) == pytest.approx(1.0, abs=1e-4)
    assert design.antinode_ratio(x, np.sin(x) * (1 + x / x[-1])) == pytest.approx(1.15 / 1.85, rel=1e-3)   # whole half-waves only: peaks at 1.5 pi .. 8.5 pi


# --- the physics route on a plate the paper measured ------------------------------------------

def test_strip_is_the_plate_model_of_table3(strip_prediction):
    """The design of Table 3's plate gives what the report's predicted column gives for it
    (same model, same shared damping), and the paper's 9 antinodes from geometry alone."""
    v = strip_prediction.nominal.values
    # the predicted column's first row, alone (all of predictions() solves 15 more plates)
    table, item, _, geometry, _, antinodes = next(predicted_plates.paper_plates())
    predicted = predicted_plates._at_centre(geometry, *predicted_plates._solve_working(geometry, antinodes, None))
    assert v["interior_antinodes"] == 9 == predicted_plates._printed(table, item)["printed_antinodes"]
    assert v["frequency_hz"] == pytest.approx(predicted["frequency_hz"], rel=2e-3)


def test_frequency_budget_matches_the_scaling_law(strip_prediction):
    """A thin plate's f ~ h sqrt(E / rho): the budget's U equals that law's (the piezo layer
    changes the exponents by a few per cent)."""
    expected = predicted_plates.frequency_relative_u(1e-3)   # the strip is 1 mm thick
    got = strip_prediction.expanded["frequency_hz"] / strip_prediction.nominal.values["frequency_hz"]
    assert got == pytest.approx(expected, rel=0.1)
    assert strip_prediction.dominant("frequency_hz") == "resonator thickness"


def test_power_and_voltage_scale_with_damping(strip_prediction):
    """At a fixed amplitude R = w M / Q: doubling Q halves the mechanical power and the voltage."""
    base = strip_prediction.nominal.values
    lossless = design.operating_point(strip(damping={"mechanical_q": 620}), modal=None).values
    assert lossless["mechanical_power_w"] == pytest.approx(base["mechanical_power_w"] / 2, rel=1e-9)
    assert lossless["voltage_vpp"] == pytest.approx(base["voltage_vpp"] / 2, rel=1e-9)


def test_power_at_the_target_is_the_closed_form(strip_prediction):
    """P_mech = (w M / Q) (w A / 2)^2 / 2 with M the modal mass at the centre and A the target."""
    v = strip_prediction.nominal.values
    omega = 2 * math.pi * v["frequency_hz"]
    expected = 0.5 * omega * v["modal_mass_g"] * 1e-3 / 310 * (omega * 1e-6 / 2) ** 2
    assert v["mechanical_power_w"] == pytest.approx(expected, rel=1e-9)
    assert v["amplitude_pp_m"] == pytest.approx(1e-6)


def test_a_touch_area_target_is_met_on_average():
    at_area = design.operating_point(strip(target={"amplitude_pp_m": 1e-6, "at": "touch_area"})).values
    assert at_area["touch_mean_amplitude_pp_m"] == pytest.approx(1e-6, rel=1e-9)


def test_budget_rows_name_every_input(strip_prediction):
    """Every input but the placement, which moves end groups (the strip has only a middle one),
    and the bond's loss, which moves only a Q from physics."""
    budget = strip_prediction.budget
    assert set(budget["input"]) == {name for name, _, _ in design.INPUTS} - {"placement_mm", "bond_loss_factor"}
    # inputs that do not enter a quantity contribute exactly nothing to it
    frequency = budget[budget["output"] == "frequency_hz"].set_index("input")["contribution"]
    assert (frequency[["d31_c_per_n", "relative_permittivity_t", "tan_delta", "mechanical_q"]] == 0).all()
    # the model-form force factor (a factor exp(2 u) = 5.6 at k = 2) outweighs the stated Q's +-30 %
    assert strip_prediction.dominant("voltage_vpp") == design.PAPER_BUILDS_FORCE_LABEL


def test_centre_on_a_nodal_line_is_refused():
    """An even count of antinodes (an odd count of nodal lines) puts a nodal line at the
    centre: a target there is refused, one over the touch area is answered."""
    with pytest.raises(design.DesignError, match="nodal line.*touch_area"):
        design.operating_point(strip(mode={"interior_antinodes": 10}))
    over_area = design.operating_point(strip(mode={"interior_antinodes": 10},
                                             target={"amplitude_pp_m": 1e-6, "at": "touch_area"})).values
    assert over_area["touch_mean_amplitude_pp_m"] == pytest.approx(1e-6)


# --- the design file ---------------------------------------------------------------------------

@pytest.mark.parametrize("change, words", [
    ({"groups": [{"name": "a", "x_mm": 1, "y_mm": [7]}]}, "overhangs the plate"),
    ({"groups": [{"name": "a", "x_mm": 38, "y_mm": [7, 10]}]}, "overlap"),
    ({"groups": [{"name": "a", "x_mm": 38, "y_mm": [7], "powered": False}]}, "no group is powered"),
    ({"target": {"amplitude_pp_m": 1e-6, "velocity_pp_mps": 0.2}}, "exactly one of amplitude_pp_m"),
    ({"mode": {"interior_antinodes": 9, "near_hz": 38000}}, "exactly one of interior_antinodes"),
    ({"touch_area": {"x_mm": [50, 10], "y_mm": [0, 41]}}, "lower bound first"),
    ({"piezo": {"length_x_mm": 5, "width_y_mm": 9, "thickness_mm": 0.5, "colour": "blue"}}, "unknown field"),
    ({"resonator": {"length_mm": 75, "width_mm": 41, "thickness_mm": 8}}, "state the plate's thickness tolerance"),
])
def test_a_bad_design_file_is_one_line_naming_the_field(tmp_path, change, words):
    data = {**STRIP, **change}
    path = tmp_path / "plate.yaml"
    path.write_text(dump_yaml(data))
    with pytest.raises(UserError, match=words) as caught:
        load_design_file(path)
    assert str(caught.value).startswith(str(path)) and "\n" not in str(caught.value)


def test_the_thickness_tolerance_is_the_sheets_unless_stated():
    assert strip().tolerance("thickness_m") == pytest.approx(0.05)   # 1 mm: +-0.05 mm (EN 485-4)
    assert strip(resonator={"length_mm": 75, "width_mm": 41, "thickness_mm": 2}).tolerance(
        "thickness_m") == pytest.approx(0.045)
    assert DesignFile.model_validate({**STRIP, "tolerances": {"thickness_m": 0.01}}).tolerance("thickness_m") == 0.01
    assert strip().tolerance("young_pa") == laminate.RELATIVE_TOLERANCES["young_pa"]


def test_shipped_large_plate_reads_nothing_measured():
    """The shipped design of the paper's large plate: geometry, datasheets and the build's damping;
    its mode is asked for by antinode count, never by the printed frequency."""
    from squeezebench import paths

    spec = load_design_file(paths.design_file("large_plate"))
    assert spec.mode.near_hz is None and spec.mode.interior_antinodes == 21
    assert spec.damping.mechanical_q == predicted_plates.MECHANICAL_Q and spec.damping.spread == "paper_builds"
    assert spec.n_powered_piezos == 8 and spec.n_powered_groups == 4


# --- layouts -----------------------------------------------------------------------------------

points = st.lists(st.tuples(st.floats(0.01, 10), st.floats(0, 1), st.booleans()), min_size=1, max_size=40)


@settings(max_examples=80, deadline=None)
@given(points)
def test_pareto_front_is_exactly_the_undominated_feasible_layouts(rows):
    frame = pd.DataFrame(rows, columns=["power_w", "weakest_antinode_ratio", "feasible"])
    front = layouts.pareto_front(frame)
    feasible = frame[frame["feasible"]]
    for i, row in frame.iterrows():
        dominated = ((feasible["power_w"] <= row.power_w) & (feasible["weakest_antinode_ratio"] >= row.weakest_antinode_ratio)
                     & ((feasible["power_w"] < row.power_w) | (feasible["weakest_antinode_ratio"] > row.weakest_antinode_ratio))).any()
        assert front[i] == (bool(row.feasible) and not dominated)


def test_layout_grid_searches_the_distance_from_the_edge_finest_near_it():
    grid = layouts.grid(half_wavelength_mm=8.0, piezo_length_x_mm=5.0)
    assert len(grid) == 216 and len(set(grid)) == 216
    assert len(layouts.tasks(grid, strip(), 9)) == 216 // len(layouts.PIEZO_THICKNESSES_MM)
    gaps = sorted({layout.edge_gap_mm(5.0) for layout in grid})
    assert gaps[0] == 0 and gaps[-1] < 8.0   # flush to short of the next half-wave's repeat
    steps = np.diff(gaps)
    assert steps[0] == min(steps) and steps[-1] == max(steps)


def test_a_layout_family_on_the_strip():
    """Piezo thickness has an optimum (a thick patch stiffens the section it bends, so the
    curvature under it falls); a column flush with a free edge, where the curvature vanishes,
    couples less than one a quarter wavelength in; a layout beyond the amplifier says so."""
    spec = strip(amplifier={"max_output_vpp": 30})
    family = [layouts.Layout("ends", 2.5 + 4.0, 4, "centred", t) for t in (0.3, 0.5, 1.0)]
    rows = pd.DataFrame(layouts.evaluate_mesh_group((tuple(family), spec, 9)))
    assert rows["voltage_vpp"].notna().all() and rows["voltage_vpp"].nunique() == 3
    flush = layouts.evaluate(layouts.Layout("ends", 2.5, 4, "centred", 0.5), spec, 9)
    quarter = layouts.evaluate(layouts.Layout("ends", 2.5 + 2.0, 4, "centred", 0.5), spec, 9)
    assert flush["voltage_vpp"] > quarter["voltage_vpp"]
    weak = layouts.evaluate(layouts.Layout("ends", 2.5, 2, "centred", 1.0), spec, 9)
    assert not weak["feasible"] and "amplifier" in weak["why_not"]
    # on a mode with an even count the two ends swing in opposition: end columns cancel
    opposed = layouts.evaluate(layouts.Layout("ends", 2.5 + 2.0, 4, "centred", 0.5),
                               strip(target={"amplitude_pp_m": 1e-6, "at": "touch_area"}), 10)
    assert opposed["coupling_share"] < design.MIN_COUPLING_SHARE
    assert not opposed["feasible"] and "cancel" in opposed["why_not"]


# --- the command ---------------------------------------------------------------------------------

def test_design_command_writes_page_json_and_tables(tmp_path, capsys):
    path = tmp_path / "strip.yaml"
    path.write_text(dump_yaml(STRIP))
    assert cli.main(["design", str(path), "--no-layouts", "--out", str(tmp_path / "out"), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["command"] == "design" and payload["design"] == "strip"
    voltage = payload["physics"]["voltage_vpp"]
    assert voltage["value"] > 0 and voltage["expanded_uncertainty"] > 0
    # the force factor's model-form term puts the voltage's U past its value: scripts get the
    # factor interval the page writes, never value - U below zero; a frequency keeps +- U
    v, u = voltage["value"], voltage["expanded_uncertainty"]
    assert u > v and voltage["interval"] == pytest.approx([v * v / (v + u), v + u])
    frequency = payload["physics"]["frequency_hz"]
    assert frequency["interval"] == pytest.approx([frequency["value"] - frequency["expanded_uncertainty"],
                                                   frequency["value"] + frequency["expanded_uncertainty"]])
    assert payload["headline"][1].startswith("strip needs ")
    assert payload["verdict"] == {"status": "feasible", "reasons": [], "changes": []}
    assert payload["headline"][0] == "Verdict: feasible."
    assert payload["placement"] is None   # a middle column only: nothing to move along the length
    for name in ("index.html", "design.json", "budget.csv", "comparison.csv", "mode.png", "power_voltage.png"):
        assert (tmp_path / "out" / name).is_file()
    page = (tmp_path / "out" / "index.html").read_text()
    assert "e+0" not in page and "e-0" not in page   # no scientific notation for a person
    assert "banner feasible" in page and "banner real" not in page


def test_design_command_names_a_missing_file(tmp_path, capsys):
    assert cli.main(["design", str(tmp_path / "nope.yaml"), "--no-layouts"]) == cli.EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert "nope.yaml" in err and "Traceback" not in err


def test_plate_modes_share_one_mesh_between_tolerance_solves():
    """A tolerance solve reuses the nominal mesh: the frequency's sensitivity to E is the
    physics' exponent 1/2 (a remesh would add its own discretisation change)."""
    spec = strip()
    nominal = design.modal_part(spec)
    stiffer = design.modal_part(spec, {"young_pa": 1.01})
    ratio = stiffer.modes.frequencies_hz[stiffer.mode_index] / nominal.modes.frequencies_hz[nominal.mode_index]
    assert math.log(ratio) / math.log(1.01) == pytest.approx(0.5, abs=0.02)
    assert plate_modes._discretisation.cache_info().hits >= 1


def test_design_from_python(tmp_path):
    import squeezebench

    path = tmp_path / "strip.yaml"
    path.write_text(dump_yaml(STRIP))
    answer = squeezebench.design(path, out_dir=tmp_path / "page")
    assert answer.layouts is None and answer.paper_route is None
    assert answer.physics.nominal.values["interior_antinodes"] == 9
    assert (tmp_path / "page" / "index.html").is_file()


# --- closing the loop: the design built on the simulated bench ----------------------------------

def test_design_built_on_the_simulated_bench_meets_its_prediction(tmp_path, capsys):
    """design -> predicted scene and campaign -> run -> design --measured: the simulated build
    lands within the prediction's U (a chain check: the scene follows the same plate model),
    and the page says the plate was simulated."""

    from squeezebench.protocols.campaign import run_campaign
    from squeezebench.simbench.scene import load_scene

    path = tmp_path / "strip.yaml"
    path.write_text(dump_yaml(STRIP))
    assert cli.main(["design", str(path), "--no-layouts", "--out", str(tmp_path / "page"),
                     "--write-build", str(tmp_path / "build"), "-q"]) == 0
    scene = load_scene(tmp_path / "build" / "strip.yaml")
    state = scene.state("built")
    assert state.predicted and "resonance_frequency_hz: predicted" in (
        tmp_path / "build" / "strip.yaml").read_text()
    predicted_hz = design.predict_physics(strip()).nominal.values["frequency_hz"]
    assert state.resonance_frequency_hz == pytest.approx(predicted_hz, rel=3e-3)   # E 67.0 vs 67.109 GPa, meshes
    run_dir = run_campaign(tmp_path / "build" / "strip_characterisation.yaml", out_dir=tmp_path / "run",
                           progress=False)
    assert cli.main(["design", str(path), "--no-layouts", "--out", str(tmp_path / "page2"),
                     "--measured", str(run_dir), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    rows = {(r["quantity"], r["source"]): r for r in payload["comparison"]}
    for quantity in ("voltage_vpp", "power_w"):
        row = rows[(quantity, "physics (a)")]
        assert row["reference"] == "measured (strip)" and row["within_u"], row
        assert abs(row["deviation"]) < 0.05, row
    assert any("simulated" in line for line in payload["headline"])
    # the check joins the history beside the designs' folders, once per measured run
    assert cli.main(["design", str(path), "--no-layouts", "--out", str(tmp_path / "page2"),
                     "--measured", str(run_dir), "-q"]) == 0
    history = pd.read_csv(tmp_path / "history.csv")
    assert set(history["design"]) == {"strip"} and len(history) == 3   # frequency, voltage, power of physics
    assert "How the designs fare" in (tmp_path / "page2" / "index.html").read_text()


def test_a_predicted_state_cannot_also_be_calibrated(tmp_path):
    from squeezebench.designing.workflow import scene_from_design
    from squeezebench.simbench.scene import SceneError, load_scene

    data = scene_from_design(strip())
    data["states"]["built"]["calibration"] = {"voltage_vpp": 20, "velocity_pp_mps": 0.2, "power_w": 0.03}
    path = tmp_path / "both.yaml"
    path.write_text(dump_yaml(data))
    with pytest.raises(SceneError, match="predicted or calibrated, not both"):
        load_scene(path)


def test_validate_says_where_a_replay_departs_from_the_model(capsys, tmp_path):
    """The shipped large plate replays the paper's numbers: its force factor and resonance
    depart from the plate model beyond the tolerances, and `validate` says so per state; a
    design's predicted scene has nothing to depart from."""

    from squeezebench.designing.workflow import scene_from_design

    path = tmp_path / "strip.yaml"
    path.write_text(dump_yaml(scene_from_design(strip())))
    # --scene: the name alone also means the shipped design, whose physics this test does not read
    assert cli.main(["validate", "--scene", "large_plate", str(path)]) == 0
    err = capsys.readouterr().err
    assert "large_plate.yaml: state 'large', a declared replay (reproduces Sec. 5's printed point" in err
    assert "departs from the plate model" in err and "force factor" in err and "strip.yaml" not in err


def test_transfer_study_on_one_drawn_build():
    """One build of `squeezebench.designing.transfer`: every plate drawn from geometry and
    datasheets, built as a predicted scene and characterised on the simulated bench. The
    physics route lands within its U (a chain check); the paper's route is computed under
    both readings and its ratio to the measurement recorded, whatever it is."""
    from squeezebench.designing import transfer as design_transfer

    rows = pd.DataFrame(design_transfer.study_build(10))   # of builds 2, 7 and 10 the cheapest (8, 10, 30 CPU-s)
    assert set(rows["route"]) == {"physics (a)", "small plates (b), paper reading",
                                  "small plates (b), physical reading"}
    physics = rows[rows["route"] == "physics (a)"].iloc[0]
    assert physics["covered"] and abs(physics["ratio"] - 1) < 0.05
    assert (rows["measured_power_w"] > 0).all() and rows["ratio"].notna().all()


def test_paper_route_from_the_small_plates_is_table5s_estimate(paper_run):
    """Route (b) for the shipped large-plate design, fed the paper campaign's small plates
    (the session's paper run, whose report prints Table 5), carries the same Q and
    tan(theta') as the report's Table 5 estimate (Plate 4's Q by Eq. 29, the mean
    tan(theta') of the 2 mm plates)."""

    from squeezebench import paths
    from squeezebench.analysis import characterisation
    from squeezebench.analysis.model import REPORT_CONVENTION
    from squeezebench.analysis.rundata import load_run
    from squeezebench.designing.workflow import characterised_plates

    run_dir, _ = paper_run
    estimate = characterisation.estimate_large_from_small(characterisation.characterise_plates(load_run(run_dir), REPORT_CONVENTION),
                                                REPORT_CONVENTION)
    spec = load_design_file(paths.design_file("large_plate"))
    route = predict_from_small_plates(design.predict_physics(spec), characterised_plates([run_dir]))
    assert route.template == "small_plate_4"
    assert route.small_plates == ("small_plate_1", "small_plate_2", "small_plate_3", "small_plate_4")   # the 2 mm ones
    assert route.q.nominal_value == pytest.approx(estimate.q.value, rel=1e-12)
    assert route.q.std_dev == pytest.approx(estimate.q.std_uncertainty, rel=1e-12)
    assert route.tan_theta.nominal_value == pytest.approx(estimate.tan_theta.value, rel=1e-12)
    assert route.tan_theta.std_dev == pytest.approx(estimate.tan_theta.std_uncertainty, rel=1e-12)


# -- the design-file guide: a plate written from docs/design-files.md alone -----------------

def _guide() -> str:
    from pathlib import Path

    return (Path(__file__).resolve().parents[1] / "docs" / "design-files.md").read_text(encoding="utf-8")


def _block(text: str, language: str, index: int = 0) -> str:
    return text.split(f"```{language}\n")[index + 1].split("```")[0]


def test_the_guides_plate_designs_on_the_first_try(tmp_path, capsys):
    """The worked example (120 x 60 x 1.5 mm) as the guide prints it, written to a file,
    validates and designs; `design --template` prints the same file."""
    example = _block(_guide(), "yaml")
    assert "length_mm: 120" in example and "width_mm: 60" in example and "thickness_mm: 1.5" in example
    assert "material: aluminium " in example and "material: NCE 41" in example and "1e-6" in example
    path = tmp_path / "my_plate.yaml"
    path.write_text(example)
    assert cli.main(["validate", str(path)]) == 0
    assert cli.main(["design", str(path), "--no-layouts", "--out", str(tmp_path / "out"), "-q"]) == 0
    assert (tmp_path / "out" / "index.html").is_file()
    capsys.readouterr()
    assert cli.main(["design", "--template"]) == 0
    assert capsys.readouterr().out == example


def test_a_file_with_three_mistakes_gets_three_messages_in_the_users_words(tmp_path):
    example = _block(_guide(), "yaml")
    wrong = (example.replace("material: aluminium ", "material: unobtainium ")
             .replace("thickness_mm: 1.5", 'thickness_mm: "1.5"').replace("max_output_vpp", "max_out_vpp"))
    path = tmp_path / "my_plate.yaml"
    path.write_text(wrong)
    with pytest.raises(UserError) as refused:
        load_design_file(path)
    message = str(refused.value)
    lines = message.splitlines()
    assert lines[0] == f"{path}: 3 problems (every field: docs/design-files.md):" and len(lines) == 4
    assert "did you mean 'max_output_vpp'?" in message and "literal" not in message.lower()
    assert "'1.5' is text, not a number" in message and "unknown material 'unobtainium'" in message
    # the guide shows the same messages
    shown = _block(_guide(), "text").splitlines()
    assert [line.strip() for line in shown[1:]] == [line.strip() for line in lines[1:]]


@pytest.mark.parametrize("written, meant", [("Al 6061-T6", "al_6061_t6"), ("aluminum", "aluminium_table2"),
                                            ("ALUMINIUM", "aluminium_table2"), ("6061-T6", "al_6061_t6")])
def test_materials_by_the_names_people_write(written, meant):
    from squeezebench.designing.design_file import RESONATOR_MATERIALS, material_name

    assert material_name(written, RESONATOR_MATERIALS) == meant
    assert material_name("nce-41", {"NCE41": None}) == "NCE41"


def test_the_guides_material_table_shows_the_constants_the_model_uses():
    from squeezebench.designing.design_file import PIEZO_MATERIALS, RESONATOR_MATERIALS

    guide = _guide()
    for material in (*RESONATOR_MATERIALS.values(), *PIEZO_MATERIALS.values()):
        assert f"| {material.young_pa / 1e9:g} | {material.poisson:g} | {material.density_kg_m3:g} |" in guide


# --- placement, verdicts and modes chosen by physics -------------------------------------------

#: The strip with a column of four at each end, 1 mm from the edges (9 antinodes: both ends
#: swing the same way, so the columns add).
ENDS = {**STRIP, "name": "ends", "groups": [{"name": "left", "x_mm": 3.5, "y_mm": [7, 16, 25, 34]},
                                            {"name": "right", "x_mm": 71.5, "y_mm": [7, 16, 25, 34]}]}


@pytest.fixture(scope="module")
def ends_prediction() -> design.PhysicsPrediction:
    return design.predict_physics(DesignFile.model_validate(ENDS))


def test_placement_is_a_named_term_of_the_budget(ends_prediction):
    spec = ends_prediction.design
    assert spec.placement_tolerance_mm == 0.5 and design.mean_edge_gap_mm(spec) == pytest.approx(1.0)
    rows = ends_prediction.budget[ends_prediction.budget["input"] == "placement_mm"].set_index("output")
    assert rows.loc["voltage_vpp", "tolerance_mm"] == 0.5
    assert rows.loc["voltage_vpp", "input_u_mm"] == pytest.approx(0.5 / math.sqrt(3))
    # near a free edge the curvature the piezos bend grows inward: moving them in lowers the voltage
    assert rows.loc["voltage_vpp", "contribution"] < 0
    wider = DesignFile.model_validate({**ENDS, "groups": [{**ENDS["groups"][0], "x_tolerance_mm": 1.5},
                                                          ENDS["groups"][1]]})
    assert wider.placement_tolerance_mm == 1.5


def test_end_groups_move_each_toward_its_own_end():
    spec = DesignFile.model_validate({**ENDS, "groups": ENDS["groups"] + [{"name": "mid", "x_mm": 37.5,
                                                                            "y_mm": [20]}]})
    at = spec.with_end_groups_at(2.0)
    assert [g.x_mm for g in at.groups] == [4.5, 70.5, 37.5]
    assert [g.x_mm for g in spec.moved_inward(0.5).groups] == [4.0, 71.0, 37.5]
    assert [at.edge_gap_mm(g) for g in at.groups[:2]] == [2.0, 2.0]


def test_placement_curve_says_where_the_piezos_drive_best(ends_prediction):
    """Flush with a free edge the curvature vanishes: the voltage there exceeds the voltage a
    couple of millimetres in, and the curve's U scales with its voltage."""
    curve = design.placement_curve(ends_prediction, np.array([0.0, 2.0]))
    assert curve["why_not"].eq("").all()
    assert curve["voltage_vpp"].iloc[0] > curve["voltage_vpp"].iloc[1]
    relative = curve["voltage_expanded_uncertainty"] / curve["voltage_vpp"]
    assert relative.iloc[0] == pytest.approx(relative.iloc[1])
    answer = DesignAnswer(ends_prediction, placement=curve)
    from squeezebench.report.design_report import placement_sentences
    words = " ".join(placement_sentences(answer))
    ratio = ends_prediction.nominal.values["voltage_vpp"] / curve["voltage_vpp"].min()
    assert f"divides the voltage by {ratio:.2g}" in words and "mm inward" in words
    printed = DesignAnswer(ends_prediction, placement=curve,
                                  printed={"voltage_vpp": float(curve["voltage_vpp"].mean()), "power_w": 1e3,
                                           "frequency_hz": 1.0})
    inferred = placement_sentences(printed)[-1]
    assert inferred.startswith("Inference, not a prediction") and "at 1.0 mm from the edges" in inferred
    below = float(curve["voltage_vpp"].min()) / 1.5
    unreached = placement_sentences(DesignAnswer(ends_prediction, placement=curve,
                                                 printed={"voltage_vpp": below, "power_w": 1e3, "frequency_hz": 1.0}))[-1]
    lowest = curve.loc[curve["voltage_vpp"].idxmin()]
    assert "nowhere" in unreached and "would have to be 1.50 times larger" in unreached
    assert f"Q {lowest['mechanical_q'] * 1.5:.0f}" in unreached


@settings(max_examples=60, deadline=None)
@given(st.floats(-5, 5), st.floats(0.1, 3), st.floats(-10, 10))
def test_crossings_of_a_line_are_its_root(intercept, slope, level):
    x = np.linspace(0, 10, 11)
    found = plate_modes.crossings(x, intercept + slope * x, level)
    root = (level - intercept) / slope
    assert found == ([pytest.approx(root)] if 0 <= root <= 10 else [])


def test_verdict_follows_the_limits_with_their_u(strip_prediction):
    from dataclasses import replace

    v, u = strip_prediction.nominal.values["voltage_vpp"], strip_prediction.expanded["voltage_vpp"]

    def verdict(amplifier_vpp):
        spec = strip(amplifier={"max_output_vpp": amplifier_vpp})
        return judge(replace(strip_prediction, design=spec))
    assert verdict(v + 2 * u).status == "feasible"
    marginal = verdict(v + u / 2)
    assert marginal.status == "marginal" and "within the U" in marginal.reasons[0]
    refused = verdict(v / 2)
    assert refused.status == "infeasible" and "amplifier" in refused.reasons[0]
    assert refused.changes == (f"a target of at most {0.5:.3g} µm pp",)
    field = strip_prediction.nominal.values["piezo_field_v_per_mm"]
    depoled = judge(replace(strip_prediction, design=strip(piezo={"max_field_v_per_mm": field / 4})))
    assert depoled.status == "infeasible" and "the ceramic's field limit" in depoled.reasons[0]
    assert depoled.changes == (f"a target of at most {0.25:.3g} µm pp",)


def test_an_infeasible_design_is_refused_unless_allowed(tmp_path, capsys):
    path = tmp_path / "strip.yaml"
    path.write_text(dump_yaml({**STRIP, "amplifier": {"max_output_vpp": 5}}))
    assert cli.main(["design", str(path), "--no-layouts", "--out", str(tmp_path / "out")]) == cli.EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert "infeasible" in err and "amplifier" in err and "Nearest feasible change: a target of at most" in err
    assert not (tmp_path / "out").exists()
    assert cli.main(["design", str(path), "--no-layouts", "--allow-infeasible", "--out", str(tmp_path / "out"),
                     "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert payload["verdict"]["status"] == "infeasible" and payload["verdict"]["changes"]
    assert "banner infeasible" in (tmp_path / "out" / "index.html").read_text()


#: The issue's new user: 120 x 60 x 1.5 mm, a column of four at each end, a mode asked for by
#: frequency. The issue's 40 kHz fell on the (12, 0) mode of the thin-plate model; the thick
#: plate puts it at 36.4 kHz and the (13, 0) at 42.2 kHz, so 37 kHz asks for the same mode.
CANCELLING = {
    "name": "cancelling", "resonator": {"length_mm": 120, "width_mm": 60, "thickness_mm": 1.5},
    "piezo": {"length_x_mm": 5, "width_y_mm": 9, "thickness_mm": 0.5},
    "groups": [{"name": "left", "x_mm": 2.5, "y_mm": [16.5, 25.5, 34.5, 43.5]},
               {"name": "right", "x_mm": 117.5, "y_mm": [16.5, 25.5, 34.5, 43.5]}],
    "mode": {"near_hz": 37000}, "target": {"amplitude_pp_m": 1e-6, "at": "touch_area"},
    "damping": {"mechanical_q": 310, "origin": "test"}, "amplifier": {"max_output_vpp": 300},
}


def test_a_mode_the_piezos_cancel_on_is_refused_naming_the_better_neighbour(tmp_path, capsys):
    """The plate's (12, 0) mode swings its two ends in opposition: the columns cancel (it
    printed 28585715 ± 9543069 Vpp in green before). The 13-antinode neighbour, nearer the
    asked frequency than the 11, is named with its voltage."""
    path = tmp_path / "cancelling.yaml"
    path.write_text(dump_yaml(CANCELLING))
    assert cli.main(["design", str(path), "--no-layouts", "--out", str(tmp_path / "out")]) == cli.EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert "cancel on the 12-antinode mode" in err and "Traceback" not in err
    named = err.split("Nearest feasible change: ")[1]
    assert named.startswith("the 13-antinode mode at ") and "mode: {interior_antinodes: 13}" in named
    voltage = float(named.split("needs about ")[1].split(" Vpp")[0])
    assert 10 < voltage < 300   # a sane drive, not millions


def test_design_command_draws_the_placement_curve(tmp_path, capsys):
    """A design with end columns: the page, design.json and placement.csv carry the voltage
    against the distance from the edges, from flush to half a wavelength in."""
    path = tmp_path / "ends.yaml"
    path.write_text(dump_yaml(ENDS))
    assert cli.main(["design", str(path), "--no-layouts", "--out", str(tmp_path / "out"), "--json"]) == 0
    payload = json.loads(capsys.readouterr().out)
    placement = payload["placement"]
    gaps = [row["edge_gap_mm"] for row in placement["curve"]]
    half_wave = payload["physics"]["half_wavelength_mm"]["value"]
    assert len(gaps) == design.PLACEMENT_POINTS and gaps[0] == 0 and gaps[-1] == pytest.approx(half_wave)
    assert placement["edge_gap_mm"] == pytest.approx(1.0) and placement["tolerance_mm"] == 0.5
    least = placement["least_voltage"]
    assert least["voltage_vpp"] == pytest.approx(min(row["voltage_vpp"] for row in placement["curve"] if row["voltage_vpp"]))
    assert placement["implied_by_printed"] is None   # not one of the paper's plates
    assert any(line.startswith("Placement: the end piezos sit 1.0 mm") for line in payload["headline"])
    assert {"placement", "placement_figure"} <= set(payload["files"])
    assert (tmp_path / "out" / "placement.png").is_file()


def test_q_from_the_loss_physics_replaces_the_stated_figure(strip_prediction):
    """With damping.source physics the plate's Q is its losses' (`plates.damping`): the budget
    carries the bond's loss factor and, by name, the losses outside the model instead of the
    build's stated Q; a stated design shows the physics' Q beside its own."""
    from squeezebench.plates import damping

    physics = design.predict_physics(strip(damping={"source": "physics", "mechanical_q": None, "tolerance_rel": 0.2}))
    values = physics.nominal.values
    modal = design.modal_part(physics.design)
    expected = damping.mechanical_q(damping.mode_loss_terms(modal.modes, modal.mode_index,
                                                            plate_modes.ALUMINIUM_TABLE2, 1e-3,
                                                            plate_modes.EPOXY.loss_factor))
    assert values["mechanical_q"] == pytest.approx(expected) == pytest.approx(values["physics_q"])
    labels = set(physics.budget["input_label"])
    assert design.UNMODELLED_LOSS_LABEL in labels and "mechanical Q of the build" not in labels
    bond = physics.budget[(physics.budget["input"] == "bond_loss_factor") & (physics.budget["output"] == "mechanical_q")]
    assert float(bond["contribution"].iloc[0]) < 0   # a lossier bond lowers Q
    # the stated design: its own Q, the physics' beside it, no bond term
    assert strip_prediction.nominal.values["mechanical_q"] == 310
    assert strip_prediction.nominal.values["physics_q"] == pytest.approx(expected, rel=1e-9)
    assert "bond_loss_factor" not in set(strip_prediction.budget["input"])
    with pytest.raises(ValueError, match="give mechanical_q, or source: physics"):
        strip(damping={"mechanical_q": None})


def test_a_q_from_the_papers_builds_spreads_as_they_realise_it(strip_prediction):
    """With spread: paper_builds the stated Q's term is log-normal with the u of ln Q the paper's
    builds show (`predicted_plates.drive_model_form`) and sized as `log_term_expanded_rel`
    sizes one: the voltage at the target goes as 1 / Q, so its U from Q alone is
    V (exp(k u) - 1), and Q's own U is Q (exp(k u) - 1); the force factor's part likewise as its
    own row; the other inputs' terms are unchanged."""
    paper = design.predict_physics(strip(damping={"mechanical_q": 310, "spread": "paper_builds", "origin": "test"}))
    u_ln = predicted_plates.drive_model_form()["u_q_ln"]
    expanded_rel = predicted_plates.log_term_expanded_rel(u_ln)
    rows = paper.budget[paper.budget["input"] == "mechanical_q"].set_index("output")
    v = paper.nominal.values
    for output in ("voltage_vpp", "mechanical_q"):
        assert abs(rows.loc[output, "contribution"]) * design.COVERAGE_FACTOR == pytest.approx(
            v[output] * expanded_rel, rel=1e-9)
    assert rows["input_label"].iloc[0] == design.PAPER_BUILDS_Q_LABEL and rows["input_u_rel"].iloc[0] == u_ln
    # the voltage at the target goes as 1 / A too: the builds' force-factor part is its own row
    u_force = predicted_plates.drive_model_form()["u_force_factor_ln"]
    force = paper.budget[paper.budget["input"] == "build_force_factor"].set_index("output")
    assert abs(force.loc["voltage_vpp", "contribution"]) * design.COVERAGE_FACTOR == pytest.approx(
        v["voltage_vpp"] * predicted_plates.log_term_expanded_rel(u_force), rel=1e-9)
    assert force["input_label"].iloc[0] == design.PAPER_BUILDS_FORCE_LABEL and force["input_u_rel"].iloc[0] == u_force
    # a voltage whose U passes its value is a range, and the headline names what to measure
    assert paper.expanded["voltage_vpp"] > v["voltage_vpp"]
    from squeezebench.report import design_report

    lines = design_report.headline(DesignAnswer(paper))
    assert " (×/÷ " in lines[1].split(" Vpp")[0] and "±" not in lines[1].split(" Vpp")[0]
    assert design.PAPER_BUILDS_FORCE_LABEL in lines[2] and "design --measured" in lines[2]
    # every other row, the force factor's among them (a design with its own Q rests its voltage on
    # the model's force factor all the same), is the stated-Q design's
    others = paper.budget[paper.budget["input"] != "mechanical_q"].reset_index(drop=True)
    stated = strip_prediction.budget[strip_prediction.budget["input"] != "mechanical_q"].reset_index(drop=True)
    pd.testing.assert_frame_equal(others, stated)
    with pytest.raises(ValueError, match="spread: paper_builds is the spread of a Q stated"):
        strip(damping={"source": "physics", "mechanical_q": None, "spread": "paper_builds"})
