"""One world, two readers: the simulated benches that err as the world errs
(`simbench.systematic_effects`, draw 2) and the budgets' model of that world
(`analysis.budgets`, error model WORLD) must describe the same errors, or the coverage
study scores the budgets against a world they were not sized for. Each check draws the
simulator's own errors (its effects, bench by bench, seeded) and compares them with what
the budgets' public API claims for them; nothing here restates the world's numbers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from squeezebench.analysis.budgets import SPECIFIED, WORLD, Budget, Term
from squeezebench.analysis.uncertainty import velocity_budget
from squeezebench.protocols.variants import ERROR_MODELS, SYSTEMATIC_EFFECTS
from squeezebench.simbench import effects as fx
from squeezebench.simbench.scene import load_scene
from test_sim_support import scene_file

BENCHES = 6000
#: The instrument error whose budget term is no limit read as a rectangle: without a deskew run
#: the CH2 delay is carried as a bias bound of known sign (`uncertainty.delay_term`,
#: `bench_errors.CLAIMED_LIMIT`), and the world draws it with that sign (`world_bias`).
BIAS_BOUNDED = {"current_probe_delay"}
#: The simulated errors that reach a velocity reading (effect: its error parameter), and the
#: velocity budget's term for each.
VELOCITY_ERRORS = {"scope_gain_error": "ch3_rel", "vibrometer_scale_error": "scale_rel",
                   "generator_frequency_error": "frequency_rel"}
VELOCITY_TERMS = {"scope_gain_error": "CH3 gain", "vibrometer_scale_error": "vibrometer decoder scale",
                  "generator_frequency_error": "generator frequency"}
#: |error| / limit at which the drawn shares are compared: inside, at and beyond the limit, and
#: either side of the out-of-specification errors' 1.5 limits.
FRACTIONS_OF_LIMIT = (0.5, 1.0, 1.4, 1.6)


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return load_scene(scene_file(tmp_path_factory.mktemp("world"), effects=[]))


def drawn(scene, name: str, error_model: str, seeds=range(1, BENCHES + 1)) -> list:
    """The effect `name` as the simulator builds it on each bench of `seeds` (`error_model`)."""
    return [fx.EFFECTS[name](scene, draw=ERROR_MODELS[error_model], bench_seed=seed) for seed in seeds]


def claimed(fraction: float, error_model: str = WORLD) -> float:
    """What the budgets claim of one limit +-a under `error_model`: P(|error| <= fraction a),
    from a budget of that limit alone (u = a / sqrt(3))."""
    one_limit = Budget("x", "1", 1.0, (Term("a limit", "B", 1.0 / math.sqrt(3.0), "a limit"),))
    return one_limit.coverage_probability(fraction * math.sqrt(3.0), error_model)


@pytest.mark.parametrize("name", sorted(set(SYSTEMATIC_EFFECTS) - BIAS_BOUNDED))
def test_each_limit_a_budget_reads_as_a_rectangle_is_drawn_as_the_budgets_world_reads_it(scene, name):
    """Spread, share beyond the limit and the out-of-specification errors' share and size: the
    simulator's draws of every instrument error against the budgets' world model of its
    limit, within 4.5 binomial standard errors (the spread's half-limit drifting by a tenth
    moves the share within the limit by 2.4 points; the out-of-specification share doubling
    moves the share between 1.4 and 1.6 limits by 1 point: both over 5 errors)."""
    fractions = np.abs([value / abs(effect.parameters[key])
                        for effect in drawn(scene, name, WORLD) for key, value in effect.values.items()])
    for fraction in FRACTIONS_OF_LIMIT:
        expected = claimed(fraction)
        standard_error = math.sqrt(expected * (1.0 - expected) / fractions.size)
        assert np.mean(fractions <= fraction) == pytest.approx(expected, abs=4.5 * standard_error + 1e-3), fraction


def test_every_simulated_error_reaching_a_velocity_has_a_term_in_its_budget(scene):
    """An instrument error the simulator applies to CH3 (a gain) or to the drive (the
    generator's frequency, through the resonance's slope) is a term of the velocity's
    budget, and the budget has no instrument term the simulator does not draw."""
    reaching = set()
    for name in SYSTEMATIC_EFFECTS:
        effect = fx.EFFECTS[name](scene)   # draw 0: at its limits
        gains = effect.gains() if hasattr(effect, "gains") else np.ones(3)
        delays = effect.delays_s(40e3) if hasattr(effect, "delays_s") else np.zeros(3)
        if gains[2] != 1.0 or delays[2] != 0.0 or "generator" in effect.stages:
            reaching.add(name)
    assert reaching == set(VELOCITY_TERMS)
    budget = velocity_budget({"velocity_pp_mps": 1.0, "velocity_pp_mps_u": 1e-3, "frequency_hz": 40e3,
                              "detuning_slope_per_hz": 1e-3})
    assert {t.name for t in budget.terms if t.type == "B"} == set(VELOCITY_TERMS.values())


@pytest.mark.parametrize("error_model", [WORLD, SPECIFIED])
def test_the_velocitys_u_covers_the_simulated_benches_as_its_budget_claims(scene, error_model):
    """The velocity's error on each simulated bench, from its drawn CH3 gain, decoder scale
    and generator frequency (a reading on resonance, and one on the flank of a Q ~ 300
    resonance as Fig. 2a's detuned points), is covered by the budget's U as often as
    `Budget.coverage_probability` claims under that error model, and at least 95 % of the time."""
    gain, scale, generator = (np.array([effect.values[key] for effect in drawn(scene, name, error_model)])
                              for name, key in VELOCITY_ERRORS.items())
    noise_rel = 1e-3
    noise = np.random.default_rng(46).normal(0.0, noise_rel, BENCHES)
    for slope_times_frequency in (0.0, 300.0):
        budget = velocity_budget({"velocity_pp_mps": 1.0, "velocity_pp_mps_u": noise_rel, "frequency_hz": 40e3,
                                  "detuning_slope_per_hz": slope_times_frequency / 40e3})
        errors = (1.0 + gain) * (1.0 + scale) * (1.0 - slope_times_frequency * generator) * (1.0 + noise) - 1.0
        share = float(np.mean(np.abs(errors) <= budget.expanded_uncertainty))
        expected = budget.coverage_probability(budget.coverage_factor, error_model)
        assert expected >= 0.95 - 1e-3
        assert share == pytest.approx(expected, abs=4.5 * math.sqrt(expected * (1.0 - expected) / BENCHES))

def test_a_benchs_velocity_errors_are_one_draw_for_all_its_plates(tmp_path):
    """The study's coverage interval takes the benches, not the values, as its trials: every
    plate a bench measures reads through the same drawn CH3 gain, decoder scale and generator
    (a coverage study's misses come by whole benches), and another bench draws anew."""
    scenes = [load_scene(scene_file(tmp_path, name, effects=[])) for name in ("one_column_1mm.yaml", "large_plate.yaml")]
    for name in VELOCITY_ERRORS:
        one, other = ([effect.values for effect in drawn(scene, name, WORLD, range(1, 4))] for scene in scenes)
        assert one == other and one[0] != one[1]


@pytest.mark.parametrize("error_model", [WORLD, SPECIFIED])
@pytest.mark.parametrize("previous_w", [0.0, 0.11])
def test_the_resonance_frequencys_u_covers_the_simulated_benches_generators(scene, error_model, previous_w):
    """A search's resonance is off by its bench's drawn generator error (the setting that
    reaches f0 is f0 / (1 + e)), its room's drift (the bench's drawn rate, at the budget's
    limit of alpha and without the plate's lag: its term's rectangle, as the budget reads it),
    its fit's scatter and what the warm plate's correction leaves (`plate_warming`: normal,
    from the heating tolerances): its budget's U (`search_budgets`,
    of a search on a plate at rest and of Table 4's third configuration after a step at
    0.11 W) covers it as often as its budget claims under the error model, and at least 95 %
    of the time: the world factor holds the world's generators, its out-of-specification
    benches among them."""
    from test_search_warming import _budget, _warm_plate_search
    from squeezebench.analysis.plate_warming import ROOM_TERM, TERM
    from squeezebench.plates.warming import ROOM_DRIFT_K_PER_S

    budget = _budget(_warm_plate_search((1.0,) * 5, previous_w, 45.0, peak_w=0.066)[0])
    generator = np.array([effect.values["frequency_rel"] for effect in drawn(scene, "generator_frequency_error",
                                                                             error_model)])
    fit = next(t for t in budget.terms if t.name == "resonance fit on the top")
    room = np.array([effect.parameters["room_drift_k_per_s"] / ROOM_DRIFT_K_PER_S
                     for effect in drawn(scene, "heating_drift", error_model)])
    warming = next(t for t in budget.terms if t.name == TERM)
    room_hz = math.sqrt(3.0) * next(t for t in budget.terms if t.name == ROOM_TERM).std_uncertainty
    rng = np.random.default_rng(46)
    errors_hz = (-generator / (1.0 + generator) * budget.value + room * room_hz
                 + rng.normal(0.0, fit.std_uncertainty, BENCHES) + rng.normal(0.0, warming.std_uncertainty, BENCHES))
    share = float(np.mean(np.abs(errors_hz) <= budget.expanded_uncertainty))
    expected = budget.coverage_probability(budget.coverage_factor, error_model)
    assert expected >= 0.95 - 1e-3
    assert share == pytest.approx(expected, abs=4.5 * math.sqrt(expected * (1.0 - expected) / BENCHES))
