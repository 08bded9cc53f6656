"""Byte-exact protocol fixture for the driver tests, in the manner of PyMeasure's
`expected_protocol`: a stand-in for a PyVISA resource that holds the exact sequence of
messages a driver must send and the replies the instrument gives, written from the
manuals and independent of the simulator.

    with expected_protocol(TDS3054B, [("HEADER OFF", None), ("*IDN?", "TEKTRONIX,...")]) as scope:
        scope.identify()

A reply of `None` means the instrument says nothing; `TIMEOUT` that the read times out
(a refused query); `CLEAR` as the message is a device clear. Leaving the block with
messages unsent fails the test, as does any message out of order.
"""

from __future__ import annotations

import os

# One BLAS thread per test process, set before NumPy loads OpenBLAS (it reads these once):
# the README's `pytest -n auto` runs a worker per core, and each worker's OpenBLAS threads
# spinning for a core the other worker holds cost CPU-seconds, not time saved (a grid-term
# test on the large plate's mode took 18 CPU-s with them, 8 without). Processes the tests
# start inherit it; loky's workers set their own (joblib: cores over workers).
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

import fcntl  # noqa: E402
import json  # noqa: E402
import tempfile  # noqa: E402
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator

import numpy as np
import pytest
from hypothesis import settings
from pyvisa import constants
from pyvisa.errors import VisaIOError
from pyvisa.util import from_ieee_block

# Hypothesis's per-example time limit fails a property on a loaded machine, not on a wrong
# answer (a 2-core machine shared with other work runs an example 3-10 times slower): no limit.
# Derandomized: the same examples on every run and machine, as every other test's seeds; a
# property is then explored by raising its max_examples, not by reruns that differ.
settings.register_profile("squeezebench", deadline=None, derandomize=True)
settings.load_profile("squeezebench")

TIMEOUT = object()
CLEAR = "<device clear>"


class ProtocolResource:
    """The PyVISA resource calls the drivers use, checked against a script."""

    def __init__(self, exchanges: list[tuple[str, Any]], resource_name: str) -> None:
        self.exchanges = list(exchanges)
        self.resource_name = resource_name
        self.read_termination = self.write_termination = None
        self.timeout = 2000.0
        self._pending: list[Any] = []

    def _next(self, message: str) -> None:
        assert self.exchanges, f"unexpected message {message!r}: the script has ended"
        expected, reply = self.exchanges.pop(0)
        assert message == expected, f"sent {message!r}, the manual-derived script expects {expected!r}"
        if reply is not None:
            self._pending.append(reply)

    def write(self, message: str) -> None:
        self._next(message)

    def read(self) -> str:
        if not self._pending or self._pending[0] is TIMEOUT:
            if self._pending:
                self._pending.pop(0)
            raise VisaIOError(constants.StatusCode.error_timeout)
        reply = self._pending.pop(0)
        return reply.decode("latin-1") if isinstance(reply, bytes) else reply

    def query(self, message: str) -> str:
        self.write(message)
        return self.read()

    def query_binary_values(self, message: str, datatype: str, is_big_endian: bool, container=np.array):
        self.write(message)
        reply = self._pending.pop(0)
        return container(from_ieee_block(reply, datatype, is_big_endian))

    def clear(self) -> None:
        self._next(CLEAR)


@contextmanager
def expected_protocol(driver_class, exchanges: list[tuple[str, Any]], resource_name: str = "FAKE::INSTR",
                      **kwargs) -> Iterator[Any]:
    resource = ProtocolResource(exchanges, resource_name)
    yield driver_class(resource, **kwargs)
    assert not resource.exchanges, f"messages the driver never sent: {resource.exchanges}"
    assert not resource._pending, f"replies the driver never read: {resource._pending}"


@pytest.fixture
def protocol():
    return expected_protocol


def session_folder(tmp_path_factory) -> Path:
    """A folder of this session that its xdist workers share (each worker's own temporary
    folder sits in the session's)."""
    base = tmp_path_factory.getbasetemp()
    return base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base


@pytest.fixture(scope="session", autouse=True)
def session_cache(tmp_path_factory):
    """This session keeps what it computes on disk (`disk_cache`: plans' measurements, plate
    solves) in a folder of its own, which its xdist workers share: a test never reads what a
    developer's runs (or another session's code) stored, and the workers solve each of the
    paper's plates once between them, not once each (the store's writes are atomic)."""
    from squeezebench.disk_cache import CACHE_VARIABLE

    folder = session_folder(tmp_path_factory) / "squeezebench-cache"
    folder.mkdir(parents=True, exist_ok=True)
    with pytest.MonkeyPatch.context() as patch:
        patch.setenv(CACHE_VARIABLE, str(folder))
        yield folder


@pytest.fixture(scope="session", autouse=True)
def _not_waiting_for_the_disk():
    """fsync makes a stored step survive a power cut, which no test in this process can
    cut: here the runs do not wait for the disk (some 6 s of the suite). The tests that
    kill runs do it to real processes, which keep their fsyncs; test_run_storage checks
    that a durable run calls fsync and a temporary one does not."""
    import os

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(os, "fsync", lambda fd: None)
        yield


@contextmanager
def recorded_traffic() -> Iterator[dict[str, list[str]]]:
    """{role: every message the drivers send meanwhile, in order}."""
    from squeezebench.instruments import base

    traffic: dict[str, list[str]] = {}
    with pytest.MonkeyPatch.context() as patch:
        for name in ("write", "query", "query_block"):
            original = getattr(base.Instrument, name)

            def recording(self, command, _original=original):
                traffic.setdefault(self.role, []).append(command)
                return _original(self, command)
            patch.setattr(base.Instrument, name, recording)
        yield traffic


def made_once(tmp_path_factory, name: str, make: Callable[[Path], None]) -> Path:
    """A folder of this session filled once for all its xdist workers by `make(folder)`:
    the first worker to ask makes it under a file lock, the others wait for it and read
    it. A marker, written last and atomically, names the whole one; a failed attempt is
    left aside unnamed and the next to ask makes it again."""
    shared = session_folder(tmp_path_factory) / name
    shared.mkdir(parents=True, exist_ok=True)
    done = shared / "made"
    with open(shared / "lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            attempt = Path(tempfile.mkdtemp(dir=shared, prefix="attempt-"))
            make(attempt)
            (attempt / "made").write_text(attempt.name)
            os.replace(attempt / "made", done)
    return shared / done.read_text()


def _campaign_run(tmp_path_factory, name: str, campaign: Path) -> tuple[Path, dict[str, list[str]]]:
    """The campaign run once per session on the simulated bench from power-on, shared by
    the session's workers (`made_once`): its run folder and {role: the messages its drivers
    sent}."""
    from squeezebench.protocols.campaign import run_campaign

    def make(folder: Path) -> None:
        with recorded_traffic() as traffic:
            run_campaign(campaign, out_dir=folder / "run", progress=False)
        (folder / "traffic.json").write_text(json.dumps(traffic))

    folder = made_once(tmp_path_factory, name, make)
    return folder / "run", json.loads((folder / "traffic.json").read_text())


def _report_once(tmp_path_factory, name: str, run_dir: Path) -> Path:
    """The report of a session's run as the command line writes it (with the simulated
    plates' section), written once for the session's workers: its index.html."""
    import squeezebench.report.simulated_plates  # noqa: F401  (the report as `report` writes it)
    from squeezebench.report.run_report import write_report

    made_once(tmp_path_factory, name, lambda folder: write_report(run_dir))
    return run_dir / "report" / "index.html"


@pytest.fixture(scope="session")
def paper_run(tmp_path_factory) -> tuple[Path, dict[str, list[str]]]:
    """The shipped paper campaign from power-on (about 25 s on 2 cores), for the tests of
    its report, of its drivers' messages and of its runs' analysis (`_campaign_run`)."""
    from squeezebench import paths

    return _campaign_run(tmp_path_factory, "paper-run", paths.paper_campaign())


@pytest.fixture(scope="session")
def paper_report(tmp_path_factory, paper_run) -> Path:
    """The paper run's report (`_report_once`): the browser's tests and the uncertainty
    report's read the same page, which is some 8 CPU-s to write."""
    return _report_once(tmp_path_factory, "paper-report", paper_run[0])


@pytest.fixture(scope="session")
def quick_run(tmp_path_factory) -> tuple[Path, dict[str, list[str]]]:
    """The shipped quick campaign from power-on (`_campaign_run`): the drivers' messages
    and the browser's report read the same run."""
    from squeezebench import paths

    return _campaign_run(tmp_path_factory, "quick-run", paths.campaigns_dir() / "quick.yaml")


@pytest.fixture(scope="session")
def quick_report(tmp_path_factory, quick_run) -> Path:
    """The quick run's report (`_report_once`)."""
    return _report_once(tmp_path_factory, "quick-report", quick_run[0])


@pytest.fixture(scope="session")
def small_study(tmp_path_factory) -> Path:
    """The accuracy study at its smallest (`small_study.SMALL`, every experiment), run once
    for the session's workers (`made_once`): the folder holding its study/."""
    from small_study import SMALL

    from squeezebench.protocols.accuracy_study import run_study

    return made_once(tmp_path_factory, "small-study", lambda folder: run_study(folder, SMALL, progress=lambda m: None))


@pytest.fixture(scope="session")
def small_campaign_run(tmp_path_factory) -> tuple[Path, Path, int]:
    """test_campaign_resume's small campaign run once, uninterrupted, for the session's
    workers (`made_once`): the uninterrupted run the kill-and-resume tests compare with
    (test_campaign_resume, test_stop_signals) and the completed run the storage tests copy
    and damage (test_run_storage, test_report_integrity), which ran it once each. Its
    campaign file, its run folder, and the instrument writes it made (where a kill may fall)."""
    from test_campaign_resume import WriteCounter, small_campaign

    from squeezebench.protocols.campaign import run_campaign

    def make(folder: Path) -> None:
        campaign = small_campaign(folder)
        with pytest.MonkeyPatch.context() as patch:
            counter = WriteCounter(patch)
            run_campaign(campaign, out_dir=folder / "run", say=lambda message: None)
        (folder / "writes.json").write_text(json.dumps({"campaign": campaign.name, "writes": counter.count}))

    folder = made_once(tmp_path_factory, "small-campaign-run", make)
    made = json.loads((folder / "writes.json").read_text())
    return folder / made["campaign"], folder / "run", made["writes"]


# Drive records (protocols.drive_record) outlive a process: this test process and its
# children keep theirs out of the user's state folder, and each test has its own, so a run
# one test kills does not tell another test's bench it was left driven.
os.environ.setdefault("SQUEEZEBENCH_STATE", tempfile.mkdtemp(prefix="squeezebench-state-"))


@pytest.fixture(scope="session")
def _drive_record_folders(tmp_path_factory) -> Path:
    """The folder of every test's own state folder (`_own_drive_records`), one a worker."""
    return tmp_path_factory.mktemp("states")


@pytest.fixture(autouse=True)
def _own_drive_records(_drive_record_folders, monkeypatch):
    # mkdtemp in a folder of their own, not tmp_path_factory.mktemp: a numbered folder is
    # found by listing the worker's whole temporary folder, which each test's own adds to
    # (some 650 tests a worker: 0.7-0.75 CPU-s of listing a worker, 0.14-0.19 without them, as simulated)
    monkeypatch.setenv("SQUEEZEBENCH_STATE", tempfile.mkdtemp(dir=_drive_record_folders))


#: The modules that take longest in the README's suite (`pytest -n auto`, issue 51's 2-core
#: machine), longest first. With `-n` each module runs whole on one worker (`--dist
#: loadscope`) in the order collected (`--no-loadscope-reorder`, pyproject): these start
#: first and the many short modules fill in behind them, so no worker idles through the end
#: while the other runs a long module it took last. The paper campaign's three readers
#: (`paper_run`, `paper_report`) start apart: the first makes it while the other worker runs
#: the study and real I/O, and the later ones find it made rather than waiting on its lock.
LONG_MODULES = ("test_instrument_commands.py", "test_accuracy_study.py", "test_realio.py", "test_uncertainty.py",
                "test_report_browser.py", "test_stop_signals.py", "test_systematics_study.py",
                "test_accuracy_plan.py", "test_misdescribed_benches.py", "test_stop_bursts.py",
                "test_previous_user_states.py", "test_analysis_report.py")


def pytest_collection_modifyitems(items):
    """The long modules first, in LONG_MODULES' order; then the rest as xdist's own
    reordering puts them, the modules with the most tests first (a module's tests keep
    their order)."""
    counts: dict[str, int] = {}
    for item in items:
        counts[item.path.name] = counts.get(item.path.name, 0) + 1

    def rank(item) -> tuple[int, int]:
        name = item.path.name
        return (LONG_MODULES.index(name), 0) if name in LONG_MODULES else (len(LONG_MODULES), -counts[name])

    items.sort(key=rank)   # stable: the modules of one count, and each module's tests, keep their order
