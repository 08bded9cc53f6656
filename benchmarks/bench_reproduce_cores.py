"""Where `reproduce` spends its CPU, phase by phase and process by process (prints figures;
not a test; Linux: it reads /proc).

`squeezebench reproduce --out TMP --quiet` (default flags, an empty plate cache) runs in
this process, its phases marked where the command calls them (the campaign, `prepare`,
the study's last wait, the report), while a thread samples every descendant process's
CPU time (/proc/PID/stat) four times a second. Printed: each phase's wall seconds, this
(main) process's CPU seconds and the other processes' (the study's workers and the report's
drawing process), then each process's total, all in seconds and reference units
(`benchmarks/reference.py`, timed before and after), with the load average: on two
cores, the command cannot take less wall time than half its CPU time, nor less than its
main process's CPU time. The modules this script imports before the command starts (the
command line, the campaign runner, the report) are not counted: about a CPU second.

Run: python benchmarks/bench_reproduce_cores.py [--workers N]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import reference  # noqa: E402
from squeezebench import cli  # noqa: E402
from squeezebench.disk_cache import CACHE_VARIABLE  # noqa: E402
from squeezebench.protocols import campaign, parallel  # noqa: E402
from squeezebench.report import run_report  # noqa: E402

TICKS_PER_S = os.sysconf("SC_CLK_TCK")
SAMPLE_S = 0.25


def descendants_cpu_s(root: int) -> dict[int, float]:
    """CPU seconds (user + system) of every process below `root`, by pid."""
    children: dict[int, list[tuple[int, float]]] = {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            stat = Path(f"/proc/{entry}/stat").read_text()
        except OSError:   # ended meanwhile
            continue
        fields = stat[stat.rindex(")") + 2:].split()   # after the command name, which may hold spaces
        children.setdefault(int(fields[1]), []).append((int(entry), (int(fields[11]) + int(fields[12])) / TICKS_PER_S))
    found, pending = {}, [root]
    while pending:
        for pid, cpu_s in children.get(pending.pop(), []):
            found[pid] = cpu_s
            pending.append(pid)
    return found


class Timeline:
    """Marks (wall, this process's CPU, the others' CPU by pid) at each phase's ends."""

    def __init__(self) -> None:
        self.start_s = time.perf_counter()
        self.marks: list[tuple[str, float, float, dict[int, float]]] = []
        self.last: dict[int, float] = {}   # each other process's CPU when last seen (a worker may end first)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)
        self._thread.start()

    def _sample(self) -> None:
        while not self._stop.wait(SAMPLE_S):
            self.last.update(descendants_cpu_s(os.getpid()))

    def mark(self, name: str) -> None:
        self.last.update(descendants_cpu_s(os.getpid()))
        self.marks.append((name, time.perf_counter() - self.start_s, sum(os.times()[:2]), dict(self.last)))

    def stop(self) -> None:
        self._stop.set()
        self._thread.join()
        self.mark("end")

    def wrap(self, owner, name: str, phase: str) -> None:
        """Mark `phase` around every call of `owner.name` (before and after)."""
        function = getattr(owner, name)

        def marked(*args, **kwargs):
            self.mark(f"{phase} starts")
            try:
                return function(*args, **kwargs)
            finally:
                self.mark(f"{phase} ends")

        setattr(owner, name, marked)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--workers", type=int, default=None, help="reproduce's --workers (default: its own)")
    args = parser.parse_args(argv)
    before = reference.measure()
    load = os.getloadavg()[0]
    timeline = Timeline()
    timeline.wrap(campaign, "run_campaign", "campaign")
    timeline.wrap(run_report, "prepare", "prepare")
    timeline.wrap(parallel.Beside, "finish", "study's last wait")
    timeline.wrap(run_report, "write_report", "report")
    with tempfile.TemporaryDirectory(prefix="squeezebench-bench-") as tmp:
        os.environ[CACHE_VARIABLE] = str(Path(tmp) / "cache")   # a first run: no plate solved before
        timeline.mark("start")
        cli.main(["reproduce", "--out", str(Path(tmp) / "paper"), "--quiet",
                  *(["--workers", str(args.workers)] if args.workers else [])])
        timeline.stop()
    unit = reference.mean(before, reference.measure())
    print(unit.line())
    print(f"load {load:.2f} before the run, {os.getloadavg()[0]:.2f} after")
    previous = timeline.marks[0]
    for mark in timeline.marks[1:]:
        name, wall_s, main_s, others = mark
        others_s = sum(others.get(pid, 0.0) - previous[3].get(pid, 0.0) for pid in others)
        if max(wall_s - previous[1], main_s - previous[2], others_s) >= 0.05:   # the instants between phases left out
            print(f"{previous[0]:>24} -> {name:<24} wall {unit.both(wall_s - previous[1])}, "
                  f"main process {main_s - previous[2]:5.1f} CPU-s, other processes {others_s:5.1f} CPU-s")
        previous = mark
    _, start_s, start_main_s, _ = timeline.marks[0]
    _, wall_s, main_s, others = timeline.marks[-1]
    wall_s, main_s = wall_s - start_s, main_s - start_main_s   # the reference's timing is no part of the command
    total_s = main_s + sum(others.values())
    print(f"total: wall {unit.both(wall_s)}, CPU {unit.both(total_s)} (main process {main_s:.1f} s; "
          + ", ".join(f"pid {pid} {cpu_s:.1f} s" for pid, cpu_s in sorted(others.items()) if cpu_s >= 0.5)
          + f"); on 2 cores at least {unit.both(max(total_s / 2, main_s))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
