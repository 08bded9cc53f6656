"""The `squeezebench` command: check, safe, run, report, reproduce, plan, study, validate, design, serve-sim.

The arguments are parsed and dispatched here; each subcommand (`squeezebench.commands`) is
a thin call into the package that does the work; the command line only turns user errors into one clear message and an exit status, and keeps the
conventions of every command: exit status 0 done, 2 user or instrument error, 130
interrupted; results on stdout (one JSON document with `--json`); the progress bar only on
a terminal; `-q` keeps only errors and what the operator must act on, `-v` adds the log
(every run and step, also kept in the run's log.txt) on stderr.
"""

from __future__ import annotations

import argparse
import difflib
import logging
import re
import sys
from pathlib import Path
from typing import NoReturn

from squeezebench import __version__, paths
from squeezebench.errors import UserError
from squeezebench.commands import (EXIT_INTERRUPTED, EXIT_USER_ERROR, STUDY_EXPERIMENTS, STUDY_REPEATS, cmd_check, cmd_design, cmd_list,
                                   cmd_plan, cmd_report, cmd_reproduce, cmd_run, cmd_safe, cmd_serve_sim, cmd_study,
                                   cmd_validate, emit_json)


def _relative_error(text: str) -> float:
    """argparse names a type's ValueError by the function's name: every refusal is said here."""
    try:
        value = float(text)
    except ValueError:
        value = None
    if value is None or not 0 < value < 1:   # inf, nan, 0 or 100 % cannot be planned for
        raise argparse.ArgumentTypeError(f"must be a number between 0 and 1 (0.01 is 1 %), got {text!r}")
    return value


def _workers(text: str) -> int:
    try:
        count = int(text)
    except ValueError:
        count = None
    if count is None or count < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number of processes, at least 1, got {text!r}")
    return count


def _add_parallel_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--workers", type=_workers, default=None, metavar="N",
                        help="run independent trials on N local processes (default: the cores this "
                             "process may use, or $SQUEEZEBENCH_WORKERS); results do not depend on N")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run the trials on the Dask cluster at ADDRESS (e.g. tcp://head:8786) instead")


#: What `squeezebench <command> --help` shows last: commands a lab types, with the comment
#: saying what each does.
EXAMPLES = {
    "check": ["squeezebench check                        # the simulated bench",
              "squeezebench check --bench my_bench.yaml  # a real one (copy data/benches/lab_example.yaml)",
              "squeezebench check --bench my_bench.yaml --json"],
    "safe": ["squeezebench safe --bench my_bench.yaml   # the plate at rest now"],
    "run": ["squeezebench run quick                    # a short campaign on the simulated bench",
            "squeezebench run paper --out runs/paper   # the paper's measurements",
            "squeezebench run my_campaign.yaml --resume  # continue after the last stored step",
            "squeezebench run cartography --plot       # a vibration map, watched live",
            "squeezebench run quick --bench served.yaml  # over pyvisa-py against serve-sim"],
    "serve-sim": ["squeezebench serve-sim --scene one_column_1mm --bench served.yaml  # then: run quick --bench served.yaml",
                  "squeezebench serve-sim --line-rate real --for 600   # serial bytes at their baud rate; stops by itself"],
    "validate": ["squeezebench validate my_campaign.yaml my_bench.yaml",
                 "squeezebench validate quick large_plate --json"],
    "report": ["squeezebench report runs/paper           # writes runs/paper/report/index.html",
               "squeezebench report runs/paper --allow-missing"],
    "reproduce": ["squeezebench reproduce                  # the paper, the study and the report",
                  "squeezebench reproduce --out /tmp/paper --no-study"],
    "study": ["squeezebench study --out runs/study",
              "squeezebench study --out runs/study --resume --coverage-benches 40"],
    "plan": ["squeezebench plan quick --target-rel-error 0.08",
             "squeezebench plan paper --target-rel-error 0.03 --write planned.yaml",
             "squeezebench plan cartography --target-rel-error 0.03 --json"],
    "list": ["squeezebench list                         # every shipped campaign, scene, design and bench",
             "squeezebench list campaigns --json"],
    "design": ["squeezebench design --template > my_plate.yaml   # a plate to fill in (docs/design-files.md)",
               "squeezebench design large_plate --no-layouts   # the paper's large plate, from physics",
               "squeezebench design large_plate --from runs/paper  # and by the paper's method from its small plates",
               "squeezebench design my_plate.yaml --write-build build/   # + its predicted scene and campaign",
               "squeezebench design my_plate.yaml --measured runs/my_plate_characterisation --json"],
}


def _loudness(parser: argparse.ArgumentParser, default) -> None:
    """-q/-v (and --version): on the top-level parser with their defaults, on each
    subcommand with SUPPRESS defaults, so one given before the subcommand's name is not
    reset by the subcommand's own default."""
    parser.add_argument("--version", action="version", version=f"squeezebench {__version__}")
    loudness = parser.add_mutually_exclusive_group()
    loudness.add_argument("-q", "--quiet", action="store_true", default=default,
                          help="only errors and what the operator must act on; no progress bar")
    loudness.add_argument("-v", "--verbose", action="store_true", default=default,
                          help="also log every run and step on stderr (as in the run's log.txt)")


def _json_flag(parser: argparse.ArgumentParser, default) -> None:
    parser.add_argument("--json", action="store_true", default=default,
                        help="print the result as one JSON document")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="squeezebench", description=__doc__,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    # The global options, before the subcommand (`squeezebench -q check`) or after it
    # (`squeezebench check -q`): every subcommand takes them from the `common` parent.
    _loudness(parser, False)
    _json_flag(parser, False)
    common = _Parser(add_help=False)
    _loudness(common, argparse.SUPPRESS)
    json_flag = _Parser(add_help=False)
    _json_flag(json_flag, argparse.SUPPRESS)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND",
                                parser_class=_Parser)
    parser.commands = {}

    def add(name: str, json: bool = False, **kwargs) -> argparse.ArgumentParser:
        lines = EXAMPLES[name]
        command = sub.add_parser(name, parents=[common, json_flag] if json else [common],
                                 epilog="examples:\n" + "\n".join(f"  {line}" for line in lines),
                                 formatter_class=argparse.RawDescriptionHelpFormatter, **kwargs)
        command.set_defaults(json_output=json)
        parser.commands[name] = command
        return command

    campaigns = ", ".join(paths.shipped_names("campaigns"))
    check = add("check", json=True, help="open every instrument and print its identification")
    check.add_argument("--bench", default="sim", help="'sim' or a bench YAML file (default: sim)")
    check.set_defaults(func=cmd_check)

    safe = add("safe", json=True, help="set the bench's generator to its minimum amplitude (and only that), "
               "saying what an unclean end left it at")
    safe.add_argument("--bench", default="sim", help="'sim' or a bench YAML file (default: sim)")
    safe.set_defaults(func=cmd_safe)

    run = add("run", help="run a campaign file")
    run.add_argument("campaign", help=f"campaign YAML file, or the name of a shipped one ({campaigns})")
    run.add_argument("--resume", action="store_true", help="continue after the last completed step")
    run.add_argument("--out", type=Path, default=None, help="run directory (default: from the campaign)")
    run.add_argument("--accept-changed-bench", action="store_true",
                     help="with --resume: continue with a bench file or scene changed since (a bench fix); "
                          "the manifest records both versions and which steps used which")
    run.add_argument("--operator-done", action="store_true",
                     help="with --resume: the operator's action the run stopped on for want of a terminal "
                          "(a cut, a plate change; it named it) has been done")
    run.add_argument("--bench", type=Path, default=None, metavar="FILE",
                     help="run every run of the campaign on this bench file (e.g. serve-sim's); a run's "
                          "scene then names the plate the operator mounts")
    run.add_argument("--plot", action="store_true",
                     help="draw the resonance sweeps, the measured points and the resonance drift live")
    run.set_defaults(func=cmd_run)

    serve = add("serve-sim", help="serve the simulated bench's instruments on this machine's TCP ports and "
                "pseudo-terminals, for a real VISA library (pyvisa-py)")
    serve.add_argument("--scene", default=str(paths.default_scene()), help="scene file or name (default: %(default)s)")
    serve.add_argument("--bench", type=Path, default=Path("served.yaml"), metavar="FILE",
                       help="bench file to write with the served addresses (default: %(default)s)")
    serve.add_argument("--line-rate", choices=("model", "real"), default="model",
                       help="real: each byte on a serial line takes its baud-rate time (default: bench clock only)")
    serve.add_argument("--timeout-allowance", type=float, default=30.0, metavar="SECONDS",
                       help="added to the clients' VISA timeouts: the simulator's computing of a reply takes "
                            "wall time a real instrument's does not (default: %(default)s; 0 for the drivers' own)")
    serve.add_argument("--for", dest="for_s", type=float, default=None, metavar="SECONDS",
                       help="stop by itself after this long (default: until Ctrl-C)")
    serve.set_defaults(func=cmd_serve_sim)

    validate = add("validate", json=True, help="check campaign, bench and scene files (and every scene "
                   "and request a campaign has) without touching a bench or a run directory")
    validate.add_argument("files", nargs="*", metavar="FILE",
                          help="campaign, bench, scene or design YAML files, or shipped ones by name")
    for kind, singular in paths.KIND_SINGULAR.items():
        validate.add_argument(f"--{singular}", dest=kind, action="append", metavar="NAME",
                              help=f"the shipped {singular} of this name (or a file), whatever else is called so")
    validate.set_defaults(func=cmd_validate)

    report = add("report", help="recompute tables and figures from a stored run")
    report.add_argument("run_dir", help="run directory written by 'squeezebench run'")
    report.add_argument("--allow-missing", action="store_true",
                        help="report without the steps whose journal line is damaged or whose files are "
                        "missing or fail their checksum (each one named)")
    report.add_argument("--allow-unverified", action="store_true",
                        help="report a run whose journal or manifest is missing (its files cannot be checked)")
    report.add_argument("--rebuild-manifest", action="store_true",
                        help="first write manifest.json again from the journal and the files' checksums")
    report.set_defaults(func=cmd_report)

    reproduce = add("reproduce", help="the whole paper on the simulated bench, then the report")
    reproduce.add_argument("--out", type=Path, default=Path("runs/paper"),
                           help="run directory (default: runs/paper); an earlier reproduction there is replaced")
    reproduce.add_argument("--resume", action="store_true", help="continue an interrupted reproduction")
    reproduce.add_argument("--no-study", action="store_true",
                           help="skip the accuracy-vs-bench-time study (about a minute)")
    reproduce.add_argument("--coverage-benches", type=int, default=0, metavar="N",
                           help="also run the paper campaign on N simulated benches with errors drawn within "
                                "specification and check the uncertainties' coverage (default 0: not run; "
                                "about 12 s of one core per bench)")
    _add_parallel_options(reproduce)
    reproduce.set_defaults(func=cmd_reproduce)

    study = add("study", help="accuracy against bench time on the simulated bench")
    study.add_argument("--out", type=Path, default=Path("runs/study"),
                       help="run directory; trials go to OUT/study/ (default: runs/study)")
    study.add_argument("--repeats", type=int, default=STUDY_REPEATS,
                       help=f"trials per configuration; for the systematics_* experiments, benches (default {STUDY_REPEATS})")
    study.add_argument("--experiment", action="append", choices=STUDY_EXPERIMENTS, metavar="NAME",
                       help="run only this experiment (repeatable; default: all): " + ", ".join(STUDY_EXPERIMENTS))
    study.add_argument("--resume", action="store_true", help="keep experiments and benches already stored")
    study.add_argument("--coverage-benches", type=int, default=None, metavar="N",
                       help="run the paper campaign on N simulated benches with errors drawn within specification "
                            "and check the uncertainties' coverage (default 40, or 0 with --experiment; "
                            "about 12 s of one core per bench)")
    study.add_argument("--coverage-errors", choices=("specified", "world"), default="specified",
                       help="how the coverage study's benches err: 'specified' (uniformly within the limits, as "
                            "the budgets assume) or 'world' (normal, a current probe lagging ~8 ns, 1 %% of errors "
                            "at 1.5 times their limit); stored side by side, the report shows both")
    _add_parallel_options(study)
    study.set_defaults(func=cmd_study)

    plan = add("plan", json=True, help="cheapest acquisition settings meeting an accuracy target")
    plan.add_argument("campaign", help=f"campaign YAML file, or the name of a shipped one ({campaigns})")
    plan.add_argument("--target-rel-error", type=_relative_error, default=0.01, help="relative error goal (default 0.01)")
    plan.add_argument("--write", type=Path, default=None, metavar="FILE",
                      help="also write the campaign with the planned settings to FILE")
    plan.add_argument("--coverage", type=Path, default=None, metavar="RUN_DIR",
                      help="a run directory holding a coverage study on the world model ('squeezebench study "
                           "--out RUN_DIR --coverage-errors world'): also say what the budgets' over-coverage there "
                           "costs in bench time")
    _add_parallel_options(plan)
    plan.set_defaults(func=cmd_plan)

    design = add("design", json=True, help="predict what a plate will need before it is built (voltage, "
                 "power, mode, layouts), from physics and from characterised small plates")
    design.add_argument("plate", nargs="?", help="design YAML file (docs/design-files.md), or the name of a "
                        f"shipped one ({', '.join(paths.shipped_names('designs'))})")
    design.add_argument("--template", action="store_true",
                        help="print a commented design file to start from (a 120 x 60 x 1.5 mm plate) and stop")
    design.add_argument("--from", dest="from_runs", nargs="+", type=Path, default=None, metavar="RUN_DIR",
                        help="characterisation runs of small plates of the same build: also predict by the "
                             "paper's method (Eqs. 25-29)")
    design.add_argument("--measured", type=Path, default=None, metavar="RUN_DIR",
                        help="a characterisation run of the built plate: set the measurement beside the predictions")
    design.add_argument("--measured-plate", default=None, metavar="NAME",
                        help="which plate of --measured is the built one (default: the design's name, or the only one)")
    design.add_argument("--out", type=Path, default=None, metavar="DIR",
                        help="write the page and its files into DIR itself (default: designs/<name>)")
    design.add_argument("--write-build", type=Path, default=None, metavar="DIR",
                        help="also write DIR/<name>.yaml, the design as a predicted scene of the simulated bench, "
                             "and DIR/<name>_characterisation.yaml, the campaign that characterises it (a dry run "
                             "of the built plate; on a real bench, name a bench file instead of the scene)")
    design.add_argument("--allow-infeasible", action="store_true",
                        help="write the page of a design that is not an answer (beyond the amplifier or the "
                             "ceramic's field, or piezos that cancel on the mode), marked infeasible in red, and "
                             "exit 0 (default: refuse it, naming the nearest feasible change, exit 2)")
    design.add_argument("--no-layouts", action="store_true",
                        help="skip the sweep of 216 piezo layouts (about 3 minutes on 2 cores for the large plate)")
    _add_parallel_options(design)
    design.set_defaults(func=cmd_design)

    listing = add("list", json=True, help="list the shipped campaigns, scenes, designs and bench examples")
    listing.add_argument("kind", nargs="?", choices=sorted(paths.SHIPPED_KINDS), metavar="KIND",
                         help=f"only these: {', '.join(paths.SHIPPED_KINDS)} (default: all)")
    listing.set_defaults(func=cmd_list)
    return parser


class _ProgressSafeHandler(logging.Handler):
    """Log lines to stderr through tqdm, so a progress bar on the terminal stays whole."""

    def emit(self, record: logging.LogRecord) -> None:
        from tqdm import tqdm

        tqdm.write(self.format(record), file=sys.stderr)


def console_log(verbose: bool) -> logging.Handler | None:
    """With -v, the package's log on stderr. Warnings and errors reach the terminal once,
    from the code that meets them (the operator's messages, this module's error line),
    so the console log carries only the running account below them."""
    if not verbose:
        return None
    handler = _ProgressSafeHandler(logging.INFO)
    handler.addFilter(lambda record: record.levelno < logging.WARNING)
    handler.setFormatter(logging.Formatter("%(asctime)s %(name)s: %(message)s", "%H:%M:%S"))
    logger = logging.getLogger("squeezebench")
    logger.addHandler(handler)
    if logger.level == logging.NOTSET or logger.level > logging.INFO:
        logger.setLevel(logging.INFO)
    return handler


class _Parser(argparse.ArgumentParser):
    """Usage errors as every other error: the usage line of the command they belong to, one
    line naming that command on stderr, exit 2, and with `--json` anywhere on the line also
    one JSON document on stdout (a script reads no usage text)."""

    commands: dict[str, argparse.ArgumentParser] = {}

    def parse_args(self, args=None, namespace=None):
        """Arguments no parser knows are the subcommand's error, said with its usage (argparse
        leaves them to the top-level parser); so are -q with -v and --json where the
        subcommand has no JSON output, whichever side of its name they were given."""
        found, extras = self.parse_known_args(args, namespace)
        command = self.commands.get(getattr(found, "command", None), self)
        if extras:
            command.error(f"unrecognized arguments: {' '.join(extras)}")
        if getattr(found, "quiet", False) and getattr(found, "verbose", False):
            command.error("-q/--quiet and -v/--verbose contradict each other: give one")
        if getattr(found, "json", False) and not getattr(found, "json_output", True):
            command.error("--json: this command has no JSON output")
        return found

    def error(self, message: str) -> NoReturn:
        argv = sys.argv[1:] if _Parser.argv is None else _Parser.argv
        invalid = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if invalid:   # a mistyped name: the closest one, as git and pip do
            choices = re.findall(r"'([^']*)'", invalid.group(2))
            close = difflib.get_close_matches(invalid.group(1), choices, n=1)
            if close:
                message += f"; did you mean '{close[0]}'?"
        sys.stderr.write(self.format_usage())
        print(f"{self.prog}: {message} (see {self.prog} --help)", file=sys.stderr)
        if "--json" in argv:
            emit_json({"command": next((a for a in argv if not a.startswith("-")), None), "error": message})
        raise SystemExit(EXIT_USER_ERROR)

    argv: list[str] | None = None


def main(argv: list[str] | None = None) -> int:
    # Piped (a log file, `tee`, a CI job) Python buffers stdout by blocks: a long reproduce
    # would print nothing for minutes. A person reads lines as they come.
    if hasattr(sys.stdout, "reconfigure"):
        sys.stdout.reconfigure(line_buffering=True)
    _Parser.argv = argv
    args = build_parser().parse_args(argv)
    logger = logging.getLogger("squeezebench")
    level = logger.level
    handler = console_log(getattr(args, "verbose", False))
    try:
        if getattr(args, "workers", 0) is None:   # only commands that run trials have the option
            from squeezebench.workers import default_workers

            args.workers = default_workers()
        return args.func(args)
    except UserError as exc:
        print(f"squeezebench {args.command}: {exc}", file=sys.stderr)
        if getattr(args, "json", False):
            emit_json({"command": args.command, "error": str(exc)})
        return EXIT_USER_ERROR
    except BaseException as exc:
        from squeezebench.stops import generator_state, stop_in

        stop = stop_in(exc)   # the stop itself, or a stop the interpreter wrapped in another error
        if stop is None:
            raise
        state = generator_state()
        print(f"squeezebench {args.command}: interrupted ({stop or 'KeyboardInterrupt'}); "
              f"{state + '; ' if state else ''}completed steps are stored, use --resume to continue",
              file=sys.stderr)
        return EXIT_INTERRUPTED
    finally:
        if handler is not None:   # main() called from Python leaves logging as it found it
            logger.removeHandler(handler)
            logger.setLevel(level)


if __name__ == "__main__":
    sys.exit(main())
