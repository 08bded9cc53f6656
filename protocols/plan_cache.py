"""What a plan measured, kept for the next plan of the same campaign.

Most of a plan does not depend on its target: the noise and cost of every scope setting
on every plate, the floors the instruments' specified errors leave, the campaign's bench
time with 512 averages. Planning the same campaign again at another target, the usual
way to learn what a target costs, reads those instead of simulating them again, and runs
only what it lacks (the planned campaign's bench time for settings not timed before, and
always the check on erring benches).

They are kept on joblib's `Memory` in `plan/` of squeezebench's cache folder
(`disk_cache.cache_dir`: $SQUEEZEBENCH_CACHE, default $XDG_CACHE_HOME/squeezebench), each
under the call's arguments and a fingerprint of all that decides it: the campaign file, every scene and bench file
it names, and squeezebench's own source. A change to any of them is a new fingerprint, so
nothing stale is ever read; the folder stays under CACHE_BYTES_LIMIT.
SQUEEZEBENCH_CACHE=off measures everything afresh.
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path
from typing import Any, Callable

import joblib

from squeezebench import disk_cache
from squeezebench.disk_cache import CACHE_VARIABLE, cache_dir
from squeezebench.protocols.parallel import map_unordered

#: The folder is kept under this size, the least recently used results going first (a
#: plan of the paper campaign keeps about 5 MB; every change of the code starts a new set).
CACHE_BYTES_LIMIT = 512 * 2**20
#: The packages whose source decides a simulated measurement.
SOURCE_PACKAGES = ("squeezebench", "squeezebench.instruments", "squeezebench.protocols",
                   "squeezebench.analysis", "squeezebench.plates", "squeezebench.simbench")


def source_fingerprint() -> str:
    """SHA-256 of squeezebench's Python source (`disk_cache.source_fingerprint`)."""
    return disk_cache.source_fingerprint(SOURCE_PACKAGES)


def fingerprint(files: list[Path]) -> str:
    """SHA-256 of the source and of `files` (the campaign and what it names), in order."""
    digest = hashlib.sha256(source_fingerprint().encode())
    for path in files:
        digest.update(f"\0{Path(path).resolve()}\0".encode())
        digest.update(Path(path).read_bytes())
    return digest.hexdigest()


def holds_nothing() -> bool:
    """Whether no measurement of any plan is kept (none stored yet, the cache off or not
    writable): a plan then simulates every one, on its workers; with something kept it may
    read all it needs."""
    location = cache_dir()
    try:
        return location is None or not joblib.Memory(location / "plan", verbose=0).store_backend.get_items()
    except OSError:   # no writable cache folder: a plan keeps and reads nothing (`PlanCache`)
        return True


def _keyed(fingerprint: str, function: Callable[..., Any], *args: Any) -> Any:
    """function(*args); `fingerprint` is only part of the cache's key."""
    return function(*args)


def _run_job(job: Callable[[], Any]) -> Any:
    return job()


class PlanCache:
    """Cached calls for one campaign: `job` gives a picklable call (for a worker) that
    reads the result where it is stored and stores it where it is not."""

    def __init__(self, files: list[Path]) -> None:
        self.fingerprint = fingerprint(files)
        self.location = cache_dir()
        try:
            memory = joblib.Memory(None if self.location is None else self.location / "plan", verbose=0)
            memory.reduce_size(bytes_limit=CACHE_BYTES_LIMIT)
        except OSError:   # an unwritable home: plan as if off, the plan says so
            self.location, memory = None, joblib.Memory(None, verbose=0)
        self._call = memory.cache(_keyed)
        self.read = self.measured = 0
        self._jobs: dict[tuple, functools.partial] = {}   # one job per call, counted once
        self._stored: set[functools.partial] = set()   # jobs found stored when made
        self._done: dict[functools.partial, Any] = {}   # results of this plan's batches

    def job(self, function: Callable[..., Any], *args: Any) -> functools.partial:
        """The call function(*args) through the cache, counted as read or measured (the
        same call asked for again is the same job, counted once)."""
        key = (function.__module__, function.__qualname__, joblib.hash(args))
        if key in self._jobs:
            return self._jobs[key]
        job = self._jobs[key] = functools.partial(self._call, self.fingerprint, function, *args)
        if self._call.check_call_in_cache(*job.args):
            self.read += 1
            self._stored.add(job)
        else:
            self.measured += 1
        return job

    def result(self, job: functools.partial) -> Any:
        """`job`'s result: from a batch it ran in, else read or computed here."""
        if job not in self._done:
            self._done[job] = job()
        return self._done[job]

    def call(self, function: Callable[..., Any], *args: Any) -> Any:
        return self.result(self.job(function, *args))

    def run(self, jobs: list[functools.partial], workers: int, scheduler: Any, description: str) -> dict:
        """{job: result} of `jobs`: the stored ones read here (cheaper than sending them to a
        worker), the others on `workers` local processes or the Dask cluster at `scheduler`."""
        done = {job: self.result(job) for job in jobs if job in self._stored or job in self._done}
        done.update(map_unordered(_run_job, [job for job in jobs if job not in done], workers, scheduler,
                                  description))
        self._done.update(done)
        return done

    def words(self) -> str:
        """Where the plan's measurements came from, for its table."""
        total = self.read + self.measured
        if self.location is None:
            return f"measurements: all {total} simulated now ({CACHE_VARIABLE}=off or no writable cache folder)"
        return (f"measurements: {self.read} of {total} read from {self.location / 'plan'} (an earlier plan of "
                f"this campaign with the same files and code), {self.measured} simulated now; "
                f"{CACHE_VARIABLE}=off simulates all")

    def as_dict(self) -> dict:
        return {"location": None if self.location is None else str(self.location / "plan"),
                "read": self.read, "simulated": self.measured}
