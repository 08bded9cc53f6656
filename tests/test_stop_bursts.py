"""Bursts of stop signals at random moments of a run never leave the plate driven.

One subprocess (signals must not reach pytest) runs the trials back to back with the
command's own code path (`squeezebench.__main__.command` under `stops.handled()`, as the
entry point does): each trial resumes a run of `small_quick` (quick's kinds of step at
fewer points), and at a random instrument write sends itself a burst of 2-10 stop signals
(SIGINT, SIGTERM, SIGHUP drawn at random) 0-50 ms apart, the first from inside the write
(mid-command), the rest from a thread. Kept fast by staying in one warm process for both
seeds, and by stopping each trial within the first quarter of a run's writes: a trial
costs the bench's opening and a few steps, and the run it interrupts goes on in the next
trial, so every trial's resume is checked by the chain it belongs to reaching exactly the
rows of an uninterrupted run.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from small_quick import small_quick

HARNESS = textwrap.dedent("""
    import contextlib, io, json, math, os, random, re, signal, sys, threading, time
    from pathlib import Path
    from pyvisa.resources import MessageBasedResource
    from squeezebench import stops
    from squeezebench.__main__ import command
    from squeezebench.instruments.agilent33120a import AMPLITUDE_RANGE_VPP
    from squeezebench.protocols.storage import read_measurements

    campaign, out, n_trials = sys.argv[1], Path(sys.argv[2]), int(sys.argv[3])
    seeds = [int(seed) for seed in sys.argv[4].split(",")]
    for sig in stops.STOP_SIGNALS:   # a signal between two trials is harmless
        signal.signal(sig, lambda *args: None)
    minimums = [low for low, _ in AMPLITUDE_RANGE_VPP.values()]
    state = {"writes": 0, "at": None, "volts": [], "first": None, "burst": None}
    write = MessageBasedResource.write

    def burst(signals, gaps):
        for sig, gap in zip(signals, gaps):
            time.sleep(gap)
            os.kill(os.getpid(), sig)

    def tapped(resource, message, *args, **kwargs):
        state["writes"] += 1
        if state["writes"] == state["at"]:
            signals, gaps = state["plan"]
            state["first"] = len(state["volts"])
            os.kill(os.getpid(), signals[0])
            state["burst"] = threading.Thread(target=burst, args=(signals[1:], gaps))
            state["burst"].start()
        match = re.match(r"^VOLT ([-+0-9.eE]+)$", message)
        if match:
            state["volts"].append(float(match.group(1)))
        return write(resource, message, *args, **kwargs)

    MessageBasedResource.write = tapped

    def one_run(run_dir, at=None, plan=None):
        state.update(writes=0, at=at, plan=plan, volts=[], first=None, burst=None)
        err = io.StringIO()
        with stops.handled(), contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            status = command(["run", campaign, "--out", str(run_dir), "--resume", "-q"])
            if state["burst"] is not None:
                state["burst"].join()   # inside: the burst's last signals are this trial's
        return status, err.getvalue()

    status, _ = one_run(out / "reference")
    n_writes = state["writes"]
    expected = read_measurements(out / "reference")

    def sample(seed):
        rng = random.Random(seed)
        trials, chains, problems, chain = 0, 0, [], 0
        while trials < n_trials:
            run_dir = out / f"seed{seed}_chain{chain}"
            n = rng.randint(2, 10)
            plan = ([rng.choice(stops.STOP_SIGNALS) for _ in range(n)], [rng.uniform(0, 0.05) for _ in range(n - 1)])
            status, err = one_run(run_dir, rng.randrange(1, n_writes // 4), plan)
            if state["first"] is None:   # the run ended before the burst's moment: compare
                assert status == 0, err
                if not read_measurements(run_dir).equals(expected):
                    problems.append(f"chain {chain}: rows differ from the uninterrupted run")
                chains += 1
                chain += 1
                continue
            trials += 1
            volts, first = state["volts"], state["first"]
            before = volts[first - 1] if first else math.inf
            log = (run_dir / "log.txt").read_text() if (run_dir / "log.txt").exists() else ""
            if status != 130:
                problems.append(f"trial {trials}: exit {status}")
            if "Traceback" in err:
                problems.append(f"trial {trials}: traceback {err}")
            if volts and not any(math.isclose(volts[-1], low) for low in minimums):
                problems.append(f"trial {trials}: generator left at {volts[-1]} Vpp")
            if any(v > before for v in volts[first:]):
                problems.append(f"trial {trials}: drive raised after the first signal {volts[first - 1:]}")
            if volts and "last commanded amplitude" not in err:
                problems.append(f"trial {trials}: final message says no amplitude: {err!r}")
            if volts and "last commanded amplitude" not in log:
                problems.append(f"trial {trials}: log.txt says no amplitude")
        # The last chain finishes uninterrupted and is compared too.
        status, err = one_run(out / f"seed{seed}_chain{chain}")
        if status != 0 or not read_measurements(out / f"seed{seed}_chain{chain}").equals(expected):
            problems.append(f"last chain: exit {status}, rows differ or {err}")
        return {"seed": seed, "trials": trials, "chains": chains + 1, "problems": problems}

    print(json.dumps([sample(seed) for seed in seeds]))
    """)


TRIALS = 20   # per seed: 40 trials in all, two seeded draws of moments and bursts (the
             # bursts of whole processes below and `benchmarks/bench_stops.py` sample the same races)
SEEDS = (29, 31)


def test_bursts_of_stop_signals_leave_the_generator_at_minimum_and_resume_exact(tmp_path):
    """Both seeds' trials in one harness: a process start and a warm-up apiece are the
    costliest part of the few trials a seed draws."""
    script = tmp_path / "harness.py"
    script.write_text(HARNESS)
    done = subprocess.run([sys.executable, str(script), str(small_quick(tmp_path / "campaign")), str(tmp_path),
                           str(TRIALS), ",".join(map(str, SEEDS))], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    results = json.loads(done.stdout.strip().splitlines()[-1])
    assert [result["seed"] for result in results] == list(SEEDS)
    for result in results:
        assert result["trials"] >= TRIALS and result["chains"] >= 1, result
        assert result["problems"] == [], result


#: The same bursts against whole processes: each trial is a child forked from one warm
#: harness (nothing imported again) that runs the real entry point, `main()`, under
#: `sys.exit` and interpreter shutdown, as the installed command does. The child signals
#: itself the burst's first signal from inside the k-th generator write and tells the
#: harness, which sends the rest 0-50 ms apart from outside, so later signals land in the
#: bring-down, the final message, `sys.exit` and the interpreter's shutdown (where the
#: default dispositions came back and killed the process: status -2 or -15).
PROCESSES = textwrap.dedent("""
    import json, os, random, select, signal, sys, time
    import tqdm
    from pyvisa.resources import MessageBasedResource
    from squeezebench import stops
    from squeezebench.__main__ import command, main

    campaign, out, n_trials, seed = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    for sig in stops.STOP_SIGNALS:   # the harness itself is never stopped by a stray signal
        signal.signal(sig, signal.SIG_IGN)
    trial = {"writes": 0, "at": None, "first": None, "tell": None}
    write = MessageBasedResource.write

    def tapped(resource, message, *args, **kwargs):
        trial["writes"] += 1
        if trial["writes"] == trial["at"] and message.startswith(("VOLT", "FREQ", "APPL", "OUTP")):
            os.write(trial["tell"], b"!")   # first: the signal may raise before the next call
            os.kill(os.getpid(), trial["first"])
        elif trial["writes"] == trial["at"]:
            trial["at"] += 1   # the burst starts at a generator write
        return write(resource, message, *args, **kwargs)

    MessageBasedResource.write = tapped

    def child(run_dir, err_file, at, first, tell):
        err = os.open(err_file, os.O_WRONLY | os.O_CREAT | os.O_TRUNC)
        os.dup2(err, 2)
        os.dup2(os.open(os.devnull, os.O_WRONLY), 1)
        signal.signal(signal.SIGINT, signal.default_int_handler)   # a terminal's dispositions
        for sig in (signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, signal.SIG_DFL)
        trial.update(writes=0, at=at, first=first, tell=tell)
        sys.exit(main(["run", campaign, "--out", run_dir, "-q"]))   # unwinds the harness: a real exit

    # Warm: the first run of a process imports lazily and solves the plate; every child
    # inherits that. tqdm's monitor thread would be forked mid-sleep: none.
    tqdm.tqdm.monitor_interval = 0
    assert command(["run", campaign, "--out", f"{out}/warm", "-q"]) == 0
    rng = random.Random(seed)
    statuses, problems, trials, finished = {}, [], 0, 0
    while trials < n_trials:
        n = rng.randint(2, 10)
        signals = [rng.choice(stops.STOP_SIGNALS) for _ in range(n)]
        gaps = [rng.uniform(0, 0.05) for _ in range(n - 1)]
        at = rng.randrange(1, 150)
        run_dir, err_file = f"{out}/run{trials}_{finished}", f"{out}/err{trials}_{finished}.txt"
        read_end, tell = os.pipe()
        pid = os.fork()
        if pid == 0:
            os.close(read_end)
            child(run_dir, err_file, at, signals[0], tell)
        os.close(tell)
        ready, _, _ = select.select([read_end], [], [], 120)
        started = bool(ready) and os.read(read_end, 1) == b"!"
        os.close(read_end)
        if started:
            for sig, gap in zip(signals[1:], gaps):
                time.sleep(gap)
                os.kill(pid, sig)   # a zombie until reaped below: never another process
        _, wait_status = os.waitpid(pid, 0)
        status = os.waitstatus_to_exitcode(wait_status)
        if not started:   # the run ended before the burst's write
            finished += 1
            if status != 0:
                problems.append(f"unsignalled run: exit {status}")
            continue
        trials += 1
        statuses[status] = statuses.get(status, 0) + 1
        err = open(err_file).read()
        if status != 130 or "Traceback" in err or "interrupted" not in err:
            problems.append(f"trial {trials}: {[signal.Signals(s).name for s in signals]}, exit {status}, {err!r}")
    print(json.dumps({"trials": trials, "statuses": statuses, "problems": problems}))
    """)


#: The suite's sample of whole-process trials, seeded: each trial's burst and moment are drawn
#: from the seed, so a failure repeats. Before the entry point ignored the stop signals on its
#: way out, 30 of 30 trials ended by a signal: a sample of 12 catches that (each trial is a
#: fork and a bench opening, the suite's longest few seconds of one core). The full 200
#: trials (issue 48, ~70 s of one core) run in `benchmarks/bench_stops.py` with this function.
SUITE_TRIALS = 12
SEED = 41


def whole_process_bursts(out_dir: Path, n_trials: int, seed: int = SEED) -> dict:
    """`n_trials` bursts against whole processes (`PROCESSES`) in one warm harness: the
    trials run, the count of each exit status and the problems found."""
    script = out_dir / "processes.py"
    script.write_text(PROCESSES)
    # small_quick: a trial's burst comes within its first 150 writes (the bench's opening,
    # the deskew), which are quick's; the warm-up runs it whole
    done = subprocess.run([sys.executable, str(script), str(small_quick(out_dir / "campaign")),
                           str(out_dir), str(n_trials), str(seed)], capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_bursts_against_whole_processes_exit_130_every_time(tmp_path):
    """A warm-up run, then per trial the bench's opening, up to 150 writes and the burst's gaps."""
    result = whole_process_bursts(tmp_path, SUITE_TRIALS)
    assert result["trials"] == SUITE_TRIALS and result["statuses"] == {"130": SUITE_TRIALS}, result
    assert result["problems"] == []
