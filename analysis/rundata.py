"""Reading a run directory (layout in docs/design.md). Pure reading: nothing is written.

A missing or empty run directory is a `UserError` naming the path; a run that lacks one
protocol is not an error here (the report says which protocol is missing).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import yaml

from squeezebench.errors import UserError
from squeezebench.yamlfiles import load_strict

#: Waveform columns (design.md) and the scope channel each one is recorded on.
WAVEFORM_CHANNELS = {"piezo_voltage_v": "CH1", "current_a": "CH2", "vibrometer_output_v": "CH3"}


class RunDataError(UserError):
    """A run directory that cannot be read, with the path and what is wrong."""


@dataclass(frozen=True)
class Waveform:
    """One stored record: the samples and the provenance metadata written beside them."""

    samples: pd.DataFrame
    metadata: dict

    def y_increments(self) -> dict[str, float]:
        """Quantisation step per column, from the scope preamble (0 where not recorded)."""
        return {column: float(_channel_preamble(self.metadata, column, channel).get("y_increment", 0.0))
                for column, channel in WAVEFORM_CHANNELS.items()}

    def averages(self) -> int:
        preambles = [_channel_preamble(self.metadata, column, channel)
                     for column, channel in WAVEFORM_CHANNELS.items()]
        counts = [int(p["averages"]) for p in preambles if "averages" in p]
        return min(counts) if counts else 1


@dataclass
class RunData:
    run_dir: Path
    manifest: dict
    measurements: pd.DataFrame
    scenes: dict[str, dict]  # file name under inputs/ -> parsed YAML
    input_sha256: dict[str, str] = field(default_factory=dict)  # recomputed, for provenance
    #: waveform file -> reduced row, filled by analysis.tables so every table sees one reduction
    reductions: dict[str, dict] = field(default_factory=dict, repr=False)
    #: convention -> every plate's characterisation, filled by analysis.characterisation: the
    #: report's sections and its readings audit ask for the same few conventions a dozen times
    characterisations: dict[object, dict] = field(default_factory=dict, repr=False)
    #: every resonance search's (run, step, budget), filled by analysis.uncertainty: Tables 3
    #: and 4 and the uncertainty section each ask for all of them (not carried by a `replace`)
    search_budgets: list[tuple] | None = field(default=None, init=False, repr=False)

    def protocol(self, name: str) -> pd.DataFrame:
        """The measurement rows of one protocol (empty frame when it was not run)."""
        if self.measurements.empty or "protocol" not in self.measurements:
            return self.measurements.iloc[0:0]
        return self.measurements[self.measurements["protocol"] == name].reset_index(drop=True)

    def waveform(self, relative_path: str) -> Waveform:
        return load_waveform(self.run_dir, relative_path)


def load_run(run_dir: Path | str) -> RunData:
    """Manifest, all measurement rows (one frame) and the scene/bench copies of a run."""
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        raise RunDataError(f"{run_dir}: no such run directory")
    files = completed_step_files(run_dir)
    manifest_path = run_dir / "manifest.json"
    if not files and not manifest_path.exists() and not (run_dir / "study").is_dir():
        raise RunDataError(f"{run_dir}: not a run directory (no manifest.json, no "
                           "measurements/*/*.parquet and no study/); run 'squeezebench run CAMPAIGN' "
                           "or 'squeezebench study' first")
    return RunData(
        run_dir=run_dir,
        manifest=_read_manifest(manifest_path),
        measurements=read_measurements(files),
        scenes=_read_inputs(run_dir / "inputs"),
        input_sha256=_hash_inputs(run_dir / "inputs"),
    )


def completed_step_files(run_dir: Path) -> list[Path]:
    """measurements/<run>/<step>.parquet of the completed steps: with a journal, only the
    steps it lists whose file matches the checksum it records (a step killed between its
    rename and its journal line is not complete; a torn or damaged line is not a step,
    the lines after it still are), otherwise every step file (unverified: `report`
    refuses such a run unless told, see RunStore.unverifiable)."""
    measurements_dir = run_dir / "measurements"
    if not measurements_dir.is_dir():
        return []
    files = sorted(p for p in measurements_dir.glob("*/*.parquet")
                   if not p.name.startswith(".") and not p.parent.name.startswith("."))
    journal = run_dir / "journal.jsonl"
    if not journal.is_file():
        return files
    digests = {}
    for line in journal.read_bytes().split(b"\n")[:-1]:  # the text after the last LF is torn
        try:
            entry = json.loads(line)
            step = (str(entry["run"]), str(entry["step"]))
            digests[step] = (entry.get("files") or {}).get(f"measurements/{step[0]}/{step[1]}.parquet")
        except (json.JSONDecodeError, KeyError, TypeError, AttributeError):
            continue   # a damaged line costs its own step, never the steps after it
    # A step file that fails its checksum is not what was measured: it is left out.
    return [p for p in files if (p.parent.name, p.stem) in digests
            and digests[p.parent.name, p.stem] in (None, hashlib.sha256(p.read_bytes()).hexdigest())]


def read_measurements(files: list[Path]) -> pd.DataFrame:
    """Concatenate the tidy rows of every step, in file order (runs, then steps)."""
    frames = []
    for path in files:
        try:   # pandas' reader of the same table and frame, its dataset layer and threads left out (0.19 -> 0.12 CPU-s a run)
            frames.append(pq.ParquetFile(path, pre_buffer=False).read(use_threads=False).to_pandas(use_threads=False))
        except Exception as exc:  # a truncated or foreign file: name it, do not crash
            raise RunDataError(f"{path}: unreadable measurement file ({exc})") from exc
    frames = [frame for frame in frames if not frame.empty]
    if not frames:
        return pd.DataFrame()
    return pd.concat(frames, ignore_index=True, sort=False)


def load_waveform(run_dir: Path, relative_path: str) -> Waveform:
    path = Path(run_dir) / relative_path
    if not path.is_file():
        raise RunDataError(f"{path}: waveform file named in the measurements is missing")
    try:   # a few kB: one file's reader, without threads or pre-buffering, is three times quicker than read_table
        table = pq.ParquetFile(path, pre_buffer=False).read(use_threads=False)
    except Exception as exc:
        raise RunDataError(f"{path}: unreadable waveform file ({exc})") from exc
    raw = (table.schema.metadata or {}).get(b"squeezebench")
    try:
        metadata = json.loads(raw) if raw else {}
    except json.JSONDecodeError as exc:
        raise RunDataError(f"{path}: the 'squeezebench' metadata is not valid JSON ({exc})") from exc
    return Waveform(samples=table.to_pandas(use_threads=False), metadata=metadata)


def _channel_preamble(metadata: dict, column: str, channel: str) -> dict:
    """The preamble of one channel, wherever the writer nested it (by column name or by
    scope channel name, at the top level or under a 'channels'/'preamble' key)."""
    for container in (metadata, metadata.get("channels", {}), metadata.get("preamble", {}),
                      metadata.get("scope", {})):
        if not isinstance(container, dict):
            continue
        for key in (column, channel, channel.lower()):
            if isinstance(container.get(key), dict):
                return container[key]
    return {}


def _read_manifest(path: Path) -> dict:
    if not path.exists():
        return {}
    try:
        return json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise RunDataError(f"{path}: not valid JSON ({exc})") from exc


def _read_inputs(inputs_dir: Path) -> dict[str, dict]:
    scenes = {}
    for path in sorted(inputs_dir.glob("*.y*ml")) if inputs_dir.is_dir() else []:
        try:
            scenes[path.name] = load_strict(path.read_text()) or {}   # as the run read them
        except yaml.YAMLError as exc:
            raise RunDataError(f"{path}: not valid YAML ({exc})") from exc
    return scenes


def _hash_inputs(inputs_dir: Path) -> dict[str, str]:
    if not inputs_dir.is_dir():
        return {}
    return {path.name: hashlib.sha256(path.read_bytes()).hexdigest()
            for path in sorted(inputs_dir.iterdir()) if path.is_file()}
