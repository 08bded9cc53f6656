"""A campaign killed anywhere and resumed stores exactly the rows of an uninterrupted run.

Faults are injected at the k-th instrument write (PyVISA level, below every driver: a
disconnect, a garbled bus or Ctrl-C in the middle of a command sequence) and at the
storage steps (a crash between a step's files and its journal line). Seeded; the rows
are compared column by column, ignoring only the wall-clock `completed_utc` (journal).
"""

from __future__ import annotations

import random

import pandas as pd
import pytest
from pyvisa.resources import MessageBasedResource

from squeezebench.instruments.errors import ConnectionLost
from squeezebench.protocols.campaign import run_campaign
from squeezebench.protocols.storage import RunStore, read_measurements
from test_protocols_support import ONE_COLUMN_PLATE, noise_free_scene, write_campaign


class InjectedFault(Exception):
    """Stands for an instrument that stops answering mid-campaign."""


#: What the drivers turn an injected fault into (a socket error is a lost connection).
RAISED_AS = {ConnectionResetError: ConnectionLost}


def small_campaign(tmp_path, effects=None):
    scene = str(noise_free_scene(tmp_path, "one_column_1mm.yaml", effects))
    search = {"start_hz": 36000, "stop_hz": 38500, "points": 11, "tolerance_hz": 1.0}
    return write_campaign(tmp_path, [
        {"name": "detuning", "protocol": "detuning", "plate": ONE_COLUMN_PLATE,
         "parameters": {"search": search, "velocity_levels_pp_mps": [0.2], "velocity_ratios": [0.8, 0.5]}},
        {"name": "cutting", "protocol": "resonator_cutting", "plate": ONE_COLUMN_PLATE,
         "parameters": {"search": search, "lengths": [
             {"plate_length_mm": 75, "state": "75x41", "n_antinodes": 9},
             {"plate_length_mm": 59, "state": "59x41", "n_antinodes": 7}]}},
    ], bench={"scene": scene})


class WriteCounter:
    """Counts instrument writes; raises `fault` once, at write number `fail_at`."""

    def __init__(self, monkeypatch, fail_at=None, fault=InjectedFault):
        self.count, self.fail_at, self.fault = 0, fail_at, fault
        original = MessageBasedResource.write

        def write(resource, message, *args, **kwargs):
            self.count += 1
            if self.count == self.fail_at:
                raise self.fault(f"injected at write {self.count}: {message!r}")
            return original(resource, message, *args, **kwargs)

        monkeypatch.setattr(MessageBasedResource, "write", write)


@pytest.fixture(scope="module")
def reference(small_campaign_run):
    """The small campaign uninterrupted (the session's, conftest): its campaign, its rows, its writes."""
    campaign, run_dir, n_writes = small_campaign_run
    return campaign, read_measurements(run_dir), n_writes


def assert_same_rows(actual: pd.DataFrame, expected: pd.DataFrame) -> None:
    assert len(actual) == len(expected)
    pd.testing.assert_frame_equal(actual, expected, check_exact=True)


def test_kill_at_random_instrument_writes_then_resume(reference, tmp_path, monkeypatch):
    campaign, expected, n_writes = reference
    rng = random.Random(20240611)
    # 7 draws: each kind of fault once with one kill and once with two (a resumed run killed
    # again); the stop bursts (test_stop_bursts) chain 40 more interrupted resumes
    for trial in range(7):
        run_dir = tmp_path / f"trial{trial}"
        fault = rng.choice([InjectedFault, KeyboardInterrupt, ConnectionResetError])
        # Up to two kills in one trial: a resumed run may be killed again. The resumed run
        # makes fewer writes, so its kill point may lie beyond its end: then it completes.
        kills = rng.sample(range(1, n_writes), rng.choice([1, 2]))
        for attempt, fail_at in enumerate(kills):
            with monkeypatch.context() as patch:
                counter = WriteCounter(patch, fail_at=fail_at, fault=fault)
                try:
                    run_campaign(campaign, resume=True, out_dir=run_dir)
                except RAISED_AS.get(fault, fault):
                    pass
                else:
                    assert attempt > 0 and counter.count < fail_at, "the first kill must land"
            visible = read_measurements(run_dir)
            # Only completed steps are visible, each once.
            journal = RunStore(run_dir).journal()
            assert len(visible) == sum(entry["rows"] for entry in journal)
        run_campaign(campaign, resume=True, out_dir=run_dir)
        assert_same_rows(read_measurements(run_dir), expected)


@pytest.mark.parametrize("where", ["write_step", "append_journal"])
def test_kill_between_a_steps_files_and_its_journal_line(reference, tmp_path, monkeypatch, where):
    campaign, expected, _ = reference
    rng = random.Random(7)
    for trial in range(3):
        run_dir = tmp_path / f"{where}{trial}"
        fail_at = rng.randrange(1, 8)
        calls = {"n": 0}
        original = getattr(RunStore, where)

        def crashing(self, *args, **kwargs):
            calls["n"] += 1
            result = original(self, *args, **kwargs)   # the files are written...
            if calls["n"] == fail_at:
                raise InjectedFault(f"killed after {where} #{fail_at}")   # ...then the crash
            return result

        with monkeypatch.context() as patch:
            patch.setattr(RunStore, where, crashing)
            with pytest.raises(InjectedFault):
                run_campaign(campaign, out_dir=run_dir)
        run_campaign(campaign, resume=True, out_dir=run_dir)
        assert_same_rows(read_measurements(run_dir), expected)
        assert len(RunStore(run_dir).journal()) == len(read_measurements(run_dir).groupby(
            ["run_name", "step_id"]))


def test_torn_journal_line_is_not_a_step(reference, tmp_path):
    campaign, expected, _ = reference
    run_dir = tmp_path / "torn"
    run_campaign(campaign, out_dir=run_dir)
    journal = run_dir / "journal.jsonl"
    lines = journal.read_bytes().splitlines(keepends=True)
    journal.write_bytes(b"".join(lines[:-1]) + lines[-1][:20])   # killed mid-append
    assert len(RunStore(run_dir).journal()) == len(lines) - 1
    run_campaign(campaign, resume=True, out_dir=run_dir)
    assert_same_rows(read_measurements(run_dir), expected)
    assert len(RunStore(run_dir).journal()) == len(lines)


def test_a_new_run_refuses_an_existing_directory(reference, tmp_path):
    from squeezebench.protocols.campaign import CampaignError

    campaign, _, _ = reference
    run_campaign(campaign, out_dir=tmp_path / "once")
    with pytest.raises(CampaignError, match="--resume"):
        run_campaign(campaign, out_dir=tmp_path / "once")


def test_a_cut_prompt_without_a_terminal_stops_cleanly_and_resumes_with_operator_done(reference, tmp_path, monkeypatch,
                                                                                     capsys):
    """An unattended run (standard input closed) reaches the resonator cut: exit 2 with the
    action named, the drive at minimum, the steps before stored; once the plate is cut,
    `run --resume --operator-done` continues where no terminal is, and stores exactly the
    rows of an uninterrupted run."""
    from squeezebench import cli
    from squeezebench.instruments import bench as bench_module
    from squeezebench.instruments.errors import OperatorUnavailable

    _, expected, _ = reference   # the same campaign, uninterrupted
    folder = tmp_path / "unattended"
    folder.mkdir()
    campaign = small_campaign(folder)

    def no_terminal(operator, instruction, state=None):   # what TerminalOperator does on EOF
        if state is not None:
            raise OperatorUnavailable(instruction, state)

    monkeypatch.setattr(bench_module.SimulatedOperator, "request", no_terminal)
    monkeypatch.setattr(bench_module.SimulatedOperator, "already_done",
                        lambda operator, instruction, state=None: operator._bench.set_state(state))
    run_dir = tmp_path / "run"
    assert cli.main(["run", str(campaign), "--out", str(run_dir), "-q"]) == 2
    message = capsys.readouterr().err
    assert "needs the operator" in message and "--operator-done" in message
    stored = read_measurements(run_dir)
    assert 0 < len(stored) < len(expected)
    assert cli.main(["run", str(campaign), "--out", str(run_dir), "-q", "--resume"]) == 2   # still no terminal
    assert cli.main(["run", str(campaign), "--out", str(run_dir), "-q", "--resume", "--operator-done"]) == 2
    assert "needs the operator" in capsys.readouterr().err   # the next cut needs the person again
    assert cli.main(["run", str(campaign), "--out", str(run_dir), "-q", "--resume", "--operator-done"]) == 0
    assert_same_rows(read_measurements(run_dir), expected)
    assert not (run_dir / "operator_request.json").exists()
    assert cli.main(["run", str(campaign), "--out", str(run_dir), "-q", "--resume", "--operator-done"]) == 2
