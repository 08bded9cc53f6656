"""Bounds that bite (issue 22): a scene must describe the plate physics predicts, or declare
itself a replay with its reason. Built from the shipped one_column_1p2mm scene: its
prediction turned into a calibration loads as it is, and is refused once moved beyond the
plate model's tolerances or given a q_mech no aluminium plate in air has."""
import dataclasses
import math

import pytest

from squeezebench import paths
from squeezebench.simbench.predicted import FORCE_FACTOR_TOLERANCE, MODAL_MASS_TOLERANCE
from squeezebench.simbench.scene import load_scene
from squeezebench.simbench.scene_bounds import scene_figures
from squeezebench.simbench.scene_model import SceneError
from squeezebench.schemas import replay_departures
from squeezebench.yamlfiles import dump_yaml, load_strict

STATE = "one_powered"
VOLTAGE_VPP = 24.0


def _raw(name="one_column_1p2mm"):
    return load_strict((paths.scenes_dir() / f"{name}.yaml").read_text())


def _write(tmp_path, raw, name="plate.yaml"):
    path = tmp_path / name
    path.write_text(dump_yaml(raw))
    return path


def _bare(raw):
    """The scene without its replay declaration, effects or provenance of the replayed numbers."""
    raw = dict(raw)
    raw.pop("replay")
    raw["effects"] = []
    raw["provenance"] = {}
    return raw


def _as_predicted(tmp_path, q_mech=310.0):
    raw = _bare(_raw())
    raw["states"][STATE] = {"description": "predicted", "resonance_frequency_hz": "predicted", "q_mech": q_mech,
                            "powered_columns": raw["states"][STATE]["powered_columns"]}
    return raw, load_scene(_write(tmp_path, raw, "predicted.yaml")).state(STATE)


def _calibrated_on(tmp_path, predicted, raw, force_scale=1.0, mass_scale=1.0):
    """The predicted branch written as a measurement at resonance (v = psi V / R, P = R v^2 / 2),
    its force factor and modal mass scaled (R = w M / q)."""
    branch = predicted.branch
    resistance = branch.resistance_ns_per_m * mass_scale
    velocity_amplitude = force_scale * branch.force_factor_n_per_v * VOLTAGE_VPP / 2 / resistance
    raw["states"][STATE] = {"description": "measured", "resonance_frequency_hz": predicted.resonance_frequency_hz,
                            "q_mech": predicted.q_mech, "powered_columns": raw["states"][STATE]["powered_columns"],
                            "calibration": {"voltage_vpp": VOLTAGE_VPP, "velocity_pp_mps": 2 * velocity_amplitude,
                                            "power_w": 0.5 * resistance * velocity_amplitude**2}}
    return _write(tmp_path, raw, "calibrated.yaml")


def test_a_calibration_that_is_the_prediction_loads_without_a_replay(tmp_path):
    raw, predicted = _as_predicted(tmp_path)
    scene = load_scene(_calibrated_on(tmp_path, predicted, raw))
    state = scene.state(STATE)
    assert scene.replay_reason is None
    assert state.branch.force_factor_n_per_v == pytest.approx(predicted.branch.force_factor_n_per_v, rel=1e-9)
    assert replay_departures(scene.path) == []


@pytest.mark.parametrize("force_scale, mass_scale, named", [
    (1 + 2 * FORCE_FACTOR_TOLERANCE, 1.0, "force factor"),
    (1.0, 1 + 2 * MODAL_MASS_TOLERANCE, "modal mass"),
])
def test_a_calibration_beyond_the_model_is_refused_unless_a_replay(tmp_path, force_scale, mass_scale, named):
    raw, predicted = _as_predicted(tmp_path)
    path = _calibrated_on(tmp_path, predicted, raw, force_scale, mass_scale)
    with pytest.raises(SceneError) as refused:
        load_scene(path)
    message = str(refused.value)
    assert f"states.{STATE}" in message and named in message and "replay: {reason" in message
    raw["replay"] = {"reason": "a bench measurement the model does not explain yet"}
    scene = load_scene(_write(tmp_path, raw, "replay.yaml"))
    assert scene.replay_reason == raw["replay"]["reason"]
    warned = replay_departures(scene.path)
    assert len(warned) == 1 and named in warned[0] and raw["replay"]["reason"] in warned[0]


@pytest.mark.parametrize("q_mech, refused", [(50.0, True), (95.0, True), (150.0, False), (1800.0, False)])
def test_q_mech_outside_the_materials_range_is_refused(tmp_path, q_mech, refused):
    raw = _bare(_raw())
    del raw["states"][STATE]["calibration"]
    raw["states"][STATE]["q_mech"] = q_mech
    path = _write(tmp_path, raw)
    if not refused:
        assert load_scene(path).state(STATE).q_mech == q_mech
        return
    with pytest.raises(SceneError, match=r"q_mech .* outside 100 to 2000"):
        load_scene(path)
    raw["replay"] = {"reason": "a plate on a lossy mount"}
    assert load_scene(_write(tmp_path, raw)).state(STATE).q_mech == q_mech


def test_q_mech_above_the_range_is_implausible():
    """(On this plate a q_mech above 2000 already makes a power factor the bounds refuse.)"""
    figures = scene_figures(load_scene(paths.scenes_dir() / "one_column_1p2mm.yaml"))[0]
    assert dataclasses.replace(figures, q_mech=1999.0).implausibilities() == []
    assert "outside 100 to 2000" in dataclasses.replace(figures, q_mech=2001.0).implausibilities()[0]


def test_a_replay_must_say_why(tmp_path):
    raw = _raw()
    raw["replay"] = {"reason": "  "}
    with pytest.raises(SceneError, match="replay.reason: must say why"):
        load_scene(_write(tmp_path, raw))
    raw["replay"] = "Table 4"
    with pytest.raises(SceneError, match="replay: must be a mapping"):
        load_scene(_write(tmp_path, raw))


def test_every_shipped_replay_is_needed():
    """The paper's scenes replay printed points: each declaration names a departure the
    model finds (a replay that no longer departs should become a plain scene)."""
    for path in sorted(paths.scenes_dir().glob("*.yaml")):
        scene = load_scene(path)
        warned = replay_departures(path)
        if scene.replay_reason is None:
            assert warned == [], path.name
        else:
            assert warned and all(scene.replay_reason in line for line in warned), path.name


def test_the_predicted_state_is_within_the_range_it_is_judged_by(tmp_path):
    """A predicted state takes its q_mech from the build: the range applies to it too."""
    with pytest.raises(SceneError, match="q_mech"):
        _as_predicted(tmp_path, q_mech=40.0)
    _, state = _as_predicted(tmp_path, q_mech=310.0)
    assert math.isfinite(state.resonance_frequency_hz)
