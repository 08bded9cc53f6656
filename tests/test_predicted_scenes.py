"""Predicted beside replay (simbench.predicted): the prediction comes from geometry and
materials only, and a replay that departs from it says so."""
from dataclasses import replace

import pytest

from squeezebench import paths
from squeezebench.simbench.predicted import geometry, predict
from squeezebench.simbench.scene import load_scene


def _scene(name):
    return load_scene(paths.scenes_dir() / f"{name}.yaml")


def test_a_prediction_never_reads_a_printed_result(monkeypatch):
    """The paper's values are out of reach, and the state's replayed resonance (only the
    centre of the mode search) and calibration can move without moving the prediction."""
    monkeypatch.setattr(paths, "paper_values_dir", lambda: pytest.fail("read the paper's values"))
    scene = _scene("one_column_1p2mm")
    state = scene.state("one_powered")
    reference = predict(scene, state)
    for factor in (0.95, 1.05):
        moved = replace(state, resonance_frequency_hz=state.resonance_frequency_hz * factor,
                        q_mech=state.q_mech * 2, calibration=None)
        again = predict(scene, moved)
        # the search centre sizes the mesh, converged to 0.1 % (test_plate_modes.py)
        assert again.frequency_hz == pytest.approx(reference.frequency_hz, rel=1e-3)
        assert again.force_factor_n_per_v == pytest.approx(reference.force_factor_n_per_v, rel=1e-2)


def test_the_large_plate_replay_is_flagged_against_its_prediction():
    scene = _scene("large_plate")
    prediction = predict(scene, scene.state("large"))
    assert prediction.interior_antinodes == 21
    assert prediction.half_wavelength_mm == pytest.approx(9.0, rel=0.05)  # Sec. 5.2's design
    assert any("force factor" in d for d in prediction.departures())


def test_a_cut_is_a_new_geometry_and_can_remove_the_only_column():
    scene = _scene("one_column_1mm")
    state = scene.state("28x41")
    assert geometry(scene, state).length_m == pytest.approx(0.028)
    assert geometry(scene, state).patches == ()
    prediction = predict(scene, state)
    assert prediction.interior_antinodes == 3
    assert "the cut removes every piezo" in prediction.departures()[0]


def test_a_scene_named_as_a_modelled_plate_is_the_plate_the_analysis_models():
    """A map of a scene's plate is compared with `predicted_plates.working_shape` of the plate
    it is named as (the report's MAC, the map planner's continuum): the two must be one plate.
    A flush patch and one 2 mm in differ by 0.94 in MAC on the large plate's (21, 0) mode."""
    from squeezebench.plates import predicted_plates

    def bounds_mm(plate):
        return sorted(tuple(round(b * 1e3, 6) for b in p.bounds) for p in plate.patches)

    scenes = [load_scene(path) for path in sorted(paths.scenes_dir().glob("*.yaml"))]
    modelled_scenes = [scene for scene in scenes if scene.plate.name in predicted_plates.GEOMETRIES]
    assert modelled_scenes, "no shipped scene is named as a plate the analysis models"
    for scene in modelled_scenes:
        simulated = geometry(scene, scene.state(scene.initial_state))
        modelled = predicted_plates.GEOMETRIES[scene.plate.name]()
        assert (simulated.length_m, simulated.width_m, simulated.thickness_m) == pytest.approx(
            (modelled.length_m, modelled.width_m, modelled.thickness_m)), scene.path
        assert bounds_mm(simulated) == bounds_mm(modelled), scene.path
