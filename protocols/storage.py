"""The run directory (docs/design.md): what a campaign writes and how it survives a crash.

Measurements are tidy Parquet tables (one row per measured point, one column per
variable). Parquet, through pyarrow, because it is typed (a float stays a float, a bool a
bool, with nulls), columnar, compact, and read by `pandas.read_parquet` with no project
code: a run directory is usable by anyone with pandas.

Crash safety. A step is the unit of atomicity:
1. its waveforms go to a hidden staging folder, renamed into place when complete;
2. its measurement table goes to a temporary file, renamed into place (`os.replace`);
3. its journal line, carrying the sha256 of every file of 1 and 2, is appended to
   `journal.jsonl` and fsynced, last.
A step is complete if and only if its journal line exists.

Nothing measured is ever deleted. Before a resume, `repair` moves what it cannot trust
into `quarantine/<time>/` (same relative paths) and says what and why: files no journal
line covers (a killed step, or a step whose journal line was damaged), journal lines
that are not entries (a torn last line, a corrupted byte), all kept byte for byte. A
step whose journal line names a file that is missing or fails its checksum loses its
line (the journal as found is kept) and its other files go to quarantine: the resume
measures it again. `report` refuses such a run (`verify`) unless told to go on.

One writer per directory: `writer()` holds an exclusive OS lock (flock) on
`.squeezebench.lock`, which records the holder's pid for the message another process
gets. A directory that is neither empty nor a run is never written into.
"""

from __future__ import annotations

import contextlib
import datetime as dt
import fcntl
import hashlib
import json
import logging
import os
import shutil
from pathlib import Path
from typing import Any, Callable, Iterator

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

import squeezebench
from squeezebench.errors import UserError

log = logging.getLogger(__name__)

JOURNAL = "journal.jsonl"
MANIFEST = "manifest.json"
CAMPAIGN_COPY = "campaign.yaml"
METADATA_KEY = b"squeezebench"
LOCK = ".squeezebench.lock"
QUARANTINE = "quarantine"
#: Step folders; everything in them is a step's file or something to quarantine.
STEP_FOLDERS = ("measurements", "waveforms")
#: What file managers drop into folders: never ours, never moved, never a reason to refuse.
OS_LITTER = frozenset({".DS_Store", "Thumbs.db", "desktop.ini", "._.DS_Store"})
#: A journal line is an entry if it is a JSON object with these fields of these types.
_ENTRY_FIELDS = {"run": str, "step": str, "rows": int, "context": dict,
                 "campaign_bench_time_s": (int, float)}


class StorageError(UserError):
    """A run directory that cannot be used as asked (locked, not a run, unreadable manifest)."""


def _sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def sha256_file(path: Path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _utc_now() -> str:
    return dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds")


def _fsync_dir(path: Path) -> None:
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:  # platforms without directory handles
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


_RESUME = "everything stored before is kept: make the folder writable (or free space), then resume with --resume"


@contextlib.contextmanager
def _writing(path: Path, then: str = _RESUME) -> Iterator[None]:
    """The OS refusing a write (a read-only folder, a full disk, a name too long) is one
    message naming the path and what to do `then`; what is stored already stays (a step
    is complete only with its journal line, written last)."""
    try:
        yield
    except OSError as exc:
        raise StorageError(f"{path}: cannot be written ({exc.strerror or exc}); {then}") from None


def check_writable_file(path: Path) -> None:
    """StorageError now if `path` could not be written later (its folder missing or
    read-only, not a folder): a file is created beside it and removed."""
    path = Path(path)
    probe = path.with_name(f".{path.name}.probe")
    with _writing(path, "choose a file in a folder you can write to"):
        probe.write_bytes(b"")
        probe.unlink()


def write_atomic(path: Path, data: bytes, durable: bool = True) -> None:
    """Write `data` to `path` so that a reader sees the old file or the new, never half;
    `durable`: on the disk (fsynced, with its folder) before returning, so a power cut
    cannot lose it."""
    with _writing(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        # the process in the name: two processes writing one file (the simulated benches'
        # shared drive record) must not move each other's half-written copy
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        with open(tmp, "wb") as handle:
            handle.write(data)
            if durable:
                handle.flush()
                os.fsync(handle.fileno())
        os.replace(tmp, path)
        if durable:
            _fsync_dir(path.parent)


def _write_staged(path: Path, data: bytes, durable: bool) -> None:
    """Write `data` to `path` in a step's staging folder: no reader sees that folder before
    it is complete and renamed, and a killed attempt's is quarantined whole, so a file in it
    needs no rename of its own, nor its folder an fsync per file (`write_step` syncs the
    folder once); `durable`: the data on the disk before returning."""
    with open(path, "wb") as handle:
        handle.write(data)
        if durable:
            handle.flush()
            os.fsync(handle.fileno())


def write_json_atomic(path: Path, value: Any, durable: bool = True) -> None:
    """A JSON document to `path`, indented and sorted, atomically (`write_atomic`); what
    JSON has no type for (a path, a timestamp) is written as its text."""
    write_atomic(path, json.dumps(value, indent=2, sort_keys=True, default=str).encode(), durable)


def write_frame_atomic(path: Path, frame: pd.DataFrame) -> None:
    """A table to `path` as parquet, atomically (`write_atomic`)."""
    write_atomic(path, _parquet_bytes(_arrow_table(frame)))


def _arrow_table(frame: pd.DataFrame) -> pa.Table:
    """`frame` as an Arrow table, its columns converted in this thread: for a frame a
    hundred times longer than wide (a waveform) pyarrow otherwise starts a thread pool per
    call, whose threads cost more than the conversion (4 % of a plan's CPU, 710 threads)."""
    return pa.Table.from_pandas(frame, preserve_index=False, nthreads=1)


def _parquet_bytes(table: pa.Table) -> bytes:
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


#: The operator's action a run stopped on when there was no terminal to confirm it.
OPERATOR_REQUEST = "operator_request.json"


class RunStore:
    """Reads and writes one run directory. A store that is not `durable` skips the fsyncs
    (a temporary run, e.g. a plan's, deleted once read: no power cut can matter to it)."""

    def __init__(self, run_dir: Path, durable: bool = True):
        self.run_dir = Path(run_dir)
        self.durable = durable
        self._quarantine_dir: Path | None = None

    # -- creation, ownership and the manifest ---------------------------------------------
    def exists(self) -> bool:
        return (self.run_dir / MANIFEST).exists()

    def foreign_entries(self) -> list[str]:
        """What makes the directory neither empty nor a run (empty if it is one of those)."""
        if not self.run_dir.exists() or self.exists():
            return []
        if not self.run_dir.is_dir():
            return [self.run_dir.name]
        return sorted(p.name for p in self.run_dir.iterdir() if p.name not in OS_LITTER | {LOCK})

    @contextlib.contextmanager
    def writer(self) -> Iterator[None]:
        """Hold the directory's exclusive lock (StorageError naming the holder's pid)."""
        try:
            self.run_dir.mkdir(parents=True, exist_ok=True)
            fd = os.open(self.run_dir / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise StorageError(f"{self.run_dir}: cannot be written ({exc.strerror or exc}); "
                               "choose an output directory you can write to") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip() or "unknown"
            os.close(fd)
            raise StorageError(f"{self.run_dir} is being written by another squeezebench process "
                               f"(pid {holder}); wait for it to finish or stop it first") from None
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
            yield
        finally:
            os.close(fd)   # releases the lock; the file stays (removing it would race)

    def create(self, campaign_file: Path) -> None:
        """Start a new run directory: a first manifest, then the campaign copy. The
        manifest comes first so a kill in between leaves a run (resumable), never a
        directory that is neither empty nor a run."""
        self.run_dir.mkdir(parents=True, exist_ok=True)
        campaign_file = Path(campaign_file)
        now = _utc_now()
        self._write_manifest({
            "software": {"name": "squeezebench", "version": squeezebench.__version__},
            "campaign": {"file": str(campaign_file.resolve()), "copy": CAMPAIGN_COPY,
                         "sha256": sha256_file(campaign_file)},
            "inputs": {},
            "instruments": {},
            "created_utc": now,
            "updated_utc": now,
        })
        self.ensure_campaign_copy(campaign_file)
        (self.run_dir / JOURNAL).touch()

    def ensure_campaign_copy(self, campaign_file: Path) -> None:
        if not (self.run_dir / CAMPAIGN_COPY).exists():
            write_atomic(self.run_dir / CAMPAIGN_COPY, Path(campaign_file).read_bytes(), self.durable)

    def manifest(self) -> dict[str, Any]:
        path = self.run_dir / MANIFEST
        rebuild = "; 'squeezebench report --rebuild-manifest' makes it again from the journal"
        try:
            manifest = json.loads(path.read_bytes())
        except OSError as exc:
            raise StorageError(f"{path}: cannot be read ({exc.strerror})") from None
        except ValueError as exc:   # JSONDecodeError and UnicodeDecodeError
            raise StorageError(f"{path}: not a valid manifest (not JSON: {exc}){rebuild}") from None
        required = {"campaign": dict, "inputs": dict, "instruments": dict}
        for key, kind in required.items():
            if not isinstance(manifest, dict) or not isinstance(manifest.get(key), kind):
                raise StorageError(f"{path}: not a valid manifest (field '{key}' missing or not an object)"
                                   f"{rebuild}")
        if not isinstance(manifest["campaign"].get("sha256"), str):
            raise StorageError(f"{path}: not a valid manifest (field 'campaign.sha256' missing){rebuild}")
        return manifest

    def unverifiable(self) -> list[str]:
        """Why the step files of this run cannot be trusted as measured (empty when they
        can): the journal holds their checksums and the manifest says what made them, so
        a run with step files and without either is refused by `report`."""
        n_files = len(list((self.run_dir / "measurements").glob("*/*.parquet")))
        if not n_files:
            return []
        reasons = []
        if not (self.run_dir / JOURNAL).is_file():
            reasons.append(f"{self.run_dir / JOURNAL}: missing, so none of the {n_files} step files can be "
                           "checked against its checksum (resume the run to measure them again)")
        if not (self.run_dir / MANIFEST).is_file():
            reasons.append(f"{self.run_dir / MANIFEST}: missing, so what campaign, inputs and instruments made "
                           "these rows is unknown (rebuild it with 'report --rebuild-manifest')")
        if not reasons:
            reasons += self.altered_sources()
        return reasons

    def altered_sources(self) -> list[str]:
        """What the run was made from that is missing or no longer what made it: the
        campaign copy, every version of every scene and bench file under inputs/, and the
        manifest's own records of them, each against the checksums the journal's entries
        hold (fsynced with each step, so the authority) and the manifest's."""
        manifest, entries = self.manifest(), self.journal()
        problems = []
        copy = self.run_dir / CAMPAIGN_COPY
        recorded = manifest["campaign"]["sha256"]
        journal_says = {entry["campaign_sha256"] for entry in entries if "campaign_sha256" in entry}
        if not copy.is_file():
            problems.append(f"{copy}: missing, so the campaign that made the run cannot be checked")
        elif (digest := sha256_file(copy)) != recorded or journal_says - {digest}:
            problems.append(f"{copy}: not the campaign the run was made with (sha256 {digest[:12]}...; the "
                            f"manifest records {recorded[:12]}...{_also(journal_says, digest)})")
        used: dict[str, set[str]] = {}   # input name -> the digests the journal says steps used
        for entry in entries:
            for name, digest in entry.get("inputs", {}).items():
                used.setdefault(name, set()).add(digest)
        for name, digests in sorted(used.items()):
            versions = {v["sha256"]: v["copy"] for v in _versions(manifest["inputs"].get(name))}
            for digest in sorted(digests):
                if digest not in versions:
                    problems.append(f"{self.run_dir / MANIFEST}: inputs.{name} does not record the version "
                                    f"(sha256 {digest[:12]}...) the journal says the run's steps used")
        for name, record in sorted(manifest["inputs"].items()):
            for version in _versions(record):
                file = self.run_dir / str(version.get("copy"))
                if not file.is_file():
                    problems.append(f"{file}: missing (a copy of {name} the run was made from)")
                elif sha256_file(file) != version.get("sha256"):
                    problems.append(f"{file}: not the {name} the run was made with (sha256 "
                                    f"{sha256_file(file)[:12]}..., recorded {str(version.get('sha256'))[:12]}...)")
        for run_name, bench in sorted(manifest.get("benches", {}).items()):
            name = Path(str(bench.get("bench_input", ""))).name
            known = used.get(name) or {v["sha256"] for v in _versions(manifest["inputs"].get(name))}
            if bench.get("bench_input_sha256") not in known:
                problems.append(f"{self.run_dir / MANIFEST}: benches.{run_name}.bench_input_sha256 "
                                f"({str(bench.get('bench_input_sha256'))[:12]}...) is not the sha256 of any "
                                f"version of {name} the run used")
        return problems

    def rebuild_manifest(self) -> dict[str, Any]:
        """A manifest made again from the journal and the files whose checksums it
        verifies (the campaign copy, the inputs each entry names, the rows' provenance);
        a damaged one is moved to quarantine first. StorageError if the journal cannot
        vouch for every file (repair the run by resuming it first)."""
        journal = self.run_dir / JOURNAL
        if not journal.is_file():
            raise StorageError(f"{journal}: missing; a manifest is rebuilt only from the journal's checksums")
        problems = self.verify()
        if problems:
            raise StorageError(f"{problems[0]}; a manifest is rebuilt only from files the journal vouches for "
                               "(resume the run first: it measures damaged steps again)")
        entries = self.journal()
        campaign_copy = self.run_dir / CAMPAIGN_COPY
        if not campaign_copy.is_file():
            raise StorageError(f"{campaign_copy}: missing; the manifest cannot say which campaign made the run")
        inputs: dict[str, dict[str, Any]] = {}
        for entry in entries:
            for name, digest in entry.get("inputs", {}).items():
                name_path = Path(name)
                candidates = [f"inputs/{name}", f"inputs/{name_path.stem}.{digest[:12]}{name_path.suffix}"]
                copy = next((c for c in candidates if (self.run_dir / c).is_file()
                             and sha256_file(self.run_dir / c) == digest), None)
                if copy is None:
                    raise StorageError(f"{self.run_dir / candidates[0]}: missing or not the file step "
                                       f"{entry['run']}/{entry['step']} used (sha256 {digest[:12]}...)")
                versions = inputs.setdefault(name, {"versions": []})["versions"]
                if not versions or versions[-1]["sha256"] != digest:
                    versions.append({"sha256": digest, "copy": copy, "steps_before": entries.index(entry)})
        for name, record in inputs.items():
            record.update(file=record["versions"][-1]["copy"], copy=record["versions"][-1]["copy"],
                          sha256=record["versions"][-1]["sha256"])
        instruments, benches = {}, {}
        for entry in entries:
            if entry["run"] in instruments or not entry["rows"]:
                continue
            row = pd.read_parquet(self.run_dir / _measurement_file(entry["run"], entry["step"])).iloc[0]
            instruments[entry["run"]] = json.loads(row["instrument_ids"])
            benches[entry["run"]] = {key: row[key] for key in ("bench", "bench_input", "bench_input_sha256")}
        if (self.run_dir / MANIFEST).exists():
            self._quarantine(self.run_dir / MANIFEST)
        now = _utc_now()
        manifest = {"software": {"name": "squeezebench", "version": squeezebench.__version__},
                    "campaign": {"file": str(campaign_copy), "copy": CAMPAIGN_COPY,
                                 "sha256": sha256_file(campaign_copy)},
                    "inputs": inputs, "instruments": instruments, "benches": benches,
                    "created_utc": entries[0]["completed_utc"] if entries else now,
                    "rebuilt_utc": now, "rebuilt_from": f"{JOURNAL} and the checksums of the files it names"}
        self._write_manifest(manifest)
        return manifest

    def _write_manifest(self, manifest: dict[str, Any]) -> None:
        manifest["updated_utc"] = _utc_now()
        write_atomic(self.run_dir / MANIFEST, json.dumps(manifest, indent=2, sort_keys=True).encode(), self.durable)

    def add_input(self, path: Path, accept_changed: bool = False) -> str:
        """Copy a scene or bench file into inputs/ and record its sha256; return the copy.

        A file that changed since the run used it (a bench fix: an address, a fault
        removed) is refused unless `accept_changed`; then the manifest keeps every
        version (`versions`, oldest first, each with its copy and the number of steps
        completed before it) and the journal entries name the version each step used."""
        path = Path(path)
        digest = sha256_file(path)
        manifest = self.manifest()
        known = manifest["inputs"].get(path.name)
        if known and known["sha256"] == digest:
            return known["copy"]
        if known and not accept_changed:
            raise StorageError(f"{path} changed since {self.run_dir} was measured with it (sha256 "
                               f"{known['sha256'][:12]}... now {digest[:12]}...); if the change is a bench fix "
                               "(an address, a fault removed), resume with --accept-changed-bench: the "
                               "manifest keeps both versions and which steps used which")
        copy = f"inputs/{path.name}" if not known else f"inputs/{path.stem}.{digest[:12]}{path.suffix}"
        write_atomic(self.run_dir / copy, path.read_bytes(), self.durable)
        versions = known.get("versions", [{"sha256": known["sha256"], "copy": known["copy"],
                                           "steps_before": 0}]) if known else []
        steps_before = len(self.journal())
        record = {"sha256": digest, "copy": copy, "steps_before": steps_before, "recorded_utc": _utc_now()}
        manifest["inputs"][path.name] = {"file": str(path.resolve()), "copy": copy, "sha256": digest,
                                         "versions": [*versions, record]}
        self._write_manifest(manifest)
        if known:
            log.warning("%s changed since the run used it; accepted as a new version after %d completed "
                        "steps (copy %s, the old one stays in %s)", path, steps_before, copy, known["copy"])
        return copy

    def record_instruments(self, run_name: str, identifications: dict[str, str],
                           bench: dict[str, str] | None = None) -> None:
        """The instruments' identifications and, with `bench`, what answered them
        (`bench_provenance`: a simulated scene or a real bench file, with its sha256)."""
        manifest = self.manifest()
        manifest["instruments"][run_name] = identifications
        if bench is not None:
            manifest.setdefault("benches", {})[run_name] = bench
        self._write_manifest(manifest)

    def write_settings(self, run_name: str, settings: dict[str, Any]) -> None:
        write_json_atomic(self.run_dir / "settings" / f"{run_name}.json", settings, self.durable)

    def write_evidence(self, run_name: str, step_id: str, evidence: dict[str, Any]) -> Path:
        """What made a step stop (an acquisition the safety check refused), kept beside the
        run's data but never among its measurements: evidence/<run>/<step>-<n>.json."""
        folder = self.run_dir / "evidence" / run_name
        n = len(list(folder.glob(f"{step_id}-*.json"))) if folder.is_dir() else 0
        path = folder / f"{step_id}-{n + 1}.json"
        write_json_atomic(path, evidence, self.durable)
        return path

    def write_operator_request(self, request: dict[str, Any]) -> None:
        """What the run stopped waiting for (no terminal to confirm it on)."""
        write_json_atomic(self.run_dir / OPERATOR_REQUEST, request, self.durable)

    def operator_request(self) -> dict[str, Any] | None:
        path = self.run_dir / OPERATOR_REQUEST
        return json.loads(path.read_text()) if path.is_file() else None

    def clear_operator_request(self) -> None:
        (self.run_dir / OPERATOR_REQUEST).unlink(missing_ok=True)

    # -- the journal ----------------------------------------------------------------------
    def journal(self) -> list[dict[str, Any]]:
        """Completed steps in order; a line that is not an entry (torn, corrupted) is not a step."""
        return self._read_journal()[0]

    def _read_journal(self) -> tuple[list[dict[str, Any]], list[tuple[int, str]]]:
        """The entries, and (line number, why) for each line that is not one."""
        path = self.run_dir / JOURNAL
        if not path.exists():
            return [], []
        entries, bad = [], []
        lines = path.read_bytes().splitlines(keepends=True)
        for number, line in enumerate(lines, start=1):
            reason = _entry_problem(line)
            if reason is None:
                entries.append(json.loads(line))
            else:
                bad.append((number, reason))
        return entries, bad

    def repair(self, say: Callable[[str], None]) -> list[dict[str, Any]]:
        """Before resuming: quarantine what cannot be trusted, say what and why; return
        the journal's entries of the steps that stay complete. Nothing is deleted."""
        path = self.run_dir / JOURNAL
        entries, bad = self._read_journal()
        damaged = {(e["run"], e["step"]): problems for e in entries if (problems := self._entry_problems(e))}
        if bad or damaged:
            kept = self._quarantine(path, copy=True)
            good = [line for line in path.read_bytes().splitlines(keepends=True)
                    if _entry_problem(line) is None and _step_of(line) not in damaged]
            write_atomic(path, b"".join(good), self.durable)
            for number, reason in bad:
                say(f"{path} line {number}: {reason}; the whole journal as found is kept in {kept}, "
                    "and the step of that line, if any, will be measured again")
            for (run_name, step_id), problems in damaged.items():
                say(f"{'; '.join(problems)}: step {run_name}/{step_id} will be measured again (its journal "
                    f"line is kept in {kept}, its other files in quarantine)")
            entries = [e for e in entries if (e["run"], e["step"]) not in damaged]
        completed = {(e["run"], e["step"]) for e in entries}
        stray = list(self._step_files_outside(completed))
        if stray and not path.exists():
            say(f"{path} is missing: no step counts as completed")
        for item in stray:
            target = self._quarantine(item)
            say(f"{item.relative_to(self.run_dir)}: no journal entry covers it (a step that did not "
                f"complete, whose journal line was lost, or whose files were damaged); moved to "
                f"{target.relative_to(self.run_dir)}")
        if not path.exists():
            path.touch()
        return entries

    def verify(self, entries: list[dict[str, Any]] | None = None,
               planned: list[tuple[str, str]] | None = None) -> list[str]:
        """One message per step file the journal names that is missing or fails its checksum
        (and, reading the journal itself, per line that is not an entry), and per step of
        `planned` ((run, step) in the campaign's order) the journal does not have: a lost
        line names no file, so only the campaign's plan can say it is gone."""
        problems = []
        if entries is None:
            entries, bad = self._read_journal()
            problems += [f"{self.run_dir / JOURNAL} line {number}: {reason}" for number, reason in bad]
        for entry in entries:
            problems += self._entry_problems(entry)
        if not (self.run_dir / JOURNAL).is_file():
            return problems   # no journal: `unverifiable` says it, once
        done = {(entry["run"], entry["step"]) for entry in entries}
        problems += [f"step {run_name}/{step_id}: planned by {self.run_dir / CAMPAIGN_COPY} but not in "
                     f"{self.run_dir / JOURNAL} (its line was lost, or the run stopped before it: resume the run "
                     "to measure it)" for run_name, step_id in planned or [] if (run_name, step_id) not in done]
        return problems

    def _entry_problems(self, entry: dict[str, Any]) -> list[str]:
        """What is wrong with the files one journal entry names (nothing: [])."""
        problems = []
        files = entry.get("files") or {_measurement_file(entry["run"], entry["step"]): None}
        for relative, digest in files.items():
            file = self.run_dir / relative
            if not file.is_file():
                problems.append(f"{file}: missing (step {entry['run']}/{entry['step']} is in the journal)")
            elif digest is not None and sha256_file(file) != digest:
                problems.append(f"{file}: fails its checksum (step {entry['run']}/{entry['step']}; "
                                "the file changed after it was measured)")
        return problems

    def check_writable(self, run_names: list[str]) -> None:
        """Make every folder the run writes into and write a file in each (removed), so a
        folder that cannot be written stops the run before its first drive."""
        folders = [self.run_dir, self.run_dir / "settings", self.run_dir / "inputs",
                   *(self.run_dir / folder / name for folder in STEP_FOLDERS for name in run_names)]
        for folder in folders:
            probe = folder / ".squeezebench.probe"
            with _writing(probe):
                folder.mkdir(parents=True, exist_ok=True)
                probe.write_bytes(b"")
                probe.unlink()

    def append_journal(self, entry: dict[str, Any]) -> None:
        with _writing(self.run_dir / JOURNAL), open(self.run_dir / JOURNAL, "ab") as handle:
            handle.write(json.dumps(entry, sort_keys=True).encode() + b"\n")
            if self.durable:
                handle.flush()
                os.fsync(handle.fileno())

    # -- steps ----------------------------------------------------------------------------
    def write_step(self, run_name: str, step_id: str, rows: list[dict[str, Any]],
                   waveforms: dict[int, tuple[pd.DataFrame, dict[str, Any]]],
                   provenance: dict[str, Any] | None = None) -> dict[str, str]:
        """Waveforms, then the measurement table (each row with the `provenance` columns,
        so a row alone says which bench produced it); return {relative path: sha256} of
        every file written, for the journal line the caller appends."""
        with _writing(self.run_dir / "waveforms" / run_name / step_id):
            return self._write_step(run_name, step_id, rows, waveforms, provenance)

    def _write_step(self, run_name: str, step_id: str, rows: list[dict[str, Any]],
                    waveforms: dict[int, tuple[pd.DataFrame, dict[str, Any]]],
                    provenance: dict[str, Any] | None) -> dict[str, str]:
        rows = [{**row, **(provenance or {})} for row in rows]
        files: dict[str, str] = {}
        final_dir = self.run_dir / "waveforms" / run_name / step_id
        staging = final_dir.with_name(f".{step_id}.partial")
        for leftover in (staging, final_dir):   # a killed earlier attempt (repair moved it already)
            if leftover.exists():
                self._quarantine(leftover)
        staging.mkdir(parents=True)
        for point_index, (frame, metadata) in waveforms.items():
            table = _arrow_table(frame)
            table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                                   METADATA_KEY: json.dumps(metadata).encode()})
            data = _parquet_bytes(table)
            _write_staged(staging / f"{point_index:04d}.parquet", data, self.durable)
            files[f"waveforms/{run_name}/{step_id}/{point_index:04d}.parquet"] = _sha256_bytes(data)
        if self.durable:   # the staged names, then the folder's new name, on the disk before the journal line
            _fsync_dir(staging)
        os.replace(staging, final_dir)
        if self.durable:
            _fsync_dir(final_dir.parent)
        columns = list(dict.fromkeys(key for row in rows for key in row))  # union, in order
        table = pa.Table.from_pylist([{key: row.get(key) for key in columns} for row in rows])
        data = _parquet_bytes(table)
        write_atomic(self.run_dir / _measurement_file(run_name, step_id), data, self.durable)
        files[_measurement_file(run_name, step_id)] = _sha256_bytes(data)
        return files

    def _step_files_outside(self, completed: set[tuple[str, str]]) -> Iterator[Path]:
        """Every item in the step folders no completed step owns (OS litter aside)."""
        for folder in STEP_FOLDERS:
            root = self.run_dir / folder
            if not root.is_dir():
                continue
            for run_dir in sorted(root.iterdir()):
                if run_dir.name in OS_LITTER:
                    continue
                if not run_dir.is_dir():
                    yield run_dir
                    continue
                for entry in sorted(run_dir.iterdir()):
                    step_id = entry.name.removesuffix(".parquet") if folder == "measurements" else entry.name
                    if entry.name not in OS_LITTER and (run_dir.name, step_id) not in completed:
                        yield entry

    def _quarantine(self, item: Path, copy: bool = False) -> Path:
        """Move (or copy) `item` to this session's quarantine folder, same relative path."""
        if self._quarantine_dir is None:
            stamp = dt.datetime.now(dt.timezone.utc).strftime("%Y%m%dT%H%M%S.%fZ")
            self._quarantine_dir = self.run_dir / QUARANTINE / stamp
        target = self._quarantine_dir / item.relative_to(self.run_dir)
        target.parent.mkdir(parents=True, exist_ok=True)
        if copy:
            shutil.copy2(item, target)
        else:
            os.replace(item, target)
        if self.durable:
            _fsync_dir(target.parent)
        log.warning("quarantined %s as %s", item, target)
        return target


def _versions(record: dict[str, Any] | None) -> list[dict[str, Any]]:
    """Every version of one input the manifest records (a run from before versions: one)."""
    if not isinstance(record, dict):
        return []
    return record.get("versions") or [{"sha256": record.get("sha256"), "copy": record.get("copy")}]


def _also(journal_says: set[str], digest: str) -> str:
    """The journal's word on the campaign, where it differs from the copy."""
    others = sorted(journal_says - {digest})
    return f", the journal {', '.join(d[:12] + '...' for d in others)}" if others else ""


def _measurement_file(run_name: str, step_id: str) -> str:
    return f"measurements/{run_name}/{step_id}.parquet"


def _step_of(line: bytes) -> tuple[str, str]:
    """(run, step) of a journal line that is an entry."""
    entry = json.loads(line)
    return entry["run"], entry["step"]


def _entry_problem(line: bytes) -> str | None:
    """Why a journal line is not an entry, or None if it is one."""
    if not line.endswith(b"\n"):
        return "torn (no end of line: the process was killed while appending it)"
    try:
        entry = json.loads(line)
    except ValueError as exc:
        return f"not a journal entry (not valid JSON: {exc})"
    if not isinstance(entry, dict):
        return "not a journal entry (not a JSON object)"
    for key, kind in _ENTRY_FIELDS.items():
        if not isinstance(entry.get(key), kind) or isinstance(entry.get(key), bool):
            return f"not a journal entry (field '{key}' missing or of the wrong type)"
    for key in ("files", "inputs"):   # {name: sha256}; absent in runs from before checksums
        value = entry.get(key, {})
        if not isinstance(value, dict) or not all(isinstance(k, str) and isinstance(v, str)
                                                  for k, v in value.items()):
            return f"not a journal entry (field '{key}' is not a mapping of file to sha256)"
    return None


def bench_provenance(scene: Path | None, bench_file: Path | None,
                     identifications: dict[str, str]) -> dict[str, str]:
    """The columns every stored row carries about its bench: `bench` is "simulated" (the
    scene answered; `bench_input` is its copy under inputs/) or "real" (the bench file
    with the VISA addresses), `bench_input_sha256` that file's digest and
    `instrument_ids` the instruments' own identifications (JSON, role -> *IDN? reply)."""
    source = Path(scene if scene is not None else bench_file)
    return {"bench": "simulated" if scene is not None else "real",
            "bench_input": f"inputs/{source.name}", "bench_input_sha256": sha256_file(source),
            "instrument_ids": json.dumps(identifications, sort_keys=True)}


def read_measurements(run_dir: Path) -> pd.DataFrame:
    """All measurement rows of the completed steps, in journal order (for tests and tools)."""
    store = RunStore(run_dir)
    frames = [pd.read_parquet(Path(run_dir) / "measurements" / e["run"] / f"{e['step']}.parquet")
              for e in store.journal()]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
