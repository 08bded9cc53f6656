"""Fast by default (issue 26; issue 17 before it): every figure in one run (not a test).

1. `squeezebench reproduce` wall time with the default flags (workers: the cores this
   process may use) and with one worker (goal, default flags: <= 20 reference units);
2. the default run's study figures against those stored in study_reference.csv
   (`analysis.study.compare_figures`: the p95 errors within their Monte Carlo uncertainty),
   and the study alone (reproduce runs it beside the campaign) with the default workers
   against one (goal on 2 cores: >= 1.7x);
3. a 512-average 10,000-point simulated acquisition and fetch against a single one
   (goal <= 4x);
4. the per-point reduction (analysis.waveforms.reduce_point) of 10,000 samples (goal <= 1 ms);
5. a simulated command (`*IDN?` through the scene backend) against a bare pyvisa-sim
   query (goal <= 2x);
6. `squeezebench plan paper --target-rel-error 0.01` with the default flags (goal <= 8
   reference units), from an empty cache (no plan measured, no plate solved), then again at
   the same target (`protocols.plan_cache`), then twice more each from an empty cache of
   its own: the goal's figure is the first run, a single one as for the other commands;
   the best of the three beside it, as the short operations take the best of several (a
   command of seconds moves more with what else the machine runs than a long one does);
7. the README's test command's suite, `python -m pytest -n auto` (goal <= 80 reference units;
   `--skip-suite` leaves it out: it takes minutes and every core; the full 200 stop-signal
   bursts, which the suite samples 25 of, are `bench_stops.py`).

Every wall time is printed in seconds and in reference units (`benchmarks/reference.py`:
a fixed workload timed before and after the commands in this same run, their mean the
unit), so a figure means the same on another machine (issue 51); goal for `reproduce`
with the default flags: <= 20 reference units.

Wall times of the commands are single runs (they are long), each in a fresh process as a
user starts it (imports and worker processes included), with Python's bytecode cached as a
user's Python keeps it (the issue's figures were so measured): the commands run without
PYTHONDONTWRITEBYTECODE, which a sandbox may set, after the checkout is compiled and the
suite collected once (`warm_bytecode`); the short operations take the best of several. The machine may be shared: each wall time is printed with the
1-minute load average taken just before it and the CPU seconds other processes took while
it ran, so a reader can tell an idle figure from a loaded one (the load average alone still
remembers the previous command).

Run: python benchmarks/bench_scaling.py [--repeat N] [--skip-reproduce] [--skip-plan] [--skip-suite]
     [--write-reference]
"""

from __future__ import annotations

import argparse
import ctypes
import functools
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "benchmarks"))

import reference  # noqa: E402
from bench_simulator import acquire_and_fetch, best_of, idn_queries, open_bare_scope, prepared_scope  # noqa: E402
from squeezebench import commands, paths  # noqa: E402
from squeezebench.workers import default_workers  # noqa: E402
from squeezebench.analysis import study  # noqa: E402
from squeezebench.analysis.waveforms import reduce_point  # noqa: E402
from squeezebench.protocols.plan_cache import CACHE_VARIABLE  # noqa: E402

FREQUENCY_HZ = 37180.0
#: The study's figures (`analysis.study.figures`) of `reproduce` before the study was made
#: cheaper: a cheaper study must give the same figures within their Monte Carlo uncertainty.
REFERENCE = ROOT / "benchmarks" / "study_reference.csv"


def load() -> str:
    return f"load {os.getloadavg()[0]:.2f}"


def machine_busy_s() -> float:
    """CPU seconds this machine has been busy since boot, all processes (Linux /proc/stat:
    user, nice, system, irq, softirq, steal; not idle or iowait)."""
    user, nice, system, _idle, _iowait, irq, softirq, steal = \
        (int(field) for field in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:9])
    return (user + nice + system + irq + softirq + steal) / os.sysconf("SC_CLK_TCK")


def command_s(arguments: list[str], environment: dict[str, str] | None = None,
              allowed: tuple[int, ...] = (0,), module: str = "squeezebench") -> tuple[float, str]:
    """Wall seconds of `python -m MODULE ARGUMENTS` in a fresh process, as a user runs
    it (start-up, imports and worker processes included), the CPU seconds it took (its
    workers' too), and whether the machine was idle meanwhile: the load average before it
    (the minute before, so partly the previous command) and the CPU seconds other processes
    took while it ran (0.0-0.4 measured here with nothing else running; a busy loop beside a
    3.8 s plan showed 3.2)."""
    elapsed_s, figures, _ = command_output(arguments, environment, allowed, module)
    return elapsed_s, figures


def command_output(arguments: list[str], environment: dict[str, str] | None = None,
                   allowed: tuple[int, ...] = (0,), module: str = "squeezebench",
                   python: str = sys.executable) -> tuple[float, str, str]:
    """`command_s` and what the command printed on stdout; `python` runs it (another
    checkout's environment: `bench_plan_cold.py --against`)."""
    before = load()
    adopts_orphans = _adopt_orphans()
    busy_s, own_s = machine_busy_s(), sum(os.times()[2:4])   # the children's user and system time
    start_s = time.perf_counter()
    done = subprocess.run([python, "-m", module, *arguments], capture_output=True, text=True,
                          env={**user_environment(), **(environment or {})}, cwd=ROOT)
    elapsed_s = time.perf_counter() - start_s
    if adopts_orphans:
        _reap_orphans()
    own_s = sum(os.times()[2:4]) - own_s
    others_s = (machine_busy_s() - busy_s) - own_s
    if done.returncode not in allowed:
        raise SystemExit(f"{module} {' '.join(arguments)} exited with {done.returncode}: {done.stderr}")
    return elapsed_s, f"{own_s:.1f} CPU-s; {before}, other processes {max(others_s, 0.0):.1f} CPU-s", done.stdout


@functools.cache
def _adopt_orphans() -> bool:
    """Make this process the reaper of its descendants' orphans (Linux's child subreaper), so
    that their CPU counts in its children's times: a command's workers forked from its
    forkserver (`protocols.parallel.preload`) are that server's children, and the server,
    which outlives the command by a moment, is nobody's once it ends. False elsewhere."""
    try:
        return ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0) == 0   # PR_SET_CHILD_SUBREAPER
    except (OSError, AttributeError):
        return False


def _reap_orphans() -> None:
    """Wait for every process left to this one (`_adopt_orphans`): their CPU is then counted."""
    while True:
        try:
            os.wait()
        except ChildProcessError:
            return


def user_environment() -> dict[str, str]:
    """This process's environment as a user's Python has it: bytecode written and read."""
    return {name: value for name, value in os.environ.items() if name != "PYTHONDONTWRITEBYTECODE"}


def warm_bytecode() -> None:
    """Compile the checkout and collect the suite once (pytest keeps its rewritten test
    modules beside them), as a user's first run leaves them: a sandbox that sets
    PYTHONDONTWRITEBYTECODE compiles every module in every process, 3.5 CPU-s more per
    suite worker's collection alone."""
    subprocess.run([sys.executable, "-m", "compileall", "-q", "-x", r"[/\\]\.venv[/\\]|[/\\]runs[/\\]", str(ROOT)],
                   check=True, env=user_environment(), cwd=ROOT, stdout=subprocess.DEVNULL)
    subprocess.run([sys.executable, "-m", "pytest", "--collect-only", "-q", "-p", "no:cacheprovider"],
                   check=True, env=user_environment(), cwd=ROOT, stdout=subprocess.DEVNULL)


def reproduce_s(workers: int | None) -> tuple[float, str, pd.DataFrame]:
    """`squeezebench reproduce` (`--workers N` unless None: the default flags) from an empty
    cache: its wall seconds, the load average before it, and its study's figures."""
    flags = [] if workers is None else ["--workers", str(workers)]
    with tempfile.TemporaryDirectory(prefix="squeezebench-bench-") as tmp:
        # an empty cache (no plate solved by an earlier run): a first run on a fresh machine
        elapsed_s, before = command_s(["reproduce", "--out", str(Path(tmp) / "paper"), "--quiet", *flags],
                                      {CACHE_VARIABLE: str(Path(tmp) / "cache")})
        return elapsed_s, before, study.figures(study.load_trials(Path(tmp) / "paper"))


def study_s(workers: int) -> tuple[float, str]:
    """`squeezebench study` with reproduce's experiments only (in `reproduce` the study shares
    the cores with the campaign) on `workers`, from an empty cache."""
    experiments = [flag for name in commands.REPRODUCE_EXPERIMENTS for flag in ("--experiment", name)]
    with tempfile.TemporaryDirectory(prefix="squeezebench-bench-") as tmp:
        return command_s(["study", "--out", str(Path(tmp) / "study"), "--quiet", "--workers", str(workers),
                          *experiments], {CACHE_VARIABLE: str(Path(tmp) / "cache")})


def figures_against_reference(found: pd.DataFrame) -> str:
    """The study's figures against the stored reference, in their Monte Carlo uncertainty."""
    reference = pd.read_csv(REFERENCE, keep_default_na=False)
    compared = study.compare_figures(found, reference)
    worst = compared.loc[compared["z"].abs().idxmax()]
    return (f"study figures against {REFERENCE.name}: {int(compared['within'].sum())} of {len(compared)} p95 errors "
            f"within 2 Monte Carlo u of the reference (about 95 % expected of an unchanged study; "
            f"{len(reference) - len(compared)} reference figures not found), largest |z| {abs(worst['z']):.1f} "
            f"({worst['experiment']} {worst['quantity']}); bench time per trial "
            f"{100 * compared['bench_time_rel_change'].median():+.1f} % (median)")


def acquisition_ratio(repeat: int) -> tuple[float, float]:
    """Acquire + fetch of 3 x 10k points in sample mode and with 512 averages (noise and
    quantisation on: the default scene)."""
    _, single = prepared_scope(paths.default_scene())
    single.write("ACQ:MOD SAM")
    _, averaged = prepared_scope(paths.default_scene())
    averaged.write("ACQ:NUMAV 512")
    return best_of(repeat, acquire_and_fetch, single), best_of(repeat, acquire_and_fetch, averaged)


def reduction_s(repeat: int) -> float:
    """One point's reduction: frequency, three sine fits, power, on a noisy 10k record."""
    n = 10_000
    time_s = (np.arange(n) - n / 2) * (20.0 / FREQUENCY_HZ / n)
    phase = 2 * math.pi * FREQUENCY_HZ * time_s
    rng = np.random.default_rng(0)
    voltage = 18.8 * np.sin(phase + 0.2) + 0.01 + rng.normal(0, 0.02, n)
    current = 0.05 * np.sin(phase + 0.9) + rng.normal(0, 1e-4, n)
    vibrometer = 1.2 * np.sin(phase + 1.3) + rng.normal(0, 1e-3, n)
    return best_of(repeat, lambda: reduce_point(time_s, voltage, current, vibrometer, 0.125, averages=16,
                                                frequency_hint_hz=FREQUENCY_HZ))


def command_ratio(repeat: int) -> tuple[float, float]:
    with tempfile.TemporaryDirectory() as tmp:
        bare = open_bare_scope(Path(tmp))
        _, scene_scope = prepared_scope(paths.default_scene())
        return best_of(repeat, idn_queries, bare) / 200, best_of(repeat, idn_queries, scene_scope) / 200


#: Plans from an empty cache: the first is the goal's figure, the best of all is printed beside it.
PLAN_COLD_RUNS = 3


def plan_s() -> tuple[list[tuple[float, str]], tuple[float, str]]:
    """`squeezebench plan paper --target-rel-error 0.01` with the default flags (its map run
    included; the target is below the floor, so it exits 2 after printing the plan): each of
    PLAN_COLD_RUNS from an empty cache of its own (the plan's measurements and the plate
    solves), and the first's again with what it stored."""
    def plan(cache: str) -> tuple[float, str]:
        return command_s(["plan", "paper", "--target-rel-error", "0.01", "--quiet"], {CACHE_VARIABLE: cache},
                         allowed=(0, 2))

    cold, warm = [], None
    for run in range(PLAN_COLD_RUNS):
        with tempfile.TemporaryDirectory() as cache:
            cold.append(plan(cache))
            if run == 0:
                warm = plan(cache)
    return cold, warm


def suite_s() -> tuple[float, str]:
    """The README's test command's suite (`python -m pytest -n auto`), from the checkout."""
    return command_s(["-n", "auto", "-q", "-p", "no:cacheprovider"], module="pytest")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=7)
    parser.add_argument("--skip-reproduce", action="store_true")
    parser.add_argument("--skip-plan", action="store_true")
    parser.add_argument("--skip-suite", action="store_true")
    parser.add_argument("--write-reference", action="store_true",
                        help=f"store this run's study figures as {REFERENCE.name} (after a change meant to keep them)")
    args = parser.parse_args()
    warm_bytecode()
    before = reference.measure()
    lines = []
    if not args.skip_reproduce:
        default_s, default_load, found = reproduce_s(None)
        if args.write_reference:
            found.to_csv(REFERENCE, index=False)
        one_s, one_load, _ = reproduce_s(1)
        lines.append(lambda unit: f"reproduce wall time: default flags ({default_workers()} workers) "
                     f"{unit.both(default_s)} ({default_load})   1 worker {unit.both(one_s)} ({one_load})   "
                     "(goal, default flags: <= 20 ref)")
        lines.append(lambda unit: figures_against_reference(found))
        (study_default_s, study_default_load), (study_one_s, study_one_load) = study_s(default_workers()), study_s(1)
        lines.append(lambda unit: f"accuracy study alone: default flags {unit.both(study_default_s)} "
                     f"({study_default_load})   1 worker {unit.both(study_one_s)} ({study_one_load})   speed-up "
                     f"{study_one_s / study_default_s:4.2f}x (goal on 2 cores: >= 1.7x)")
    single_s, averaged_s = acquisition_ratio(args.repeat)
    lines.append(lambda unit: f"acquire + fetch 3 x 10k points: sample mode {single_s * 1e3:6.2f} ms = "
                 f"{unit.units(single_s) * 1e3:.2f} mref   512 averages {averaged_s * 1e3:6.2f} ms = "
                 f"{unit.units(averaged_s) * 1e3:.2f} mref   ratio {averaged_s / single_s:4.2f} (goal <= 4)")
    point_s = reduction_s(args.repeat)
    lines.append(lambda unit: f"reduction of one 10k-sample point: {point_s * 1e3:6.2f} ms = "
                 f"{unit.units(point_s) * 1e3:.2f} mref (goal <= 1 ms)")
    bare_s, scene_s = command_ratio(args.repeat)
    lines.append(lambda unit: f"*IDN? query: pyvisa-sim {bare_s * 1e6:7.1f} us   scene backend {scene_s * 1e6:7.1f} us "
                 f"= {unit.units(scene_s) * 1e6:.1f} uref   ratio {scene_s / bare_s:4.2f} (goal <= 2)")
    if not args.skip_plan:
        cold, (warm_s, warm_load) = plan_s()
        (cold_s, cold_load), (best_s, best_load) = cold[0], min(cold)
        lines.append(lambda unit: f"plan on the paper campaign, default flags: empty cache {unit.both(cold_s)} "
                     f"({cold_load})   again {unit.both(warm_s)} ({warm_load})   best of {len(cold)} from an "
                     f"empty cache {unit.both(best_s)} ({best_load}) (goal, empty cache, the first: <= 8 ref)")
    if not args.skip_suite:
        test_s, test_load = suite_s()
        lines.append(lambda unit: f"the README's test command's suite (pytest -n auto): {unit.both(test_s)} "
                     f"({test_load}) (goal <= 80 ref)")
    after = reference.measure()
    unit = reference.mean(before, after)
    print(f"before: {before.line()}\nafter:  {after.line()}\nunit: their mean, {unit.seconds:.3f} s")
    for line in lines:
        print(line(unit))

if __name__ == "__main__":
    main()
