"""Any file `validate` accepts, the command that uses it accepts too; what that command
refuses for a file reason, `validate` refuses first, in the same words.

The files are mutations of the shipped ones (a number zeroed, negated, halved, doubled or
multiplied by 1000, a text made unknown or 300 characters long, a key or item dropped),
drawn by hypothesis with a fixed seed. The running command is stopped where its file checks
end: `run` when it would open the instruments (a stop, exit 130, as Ctrl-C there), `design`
once its physics is solved. So an example costs the checks, not a measurement.
"""

from __future__ import annotations

import copy
import tempfile
from pathlib import Path

import pytest
import yaml
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

from squeezebench import cli, paths
from squeezebench.designing import design as design_model
from squeezebench.protocols import campaign as campaign_module

REFUSED, STOPPED = cli.EXIT_USER_ERROR, 130
NUMBER_CHANGES = (0.0, -1.0, 0.5, 2.0, 1000.0)
TEXT_CHANGES = ("no_such_name", "n" * 300)
#: Bounded and derandomized: the suite stays fast and the same from run to run.
#: No shrinking: a failing example is reported as drawn (each costs seconds of checks).
EXAMPLES = settings(max_examples=12, deadline=None, derandomize=True, phases=(Phase.explicit, Phase.generate),
                    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
MUTATION = {"leaf": st.integers(0, 10_000), "change": st.integers(0, 100)}


def leaves(node, where: tuple = ()) -> list[tuple]:
    """The path to every number, text and truth value of a YAML tree."""
    if isinstance(node, dict):
        return [p for key, value in node.items() for p in leaves(value, (*where, key))]
    if isinstance(node, list):
        return [p for i, value in enumerate(node) for p in leaves(value, (*where, i))]
    return [where] if where else []


def mutated(data, leaf: int, change: int, skip: tuple[str, ...] = ()):
    """`data` with one leaf changed (or dropped): the `leaf`-th, `change` picking how.
    Top-level sections in `skip` are left alone."""
    data = copy.deepcopy(data)
    found = [p for p in leaves(data) if p[0] not in skip]
    where = found[leaf % len(found)]
    parent = data
    for key in where[:-1]:
        parent = parent[key]
    value = parent[where[-1]]
    numeric = isinstance(value, (int, float)) and not isinstance(value, bool)
    changes = (NUMBER_CHANGES if numeric else TEXT_CHANGES) + (None,)
    how = changes[change % len(changes)]
    if how is None:   # dropped
        del parent[where[-1]]
    elif numeric:   # an integer stays one where the change keeps it whole
        new = value * how
        parent[where[-1]] = int(new) if isinstance(value, int) and float(new).is_integer() else new
    else:
        parent[where[-1]] = how
    return data


def _write(folder: Path, name: str, data) -> str:
    path = folder / name
    path.write_text(yaml.safe_dump(data), encoding="utf-8")
    return str(path)


def _shipped(kind_dir: Path, name: str):
    return yaml.safe_load((kind_dir / name).read_text(encoding="utf-8"))


def _cause(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    return err.split(": ", 1)[1]


@pytest.fixture
def stopped_at_the_bench(monkeypatch):
    """`run` stops where it would open the instruments, as a Ctrl-C there would."""
    def stop(config):
        raise KeyboardInterrupt("stopped at the bench by the test")

    monkeypatch.setattr(campaign_module, "open_bench", stop)


def _validate_and_run_agree(folder: Path, capsys, campaign: str) -> str | None:
    """The campaign through `validate`, then `run` (stopped at the bench): accepted by both,
    or refused by both in the same words, nothing written. Returns the refusal."""
    capsys.readouterr()
    out = Path(tempfile.mkdtemp(dir=folder)) / "run"   # tmp_path is one for every example
    if cli.main(["validate", campaign, "-q"]) == 0:
        assert cli.main(["run", campaign, "--out", str(out), "-q"]) == STOPPED, capsys.readouterr().err
        return None
    refused = _cause(capsys)
    assert cli.main(["run", campaign, "--out", str(out), "-q"]) == REFUSED
    assert _cause(capsys) == refused
    assert not out.exists()
    return refused


@EXAMPLES
@given(name=st.sampled_from(["quick.yaml", "cartography.yaml"]), **MUTATION)
def test_a_campaign_validate_accepts_run_accepts(tmp_path, capsys, stopped_at_the_bench, name, leaf, change):
    campaign = _write(tmp_path, name, mutated(_shipped(paths.campaigns_dir(), name), leaf, change))
    _validate_and_run_agree(tmp_path, capsys, campaign)


@EXAMPLES
@given(**MUTATION)
def test_a_scene_validate_accepts_a_run_on_it_accepts(tmp_path, capsys, stopped_at_the_bench, leaf, change):
    """The scene alone and the quick campaign on it. A scene `validate` refuses is refused by
    both for the campaign, naming the scene in the same words; a campaign may also be refused
    for asking the scene what it lacks (a state, a column), by both alike."""
    capsys.readouterr()
    scene = _write(tmp_path, "mutant.yaml", mutated(_shipped(paths.scenes_dir(), "one_column_1mm.yaml"), leaf,
                                                     change, skip=("provenance", "description", "replay")))
    campaign_data = _shipped(paths.campaigns_dir(), "quick.yaml")
    campaign_data["bench"] = {"scene": scene}
    campaign = _write(tmp_path, "on_mutant.yaml", campaign_data)
    scene_refused = None if cli.main(["validate", scene, "-q"]) == 0 else _cause(capsys)
    refused = _validate_and_run_agree(tmp_path, capsys, campaign)
    if scene_refused is not None:
        assert refused is not None and refused.endswith(scene_refused), (refused, scene_refused)


@EXAMPLES
@given(**MUTATION)
def test_a_bench_file_validate_accepts_a_run_on_it_accepts(tmp_path, capsys, stopped_at_the_bench, leaf, change):
    """The example bench file with a stage, and a map on it: `check` refuses what `validate`
    refuses, in the same words (it opens nothing then); a campaign on it is accepted or
    refused by `validate` and `run` alike."""
    capsys.readouterr()
    data = _shipped(paths.benches_dir(), "lab_example.yaml")
    data["resources"]["stage"] = "ASRL2::INSTR"
    data["stage_travel_mm"] = {"x": [0, 300], "y": [0, 200]}
    bench = _write(tmp_path, "bench.yaml", mutated(data, leaf, change))
    if cli.main(["validate", bench, "-q"]) != 0:
        refused = _cause(capsys)
        assert cli.main(["check", "--bench", bench]) == REFUSED
        assert _cause(capsys) == refused
    campaign_data = _shipped(paths.campaigns_dir(), "cartography.yaml")
    campaign_data["bench"] = {"file": bench}
    campaign_data["runs"][0]["plate"]["name"] = "large_plate"   # no scene names it on a real bench
    _validate_and_run_agree(tmp_path, capsys, _write(tmp_path, "map.yaml", campaign_data))


@EXAMPLES
@given(**MUTATION)
def test_a_design_file_validate_accepts_design_accepts(tmp_path, capsys, monkeypatch, leaf, change):
    """The design template, mutated outside its geometry (a new geometry is a plate-model solve
    of tens of seconds; the geometry's bounds have their own tests), through `validate` and
    `design` (stopped once its physics is solved; an infeasible verdict is allowed: it is the
    design's answer, not the file's fault)."""
    capsys.readouterr()
    data = yaml.safe_load(paths.design_template().read_text(encoding="utf-8"))
    data.update(touch_area={"x_mm": [12, 108], "y_mm": [6, 54]}, tolerances={"placement_mm": 0.5, "tan_delta": 0.3},
                from_small_plates={"template_plate": "small_plate_4", "origin": "the paper's Plate 4"})
    design = _write(tmp_path, "design.yaml", mutated(data, leaf, change,
                                                     skip=("resonator", "piezo", "groups", "mode", "description")))
    accepted = cli.main(["validate", design, "-q"]) == 0
    refused = None if accepted else _cause(capsys)
    solve = design_model.predict_physics

    def solved_then_stopped(*args, **kwargs):
        solve(*args, **kwargs)
        raise KeyboardInterrupt("stopped after the physics by the test")

    with monkeypatch.context() as patch:
        patch.setattr(design_model, "predict_physics", solved_then_stopped)
        status = cli.main(["design", design, "--no-layouts", "--allow-infeasible", "--out", str(tmp_path / "out"),
                           "-q"])
    if accepted:
        assert status == STOPPED, capsys.readouterr().err
    else:
        assert status == REFUSED and _cause(capsys) == refused
