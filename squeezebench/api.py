"""squeezebench from Python (a notebook, a script): the same work as the command line.

    from squeezebench import api

    plate = {"n_powered_columns": 1, "n_powered_piezos": 4}
    search = {"start_hz": 36000, "stop_hz": 38500, "points": 26}
    found = api.resonance_search("runs/nb/search", plate=plate, search=search,
                                 scene="one_column_1mm.yaml")
    found.points()                       # pandas: one row per measured point
    swept = api.characterisation("runs/nb/char", plate=plate, search=search,
                                 voltages_vpp=[20, 40, 60], scene="one_column_1mm.yaml")
    swept.waveforms()                    # every kept record, one row per sample
    swept.report()                       # runs/nb/char/report/index.html

- `open_bench(scene=... | bench_file=...)`: the instruments, for talking to them directly.
- `run_protocol(...)` (and `resonance_search`, `characterisation`): one protocol run, with
  the campaign runner's safety limits, crash-safe storage, `resume` and provenance; the
  run directory is an ordinary one (`squeezebench report` reads it).
- `run_campaign(campaign, ...)`: a campaign file, or a shipped one by name (`"quick"`).
- `load_run(run_dir)`: a stored run as DataFrames: `points()`, `waveforms()`, `settings()`
  (one row per run, one typed column per setting), `table3()`/`table4()`/`table5()`;
  `report()` regenerates its report.
- `table3(run, wide=True)` (and `table4`, `table5`): the paper's table recomputed, one row
  per plate, one column per quantity with its unit in the name, `_expanded_u` columns for U.
- `design(plate, ...)`: what a plate will need before it is built (`squeezebench design`):
  `answer.physics.nominal.values`, `answer.physics.expanded` (U, k = 2), `answer.physics.budget`,
  `answer.comparison()`, `answer.layouts`; `out_dir` also writes the page.

Every run takes `on_point` / `on_step` watchers (protocols.campaign.Watchers);
`squeezebench.liveplot.LivePlot` is one. Errors a user can fix are `UserError`s naming the
file, field or instrument, as on the command line.
"""

from __future__ import annotations

import json
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Iterator, Mapping, Sequence

import pandas as pd

from squeezebench import paths
from squeezebench.yamlfiles import dump_yaml
from squeezebench.errors import UserError

Watcher = Callable[[dict[str, Any]], None]


def open_bench(scene: str | Path | None = None, bench_file: str | Path | None = None):
    """The bench, as a context manager: the simulated one answering from `scene` (a shipped
    scene's name or a path), or the real one a bench file describes. `bench.generator`,
    `bench.scope`, `bench.vibrometer` are the drivers; `bench.electronics` the amplifier
    and probes. Closing it closes the VISA session (the generator is left as it is:
    protocols, not this, bring it to its minimum)."""
    from squeezebench.instruments.bench import open_bench as open_configured, sim_bench_config
    from squeezebench.schemas import load_bench_file

    if (scene is None) == (bench_file is None):
        raise UserError("open_bench needs exactly one of scene= (simulated bench) or bench_file= (real bench)")
    config = sim_bench_config(_scene_path(scene)) if scene is not None else load_bench_file(Path(bench_file))
    return open_configured(config)


def run_campaign(campaign: str | Path, out_dir: str | Path | None = None, resume: bool = False,
                 on_point: Watcher | None = None, on_step: Watcher | None = None,
                 progress: bool = False) -> RunResults:
    """Run (or continue) a campaign file, or a shipped campaign by name; the stored run."""
    from squeezebench.protocols.campaign import run_campaign as run

    run_dir = run(paths.campaign_file(campaign), resume=resume, out_dir=None if out_dir is None else Path(out_dir),
                  progress=progress, on_point=on_point, on_step=on_step)
    return RunResults(run_dir)


def run_protocol(protocol: str, out_dir: str | Path, *, plate: Mapping[str, Any],
                 parameters: Mapping[str, Any], scene: str | Path | None = None,
                 bench_file: str | Path | None = None, acquisition: Mapping[str, Any] | None = None,
                 safety: Mapping[str, Any] | None = None, name: str | None = None, resume: bool = False,
                 on_point: Watcher | None = None, on_step: Watcher | None = None,
                 progress: bool = False) -> RunResults:
    """One run of `protocol` (protocols.campaign.PROTOCOLS) into `out_dir`: a campaign of
    one run, written out and checked exactly as a campaign file would be (the run keeps
    the file as campaign.yaml), so every field name and every error is the campaign's.
    `name` (default: the protocol's) names the run's folders inside `out_dir`."""
    if (scene is None) == (bench_file is None):
        raise UserError("run_protocol needs exactly one of scene= (simulated bench) or bench_file= (real bench)")
    bench = ({"scene": str(_scene_path(scene))} if scene is not None
             else {"file": str(Path(bench_file).resolve())})
    run = {"name": name or protocol, "protocol": protocol, "bench": bench, "plate": dict(plate),
           "parameters": _plain(parameters)}
    if acquisition:
        run["acquisition"] = dict(acquisition)
    if safety:
        run["safety"] = dict(safety)
    out_dir = Path(out_dir)
    with tempfile.TemporaryDirectory(prefix="squeezebench-api-") as tmp:
        campaign = Path(tmp) / f"{out_dir.name}.yaml"
        campaign.write_text(dump_yaml({"name": out_dir.name, "runs": [run]}))
        return run_campaign(campaign, out_dir, resume=resume, on_point=on_point, on_step=on_step,
                            progress=progress)


def resonance_search(out_dir: str | Path, *, plate: Mapping[str, Any], search: Mapping[str, Any],
                     **run: Any) -> RunResults:
    """Section 2.1's resonance search (protocols.resonance): a coarse sweep, then golden
    section. `search` holds SearchSettings' fields (start_hz, stop_hz, points, ...); the
    points have `sweep` True for the search and False for the point at the resonance."""
    return run_protocol("resonance_search", out_dir, plate=plate, parameters={"search": search}, **run)


def characterisation(out_dir: str | Path, *, plate: Mapping[str, Any], search: Mapping[str, Any],
                     voltages_vpp: Sequence[float], **run: Any) -> RunResults:
    """Sections 4-5's characterisation (protocols.characterisation): at the resonance,
    re-found before each voltage, one point per piezo voltage (peak-to-peak)."""
    return run_protocol("characterisation", out_dir, plate=plate,
                        parameters={"search": search, "voltages_vpp": list(voltages_vpp)}, **run)


def design(plate: str | Path, *, from_runs: Sequence[str | Path] = (), measured: str | Path | None = None,
           measured_plate: str | None = None, layouts: bool = False, out_dir: str | Path | None = None,
           workers: int | None = None):
    """A plate design's prediction (`designing.answer.DesignAnswer`), as `squeezebench design`
    (the layout sweep only when `layouts`, a few minutes for a large plate); with `out_dir`,
    its page, design.json and tables are written there too."""
    from squeezebench.designing.workflow import run_design
    from squeezebench.report.design_report import write_design

    answer = run_design(plate, from_runs=from_runs, measured=measured, measured_plate=measured_plate,
                        sweep=layouts, workers=workers)
    if out_dir is not None:
        write_design(answer, out_dir, measured_run=measured)
    return answer


def table3(run: RunResults | str | Path, wide: bool = False) -> pd.DataFrame:
    """Table 3 of a run (a `load_run` result or its directory); see `RunResults.table3`."""
    return (run if isinstance(run, RunResults) else load_run(run)).table3(wide)


def table4(run: RunResults | str | Path, wide: bool = False) -> pd.DataFrame:
    """Table 4 of a run; see `RunResults.table4`."""
    return (run if isinstance(run, RunResults) else load_run(run)).table4(wide)


def table5(run: RunResults | str | Path, wide: bool = False) -> pd.DataFrame:
    """Table 5 of a run; see `RunResults.table5`."""
    return (run if isinstance(run, RunResults) else load_run(run)).table5(wide)


def load_run(run_dir: str | Path) -> RunResults:
    """A stored run (from `squeezebench run`, `reproduce` or this module)."""
    run = RunResults(Path(run_dir))
    if not run.run_dir.is_dir():
        raise UserError(f"{run.run_dir}: no such run directory")
    return run


@dataclass(frozen=True)
class RunResults:
    """A run directory read as tidy DataFrames (layout in docs/design.md). Each call reads
    the files again, so a run still being written shows its completed steps so far."""

    run_dir: Path

    def points(self) -> pd.DataFrame:
        """One row per measured point, units in the column names; only completed steps."""
        from squeezebench.analysis.rundata import completed_step_files, read_measurements

        return read_measurements(completed_step_files(self.run_dir))

    def waveforms(self, run: str | None = None, step: str | None = None) -> pd.DataFrame:
        """Every kept scope record (of one run / step if given), one row per sample: the
        point's run_name, step_id and point_index, then time_s and the channels in SI units."""
        from squeezebench.analysis.rundata import load_waveform

        points = self.points()
        if points.empty:
            return pd.DataFrame()
        kept = points[points["waveform_file"].notna()]
        if run is not None:
            kept = kept[kept["run_name"] == run]
        if step is not None:
            kept = kept[kept["step_id"] == step]
        frames = [load_waveform(self.run_dir, row.waveform_file).samples.assign(
                      run_name=row.run_name, step_id=row.step_id, point_index=row.point_index)
                  for row in kept.itertuples()]
        if not frames:
            return pd.DataFrame()
        frame = pd.concat(frames, ignore_index=True)
        return frame[["run_name", "step_id", "point_index",
                      *[c for c in frame.columns if c not in ("run_name", "step_id", "point_index")]]]

    def settings(self, long: bool = False) -> pd.DataFrame:
        """The settings each protocol run started with (instruments as read back,
        acquisition, safety, electronics, parameters): one row per run, one column per
        setting ('acquisition.averages'), each of one type (a number, a word, a flag);
        `long=True`: one row per run and setting, the values in one mixed column."""
        rows = [{"run_name": file.stem, "setting": setting, "value": value}
                for file in sorted((self.run_dir / "settings").glob("*.json"))
                for setting, value in _flatten(json.loads(file.read_text()))]
        frame = pd.DataFrame(rows, columns=["run_name", "setting", "value"])
        if long:
            return frame
        wide = pd.DataFrame.from_dict({run: dict(zip(group["setting"], group["value"]))
                                       for run, group in frame.groupby("run_name", sort=False)}, orient="index")
        # a column a list filled (a sweep's voltages) stays as it is; every other takes one type:
        # numbers and words infer theirs, a flag some runs lack is a nullable boolean
        wide = wide.infer_objects()
        flags = [name for name, column in wide.items()
                 if column.dtype == object and pd.api.types.infer_dtype(column, skipna=True) == "boolean"]
        wide[flags] = wide[flags].astype("boolean")
        return wide.rename_axis("run_name").reset_index()

    def table3(self, wide: bool = False) -> pd.DataFrame:
        """Table 3 recomputed: tidy, one row per (plate length, quantity); `wide=True` one row
        per plate, one column per quantity (unit in its name) and `<quantity>_expanded_u`, its U
        (k = 2), `paper_<quantity>`, `<quantity>_status`."""
        return self._paper_table("table3", wide)

    def table4(self, wide: bool = False) -> pd.DataFrame:
        """Table 4 recomputed, as `table3`; one row per configuration when wide."""
        return self._paper_table("table4", wide)

    def table5(self, wide: bool = False) -> pd.DataFrame:
        """Table 5 recomputed (the report's reading), as `table3`; one row per estimate when wide."""
        return self._paper_table("table5", wide)

    def _paper_table(self, name: str, wide: bool) -> pd.DataFrame:
        from squeezebench.analysis import characterisation, tables
        from squeezebench.analysis.rundata import load_run as load_stored_run

        run = load_stored_run(self.run_dir)
        if name == "table5":
            from squeezebench.analysis.model import REPORT_CONVENTION

            frame = characterisation.table5(characterisation.characterise_plates(run, REPORT_CONVENTION), REPORT_CONVENTION)
        else:
            frame = getattr(tables, name)(run)
        frame = tables.finish_table(frame)
        return tables.wide_table(frame) if wide else frame

    def manifest(self) -> dict[str, Any]:
        """Software version, input files with their sha256, instrument identifications."""
        return json.loads((self.run_dir / "manifest.json").read_text())

    def uncertainties(self) -> pd.DataFrame:
        """One row per stored point that kept its record (a sweep's points keep none):
        each quantity (power_w, velocity_pp_mps, piezo_voltage_vpp, frequency_hz) reduced
        from the record, with its expanded uncertainty (`<quantity>_U`, k = 2, the whole
        budget) and the budget's dominant term (`<quantity>_dominant`)."""
        from squeezebench.analysis.rundata import load_run as load_stored_run
        from squeezebench.analysis.uncertainty import run_uncertainties

        return run_uncertainties(load_stored_run(self.run_dir)).points

    def tables(self) -> dict[str, pd.DataFrame]:
        """The report's tables (Tables 3-5, Figs. 2 and 5, the map's summary, the budgets...)
        by name, recomputed from the stored data: `report()` is run, its CSVs read back
        (one dtype per column: missing numbers are NaN, the `status` column says why)."""
        folder = self.report().parent
        return {path.stem: pd.read_csv(path) for path in sorted(folder.glob("*.csv"))
                if path.name != "columns.csv" and path.stat().st_size > 1}

    def report(self) -> Path:
        """Regenerate RUN_DIR/report/ from the stored data; the index.html path (the same
        report as `squeezebench report`, the simulated plates' section included)."""
        import squeezebench.report.simulated_plates  # noqa: F401  (adds the simulated plates' section)
        from squeezebench.report.run_report import write_report

        return write_report(self.run_dir)


def _scene_path(scene: str | Path) -> Path:
    """A scene file given by path, else a shipped scene by name."""
    path = Path(scene)
    return path.resolve() if path.exists() else paths.scenes_dir() / path


def _plain(value: Any) -> Any:
    """Parameters as YAML can hold them (tuples and numpy numbers from a notebook)."""
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if hasattr(value, "item"):   # a numpy scalar
        return value.item()
    if isinstance(value, Path):
        return str(value)
    return value


def _flatten(settings: Mapping[str, Any], prefix: str = "") -> Iterator[tuple[str, Any]]:
    for key, value in settings.items():
        if isinstance(value, Mapping):
            yield from _flatten(value, f"{prefix}{key}.")
        else:
            yield f"{prefix}{key}", value
