"""The run directory (docs/design.md): what a campaign writes and how it survives a crash.

Measurements are tidy Parquet tables (one row per measured point, one column per
variable). Parquet, through pyarrow, because it is typed (a float stays a float, a bool a
bool, with nulls), columnar, compact, and read by `pandas.read_parquet` with no project
code: a run directory is usable by anyone with pandas.

Crash safety. A step is the unit of atomicity:
1. its waveforms go to a hidden staging folder, renamed into place when complete;
2. its measurement table goes to a temporary file, renamed into place (`os.replace`);
3. its journal line is appended to `journal.jsonl` and fsynced, last.
A step is complete if and only if its journal line exists. Opening a run directory for
resume deletes whatever a killed step left between 1 and 3, so a partially written step
never shows rows; a torn last journal line (killed mid-write) is ignored and truncated.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import logging
import os
import shutil
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

import squeezebench

log = logging.getLogger(__name__)

JOURNAL = "journal.jsonl"
MANIFEST = "manifest.json"
CAMPAIGN_COPY = "campaign.yaml"
METADATA_KEY = b"squeezebench"


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


def write_atomic(path: Path, data: bytes) -> None:
    """Write `data` to `path` so that a reader sees the old file or the new, never half."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb") as handle:
        handle.write(data)
        handle.flush()
        os.fsync(handle.fileno())
    os.replace(tmp, path)
    _fsync_dir(path.parent)


def _parquet_bytes(table: pa.Table) -> bytes:
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


class RunStore:
    """Reads and writes one run directory."""

    def __init__(self, run_dir: Path):
        self.run_dir = Path(run_dir)

    # -- creation and the manifest --------------------------------------------------------
    def exists(self) -> bool:
        return (self.run_dir / MANIFEST).exists()

    def create(self, campaign_file: Path) -> None:
        """Start a new run directory: the campaign copy and a first manifest."""
        self.run_dir.mkdir(parents=True, exist_ok=True)
        campaign_file = Path(campaign_file)
        write_atomic(self.run_dir / CAMPAIGN_COPY, campaign_file.read_bytes())
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
        (self.run_dir / JOURNAL).touch()

    def manifest(self) -> dict[str, Any]:
        return json.loads((self.run_dir / MANIFEST).read_text())

    def _write_manifest(self, manifest: dict[str, Any]) -> None:
        manifest["updated_utc"] = _utc_now()
        write_atomic(self.run_dir / MANIFEST, json.dumps(manifest, indent=2, sort_keys=True).encode())

    def add_input(self, path: Path) -> str:
        """Copy a scene or bench file into inputs/ and record its sha256; return the copy."""
        path = Path(path)
        digest = sha256_file(path)
        manifest = self.manifest()
        copy = f"inputs/{path.name}"
        known = manifest["inputs"].get(path.name)
        if known and known["sha256"] != digest:
            raise FileExistsError(f"{path}: another file named {path.name} is already an input of "
                                  f"{self.run_dir} with different content")
        if not known:
            write_atomic(self.run_dir / copy, path.read_bytes())
            manifest["inputs"][path.name] = {"file": str(path.resolve()), "copy": copy, "sha256": digest}
            self._write_manifest(manifest)
        return copy

    def record_instruments(self, run_name: str, identifications: dict[str, str]) -> None:
        manifest = self.manifest()
        manifest["instruments"][run_name] = identifications
        self._write_manifest(manifest)

    def write_settings(self, run_name: str, settings: dict[str, Any]) -> None:
        write_atomic(self.run_dir / "settings" / f"{run_name}.json",
                     json.dumps(settings, indent=2, sort_keys=True, default=str).encode())

    # -- the journal ----------------------------------------------------------------------
    def journal(self) -> list[dict[str, Any]]:
        """Completed steps in order; a torn last line (killed mid-append) is not a step."""
        return self._read_journal()[0]

    def _read_journal(self) -> tuple[list[dict[str, Any]], int]:
        path = self.run_dir / JOURNAL
        if not path.exists():
            return [], 0
        entries, good_bytes = [], 0
        with open(path, "rb") as handle:
            for line in handle:
                if not line.endswith(b"\n"):
                    break
                try:
                    entries.append(json.loads(line))
                except json.JSONDecodeError:
                    break
                good_bytes += len(line)
        return entries, good_bytes

    def repair(self) -> list[dict[str, Any]]:
        """Before resuming: drop a torn journal line and every file of an incomplete step."""
        entries, good_bytes = self._read_journal()
        path = self.run_dir / JOURNAL
        if path.exists() and good_bytes != path.stat().st_size:
            log.warning("%s: dropping a torn last line", path)
            with open(path, "r+b") as handle:
                handle.truncate(good_bytes)
        self._discard_incomplete({(e["run"], e["step"]) for e in entries})
        return entries

    def append_journal(self, entry: dict[str, Any]) -> None:
        with open(self.run_dir / JOURNAL, "ab") as handle:
            handle.write(json.dumps(entry, sort_keys=True).encode() + b"\n")
            handle.flush()
            os.fsync(handle.fileno())

    # -- steps ----------------------------------------------------------------------------
    def write_step(self, run_name: str, step_id: str, rows: list[dict[str, Any]],
                   waveforms: dict[int, tuple[pd.DataFrame, dict[str, Any]]]) -> None:
        """Waveforms, then the measurement table; the caller appends the journal line."""
        final_dir = self.run_dir / "waveforms" / run_name / step_id
        staging = final_dir.with_name(f".{step_id}.partial")
        shutil.rmtree(staging, ignore_errors=True)
        staging.mkdir(parents=True)
        for point_index, (frame, metadata) in waveforms.items():
            table = pa.Table.from_pandas(frame, preserve_index=False)
            table = table.replace_schema_metadata({**(table.schema.metadata or {}),
                                                   METADATA_KEY: json.dumps(metadata).encode()})
            write_atomic(staging / f"{point_index:04d}.parquet", _parquet_bytes(table))
        shutil.rmtree(final_dir, ignore_errors=True)   # a killed earlier attempt
        os.replace(staging, final_dir)
        columns = list(dict.fromkeys(key for row in rows for key in row))  # union, in order
        table = pa.Table.from_pylist([{key: row.get(key) for key in columns} for row in rows])
        write_atomic(self.run_dir / "measurements" / run_name / f"{step_id}.parquet", _parquet_bytes(table))

    def _discard_incomplete(self, completed: set[tuple[str, str]]) -> None:
        """Remove every step file not covered by a journal line (what a kill left)."""
        for folder in ("measurements", "waveforms"):
            root = self.run_dir / folder
            if not root.exists():
                continue
            for run_dir in root.iterdir():
                for entry in run_dir.iterdir():
                    step_id = entry.name.removesuffix(".parquet")
                    if entry.name.startswith(".") or (run_dir.name, step_id) not in completed:
                        log.info("removing %s: its step did not complete", entry)
                        if entry.is_dir():
                            shutil.rmtree(entry)
                        else:
                            entry.unlink()


def read_measurements(run_dir: Path) -> pd.DataFrame:
    """All measurement rows of the completed steps, in journal order (for tests and tools)."""
    store = RunStore(run_dir)
    frames = [pd.read_parquet(Path(run_dir) / "measurements" / e["run"] / f"{e['step']}.parquet")
              for e in store.journal()]
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()
