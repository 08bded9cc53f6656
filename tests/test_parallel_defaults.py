"""How many local processes a command uses when told nothing (`--workers` unset)."""

from __future__ import annotations

import os

import pytest

from squeezebench import cli
from squeezebench.errors import UserError
from squeezebench.workers import WORKERS_VARIABLE, default_workers


def test_default_is_the_cores_this_process_may_use(monkeypatch):
    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    assert default_workers() == len(os.sched_getaffinity(0))


def test_the_affinity_mask_not_the_machine_decides(monkeypatch):
    monkeypatch.delenv(WORKERS_VARIABLE, raising=False)
    monkeypatch.setattr(os, "sched_getaffinity", lambda pid: {0})
    assert default_workers() == 1


def test_the_variable_overrides_the_cores(monkeypatch):
    monkeypatch.setenv(WORKERS_VARIABLE, "3")
    assert default_workers() == 3


@pytest.mark.parametrize("text", ["0", "-2", "two", "1.5"])
def test_a_bad_variable_is_one_message(monkeypatch, text):
    monkeypatch.setenv(WORKERS_VARIABLE, text)
    with pytest.raises(UserError, match=WORKERS_VARIABLE):
        default_workers()


def test_commands_that_run_trials_take_the_default(monkeypatch):
    monkeypatch.setenv(WORKERS_VARIABLE, "3")
    seen = {}
    parser = cli.build_parser()
    args = parser.parse_args(["study", "--out", "somewhere"])
    assert args.workers is None   # unset until main resolves it, so the variable is read at run time
    monkeypatch.setattr(args, "func", lambda a: seen.setdefault("workers", a.workers) and 0, raising=False)
    monkeypatch.setattr(cli, "build_parser", lambda: type("P", (), {"parse_args": lambda self, argv: args})())
    assert cli.main(["study"]) == 0
    assert seen["workers"] == 3


def test_a_bad_variable_exits_2(monkeypatch, capsys):
    monkeypatch.setenv(WORKERS_VARIABLE, "none")
    assert cli.main(["plan", "quick", "--target-rel-error", "0.05"]) == 2
    assert WORKERS_VARIABLE in capsys.readouterr().err


def test_ci_runs_exactly_the_readmes_test_command():
    """A newcomer's command is the one CI proves: chromium, the venv, the suite on every core."""
    from pathlib import Path

    root = Path(__file__).resolve().parent.parent
    readme = (root / "README.md").read_text()
    command = next(line for line in readme.splitlines() if "pip install -e '.[test]'" in line)
    assert "apt-get install -y chromium" in command and "pytest -n auto" in command
    assert command in (root / ".ci" / "run").read_text().splitlines()
