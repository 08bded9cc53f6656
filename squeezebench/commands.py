"""The command line's subcommands, one function each (`cmd_check`, `cmd_run`, `cmd_report`,
`cmd_reproduce`, `cmd_study`, `cmd_plan`, `cmd_design`, ...): a thin call into the package
that does the work, what it prints, and the exit statuses. `squeezebench.cli` parses the
arguments and dispatches here; nothing here imports the command line.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
from pathlib import Path

from squeezebench import paths
from squeezebench.errors import UserError

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130
#: protocols.accuracy_study.AccuracyStudy.EXPERIMENTS, spelled here so `--help` imports nothing heavy.
STUDY_EXPERIMENTS = ("averages", "record", "search", "settle", "sweep", "heating",
                     *(f"systematics_{point}{suffix}" for point in ("table3", "stress")
                       for suffix in ("", "_calibrated")),
                     "systematics_search", "systematics_campaign", "systematics_campaign_calibrated",
                     "systematics_sweep", "systematics_sweep_calibrated")
#: protocols.accuracy_study.StudySettings.repeats, spelled here for `--help` likewise.
STUDY_REPEATS = 6


#: `reproduce` leaves out the study's slowest experiments (the whole campaign per bench, a
#: few minutes): `study --out RUN_DIR --resume` adds them to a reproduction.
REPRODUCE_EXPERIMENTS = tuple(e for e in STUDY_EXPERIMENTS if not e.startswith("systematics_campaign"))


#: What `reproduce`'s worker processes run: the study's trials on the simulated bench (its
#: VISA library), and the report's plate solves and figures (`parallel.preload`).
REPRODUCE_WORKER_MODULES = ("squeezebench.protocols.accuracy_study", "pyvisa_simbench",
                            "squeezebench.report.run_report")


def say(args: argparse.Namespace, message: str) -> None:
    """A result line for a person: on stdout, unless `-q` or `--json`."""
    if not (args.quiet or getattr(args, "json", False)):
        print(message)


def emit_json(payload: dict) -> None:
    """The one JSON document a `--json` command writes to stdout."""
    json.dump(payload, sys.stdout, indent=2, default=str)
    sys.stdout.write("\n")


def show_progress(args: argparse.Namespace) -> bool:
    """Progress bars redraw in place: only on a terminal, never into a file or a pipe."""
    return not args.quiet and sys.stderr.isatty()


def _bench_config(bench: str):
    from squeezebench.instruments.bench import sim_bench_config
    from squeezebench.schemas import load_bench_file   # the validator `run` uses

    if bench == "sim":
        return sim_bench_config(paths.default_scene())
    return load_bench_file(Path(bench))


def cmd_check(args: argparse.Namespace) -> int:
    from squeezebench.instruments.bench import inspect_bench

    lines: list[str] = []

    def out(line: str) -> None:
        lines.append(line)
        say(args, line)

    from squeezebench.protocols.drive_record import bring_to_rest

    config = _bench_config(args.bench)
    bring_to_rest(config, out)   # after an unclean end, said first
    found = inspect_bench(config, out=out)
    passed = found.passed
    if args.json:   # per instrument for scripts; `lines` as a person reads them
        emit_json({"command": "check", "bench": args.bench, **found.as_dict(), "lines": lines})
    elif args.quiet and not passed:
        print(f"squeezebench check: {lines[-1]}", file=sys.stderr)   # the cause, said last
    return 0 if passed else EXIT_USER_ERROR


def cmd_serve_sim(args: argparse.Namespace) -> int:
    import threading
    import time

    import yaml

    from squeezebench.instruments.bench import sim_bench_config
    from squeezebench.instruments.served import served_bench_file
    from squeezebench.schemas import stage_travel_mm
    from squeezebench.simbench.serve_sim import ServedSim

    if not args.timeout_allowance >= 0:
        raise UserError(f"--timeout-allowance must be 0 or more seconds, got {args.timeout_allowance:g}")
    scene = paths.input_file(args.scene)
    config = sim_bench_config(scene)   # a BenchFileError names a scene that cannot be read
    with ServedSim(scene, args.line_rate, on_event=lambda text: print(f"serve-sim: {text}", file=sys.stderr),
                   computing_allowance_s=args.timeout_allowance) as sim:
        bench = served_bench_file(sim.addresses, config.electronics, stage_travel_mm(config))
        try:
            args.bench.write_text(f"# written by `squeezebench serve-sim --scene {scene}`; valid while it runs\n"
                                  + yaml.safe_dump(bench, sort_keys=False), encoding="utf-8")
        except OSError as exc:
            raise UserError(f"the bench file {args.bench} cannot be written ({exc.strerror or exc})") from None
        for role, address in sim.addresses.items():
            say(args, f"{role}: {address}")
        say(args, f"bench file {args.bench}: squeezebench check --bench {args.bench}; stop with Ctrl-C")
        try:
            time.sleep(args.for_s) if args.for_s is not None else threading.Event().wait()
        except KeyboardInterrupt:
            print("squeezebench serve-sim: stopped", file=sys.stderr)
            return EXIT_INTERRUPTED
    return 0


def cmd_safe(args: argparse.Namespace) -> int:
    """Only the generator, to its minimum amplitude (saying an unclean end first)."""
    from squeezebench.protocols.drive_record import bring_to_rest

    found = bring_to_rest(_bench_config(args.bench), lambda line: say(args, line), always=True)
    if args.json:
        emit_json({"command": "safe", "bench": args.bench, "left_driven": found})
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    from squeezebench.protocols.campaign import run_campaign
    from squeezebench.schemas import load_checked_campaign

    file = paths.shipped_of_kind(args.campaign, "campaigns")
    campaign = load_checked_campaign(file, bench_file=args.bench)
    if args.accept_changed_bench and not args.resume:
        raise UserError("--accept-changed-bench continues a stopped run: use it with --resume")
    if args.operator_done and not args.resume:
        raise UserError("--operator-done continues a run stopped at an operator's action: use it with --resume")
    watchers = {}
    if args.plot:
        from squeezebench.liveplot import LivePlot

        plot = LivePlot()
        watchers = {"on_point": plot.on_point, "on_step": plot.on_step}
        if not plot.interactive:
            print("squeezebench run: --plot found no display (matplotlib draws off-screen): the plot is "
                  "written as RUN_DIR/live_plot.png at the end (set MPLBACKEND to QtAgg or TkAgg for a "
                  "window)", file=sys.stderr)
    run_dir = run_campaign(file, resume=args.resume, out_dir=args.out,
                           progress=show_progress(args), accept_changed_bench=args.accept_changed_bench,
                           operator_done=args.operator_done, bench_file=args.bench, **watchers)
    say(args, f"run stored in {run_dir}")
    for line in _map_headline(campaign, run_dir):   # a map's answer now, not at `report`
        say(args, line)
    if not args.quiet:   # after the run: an error stays the one line it is
        for note in _campaign_notes(campaign, args.campaign):
            print(f"squeezebench run: {note}", file=sys.stderr)
    if args.plot:
        say(args, f"plot written to {plot.save(Path(run_dir) / 'live_plot.png')}")
    if args.plot and plot.interactive:
        import matplotlib.pyplot as plt

        say(args, "close the plot window to finish")
        plt.show()
    return 0


def _map_headline(campaign, run_dir: Path) -> list[str]:
    """The report's lines for each vibration map the campaign made (nothing without one)."""
    from squeezebench.protocols.variants import MAP_PROTOCOLS

    if not any(run.protocol in MAP_PROTOCOLS for run in campaign.runs):
        return []
    from squeezebench.report.cartography_report import map_summaries
    from squeezebench.report.headline import map_lines
    from squeezebench.analysis.rundata import load_run

    summaries, _ = map_summaries(load_run(run_dir))
    return [line.text for line in map_lines(summaries)]


def _campaign_notes(campaign, name: str) -> list[str]:
    """What a person should know of a campaign that ran: the replay scenes it used and the
    powers it read off resonance without a deskew run."""
    notes = []
    replays = _declared_replays(campaign)
    if replays:
        notes.append(f"{len(replays)} scene{'s' if len(replays) > 1 else ''} of this campaign "
                     f"{'are declared replays' if len(replays) > 1 else 'is a declared replay'} of published "
                     f"points the plate model does not predict ({', '.join(replays)}): `squeezebench validate "
                     "NAME` shows each departure; the report says so too.")
    undeskewed = campaign.powers_off_resonance_without_deskew()
    if undeskewed:
        notes.append(f"{', '.join(undeskewed)} read powers off resonance, where the current probe's delay moves "
                     "them most, and the campaign has no deskew_calibration run: their U carries the delay's "
                     f"bias bound. `squeezebench plan {name} --target-rel-error X --write FILE` adds the "
                     "run; the report counts the powers concerned.")
    return notes


def _declared_replays(campaign) -> list[str]:
    """The campaign's scene files that declare `replay:` (read as text: no plate is solved)."""
    from squeezebench.yamlfiles import read_yaml

    files = dict.fromkeys(path for run in campaign.runs for path in run.input_files()
                          if path.suffix in (".yaml", ".yml"))
    return [path.stem for path in files
            if isinstance(data := read_yaml(path), dict) and "replay" in data and "plate" in data]


def cmd_validate(args: argparse.Namespace) -> int:
    """Each file checked on its own: one line per file (stdout if sound, stderr if not)."""
    from squeezebench.schemas import validate_file

    checked = _files_to_validate(args)
    if not checked:
        raise UserError("name at least one file (or --campaign, --scene, --design, --bench NAME)")
    results = []
    for label, path, problem in checked:
        if problem:
            results.append({"file": label, "ok": False, "error": problem, "warnings": []})
            continue
        try:
            results.append({**validate_file(path), "ok": True, "error": None})
        except UserError as exc:
            results.append({"file": label, "ok": False, "error": str(exc), "warnings": []})
    passed = all(result["ok"] for result in results)
    if args.json:
        emit_json({"command": "validate", "passed": passed, "files": results})
    else:
        for result in results:
            if result["ok"]:
                summary = f" ({result['summary']})" if result["summary"] else ""
                say(args, f"{result['file']}: valid {result['kind']}{summary}")
            else:
                print(f"squeezebench validate: {result['error']}", file=sys.stderr)
            for warning in result["warnings"]:
                print(f"squeezebench validate: warning: {warning}", file=sys.stderr)
    return 0 if passed else EXIT_USER_ERROR


def _files_to_validate(args: argparse.Namespace) -> list[tuple[str, Path | None, str]]:
    """(name as given, file, problem) for each file to check: a file as given; a shipped
    name, resolved by kind with --campaign/--scene/--design/--bench, else in every kind that
    has it (said once on stderr: `validate large_plate` means the scene and the design)."""
    found = []
    for kind in paths.SHIPPED_KINDS:
        for name in getattr(args, kind) or ():
            try:
                found.append((name, paths.shipped_of_kind(name, kind), ""))
            except UserError as exc:
                found.append((name, None, str(exc)))
    for name in args.files:
        if Path(name).is_file():
            found.append((name, Path(name), ""))
            continue
        kinds = [kind for kind in paths.SHIPPED_KINDS if _shipped(name, kind)]
        if not kinds:
            found.append((name, None, paths.unknown_name(name, list(paths.SHIPPED_KINDS))))
            continue
        if len(kinds) > 1 and not args.quiet:
            words = " and the ".join(paths.KIND_SINGULAR[kind] for kind in kinds)
            print(f"squeezebench validate: {len(kinds)} shipped files are called {name}: the {words}; checking "
                  f"each ({' or '.join(f'--{paths.KIND_SINGULAR[k]} {name}' for k in kinds)} checks one)",
                  file=sys.stderr)
        found.extend((name, _shipped(name, kind), "") for kind in kinds)
    return found


def _shipped(name: str, kind: str) -> Path | None:
    try:
        return paths.shipped_of_kind(name, kind)
    except UserError:
        return None


def cmd_report(args: argparse.Namespace) -> int:
    import squeezebench.report.simulated_plates  # noqa: F401  (adds the simulated plates' section)
    from squeezebench.report.run_report import write_report
    from squeezebench.protocols.storage import RunStore

    store = RunStore(Path(args.run_dir))
    if args.rebuild_manifest:
        with store.writer():
            store.rebuild_manifest()
        say(args, f"{store.run_dir / 'manifest.json'} rebuilt from the journal and the files' checksums")
    unverified = store.unverifiable()
    if unverified and not args.allow_unverified:
        raise UserError(f"{'; '.join(unverified)}; the report would trust unchecked data: pass "
                        "--allow-unverified to report it anyway")
    for reason in unverified:
        print(f"squeezebench report: warning: UNVERIFIED: {reason}", file=sys.stderr)
    if store.exists():
        store.manifest()   # a malformed manifest is one message, not a traceback in the report
    problems = store.verify(planned=_planned_steps(store))
    if problems and not args.allow_missing:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise UserError(f"{problems[0]}{more}; the report would lack their rows: restore the "
                        "files, or pass --allow-missing to report without them")
    for problem in problems:
        print(f"squeezebench report: warning: {problem}", file=sys.stderr)
    index = write_report(Path(args.run_dir), left_out=[*(f"UNVERIFIED: {r}" for r in unverified), *problems])
    say(args, _finished(index))
    return 0


def _planned_steps(store) -> list[tuple[str, str]] | None:
    """The steps the run's campaign copy plans (None for a run without one, a study);
    a copy that cannot be read plans nothing and is said (the report leaves it out)."""
    from squeezebench.protocols.campaign import planned_steps
    from squeezebench.protocols.storage import CAMPAIGN_COPY

    copy = store.run_dir / CAMPAIGN_COPY
    if not copy.is_file():
        return None
    try:
        return planned_steps(copy)
    except UserError as exc:
        raise UserError(f"{exc}; which steps the run should have is unknown (restore the run's campaign copy)") \
            from None


def cmd_reproduce(args: argparse.Namespace) -> int:
    import squeezebench.report.simulated_plates  # noqa: F401  (adds the simulated plates' section)
    from squeezebench.report.drawing import stop_beside
    from squeezebench.report.run_report import prepare, solve_ahead, write_report
    from squeezebench.protocols.accuracy_study import run_study
    from squeezebench.protocols.campaign import run_campaign
    from squeezebench.protocols.parallel import Beside, preload

    from squeezebench.workers import default_workers

    if (args.workers or default_workers()) > 1:   # three workers (the drawing process, the study's
        preload(*REPRODUCE_WORKER_MODULES)       # two): one import of what they run, not three
    coverage_benches = _coverage_benches(args)
    if not args.resume:
        _clear_previous_reproduction(args, args.out)
    # The plates the campaign's maps and the report's predictions need no run: solved on the
    # report's drawing process meanwhile, the maps' first (the campaign waits for neither).
    campaign_plates = _solve_campaign_plates_ahead(args.workers)
    plates = solve_ahead(args.workers)
    # The study reads only shipped scenes: its trials run on the workers while the campaign
    # runs here, from the campaign's first stored step (its run directory made) on.
    study = Beside(lambda stop: None if args.no_study else run_study(
        args.out, experiments=REPRODUCE_EXPERIMENTS, resume=args.resume, progress=lambda message: say(args, message),
        workers=args.workers, scheduler=args.scheduler, stop=stop, bar=False))
    maps = _StoredMapsAhead(args.out, args.workers)

    def on_step(entry: dict) -> None:
        study.start()
        maps.step(entry)

    try:
        run_dir = run_campaign(paths.paper_campaign(), resume=args.resume, out_dir=args.out,
                               progress=show_progress(args), on_step=on_step)
        maps.step({})   # a map that was the campaign's last run
        prepare(plates)   # the report's part that needs no run, here instead of waiting idle for the study
    except BaseException:   # a stop: neither the study nor the plates' process may outlive it
        study.cancel()
        for work in (campaign_plates, plates, *maps.handed):
            stop_beside(work)
        raise
    study.finish()
    _run_coverage(args, run_dir, coverage_benches)
    index = write_report(run_dir, args.workers)
    say(args, f"run stored in {run_dir}\n" + _finished(index))
    return 0


class _StoredMapsAhead:
    """Watches the campaign's steps; once a map run's last step is stored (the next step is
    another run's), its plate's solve at the map's drive frequency goes to the report's
    drawing process (`cartography_report.solve_stored_map`), idle by then in the campaign's
    last runs, instead of being the first thing the report's figures wait for there."""

    def __init__(self, run_dir: Path, workers: int) -> None:
        from squeezebench.protocols.campaign import load_campaign
        from squeezebench.protocols.variants import MAP_PROTOCOLS

        self._run_dir, self._workers = Path(run_dir), workers
        self._maps = {run.name for run in load_campaign(paths.paper_campaign()).runs if run.protocol in MAP_PROTOCOLS}
        self._current: str | None = None
        self.handed: list = []   # the futures handed out (a stop ends them)

    def step(self, entry: dict) -> None:
        """`entry`: a stored step's journal entry; an empty one once the campaign ends."""
        import functools

        from squeezebench.report.cartography_report import solve_stored_map
        from squeezebench.report.drawing import beside

        run = entry.get("run")
        if self._current in self._maps and run != self._current:
            self.handed.append(beside(self._workers, functools.partial(solve_stored_map, self._run_dir, self._current)))
        self._current = run


def _solve_campaign_plates_ahead(workers: int):
    """The working modes the paper campaign's maps scan, solved on the report's drawing
    process into the disk cache (`_solve_campaign_plates`): on this process they were the campaign's
    one plate solve (about 2 CPU-s), on its critical path once the study ends first. Then
    those of the plates it characterises, which the report predicts at its end, when this
    process is the last one working. None without the disk cache or a second worker."""
    import functools

    from squeezebench.report.drawing import beside

    return beside(workers, functools.partial(_solve_campaign_plates, paths.paper_campaign()))


def _solve_campaign_plates(campaign: Path) -> None:
    """On the drawing process: what `simbench.modeshape` solves for the campaign's maps, then
    for its characterised plates (`simbench.predicted.predict` solves the same)."""
    from squeezebench.protocols.campaign import characterised_scenes, mapped_scenes
    from squeezebench.simbench import modeshape

    modeshape.solve_ahead(list(dict.fromkeys([*mapped_scenes(campaign), *characterised_scenes(campaign)])))


def _solve_coverage_plates(campaign: Path) -> None:
    """The plates every coverage bench reads, solved here into the disk cache before the
    benches are handed to the workers: the modes the campaign's maps scan (a bench's drawn
    tolerances leave a mode's shape the nominal plate's, `simbench.plate_draws`) and the paper's
    plates Tables 3-4 are printed beside (`predicted_plates.predictions`). With a cold cache
    the first two benches solved the same plates at once, each worker growing from about 130
    to 480-500 MB, past what loky takes for a leak (300 MB over its size after its first task,
    the warming's import): both were retired with a warning ("A worker stopped while some
    jobs were given to the executor") and their other caches lost. With a warm cache this
    reads them back (under 1 CPU-s)."""
    from squeezebench.protocols.campaign import mapped_scenes
    from squeezebench.report.run_report import solve_paper_plates
    from squeezebench.simbench import modeshape

    modeshape.solve_ahead(mapped_scenes(campaign))
    solve_paper_plates()


def _finished(index: Path) -> str:
    """What a person reads last: the report's headline, then where the report is."""
    from squeezebench.report.run_report import HEADLINE_FILE

    return (index.parent / HEADLINE_FILE).read_text() + f"report written to {index}"


def _clear_previous_reproduction(args: argparse.Namespace, out: Path) -> None:
    """`reproduce` again into its own earlier output starts afresh: everything in it was
    computed from the shipped paper campaign and is computed again. Any other run, or a
    directory that is not a run, is never removed (the campaign runner refuses it)."""
    from squeezebench.protocols.storage import LOCK, RunStore, sha256_file

    store = RunStore(out)
    if not store.exists():
        return
    campaign = store.manifest().get("campaign", {})
    paper = paths.paper_campaign()
    if (Path(campaign.get("file", "")) != paper.resolve()
            and campaign.get("sha256") != sha256_file(paper)):
        raise UserError(f"{out} holds a run of {campaign.get('file')}, not a reproduction of the "
                        "paper; choose another --out")
    with store.writer():   # not while another process writes it
        for entry in out.iterdir():
            if entry.is_dir():
                shutil.rmtree(entry)
            elif entry.name != LOCK:
                entry.unlink()
    say(args, f"replacing the previous reproduction in {out} (--resume continues one instead)")


def _coverage_benches(args: argparse.Namespace) -> int:
    """How many benches the coverage study runs on (checked before anything runs)."""
    benches = args.coverage_benches
    if benches is None:   # study: all of it by default, only what was asked for with --experiment
        benches = 0 if getattr(args, "experiment", None) else 40
    if benches < 0:
        raise UserError(f"--coverage-benches must be 0 or more, got {benches}")
    return benches


def _run_coverage(args: argparse.Namespace, out: Path, benches: int) -> None:
    """The coverage study (protocols.bench_errors) into OUT/study/coverage/, when benches > 0."""
    if benches:
        from squeezebench.protocols.bench_errors import run_coverage_study

        import pandas as pd

        from squeezebench.analysis.study import coverage_lines, coverage_table, coverage_verdict, design_coverage_points
        from squeezebench.disk_cache import cache_dir
        from squeezebench.workers import default_workers

        error_model = getattr(args, "coverage_errors", "specified")
        if args.scheduler is None and (args.workers or default_workers()) > 1 and cache_dir() is not None:
            _solve_coverage_plates(paths.paper_campaign())
        stored = run_coverage_study(out, benches, resume=args.resume, workers=args.workers, scheduler=args.scheduler,
                                    progress=lambda message: say(args, message), error_model=error_model)
        scored = pd.concat([pd.read_parquet(stored).assign(error_model=error_model), design_coverage_points()],
                           ignore_index=True)   # the design's predictions against the paper's print
        table = coverage_table(scored)
        for line in [coverage_verdict(table), *coverage_lines(table)]:   # what it found, then each quantity
            print(f"coverage: {line}", flush=True)


def cmd_study(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from squeezebench.protocols import parallel

    if args.scheduler is None:   # the workers import their trials' code while this process does
        parallel.warm(args.workers, "squeezebench.protocols.accuracy_study")
    from squeezebench.protocols.accuracy_study import StudySettings, run_study

    try:
        settings = replace(StudySettings(), repeats=args.repeats)
    except ValueError as exc:
        raise UserError(f"--repeats: {exc}") from None
    coverage_benches = _coverage_benches(args)
    experiments = tuple(args.experiment) if args.experiment else STUDY_EXPERIMENTS
    study_dir = run_study(args.out, settings, experiments, resume=args.resume,
                          progress=lambda message: say(args, message),
                          workers=args.workers, scheduler=args.scheduler)
    _run_coverage(args, args.out, coverage_benches)
    say(args, f"study stored in {study_dir}; 'squeezebench report {args.out}' shows it")
    return 0


def _world_shrink_factors(run_dir: Path) -> dict[str, float]:
    """{quantity: shrink factor} of the world-model coverage study stored in `run_dir`
    (`analysis.over_coverage`); a run directory without one is refused."""
    from squeezebench.analysis.over_coverage import MIN_BENCHES, WORLD, shrink_factors
    from squeezebench.analysis.study import STUDY_DIR, coverage_dir, coverage_table, load_coverage

    points = load_coverage(run_dir)
    if points is None or WORLD not in set(points["error_model"]):
        raise UserError(f"--coverage {run_dir}: no coverage study on the world model there "
                        f"({Path(run_dir) / STUDY_DIR / coverage_dir(WORLD)}); 'squeezebench study --out {run_dir} "
                        "--coverage-errors world' writes one")
    world = points[points["error_model"] == WORLD]
    if world["bench_seed"].nunique() < MIN_BENCHES:
        raise UserError(f"--coverage {run_dir}: its world coverage study has {world['bench_seed'].nunique()} benches; "
                        f"an over-coverage needs at least {MIN_BENCHES} to be told from luck ('squeezebench study "
                        f"--out {run_dir} --resume --coverage-errors world --coverage-benches 40' adds them)")
    return shrink_factors(coverage_table(world))


def cmd_plan(args: argparse.Namespace) -> int:
    from squeezebench.protocols import parallel, plan_cache
    from squeezebench.protocols.variants import MAP_PROTOCOLS

    campaign = paths.shipped_of_kind(args.campaign, "campaigns")
    # nothing kept: all is simulated, on the workers, which import its code while this process
    # does; a campaign of maps alone starts none (its map is planned here, `plan_map`)
    if args.scheduler is None and not _maps_only(campaign) and plan_cache.holds_nothing():
        parallel.warm(args.workers, "squeezebench.protocols.planning")
    from squeezebench.protocols.campaign import load_campaign
    from squeezebench.protocols.map_planning import map_job, plan_map, write_planned_maps
    from squeezebench.protocols.planning import campaign_cache, make_plan, plan_text, write_planned_campaign

    if args.write is not None:   # refused before minutes of planning, not after
        from squeezebench.protocols.storage import check_writable_file

        check_writable_file(args.write)
    shrink = None if args.coverage is None else _world_shrink_factors(args.coverage)   # before minutes of planning
    if campaign != Path(args.campaign):
        say(args, f"campaign: {campaign} (shipped; no file named {args.campaign} here)")
    runs = load_campaign(campaign).runs
    cache = campaign_cache(campaign)
    map_runs = [run for run in runs if run.protocol in MAP_PROTOCOLS]
    plan = None if len(map_runs) == len(runs) else make_plan(
        campaign, args.target_rel_error, workers=args.workers, scheduler=args.scheduler, cache=cache,
        alongside=[map_job(run, cache) for run in map_runs],   # on the same workers
        shrink_factors=shrink, shrink_source=str(args.coverage or ""))
    maps = [plan_map(run, args.target_rel_error, cache=cache) for run in map_runs]
    written = None
    if args.write:
        written = write_planned_campaign(campaign, plan, args.write) if plan else Path(shutil.copyfile(campaign, args.write))
        write_planned_maps(campaign, maps, written)
    if args.json:
        emit_json({"command": "plan", "campaign": campaign, **(plan.as_dict() if plan else {}),
                   "maps": [m.as_dict() for m in maps], "written": written})
    else:
        texts = [m.table() for m in maps] + [plan_text(plan, written) if plan else
                                             (f"planned campaign written to {written}" if written else "")]
        say(args, "\n\n".join(t for t in texts if t))
    if plan is not None and not plan.reachable:   # the table says why; a script must not take the plan for one that meets it
        quantities = sorted({f.quantity for f in plan.floors.below_floor()})
        print(f"squeezebench plan: target {args.target_rel_error:g} is below the floor the instruments' "
              f"specified errors (and the plates' tolerances) leave on {', '.join(quantities)}; no setting meets it",
              file=sys.stderr)
        return EXIT_USER_ERROR
    if any(m.chosen is None for m in maps):
        print(f"squeezebench plan: no grid step meets the map target {args.target_rel_error:g}", file=sys.stderr)
        return EXIT_USER_ERROR
    return 0


def _maps_only(campaign: Path) -> bool:
    """Whether every run of the campaign file is a map, read from the file alone (before the
    campaign's code is imported); a file that cannot be read is `load_campaign`'s to report."""
    from squeezebench.protocols.variants import MAP_PROTOCOLS
    from squeezebench.yamlfiles import FileFormatError, read_yaml

    try:
        data = read_yaml(campaign)
    except FileFormatError:
        return True
    runs = data.get("runs") if isinstance(data, dict) else None
    return isinstance(runs, list) and all(isinstance(run, dict) and run.get("protocol") in MAP_PROTOCOLS
                                          for run in runs)


def cmd_design(args: argparse.Namespace) -> int:
    if args.template:   # a file to fill in: `squeezebench design --template > my_plate.yaml`
        sys.stdout.write(paths.design_template().read_text(encoding="utf-8"))
        return 0
    if args.plate is None:
        raise UserError("name a design file (or a shipped design), or start one with: squeezebench design "
                        "--template > my_plate.yaml")
    from squeezebench.report.design_report import headline, payload
    from squeezebench.designing.workflow import run_design, write_build
    from squeezebench.report.design_report import write_design

    answer = run_design(args.plate, from_runs=args.from_runs or (), measured=args.measured,
                        measured_plate=args.measured_plate, sweep=not args.no_layouts,
                        workers=args.workers, scheduler=args.scheduler, allow_infeasible=args.allow_infeasible)
    folder, files = write_design(answer, args.out, measured_run=args.measured)
    build = {}
    if args.write_build is not None:
        scene, campaign = write_build(answer.design, answer.physics.nominal.values, args.write_build)
        build = {"scene": str(scene), "campaign": str(campaign)}
    if args.json:   # design.json's document, as written beside the page
        emit_json(payload(answer, files) | {"out": str(folder), "build": build})
    else:
        say(args, "\n".join(headline(answer)))
        if answer.layouts_note:
            say(args, answer.layouts_note)
        say(args, f"design page written to {folder / files['page']}")
        if build:
            say(args, f"predicted scene {build['scene']}; characterise it with: squeezebench run {build['campaign']}")
    return 0


def cmd_list(args: argparse.Namespace) -> int:
    """The shipped files by kind: the names `run`, `plan`, `validate` and `design` accept."""
    kinds = [args.kind] if args.kind else list(paths.SHIPPED_KINDS)
    listed = {kind: [{"name": path.stem, "file": str(path), "about": _about(path)} for path in paths.shipped(kind)]
              for kind in kinds}
    if args.json:
        emit_json({"command": "list", **listed})
        return 0
    for kind, entries in listed.items():
        say(args, f"{kind} ({len(entries)}):")
        width = max((len(entry["name"]) for entry in entries), default=0)
        for entry in entries:
            say(args, f"  {entry['name']:<{width}}  {entry['about']}".rstrip())
    return 0


def _about(path: Path) -> str:
    """A shipped file's first sentence: every shipped file opens with a comment saying what
    it is (up to its first command example, indented)."""
    words = []
    for line in path.read_text(encoding="utf-8").splitlines():
        if not line.startswith("#") or line.startswith("#  "):
            break
        words.append(line.lstrip("#").strip())
    text = " ".join(words)
    end = next((m.end(1) for m in re.finditer(r"(\S+\.) ", text) if m.group(1).lstrip("(") not in _ABBREVIATIONS), len(text))
    return text[:end]


#: Words ending in a full stop that do not end a sentence ("Fig. 7").
_ABBREVIATIONS = {"Fig.", "Figs.", "Sec.", "Eq.", "Eqs.", "e.g.", "i.e.", "cf."}
