"""After an unclean end (a SIGKILLed run), the next `check` or `run` says the generator was
left driven and at what amplitude, and sets it to its minimum first; `safe` does only that."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap

import pytest

from small_quick import small_quick
from squeezebench import cli, paths
from squeezebench.instruments.bench import sim_bench_config
from squeezebench.protocols.drive_record import left_driven, record_file

#: Killed runs, each a child forked from one warm process (the command's modules imported
#: once, not once per cold interpreter): `squeezebench run` of `small_quick` (quick's kinds of
#: step) in the test's own state folder, SIGKILLed inside the n-th write of an amplitude
#: above 0.2 Vpp (the generator then holds the amplitude before: no process can help that).
KILLER = textwrap.dedent("""
    import json, os, re, signal, sys
    from pyvisa.resources import MessageBasedResource
    from squeezebench import cli
    import squeezebench.commands, squeezebench.protocols.campaign   # what a run imports: once, for every child
    write = MessageBasedResource.write
    trial = {"n": 0, "at": None, "said": None}

    def tapped(resource, message, *args, **kwargs):
        match = re.match(r"^VOLT ([-+0-9.eE]+)$", message)
        if match and float(match.group(1)) > 0.2:
            trial["n"] += 1
            if trial["n"] == trial["at"]:
                with open(trial["said"], "w") as said:
                    said.write(match.group(1))
                os.kill(os.getpid(), signal.SIGKILL)
        return write(resource, message, *args, **kwargs)

    MessageBasedResource.write = tapped
    for line in sys.stdin:
        request = json.loads(line)
        pid = os.fork()
        if pid == 0:
            os.environ["SQUEEZEBENCH_STATE"] = request["state"]
            trial.update(at=request["at"], said=request["said"])
            os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
            sys.exit(cli.main(["run", request["campaign"], "--out", request["out"], "-q"]))
        _, status = os.waitpid(pid, 0)
        print(json.dumps(os.waitstatus_to_exitcode(status)), flush=True)
    """)


@pytest.fixture(scope="module")
def killer(tmp_path_factory):
    """kill(tmp_path, name, at): the amplitude (generator Vpp) the killed run was sending."""
    folder = tmp_path_factory.mktemp("killer")
    script = folder / "killer.py"
    script.write_text(KILLER)
    process = subprocess.Popen([sys.executable, str(script)], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                               stderr=subprocess.PIPE, text=True)

    def kill(tmp_path, name: str, at: int) -> float:
        said = tmp_path / f"{name}.amplitude"
        request = {"campaign": str(small_quick(tmp_path / "campaign")), "out": str(tmp_path / name), "at": at,
                   "said": str(said), "state": os.environ["SQUEEZEBENCH_STATE"]}
        process.stdin.write(json.dumps(request) + "\n")
        process.stdin.flush()
        status = process.stdout.readline()
        assert status and json.loads(status) == -signal.SIGKILL, (status, process.poll())
        return float(said.read_text())

    yield kill
    process.stdin.close()
    assert process.wait(timeout=60) == 0, process.stderr.read()


def test_a_killed_run_is_said_by_the_next_check_which_sets_the_generator_to_minimum(killer, tmp_path, capsys):
    amplitude = killer(tmp_path, "run", at=5)
    config = sim_bench_config(paths.default_scene())
    record = left_driven(config)
    assert record["generator_amplitude_vpp"] == amplitude   # recorded before it was sent
    assert cli.main(["check"]) == 0
    out = capsys.readouterr().out
    first = out.splitlines()[0]
    assert first.startswith("UNCLEAN END") and f"left driven at {amplitude:g} Vpp" in first
    assert "set to its minimum amplitude" in out
    assert not record_file(config).exists()
    assert cli.main(["check"]) == 0   # said once: the generator is at rest now
    assert "UNCLEAN END" not in capsys.readouterr().out


def test_safe_says_the_unclean_end_and_only_brings_the_generator_down(killer, tmp_path, capsys):
    amplitude = killer(tmp_path, "run", at=12)
    assert cli.main(["safe", "--bench", "sim", "--json"]) == 0
    found = json.loads(capsys.readouterr().out)
    assert found["left_driven"]["generator_amplitude_vpp"] == amplitude
    assert found["left_driven"]["pid"] != os.getpid()
    assert cli.main(["safe"]) == 0   # nothing recorded: only the minimum, said
    out = capsys.readouterr().out
    assert "UNCLEAN END" not in out and "set to its minimum amplitude" in out


def test_the_next_run_says_the_unclean_end_before_it_drives(killer, tmp_path, capsys):
    amplitude = killer(tmp_path, "run", at=3)
    campaign = str(small_quick(tmp_path / "campaign"))
    assert cli.main(["run", campaign, "--out", str(tmp_path / "run"), "--resume", "-q"]) == 0
    err = capsys.readouterr().err
    assert "UNCLEAN END: the generator at" in err and f"{amplitude:g} Vpp" in err
    assert "UNCLEAN END" in (tmp_path / "run" / "log.txt").read_text()
    assert left_driven(sim_bench_config(paths.default_scene())) is None   # the run ended at rest
