"""No journal, no trust: `report` checks every step file against its checksum, refuses a
run it cannot check (no journal, no manifest) unless told, reads every intact step past a
damaged journal line, and can make a lost or damaged manifest again from the journal."""

from __future__ import annotations

import hashlib
import json

import pandas as pd
import yaml

from squeezebench import cli
from squeezebench.analysis.rundata import load_run
from squeezebench.protocols.campaign import run_campaign
from squeezebench.protocols.storage import RunStore
from test_run_storage import completed, run  # noqa: F401 - fixtures: a completed small campaign, a copy


def _alter_power(path) -> None:
    """What the integrity test did: a Parquet whose numbers were changed after measuring."""
    frame = pd.read_parquet(path)
    numeric = frame.select_dtypes("number").columns
    frame[numeric] = frame[numeric] * 10
    frame.to_parquet(path)


def _one_message(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


def test_a_journal_less_run_with_an_altered_parquet_is_refused_by_report(run, capsys):
    _, run_dir = run
    _alter_power(next((run_dir / "measurements" / "detuning").glob("*.parquet")))
    (run_dir / "journal.jsonl").unlink()
    assert cli.main(["report", str(run_dir)]) == cli.EXIT_USER_ERROR
    err = _one_message(capsys)
    assert "journal.jsonl: missing" in err and "--allow-unverified" in err
    assert not (run_dir / "report").exists()
    assert cli.main(["report", str(run_dir), "--allow-unverified", "-q"]) == 0
    assert "UNVERIFIED" in capsys.readouterr().err


def test_an_altered_parquet_is_refused_and_left_out_with_allow_missing(run, capsys):
    _, run_dir = run
    altered = next((run_dir / "measurements" / "detuning").glob("*.parquet"))
    n_rows = len(load_run(run_dir).measurements)
    n_altered = len(pd.read_parquet(altered))
    _alter_power(altered)
    assert cli.main(["report", str(run_dir)]) == cli.EXIT_USER_ERROR
    assert str(altered) in _one_message(capsys)
    assert cli.main(["report", str(run_dir), "--allow-missing", "-q"]) == 0
    assert len(load_run(run_dir).measurements) == n_rows - n_altered   # its rows, not altered ones


def test_a_deleted_manifest_is_refused_then_rebuilt_from_the_journal(run, capsys):
    campaign, run_dir = run
    before = json.loads((run_dir / "manifest.json").read_text())
    (run_dir / "manifest.json").unlink()
    assert cli.main(["report", str(run_dir)]) == cli.EXIT_USER_ERROR
    assert "manifest.json: missing" in _one_message(capsys)
    assert cli.main(["report", str(run_dir), "--rebuild-manifest", "-q"]) == 0
    rebuilt = json.loads((run_dir / "manifest.json").read_text())
    assert rebuilt["campaign"]["sha256"] == before["campaign"]["sha256"]
    assert {name: entry["sha256"] for name, entry in rebuilt["inputs"].items()} == \
        {name: entry["sha256"] for name, entry in before["inputs"].items()}
    assert rebuilt["instruments"] == before["instruments"]
    run_campaign(campaign, resume=True, out_dir=run_dir, say=lambda message: None)   # resumable again


def test_a_corrupt_manifest_is_one_message_and_rebuilt_with_the_damaged_one_kept(run, capsys):
    _, run_dir = run
    (run_dir / "manifest.json").write_text('{"campaign": 1')
    assert cli.main(["report", str(run_dir)]) == cli.EXIT_USER_ERROR
    assert "--rebuild-manifest" in _one_message(capsys)
    assert cli.main(["report", str(run_dir), "--rebuild-manifest", "-q"]) == 0
    assert [p.read_text() for p in (run_dir / "quarantine").rglob("manifest.json")] == ['{"campaign": 1']


def test_allow_missing_skips_only_the_damaged_lines_and_names_each(run, capsys):
    _, run_dir = run
    journal = run_dir / "journal.jsonl"
    lines = journal.read_bytes().splitlines(keepends=True)
    entries = [json.loads(line) for line in lines]
    assert len(lines) >= 5
    for number in (2, 4):   # lines 2 and 4 damaged, the others intact
        lines[number - 1] = b"{not json\n"
    journal.write_bytes(b"".join(lines))
    assert cli.main(["report", str(run_dir)]) == cli.EXIT_USER_ERROR
    capsys.readouterr()
    assert cli.main(["report", str(run_dir), "--allow-missing", "-q"]) == 0
    err = capsys.readouterr().err
    assert "journal.jsonl line 2" in err and "journal.jsonl line 4" in err
    kept = sum(entry["rows"] for number, entry in enumerate(entries, start=1) if number not in (2, 4))
    assert len(load_run(run_dir).measurements) == kept
    assert len(RunStore(run_dir).journal()) == len(lines) - 2


# -- the run checked whole: every step its campaign plans, every file it was made from ----
def _refused_naming(run_dir, capsys, *named: str) -> str:
    assert cli.main(["report", str(run_dir)]) == cli.EXIT_USER_ERROR
    err = _one_message(capsys)
    assert all(name in err for name in named), err
    assert not (run_dir / "report").exists()
    return err


def _left_out_says(run_dir, flag: str, capsys, *named: str) -> None:
    """With `flag` the report is written, and its page and headline name what it left out."""
    assert cli.main(["report", str(run_dir), flag, "-q"]) == 0
    capsys.readouterr()
    page = (run_dir / "report" / "index.html").read_text()
    headline = (run_dir / "report" / "headline.txt").read_text()
    assert "Left out of this report" in page and headline.startswith("LEFT OUT of this report")
    assert all(name in page and name in headline for name in named)


def test_a_lost_first_journal_line_is_refused_naming_its_step(run, capsys):
    """The harness deleted the first line: report said nothing of `detuning/resonance` and
    wrote a report of the other steps' points with exit 0."""
    _, run_dir = run
    journal = run_dir / "journal.jsonl"
    lines = journal.read_bytes().splitlines(keepends=True)
    lost = json.loads(lines[0])
    journal.write_bytes(b"".join(lines[1:]))
    step = f"step {lost['run']}/{lost['step']}"
    _refused_naming(run_dir, capsys, step, "journal.jsonl", "--allow-missing")
    _left_out_says(run_dir, "--allow-missing", capsys, step)


def test_an_altered_scene_copy_is_refused_naming_the_file(run, capsys):
    _, run_dir = run
    scene = run_dir / "inputs" / "one_column_1mm.yaml"
    text = scene.read_text()
    assert "q_mech: 310\n" in text
    scene.write_text(text.replace("q_mech: 310\n", "q_mech: 400\n", 1))
    _refused_naming(run_dir, capsys, str(scene), "--allow-unverified")
    _left_out_says(run_dir, "--allow-unverified", capsys, str(scene))


def test_an_altered_campaign_copy_is_refused_naming_the_file(run, capsys):
    _, run_dir = run
    copy = run_dir / "campaign.yaml"
    data = yaml.safe_load(copy.read_text())
    data["acquisition"] = {**data.get("acquisition", {}), "averages": 8}
    copy.write_text(yaml.safe_dump(data))
    _refused_naming(run_dir, capsys, str(copy), "--allow-unverified")
    _left_out_says(run_dir, "--allow-unverified", capsys, str(copy))


def test_an_altered_campaign_copy_is_refused_even_with_its_manifest_checksum_altered_too(run, capsys):
    """The journal's lines carry the campaign's checksum: the manifest alone cannot vouch."""
    _, run_dir = run
    copy = run_dir / "campaign.yaml"
    copy.write_text(copy.read_text() + "# edited\n")
    manifest = json.loads((run_dir / "manifest.json").read_text())
    manifest["campaign"]["sha256"] = hashlib.sha256(copy.read_bytes()).hexdigest()
    (run_dir / "manifest.json").write_text(json.dumps(manifest))
    _refused_naming(run_dir, capsys, str(copy), "the journal")


def test_a_zeroed_bench_checksum_in_the_manifest_is_refused_naming_the_field(run, capsys):
    _, run_dir = run
    manifest = json.loads((run_dir / "manifest.json").read_text())
    bench = next(iter(manifest["benches"]))
    manifest["benches"][bench]["bench_input_sha256"] = "0" * 64
    (run_dir / "manifest.json").write_text(json.dumps(manifest))
    field = f"benches.{bench}.bench_input_sha256"
    _refused_naming(run_dir, capsys, "manifest.json", field)
    _left_out_says(run_dir, "--allow-unverified", capsys, field)


def test_an_intact_run_reports_with_nothing_left_out(run, capsys):
    _, run_dir = run
    assert RunStore(run_dir).altered_sources() == []
    assert cli.main(["report", str(run_dir), "-q"]) == 0
    assert capsys.readouterr().err == ""
    assert "Left out" not in (run_dir / "report" / "index.html").read_text()
