"""After an unclean end (a SIGKILLed run), the next `check` or `run` says the generator was
left driven and at what amplitude, and sets it to its minimum first; `safe` does only that."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import textwrap

from squeezebench import cli, paths
from squeezebench.instruments.bench import sim_bench_config
from squeezebench.protocols.drive_record import left_driven, record_file

#: A real `squeezebench run quick`, SIGKILLed inside the n-th write of an amplitude above
#: 0.2 Vpp (the generator then holds the amplitude before: no process can help that).
KILLED = textwrap.dedent("""
    import os, re, signal, sys
    from pyvisa.resources import MessageBasedResource
    from squeezebench import cli
    write = MessageBasedResource.write
    count = {"n": 0}

    def tapped(resource, message, *args, **kwargs):
        match = re.match(r"^VOLT ([-+0-9.eE]+)$", message)
        if match and float(match.group(1)) > 0.2:
            count["n"] += 1
            if count["n"] == int(sys.argv[2]):
                print(match.group(1), flush=True)
                os.kill(os.getpid(), signal.SIGKILL)
        return write(resource, message, *args, **kwargs)

    MessageBasedResource.write = tapped
    cli.main(["run", "quick", "--out", sys.argv[1], "-q"])
    """)


def _killed_run(tmp_path, name: str, at: int) -> float:
    """The amplitude (generator Vpp) the killed run was sending."""
    script = tmp_path / "killed.py"
    script.write_text(KILLED)
    done = subprocess.run([sys.executable, str(script), str(tmp_path / name), str(at)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == -signal.SIGKILL, done.stderr
    return float(done.stdout.split()[-1])


def test_a_killed_run_is_said_by_the_next_check_which_sets_the_generator_to_minimum(tmp_path, capsys):
    amplitude = _killed_run(tmp_path, "run", at=5)
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


def test_safe_says_the_unclean_end_and_only_brings_the_generator_down(tmp_path, capsys):
    amplitude = _killed_run(tmp_path, "run", at=12)
    assert cli.main(["safe", "--bench", "sim", "--json"]) == 0
    found = json.loads(capsys.readouterr().out)
    assert found["left_driven"]["generator_amplitude_vpp"] == amplitude
    assert found["left_driven"]["pid"] != os.getpid()
    assert cli.main(["safe"]) == 0   # nothing recorded: only the minimum, said
    out = capsys.readouterr().out
    assert "UNCLEAN END" not in out and "set to its minimum amplitude" in out


def test_the_next_run_says_the_unclean_end_before_it_drives(tmp_path, capsys):
    amplitude = _killed_run(tmp_path, "run", at=3)
    assert cli.main(["run", "quick", "--out", str(tmp_path / "run"), "--resume", "-q"]) == 0
    err = capsys.readouterr().err
    assert "UNCLEAN END: the generator at" in err and f"{amplitude:g} Vpp" in err
    assert "UNCLEAN END" in (tmp_path / "run" / "log.txt").read_text()
    assert left_driven(sim_bench_config(paths.default_scene())) is None   # the run ended at rest
