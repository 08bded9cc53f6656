"""Faults injected through PyVISA on the simulated bench, and malformed input files.

Faults are raised at MessageBasedResource level (below every driver) so the driver's
own translation to typed errors is what is tested: a VISA timeout, a garbled reply and a
disconnect in the middle of a campaign. Then the same faults named in a scene (the
simulated bench's fault effects), which come back in every resumed session, and a
clipped trace the protocol must re-range. After each: the typed error names what failed,
the generator was last set to its minimum amplitude (the plate is safe to touch), every
completed step is stored and visible, a resume completes the campaign, and no NaN/inf
reaches any stored measurement table.

Malformed scene / campaign / bench files go through the command line: exit status 2, a
message naming the file and the field, never a traceback.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from pyvisa import constants
from pyvisa.errors import VisaIOError
from pyvisa.resources import MessageBasedResource

from squeezebench.instruments.agilent33120a import AMPLITUDE_RANGE_VPP
from squeezebench.instruments.errors import ConnectionLost, GarbledReply, InstrumentError, InstrumentTimeout
from squeezebench.protocols.campaign import run_campaign
from squeezebench.protocols.storage import RunStore, read_measurements
from squeezebench import cli, paths
from squeezebench.yamlfiles import dump_yaml, load_strict
from test_campaign_resume import small_campaign
from test_protocols_support import FAST_ACQUISITION, ONE_COLUMN_PLATE, write_campaign

#: "VOLT 0.1" sets the amplitude; VOLT:OFFS / VOLT:UNIT do not.
_AMPLITUDE_WRITE = re.compile(r"^VOLT ([-+0-9.eE]+)\s*$")


#: How every measurement message ends (MEASUREMENT:IMMED's SOURCE, TYPE, then VALUE?).
MEASUREMENT_VALUE = ";VALUE?"


class BusTap:
    """Watches every write and query; raises `fault` once at the `fail_at`-th write (the
    first from there to a resource whose name holds `fail_on`, if given), or
    answers `garbled` to the `garble_at`-th query ending in `garble_command` (a measurement's
    VALUE? ends the message that also sets its source and type).

    Records the last amplitude written to the generator (after the fault too: the
    DriveController's exit path must still bring it down).
    """

    def __init__(self, monkeypatch, fail_at=None, fault=None, garble_command=None, garble_at=None,
                 garbled=b"#@!", fail_on=None):
        self.writes = 0
        self.queries = 0
        self.fired = False
        self.last_amplitude_vpp = None
        self.fail_at, self.fault, self.fail_on = fail_at, fault, fail_on
        self.garble_command, self.garble_at, self.garbled = garble_command, garble_at, garbled
        original_write = MessageBasedResource.write
        original_query = MessageBasedResource.query
        tap = self

        def write(resource, message, *args, **kwargs):
            tap.writes += 1
            if (tap.fail_at is not None and tap.writes >= tap.fail_at and not tap.fired
                    and (tap.fail_on is None or tap.fail_on in resource.resource_name)):
                tap.fired = True
                raise tap.fault()
            match = _AMPLITUDE_WRITE.match(message)
            result = original_write(resource, message, *args, **kwargs)
            if match:   # only amplitudes the generator actually received
                tap.last_amplitude_vpp = float(match.group(1))
            return result

        def query(resource, message, *args, **kwargs):
            if tap.garble_command is not None and message.endswith(tap.garble_command):
                tap.queries += 1
                if tap.queries == tap.garble_at:
                    tap.fired = True
                    original_query(resource, message, *args, **kwargs)   # keep the bus in step
                    # The driver strips and parses a str; a garbled byte string decodes as-is.
                    return tap.garbled.decode("latin-1")
            return original_query(resource, message, *args, **kwargs)

        monkeypatch.setattr(MessageBasedResource, "write", write)
        monkeypatch.setattr(MessageBasedResource, "query", query)


def visa_timeout():
    return VisaIOError(constants.StatusCode.error_timeout)


def connection_reset():
    return ConnectionResetError("injected: the instrument went away")


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """An uninterrupted run: its rows, and how many writes / MEASUREMENT:IMMED:VALUE? queries it made."""
    tmp_path = tmp_path_factory.mktemp("faults_reference")
    campaign = small_campaign(tmp_path)
    with pytest.MonkeyPatch.context() as monkeypatch:
        tap = BusTap(monkeypatch, garble_command=MEASUREMENT_VALUE)
        run_dir = run_campaign(campaign, out_dir=tmp_path / "run")
    return campaign, read_measurements(run_dir), tap.writes, tap.queries


def assert_no_nonfinite(run_dir: Path) -> None:
    """Every numeric column of every stored parquet file (tables and waveforms) is finite
    where it is not null (nulls are the storage's 'not measured')."""
    files = sorted(Path(run_dir).rglob("*.parquet"))
    assert files, "no parquet files stored"
    for path in files:
        frame = pd.read_parquet(path)
        for column in frame.columns:
            series = frame[column]
            if pd.api.types.is_bool_dtype(series) or not pd.api.types.is_numeric_dtype(series):
                continue
            values = series.dropna().to_numpy(dtype=float)
            assert np.isfinite(values).all(), f"{path}: column {column} holds NaN/inf"


def _is_minimum(amplitude_vpp: float) -> bool:
    # The minimum depends on the generator's load setting (50 ohm or high Z); either
    # setting's minimum is "at its minimum amplitude".
    return any(math.isclose(amplitude_vpp, low) for low, _ in AMPLITUDE_RANGE_VPP.values())


def _resume_and_compare(campaign, run_dir, expected):
    run_campaign(campaign, resume=True, out_dir=run_dir)
    pd.testing.assert_frame_equal(read_measurements(run_dir), expected, check_exact=True)
    assert_no_nonfinite(run_dir)


@pytest.mark.parametrize("fraction", [0.3, 0.7])
def test_visa_timeout_stops_safely_and_resumes(reference, tmp_path, monkeypatch, fraction):
    campaign, expected, n_writes, _ = reference
    run_dir = tmp_path / "run"
    with monkeypatch.context() as patch:
        tap = BusTap(patch, fail_at=int(n_writes * fraction), fault=visa_timeout)
        with pytest.raises(InstrumentTimeout) as caught:
            run_campaign(campaign, out_dir=run_dir)
    assert caught.value.operation   # names the command waited for
    assert caught.value.operation in str(caught.value)
    assert tap.last_amplitude_vpp is not None and _is_minimum(tap.last_amplitude_vpp)
    # At 30 % of the writes the first step may still be running: nothing is stored yet.
    journal = RunStore(run_dir).journal()
    if journal:
        assert len(read_measurements(run_dir)) == sum(e["rows"] for e in journal)
        assert_no_nonfinite(run_dir)
    _resume_and_compare(campaign, run_dir, expected)


def test_garbled_measurement_reply_names_the_command(reference, tmp_path, monkeypatch):
    campaign, expected, _, n_queries = reference
    run_dir = tmp_path / "run"
    with monkeypatch.context() as patch:
        tap = BusTap(patch, garble_command=MEASUREMENT_VALUE, garble_at=n_queries // 2)
        with pytest.raises(GarbledReply) as caught:
            run_campaign(campaign, out_dir=run_dir)
    assert caught.value.command.startswith("MEASUREMENT:IMMED:SOURCE") and caught.value.command.endswith("VALUE?")
    assert "MEASUREMENT:IMMED:SOURCE" in str(caught.value) and "#@!" in str(caught.value)
    assert tap.last_amplitude_vpp is not None and _is_minimum(tap.last_amplitude_vpp)
    journal = RunStore(run_dir).journal()
    assert journal, "half-way through, some steps must be complete"
    assert len(read_measurements(run_dir)) == sum(e["rows"] for e in journal)
    assert_no_nonfinite(run_dir)
    _resume_and_compare(campaign, run_dir, expected)


def test_disconnect_mid_campaign_stops_safely_and_resumes(reference, tmp_path, monkeypatch):
    campaign, expected, n_writes, _ = reference
    run_dir = tmp_path / "run"
    with monkeypatch.context() as patch:
        tap = BusTap(patch, fail_at=n_writes // 2, fault=connection_reset, fail_on="TCPIP")   # the scope
        with pytest.raises(ConnectionLost) as caught:
            run_campaign(campaign, out_dir=run_dir)
    assert "went away" in str(caught.value) and caught.value.role == "scope"
    assert tap.last_amplitude_vpp is not None and _is_minimum(tap.last_amplitude_vpp)
    journal = RunStore(run_dir).journal()
    assert journal
    assert len(read_measurements(run_dir)) == sum(e["rows"] for e in journal)
    assert_no_nonfinite(run_dir)
    _resume_and_compare(campaign, run_dir, expected)


def test_repeated_faults_then_resume_leave_only_finite_values(reference, tmp_path, monkeypatch):
    """Timeout, then a garbled reply, then a disconnect on successive resumes."""
    campaign, expected, n_writes, n_queries = reference
    run_dir = tmp_path / "run"
    faults = [dict(fail_at=n_writes // 5, fault=visa_timeout),
              dict(garble_command=MEASUREMENT_VALUE, garble_at=max(1, n_queries // 5)),
              dict(fail_at=n_writes // 5, fault=connection_reset)]
    for fault in faults:
        with monkeypatch.context() as patch:
            tap = BusTap(patch, **fault)
            try:
                run_campaign(campaign, resume=True, out_dir=run_dir)
            except (InstrumentTimeout, GarbledReply, ConnectionLost):
                pass
        if tap.fired:
            assert tap.last_amplitude_vpp is not None and _is_minimum(tap.last_amplitude_vpp)
        if RunStore(run_dir).journal():
            assert_no_nonfinite(run_dir)
    _resume_and_compare(campaign, run_dir, expected)


# -- malformed input files through the command line -----------------------------------------
def _cli(argv, capsys):
    status = cli.main([str(a) for a in argv])
    captured = capsys.readouterr()
    return status, captured.err


def _assert_user_error(status, err, *words):
    assert status == 2
    assert "Traceback" not in err
    for word in words:
        assert str(word) in err, f"{word!r} not in {err!r}"


SEARCH = {"start_hz": 36000, "stop_hz": 38500, "points": 11, "tolerance_hz": 1.0}


@pytest.mark.parametrize("broken, field", [
    ({"runs": []}, "runs"),
    ({"runs": [{"name": "a b", "protocol": "detuning", "plate": ONE_COLUMN_PLATE}]}, "runs[0].name"),
    ({"runs": [{"name": "a", "protocol": "nope", "plate": ONE_COLUMN_PLATE}]}, "runs[0].protocol"),
    ({"runs": [{"name": "a", "protocol": "detuning", "plate": ONE_COLUMN_PLATE}], "colour": 1}, "colour"),
    ({"runs": [{"name": "a", "protocol": "detuning", "plate": ONE_COLUMN_PLATE}],
      "acquisition": {"averages": "many"}}, "averages"),
    ({"runs": [{"name": "a", "protocol": "detuning", "plate": ONE_COLUMN_PLATE, "parameters": {"search": SEARCH},
                "bench": {"scene": "no_such_scene.yaml"}}]}, "runs[0].bench.scene"),
])
def test_malformed_campaign_file(tmp_path, capsys, broken, field):
    campaign = {"name": "broken", "bench": {"scene": "one_column_1mm.yaml"},
                "acquisition": FAST_ACQUISITION, **broken}
    path = tmp_path / "broken.yaml"
    path.write_text(dump_yaml(campaign))
    status, err = _cli(["run", path, "--out", tmp_path / "run"], capsys)
    _assert_user_error(status, err, path, field)


def test_campaign_file_that_is_not_yaml(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text("runs: [unclosed\n  - : :")
    status, err = _cli(["run", path, "--out", tmp_path / "run"], capsys)
    _assert_user_error(status, err, path)


def test_malformed_scene_file(tmp_path, capsys):
    """A scene with an unknown top-level key and one with a key removed: both named."""
    scene = load_strict((paths.scenes_dir() / "one_column_1mm.yaml").read_text())
    cases = []
    unknown = dict(scene, not_a_scene_field=1)
    cases.append((unknown, "not_a_scene_field"))
    for key in scene:   # the first required key, removed
        if key not in ("effects", "name", "description"):
            missing = {k: v for k, v in scene.items() if k != key}
            cases.append((missing, key))
            break
    for i, (data, field) in enumerate(cases):
        path = tmp_path / f"scene{i}.yaml"
        path.write_text(dump_yaml(data))
        campaign = write_campaign(tmp_path, [{"name": "r", "protocol": "resonance_search",
                                              "plate": ONE_COLUMN_PLATE, "parameters": {"search": SEARCH}}],
                                  name=f"c{i}", bench={"scene": str(path)})
        status, err = _cli(["run", campaign, "--out", tmp_path / f"run{i}"], capsys)
        _assert_user_error(status, err, path.name, field)


@pytest.mark.parametrize("text, field", [
    ("generator: {resource: GPIB0::10::INSTR}\n", "generator"),   # roles belong under resources
    ("- just\n- a list\n", "top level"),
    ("{unclosed", "not valid YAML"),   # check reads bench files as run does
    ("resources: {generator: 5}\n", "resources"),
])
def test_malformed_bench_file(tmp_path, capsys, text, field):
    path = tmp_path / "lab_bench.yaml"
    path.write_text(text)
    status, err = _cli(["check", "--bench", path], capsys)
    _assert_user_error(status, err, path, f": {field}")


# -- faults named in the scene (the simulated bench's fault effects) ---------------------------
def _until_complete(campaign, run_dir, expected_error, max_sessions=30):
    """Run, then resume after each fault, until the campaign completes; the errors seen."""
    errors = []
    for _ in range(max_sessions):
        try:
            run_campaign(campaign, resume=True, out_dir=run_dir)
            return errors
        except expected_error as exc:
            errors.append(exc)
            journal = RunStore(run_dir).journal()
            if journal:
                assert len(read_measurements(run_dir)) == sum(e["rows"] for e in journal)
                assert_no_nonfinite(run_dir)
    raise AssertionError(f"still failing after {max_sessions} sessions: {errors[-1]}")


@pytest.mark.parametrize("effect, parameters, error, words", [
    ("disconnect", {"instrument": 2}, ConnectionLost, ("scope", "connection lost")),
    ("bus_timeout", {"instrument": 2}, InstrumentTimeout, ("scope", "no answer")),
    ("truncated_reply", {"instrument": 1}, InstrumentTimeout, ("generator", "no answer")),
    ("garbled_reply", {"instrument": 2}, GarbledReply, ("scope", "not ASCII")),
    ("instrument_error", {"instrument": 1, "count": 3}, InstrumentError, ("generator", "Data out of range")),
])
def test_scene_faults_stop_cleanly_and_every_resume_keeps_what_was_measured(
        reference, tmp_path, monkeypatch, effect, parameters, error, words):
    """The fault comes back in every session (a flaky bench stays flaky), so each session
    completes the steps before it; in the end the rows are the fault-free run's."""
    _, expected, _, _ = reference
    # Message 1200 of a bench session (each run opens its own): a session opens with ~170
    # messages and the longest step takes ~670, so every session completes a step before the
    # fault comes back, and both runs (~1450 and ~1500 messages) meet it.
    campaign = small_campaign(tmp_path, effects=[{effect: {"at_message": 1200, **parameters}}])
    with monkeypatch.context() as patch:
        tap = BusTap(patch)
        errors = _until_complete(campaign, tmp_path / "run", error)
    assert errors, "the fault must fire"
    for word in words:
        assert word in str(errors[0])
    assert tap.last_amplitude_vpp is not None and _is_minimum(tap.last_amplitude_vpp)
    # the faulty scene is another file: every column but its digest is the fault-free run's
    pd.testing.assert_frame_equal(read_measurements(tmp_path / "run").drop(columns="bench_input_sha256"),
                                  expected.drop(columns="bench_input_sha256"), check_exact=True)


def test_a_clipped_trace_is_re_ranged_and_the_campaign_completes(reference, tmp_path):
    _, expected, _, _ = reference
    campaign = small_campaign(tmp_path, effects=[{"clipped_trace": {"at_acquisition": 30, "count": 2}}])
    rows = read_measurements(run_campaign(campaign, out_dir=tmp_path / "run"))
    assert "CH2 clipped" in (tmp_path / "run" / "log.txt").read_text()
    # noise-free: the re-ranged points read what the undisturbed run read, only later
    assert (rows["bench_time_s"] >= expected["bench_time_s"]).all()
    later = [column for column in rows if column.endswith("bench_time_s")] + ["bench_input_sha256"]
    pd.testing.assert_frame_equal(rows.drop(columns=later), expected.drop(columns=later), check_exact=False, rtol=1e-9)
    assert_no_nonfinite(tmp_path / "run")
