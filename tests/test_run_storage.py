"""Nothing measured is ever deleted, and one process at a time writes a run directory.

A completed small campaign is copied per test, damaged the way the stress test damaged
runs (a corrupted middle journal line, a deleted journal, a lost step file, a stray
.DS_Store, a second writer), then resumed or reported. Every byte measured before the
damage must still be somewhere in the run directory (in place or in quarantine/).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from squeezebench import cli
from squeezebench.protocols.campaign import CampaignError, run_campaign
from squeezebench.protocols.storage import RunStore, StorageError, read_measurements
from test_campaign_resume import small_campaign


@pytest.fixture(scope="module")
def completed(small_campaign_run):
    """The small campaign completed (the session's, conftest; never written into): its campaign, its run."""
    campaign, run_dir, _ = small_campaign_run
    return campaign, run_dir


@pytest.fixture
def run(completed, tmp_path):
    campaign, run_dir = completed
    copy = tmp_path / "run"
    shutil.copytree(run_dir, copy)
    return campaign, copy


def digests(root: Path, folders=("measurements", "waveforms")) -> dict[str, str]:
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for folder in folders for p in (root / folder).rglob("*") if p.is_file()}


def assert_nothing_lost(before: dict[str, str], run_dir: Path) -> None:
    """Every file measured before is still in the run directory, byte for byte."""
    kept = {hashlib.sha256(p.read_bytes()).hexdigest() for p in run_dir.rglob("*.parquet")}
    assert set(before.values()) <= kept


def sorted_rows(run_dir):
    return read_measurements(run_dir).sort_values(["run_name", "step_id", "point_index"]).reset_index(drop=True)


@pytest.mark.parametrize("durable", [True, False])
def test_a_run_is_fsynced_unless_it_is_a_temporary_one(completed, tmp_path, monkeypatch, durable):
    # a scratch run (a plan's, deleted once read) skips the fsyncs; the same files either way
    campaign, reference = completed
    synced = []
    real_fsync = os.fsync
    monkeypatch.setattr(os, "fsync", lambda fd: synced.append(fd) or real_fsync(fd))
    run_dir = run_campaign(campaign, out_dir=tmp_path / "run", say=lambda message: None, durable=durable)
    assert bool(synced) == durable
    assert digests(run_dir) == digests(reference)
    assert RunStore(run_dir).verify() == []


def test_a_durable_step_syncs_each_waveform_once_and_its_folders_once(tmp_path, monkeypatch):
    """A step's waveforms are staged in a hidden folder renamed whole: each file is fsynced
    and none renamed on its own, the staging folder is fsynced once (not once per file),
    and the rename of it is fsynced before the step's table (and then its journal line)."""
    import pandas as pd

    store = RunStore(tmp_path / "run")
    synced, renamed = [], []
    real_fsync, real_replace = os.fsync, os.replace
    monkeypatch.setattr(os, "fsync", lambda fd: synced.append(Path(os.readlink(f"/proc/self/fd/{fd}")))
                        or real_fsync(fd))
    monkeypatch.setattr(os, "replace", lambda a, b: renamed.append((Path(a), Path(b))) or real_replace(a, b))
    frame = pd.DataFrame({"time_s": [0.0, 1e-6], "piezo_voltage_v": [0.0, 1.0]})
    files = store.write_step("sweep", "s01", [{"point_index": i} for i in range(3)],
                             {i: (frame, {"point": i}) for i in range(3)})
    folder = tmp_path / "run" / "waveforms" / "sweep"
    staging = folder / ".s01.partial"
    assert [b for _, b in renamed] == [folder / "s01", tmp_path / "run" / "measurements" / "sweep" / "s01.parquet"]
    assert synced[:5] == [staging / "0000.parquet", staging / "0001.parquet", staging / "0002.parquet", staging,
                          folder]
    table = tmp_path / "run" / "measurements" / "sweep"
    assert [path.parent for path in synced[5:]] == [table, table.parent]   # its temporary file, then its folder
    assert set(files) == {"measurements/sweep/s01.parquet", *(f"waveforms/sweep/s01/{i:04d}.parquet" for i in range(3))}


def test_journal_entries_carry_the_checksums_of_their_files(run):
    _, run_dir = run
    for entry in RunStore(run_dir).journal():
        assert f"measurements/{entry['run']}/{entry['step']}.parquet" in entry["files"]
        for relative, digest in entry["files"].items():
            assert hashlib.sha256((run_dir / relative).read_bytes()).hexdigest() == digest
    assert RunStore(run_dir).verify() == []


def test_corrupted_middle_journal_line_loses_no_file(run):
    campaign, run_dir = run
    expected = sorted_rows(run_dir)
    before = digests(run_dir)
    journal = run_dir / "journal.jsonl"
    lines = journal.read_bytes().splitlines(keepends=True)
    middle = len(lines) // 2
    lines[middle] = lines[middle][:10] + b"\xff" + lines[middle][11:]   # one corrupted byte
    journal.write_bytes(b"".join(lines))
    said = []
    run_campaign(campaign, resume=True, out_dir=run_dir, say=said.append)
    assert_nothing_lost(before, run_dir)
    assert any(f"line {middle + 1}" in message for message in said)
    quarantined = list((run_dir / "quarantine").rglob("*"))
    assert any(p.name == "journal.jsonl" for p in quarantined)   # the journal as found
    # The later steps stayed complete: only the damaged line's step was measured again
    # (the same rows; its campaign bench time now counts from the end of the run).
    assert len(RunStore(run_dir).journal()) == len(lines)
    assert_frame_equal_rows(sorted_rows(run_dir).drop(columns="bench_time_s"),
                            expected.drop(columns="bench_time_s"))
    log = (run_dir / "log.txt").read_text()
    assert "quarantine" in log and f"line {middle + 1}" in log


def assert_frame_equal_rows(actual, expected):
    import pandas as pd

    pd.testing.assert_frame_equal(actual, expected, check_exact=True)


def test_a_deleted_journal_quarantines_every_step_and_says_so(run):
    campaign, run_dir = run
    before = digests(run_dir)
    (run_dir / "journal.jsonl").unlink()
    said = []
    run_campaign(campaign, resume=True, out_dir=run_dir, say=said.append)
    assert_nothing_lost(before, run_dir)
    assert any("journal.jsonl is missing" in message for message in said)
    assert sum("moved to quarantine" in message for message in said) >= len(before) // 10


def test_a_missing_step_file_stops_the_report(run, capsys):
    _, run_dir = run
    lost = next((run_dir / "measurements" / "cutting").glob("*.parquet"))
    lost.unlink()
    assert cli.main(["report", str(run_dir)]) == cli.EXIT_USER_ERROR
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and str(lost) in err and "--allow-missing" in err
    assert not (run_dir / "report").exists()


@pytest.mark.parametrize("damage", ["missing", "checksum"])
def test_a_damaged_step_is_measured_again_on_resume(run, completed, damage, capsys):
    """A step whose file is lost or changed counts as not done: resume measures it again,
    keeps what was left of it in quarantine, and the run reports again."""
    campaign, run_dir = run
    before = digests(run_dir)
    step_dir = next((run_dir / "waveforms" / "detuning").iterdir())
    damaged = next(step_dir.glob("*.parquet"))
    if damage == "missing":
        damaged.unlink()
    else:
        damaged.write_bytes(damaged.read_bytes() + b"\0")
    said = []
    run_campaign(campaign, resume=True, out_dir=run_dir, say=said.append)
    assert any(str(damaged) in message and "measured again" in message for message in said)
    assert damaged.is_file() and RunStore(run_dir).verify() == []
    intact = {name: digest for name, digest in before.items() if Path(name) != damaged.relative_to(run_dir)}
    assert_nothing_lost(intact, run_dir)   # the step's other files, as measured, are in quarantine
    assert len(sorted_rows(run_dir)) == len(sorted_rows(completed[1]))   # the step's rows are back
    capsys.readouterr()
    assert cli.main(["report", str(run_dir), "-q"]) == 0


def test_a_step_file_failing_its_checksum_is_reported(run):
    _, run_dir = run
    changed = next((run_dir / "waveforms" / "detuning").rglob("*.parquet"))
    changed.write_bytes(changed.read_bytes() + b"\0")
    (problem,) = RunStore(run_dir).verify()
    assert str(changed) in problem and "checksum" in problem


def test_a_stray_ds_store_is_left_alone(run):
    campaign, run_dir = run
    for folder in (run_dir / "measurements", run_dir / "measurements" / "cutting", run_dir / "waveforms"):
        (folder / ".DS_Store").write_bytes(b"\0\0\0\1Bud1")
    said = []
    run_campaign(campaign, resume=True, out_dir=run_dir, say=said.append)
    assert said == [] and (run_dir / "measurements" / "cutting" / ".DS_Store").exists()


def test_a_second_resume_is_refused_naming_the_first(completed, tmp_path):
    """Two `run --resume` on one directory: the first (a real process, paused while it
    drives the bench) holds the lock; the second is refused with its pid and changes
    nothing; SIGTERM ends the first cleanly, and a later resume completes the run."""
    campaign, reference_dir = completed
    run_dir = tmp_path / "run"
    first = subprocess.Popen([sys.executable, "-c", textwrap.dedent(f"""
        import sys, time
        from pyvisa.resources import MessageBasedResource
        from squeezebench import cli
        write, count = MessageBasedResource.write, [0]
        def paused(resource, message, *args, **kwargs):
            count[0] += 1
            if count[0] == 200:
                print("driving", flush=True)
                time.sleep(60)
            return write(resource, message, *args, **kwargs)
        MessageBasedResource.write = paused
        sys.exit(cli.main(["run", {str(campaign)!r}, "--out", {str(run_dir)!r}, "--resume"]))
        """)], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert first.stdout.readline().strip() == "driving"
        before = digests(run_dir) if (run_dir / "measurements").exists() else {}
        journal = (run_dir / "journal.jsonl").read_bytes()
        with pytest.raises(StorageError, match=f"pid {first.pid}"):
            run_campaign(campaign, resume=True, out_dir=run_dir)
        assert (run_dir / "journal.jsonl").read_bytes() == journal
        assert (digests(run_dir) if (run_dir / "measurements").exists() else {}) == before
        first.send_signal(signal.SIGTERM)
        assert first.wait(timeout=60) == 130
    finally:
        first.kill()
        first.wait()
    run_campaign(campaign, resume=True, out_dir=run_dir, say=lambda m: None)
    assert_frame_equal_rows(read_measurements(run_dir), read_measurements(reference_dir))


def test_a_directory_that_is_not_a_run_is_never_written_into(completed, tmp_path):
    campaign, _ = completed
    users = tmp_path / "users_folder"
    users.mkdir()
    (users / "campaign.yaml").write_text("my own notes\n")
    for resume in (False, True):
        with pytest.raises(CampaignError, match="not empty and holds no run"):
            run_campaign(campaign, resume=resume, out_dir=users)
    assert sorted(p.name for p in users.iterdir()) == ["campaign.yaml"]
    assert (users / "campaign.yaml").read_text() == "my own notes\n"


def test_a_malformed_manifest_is_one_message(run):
    campaign, run_dir = run
    (run_dir / "manifest.json").write_text('{"campaign": 1')
    with pytest.raises(StorageError, match="manifest.json: not a valid manifest"):
        run_campaign(campaign, resume=True, out_dir=run_dir)


def test_a_malformed_journal_entry_is_quarantined_not_obeyed(run):
    campaign, run_dir = run
    expected = sorted_rows(run_dir)
    entry = json.loads((run_dir / "journal.jsonl").read_bytes().splitlines()[-1])
    with open(run_dir / "journal.jsonl", "ab") as handle:
        handle.write(b'{"run": "cutting", "step": 3}\n')
        handle.write(json.dumps({**entry, "files": ["not", "a", "mapping"]}).encode() + b"\n")
    assert cli.main(["report", str(run_dir)]) == cli.EXIT_USER_ERROR   # one message, no traceback
    said = []
    run_campaign(campaign, resume=True, out_dir=run_dir, say=said.append)
    assert any("field 'step'" in message for message in said)
    assert any("field 'files'" in message for message in said)
    assert_frame_equal_rows(sorted_rows(run_dir), expected)
    assert os.path.getsize(run_dir / "journal.jsonl") > 0


def test_a_fixed_bench_lets_a_stopped_run_continue(completed, tmp_path, capsys):
    """A scene fault (the scope drops off the bus) stops the run; the operator removes it
    from the scene. Resume refuses the changed file unless told; told, it continues, the
    manifest keeps both versions and the journal says which steps used which."""
    from squeezebench.instruments.errors import ConnectionLost
    from test_protocols_support import noise_free_scene

    campaign = small_campaign(tmp_path, effects=[{"disconnect": {"at_message": 1200, "instrument": 2}}])
    run_dir = tmp_path / "run"
    with pytest.raises(ConnectionLost):
        run_campaign(campaign, out_dir=run_dir, say=lambda message: None)
    stopped_after = len(RunStore(run_dir).journal())
    assert stopped_after >= 1
    noise_free_scene(tmp_path, "one_column_1mm.yaml")   # the fix: the same scene without the fault
    journal = (run_dir / "journal.jsonl").read_bytes()
    capsys.readouterr()
    assert cli.main(["run", str(campaign), "--out", str(run_dir), "--resume"]) == cli.EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert "--accept-changed-bench" in err and "one_column_1mm.yaml changed" in err
    assert (run_dir / "journal.jsonl").read_bytes() == journal
    assert cli.main(["run", str(campaign), "--out", str(run_dir), "--resume", "--accept-changed-bench"]) == 0
    versions = RunStore(run_dir).manifest()["inputs"]["one_column_1mm.yaml"]["versions"]
    assert len(versions) == 2 and versions[1]["steps_before"] == stopped_after
    assert all((run_dir / v["copy"]).is_file() for v in versions)
    used = [entry["inputs"]["one_column_1mm.yaml"] for entry in RunStore(run_dir).journal()]
    assert used == [versions[0]["sha256"]] * stopped_after + [versions[1]["sha256"]] * (len(used) - stopped_after)
    rows = read_measurements(run_dir)   # each row names the scene version that produced it
    assert set(rows["bench_input_sha256"]) == {v["sha256"] for v in versions}
    assert_frame_equal_rows(rows.drop(columns="bench_input_sha256"),
                            read_measurements(completed[1]).drop(columns="bench_input_sha256"))   # uninterrupted
