"""Every way out ends safe: SIGTERM and SIGHUP as Ctrl-C, a lost generator said in capitals,
and a seeded randomized kill-and-resume test with real processes (SIGKILL, SIGTERM).

In-process tests send the signal to this process at the k-th instrument write, so it
lands mid-command-sequence; the subprocess test kills real processes running `squeezebench
run` the same way (children of a small wrapper that patches the PyVISA write, below every
driver) and, for SIGKILL, also inside the storage window between a step's files and its
journal line.
"""

from __future__ import annotations

import json
import os
import random
import signal
import subprocess
import sys
import textwrap
import time
import types

import pandas as pd
import pytest
from pyvisa.resources import MessageBasedResource

from small_quick import SMALL_QUICK_STEPS, small_quick
from squeezebench import stops
from squeezebench.instruments.errors import ConnectionLost
from squeezebench.protocols.campaign import run_campaign
from squeezebench.protocols.storage import RunStore, read_measurements
from test_campaign_resume import reference  # noqa: F401 - the uninterrupted run, a fixture
from test_faults import BusTap, _is_minimum


@pytest.fixture
def as_from_a_terminal():
    """The stop signals' dispositions a user at a terminal has. A test runner started in the
    background of a script has SIGINT ignored (and under nohup SIGHUP), which a run rightly
    keeps ignored (test_nohup_ignored_sighup_does_not_stop_the_run); a test that sends itself
    one of them would see nothing happen."""
    previous = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)}
    signal.signal(signal.SIGINT, signal.default_int_handler)
    for sig in (signal.SIGTERM, signal.SIGHUP):
        if previous[sig] is signal.SIG_IGN:
            signal.signal(sig, signal.SIG_DFL)
    yield
    for sig, handler in previous.items():
        if handler is not None:
            signal.signal(sig, handler)


@pytest.mark.parametrize("sig, fraction", [(signal.SIGTERM, 0.4), (signal.SIGHUP, 0.8)])
def test_sigterm_and_sighup_leave_the_generator_at_minimum(reference, tmp_path, monkeypatch, sig, fraction,
                                                           as_from_a_terminal):
    campaign, expected, n_writes = reference
    original = MessageBasedResource.write
    count = {"n": 0}

    def write(resource, message, *args, **kwargs):
        count["n"] += 1
        if count["n"] == int(fraction * n_writes):
            os.kill(os.getpid(), sig)   # delivered at the next bytecode: mid-sequence
        return original(resource, message, *args, **kwargs)

    monkeypatch.setattr(MessageBasedResource, "write", write)
    tap = BusTap(monkeypatch)   # records the amplitudes the generator received
    with pytest.raises(KeyboardInterrupt, match=signal.Signals(sig).name):
        run_campaign(campaign, out_dir=tmp_path / "run")
    assert _is_minimum(tap.last_amplitude_vpp)
    assert getattr(signal.getsignal(sig), "__name__", None) != "_on_stop"   # restored
    monkeypatch.undo()
    run_campaign(campaign, resume=True, out_dir=tmp_path / "run")
    pd.testing.assert_frame_equal(read_measurements(tmp_path / "run"), expected, check_exact=True)


def test_a_swallowed_interrupt_still_stops_the_run(reference, tmp_path, monkeypatch, as_from_a_terminal):
    """The stress test saw Ctrl-C during start-up swallowed: a KeyboardInterrupt raised
    inside code that catches everything (a __del__, a library's catch-all) is lost, but the
    signal was received, and the run stops before the drive goes up or a step starts."""
    campaign, _, n_writes = reference
    original = MessageBasedResource.write
    count = {"n": 0}

    at_signal = {}

    def write(resource, message, *args, **kwargs):
        count["n"] += 1
        if count["n"] == 30:   # while the bench is set up
            at_signal.update(message=message, handler=signal.getsignal(signal.SIGINT))
            try:
                os.kill(os.getpid(), signal.SIGINT)
                sum(range(1000))   # the handler runs here...
            except BaseException as exc:
                at_signal["swallowed"] = repr(exc)   # ...and its KeyboardInterrupt is swallowed
        return original(resource, message, *args, **kwargs)

    monkeypatch.setattr(MessageBasedResource, "write", write)
    tap = BusTap(monkeypatch)
    before = signal.getsignal(signal.SIGINT)
    try:
        run_campaign(campaign, out_dir=tmp_path / "run")
    except KeyboardInterrupt as exc:
        assert "SIGINT" in str(exc)
    else:   # say what the process was like (it was SIGINT ignored, before the fixture above)
        pytest.fail(f"the run completed: SIGINT's disposition before the run {before!r}, at the "
                    f"signal {at_signal}, stops' state {stops._depth} {stops.received()}")
    assert count["n"] < n_writes // 2 and _is_minimum(tap.last_amplitude_vpp)
    assert RunStore(tmp_path / "run").journal() == []


def test_a_lost_generator_is_said_in_capitals(reference, tmp_path, monkeypatch, capsys):
    campaign, _, n_writes = reference
    original = MessageBasedResource.write
    count = {"n": 0}

    def write(resource, message, *args, **kwargs):
        count["n"] += 1
        if count["n"] >= n_writes // 4:   # the bus is gone for good, mid-step with the drive up
            raise ConnectionResetError("injected: cable pulled")
        return original(resource, message, *args, **kwargs)

    monkeypatch.setattr(MessageBasedResource, "write", write)
    with pytest.raises(ConnectionLost):
        run_campaign(campaign, out_dir=tmp_path / "run")
    err = capsys.readouterr().err
    assert "GENERATOR OUTPUT STATE UNKNOWN" in err and "BY HAND" in err.upper()
    assert "GENERATOR OUTPUT STATE UNKNOWN" in (tmp_path / "run" / "log.txt").read_text()


#: Runs `squeezebench run` in a child process per trial (SIGNAL, WHERE, AT), which kills
#: itself with SIGNAL at instrument write AT ("write") or after the step files of step AT
#: and before its journal line ("files"); reports each child's exit status, the last
#: generator amplitude it wrote and its standard error. The children are forked from one
#: process that has run the campaign once: each is a real process with its own files and
#: locks that dies as a run would, without paying the interpreter's start and the run's
#: imports again (a second apiece, the most of what a trial cost).
KILLER = textwrap.dedent("""
    import json, os, re, signal, sys
    from pyvisa.resources import MessageBasedResource
    from squeezebench import cli
    from squeezebench.protocols.storage import RunStore

    campaign, out, trials = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
    trial = {"sig": None, "where": None, "at": None}
    state = {}
    write, write_step = MessageBasedResource.write, RunStore.write_step

    def tapped(resource, message, *args, **kwargs):
        state["writes"] += 1
        if trial["where"] == "write" and state["writes"] == trial["at"]:
            os.kill(os.getpid(), trial["sig"])
        result = write(resource, message, *args, **kwargs)
        match = re.match(r"^VOLT ([-+0-9.eE]+)$", message)
        if match:
            state["amplitude"] = float(match.group(1))
        return result

    def files_then_kill(self, *args, **kwargs):
        result = write_step(self, *args, **kwargs)
        state["steps"] += 1
        if trial["where"] == "files" and state["steps"] == trial["at"]:
            os.kill(os.getpid(), trial["sig"])
        return result

    MessageBasedResource.write, RunStore.write_step = tapped, files_then_kill

    def run(run_dir):
        state.update(writes=0, steps=0, amplitude=None)
        return cli.main(["run", campaign, "--out", run_dir, "--resume"])

    assert run(f"{out}/warm") == 0   # the modules a run imports as it goes, loaded for every child
    results = []
    for index, (sig, where, at) in enumerate(trials):
        report, err = f"{out}/trial{index}.json", f"{out}/trial{index}.err"
        pid = os.fork()
        if pid == 0:
            os.dup2(os.open(err, os.O_WRONLY | os.O_CREAT | os.O_TRUNC), 2)
            os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
            trial.update(sig=sig, where=where, at=at)
            status = run(f"{out}/trial{index}")
            with open(report, "w") as handle:
                json.dump(state, handle)
            sys.exit(status)
        _, wait_status = os.waitpid(pid, 0)
        results.append({"status": os.waitstatus_to_exitcode(wait_status), "err": open(err).read(),
                        "state": json.load(open(report)) if os.path.exists(report) else None})
    print(json.dumps(results))
    """)


def test_randomized_real_kills_then_resume_lose_and_duplicate_nothing(reference, tmp_path):
    campaign, expected, n_writes = reference
    script = tmp_path / "killer.py"
    script.write_text(KILLER)
    rng = random.Random(18)
    n_steps = expected.groupby(["run_name", "step_id"]).ngroups
    # each way a process dies once: a child process and a resume apiece
    ways = [(signal.SIGKILL, "write"), (signal.SIGKILL, "files"), (signal.SIGTERM, "write")]
    trials = [(int(sig), where, rng.randrange(1, n_steps) if where == "files" else rng.randrange(1, n_writes))
              for sig, where in ways]
    done = subprocess.run([sys.executable, str(script), str(campaign), str(tmp_path), json.dumps(trials)],
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-3000:]
    results = json.loads(done.stdout.strip().splitlines()[-1])
    for trial, ((sig, where, at), result) in enumerate(zip(trials, results, strict=True)):
        run_dir = tmp_path / f"trial{trial}"
        if sig == signal.SIGKILL:
            assert result["status"] == -signal.SIGKILL, result
        else:
            assert result["status"] == 130, result
            assert _is_minimum(result["state"]["amplitude"]), result
        run_campaign(campaign, resume=True, out_dir=run_dir, progress=False, say=lambda message: None)
        rows = read_measurements(run_dir)
        keys = rows[["run_name", "step_id", "point_index"]]
        assert not keys.duplicated().any()                      # 0 duplicated
        pd.testing.assert_frame_equal(rows, expected, check_exact=True)   # 0 lost, 0 changed
        assert RunStore(run_dir).verify() == []


def _command(*args: str) -> list[str]:
    return [os.path.join(os.path.dirname(sys.executable), "squeezebench"), *args]


def _entry_point_started(pid: int) -> bool:
    """The entry point has taken the stop signals over: SIGTERM is in /proc's mask of caught
    signals. The interpreter catches only SIGINT of its own, and before the entry point runs
    (site's .pth files, the console script's imports) no code of the program can catch a
    signal: a test that signalled from the interpreter's own SIGINT handler on raced those
    tens of milliseconds, and lost under load (SIGHUP's default action ended the process)."""
    with open(f"/proc/{pid}/status") as status:
        caught = next(int(line.split()[1], 16) for line in status if line.startswith("SigCgt:"))
    return bool(caught >> (signal.SIGTERM - 1) & 1)


def _as_from_a_terminal() -> None:
    for sig in (signal.SIGINT, signal.SIGHUP):
        signal.signal(sig, signal.SIG_DFL)


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="reads /proc")
def test_a_stop_signal_at_any_moment_of_start_up_exits_130_without_a_traceback(tmp_path):
    """From the moment the entry point runs (while the command imports its modules, parses
    its arguments, opens the bench), any burst of stop signals gives 130 and one line."""
    rng = random.Random(29)
    for trial in range(12):
        sig = rng.choice([signal.SIGINT, signal.SIGTERM, signal.SIGHUP])
        # As from a terminal: a test runner started in the background of a script has SIGINT
        # ignored, and under nohup SIGHUP too, which the command rightly keeps ignored; the
        # user's terminal does not.
        process = subprocess.Popen(_command("run", "quick.yaml", "--out", str(tmp_path / f"run{trial}"), "-q"),
                                   stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                   preexec_fn=_as_from_a_terminal)
        deadline = time.monotonic() + 30.0
        while not _entry_point_started(process.pid):
            assert time.monotonic() < deadline and process.poll() is None, \
                "the command never took its stop signals over before it ended"
            time.sleep(0.002)   # a spinning poll takes a core from the starting command
        time.sleep(rng.uniform(0.02, 0.4))
        burst = [sig, *(rng.choice(stops.STOP_SIGNALS) for _ in range(rng.randint(1, 9)))]
        for later in burst:   # a burst, as a shell's Ctrl-C repeated or a supervisor's TERM then HUP
            process.send_signal(later)
            time.sleep(rng.uniform(0, 0.05))
        out, err = process.communicate(timeout=60)
        assert process.returncode == 130, (burst, err)
        assert "Traceback" not in err and "interrupted" in err


def test_nohup_ignored_sighup_does_not_stop_the_run(tmp_path):
    """A parent that ignores SIGHUP (nohup, a scheduler) keeps it ignored: the run completes."""
    campaign = str(small_quick(tmp_path / "campaign"))
    process = subprocess.Popen(["nohup", *_command("run", campaign, "--out", str(tmp_path / "run"), "-q")],
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    for delay_s in (0.2, 0.8, 1.5, 2.5):   # start-up, bench open, steps
        try:
            process.wait(timeout=delay_s)
            break   # ended: nothing left to signal
        except subprocess.TimeoutExpired:
            process.send_signal(signal.SIGHUP)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 0, err
    assert len(RunStore(tmp_path / "run").journal()) == SMALL_QUICK_STEPS   # every step, the deskew run's included


def test_the_entry_point_imports_nothing_heavy_before_it_takes_the_signals_over():
    """The console script imports `squeezebench.__main__` and then calls `main`, whose first
    act takes the stop signals over: until then only the standard library and these three
    small modules may load (the command's own modules, numpy, pandas come after)."""
    code = ("import sys; before = set(sys.modules); import squeezebench.__main__; "
            "print(' '.join(sorted(set(sys.modules) - before)))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60).stdout.split()
    ours = {name for name in loaded if name.split(".")[0] not in sys.stdlib_module_names}
    assert ours == {"squeezebench", "squeezebench.__main__", "squeezebench.stops"}


def test_a_signal_in_an_import_locks_callback_is_recorded_and_the_next_one_raises():
    """The interpreter swallows an exception raised in importlib's weakref callback `cb` (and
    prints "Exception ignored" with a traceback): a stop there is recorded, not raised, and
    does not count as the first, so the next stop raises."""
    namespace: dict = {}
    exec(compile("def cb():\n    pass\n", "<frozen importlib._bootstrap>", "exec"), namespace)
    in_callback = types.SimpleNamespace(f_code=namespace["cb"].__code__, f_back=None)
    elsewhere = types.SimpleNamespace(f_code=test_nohup_ignored_sighup_does_not_stop_the_run.__code__, f_back=None)
    with stops.handled():
        stops._on_stop(signal.SIGTERM, in_callback)   # no raise
        with pytest.raises(KeyboardInterrupt):
            stops._on_stop(signal.SIGINT, elsewhere)
        stops._on_stop(signal.SIGHUP, elsewhere)   # a later one is only recorded
        assert stops.received() == ["SIGTERM", "SIGINT", "SIGHUP"]


def _stop_in_a_class_body():
    """A stop's KeyboardInterrupt raised in a descriptor's `__set_name__` while a class body
    runs, as a signal can land while an import defines numpy's `finfo`."""
    class Takes:
        def __set_name__(self, owner, name):
            raise KeyboardInterrupt("stopped by SIGINT")

    class Owner:   # noqa: F841 - its creation is what raises
        attribute = Takes()


def test_a_stop_wrapped_by_the_interpreter_is_still_a_stop(monkeypatch, capsys):
    """Python 3.11 re-raises an exception from `__set_name__` as RuntimeError caused by it
    (the start-up burst test met it in numpy's import): the entry point and the command's
    handler find the stop under it and exit 130 with one line, and an error that merely
    happened while a stop was handled stays that error."""
    with pytest.raises(BaseException) as raised:
        _stop_in_a_class_body()
    assert sys.version_info >= (3, 12) or type(raised.value) is RuntimeError   # what the start-up test met
    assert stops.stop_in(raised.value) is not None
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise OSError("generator lost while bringing it down")
    except OSError as lost:
        assert stops.stop_in(lost) is None

    status, err = _through_the_entry_point(monkeypatch, capsys, _stop_in_a_class_body)
    assert status == 130 and err.count("\n") == 1 and "squeezebench run: interrupted (stopped by SIGINT)" in err


def _through_the_entry_point(monkeypatch, capsys, command) -> tuple[int, str]:
    """The entry point's status and standard error for a `run` whose work is `command()`."""
    import squeezebench.__main__ as entry
    from squeezebench import cli

    monkeypatch.setattr(cli, "build_parser", lambda: types.SimpleNamespace(
        parse_args=lambda argv: types.SimpleNamespace(command="run", func=lambda args: command())))
    with stops.handled():
        status = entry.command([])
    return status, capsys.readouterr().err


def _stop_cutting_an_extensions_import(tmp_path):
    """A stop landing while an extension module initialises (it then refuses a second load,
    as numpy 2's do), and a bring-down that imports it again, as the start-up burst test met
    in numpy.linalg."""
    (tmp_path / "once_only.py").write_text(
        "import sys\n"
        "if getattr(sys, '_once_only_loaded', False):\n"
        "    raise ImportError('cannot load module more than once per process')\n"
        "sys._once_only_loaded = True\n"
        "raise KeyboardInterrupt('stopped by SIGTERM')\n")

    def command():
        try:
            import once_only  # noqa: F401
        finally:   # the bring-down needs the module again
            import once_only  # noqa: F401,F811
    return command


def test_an_import_a_stop_cut_short_fails_again_as_the_stop(tmp_path, monkeypatch, capsys):
    """The second import's ImportError is raised while the stop is handled, its context the
    stop: the entry point exits 130 with one line, where any other error met while a stop
    was handled stays that error."""
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delattr(sys, "_once_only_loaded", raising=False)
    command = _stop_cutting_an_extensions_import(tmp_path)
    with pytest.raises(ImportError) as raised:
        command()
    assert stops.stop_in(raised.value) is not None
    assert stops.stop_in(ImportError("no stop behind it")) is None

    monkeypatch.delattr(sys, "_once_only_loaded")
    monkeypatch.delitem(sys.modules, "once_only", raising=False)
    status, err = _through_the_entry_point(monkeypatch, capsys, command)
    assert status == 130 and err.count("\n") == 1 and "squeezebench run: interrupted (stopped by SIGTERM)" in err
