"""The `squeezebench` command: check, run, report, reproduce, plan, study.

Each subcommand is a thin call into the package that does the work; the command line
only turns user errors into one clear message and an exit status.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from squeezebench import __version__, paths
from squeezebench.errors import UserError

EXIT_USER_ERROR = 2
EXIT_INTERRUPTED = 130
#: protocols.accuracy_study.AccuracyStudy.EXPERIMENTS, spelled here so `--help` imports nothing heavy.
STUDY_EXPERIMENTS = ("averages", "record", "search", "settle", "sweep", "heating")


def _bench_config(bench: str):
    from squeezebench.instruments.bench import load_bench_file, sim_bench_config

    if bench == "sim":
        return sim_bench_config(paths.default_scene())
    return load_bench_file(Path(bench))


def cmd_check(args: argparse.Namespace) -> int:
    from squeezebench.instruments.bench import check_bench

    return check_bench(_bench_config(args.bench), out=print)


def cmd_run(args: argparse.Namespace) -> int:
    from squeezebench.protocols.campaign import run_campaign

    if args.accept_changed_bench and not args.resume:
        raise UserError("--accept-changed-bench continues a stopped run: use it with --resume")
    run_dir = run_campaign(Path(args.campaign), resume=args.resume, out_dir=args.out,
                           accept_changed_bench=args.accept_changed_bench, progress=sys.stderr.isatty())
    print(f"run stored in {run_dir}")
    return 0


def cmd_validate(args: argparse.Namespace) -> int:
    """Each file checked on its own: one line per file (stdout if sound, stderr if not)."""
    import json

    from squeezebench.schemas import validate_file

    results = []
    for file in args.files:
        try:
            results.append({**validate_file(Path(file)), "ok": True, "error": None})
        except UserError as exc:
            results.append({"file": file, "ok": False, "error": str(exc), "warnings": []})
    if args.json:
        print(json.dumps(results, indent=2))
    else:
        for result in results:
            if result["ok"]:
                summary = f" ({result['summary']})" if result["summary"] else ""
                print(f"{result['file']}: valid {result['kind']}{summary}")
            else:
                print(f"squeezebench validate: {result['error']}", file=sys.stderr)
            for warning in result["warnings"]:
                print(f"squeezebench validate: warning: {warning}", file=sys.stderr)
    return 0 if all(result["ok"] for result in results) else EXIT_USER_ERROR


def cmd_report(args: argparse.Namespace) -> int:
    from squeezebench.analysis.report import write_report
    from squeezebench.protocols.storage import RunStore

    problems = RunStore(Path(args.run_dir)).verify()
    if problems and not args.allow_missing:
        more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
        raise UserError(f"{problems[0]}{more}; the report would lack their rows: restore the "
                        "files, or pass --allow-missing to report without them")
    for problem in problems:
        print(f"squeezebench report: warning: {problem}", file=sys.stderr)
    index = write_report(Path(args.run_dir))
    print(f"report written to {index}")
    return 0


def cmd_reproduce(args: argparse.Namespace) -> int:
    from squeezebench.analysis.report import write_report
    from squeezebench.protocols.accuracy_study import run_study
    from squeezebench.protocols.campaign import run_campaign

    run_dir = run_campaign(paths.paper_campaign(), resume=args.resume, out_dir=args.out)
    if not args.no_study:
        run_study(run_dir, resume=args.resume)
    index = write_report(run_dir)
    print(f"run stored in {run_dir}\nreport written to {index}")
    return 0


def cmd_study(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from squeezebench.protocols.accuracy_study import StudySettings, run_study

    try:
        settings = replace(StudySettings(), repeats=args.repeats)
    except ValueError as exc:
        raise UserError(f"--repeats: {exc}") from None
    experiments = tuple(args.experiment) if args.experiment else STUDY_EXPERIMENTS
    study_dir = run_study(args.out, settings, experiments, resume=args.resume)
    print(f"study stored in {study_dir}; 'squeezebench report {args.out}' shows it")
    return 0


def cmd_plan(args: argparse.Namespace) -> int:
    from squeezebench.protocols.planning import plan_campaign

    print(plan_campaign(Path(args.campaign), target_rel_error=args.target_rel_error, write=args.write))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="squeezebench", description=__doc__)
    parser.add_argument("--version", action="version", version=f"squeezebench {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    check = sub.add_parser("check", help="open every instrument and print its identification")
    check.add_argument("--bench", default="sim", help="'sim' or a bench YAML file (default: sim)")
    check.set_defaults(func=cmd_check)

    run = sub.add_parser("run", help="run a campaign file")
    run.add_argument("campaign", help="campaign YAML file")
    run.add_argument("--resume", action="store_true", help="continue after the last completed step")
    run.add_argument("--out", type=Path, default=None, help="run directory (default: from the campaign)")
    run.add_argument("--accept-changed-bench", action="store_true",
                     help="with --resume: continue with a bench file or scene changed since (a bench fix); "
                          "the manifest records both versions and which steps used which")
    run.set_defaults(func=cmd_run)

    validate = sub.add_parser("validate", help="check campaign, bench and scene files (and every scene "
                              "and request a campaign has) without touching a bench or a run directory")
    validate.add_argument("files", nargs="+", metavar="FILE", help="campaign, bench or scene YAML files")
    validate.add_argument("--json", action="store_true", help="one JSON list of results on stdout")
    validate.set_defaults(func=cmd_validate)

    report = sub.add_parser("report", help="recompute tables and figures from a stored run")
    report.add_argument("run_dir", help="run directory written by 'squeezebench run'")
    report.add_argument("--allow-missing", action="store_true",
                        help="report even if step files in the journal are missing or fail their checksum")
    report.set_defaults(func=cmd_report)

    reproduce = sub.add_parser("reproduce", help="the whole paper on the simulated bench, then the report")
    reproduce.add_argument("--out", type=Path, default=Path("runs/paper"), help="run directory (default: runs/paper)")
    reproduce.add_argument("--resume", action="store_true", help="continue an interrupted reproduction")
    reproduce.add_argument("--no-study", action="store_true",
                           help="skip the accuracy-vs-bench-time study (about a minute)")
    reproduce.set_defaults(func=cmd_reproduce)

    study = sub.add_parser("study", help="accuracy against bench time on the simulated bench")
    study.add_argument("--out", type=Path, default=Path("runs/study"),
                       help="run directory; trials go to OUT/study/ (default: runs/study)")
    study.add_argument("--repeats", type=int, default=8, help="trials per configuration (default 8)")
    study.add_argument("--experiment", action="append", choices=STUDY_EXPERIMENTS,
                       help="run only this experiment (repeatable; default: all)")
    study.add_argument("--resume", action="store_true", help="keep experiments already stored")
    study.set_defaults(func=cmd_study)

    plan = sub.add_parser("plan", help="cheapest acquisition settings meeting an accuracy target")
    plan.add_argument("campaign", help="campaign YAML file")
    plan.add_argument("--target-rel-error", type=float, default=0.01, help="relative error goal (default 0.01)")
    plan.add_argument("--write", type=Path, default=None, metavar="FILE",
                      help="also write the campaign with the planned settings to FILE")
    plan.set_defaults(func=cmd_plan)
    return parser


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except UserError as exc:
        print(f"squeezebench {args.command}: {exc}", file=sys.stderr)
        return EXIT_USER_ERROR
    except KeyboardInterrupt:
        print(f"squeezebench {args.command}: interrupted; completed steps are stored, "
              "use --resume to continue", file=sys.stderr)
        return EXIT_INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
