"""The command line keeps the names users script against."""

import sys

import pytest

from squeezebench import cli, commands
from squeezebench.errors import UserError


def test_subcommands_and_defaults():
    parser = cli.build_parser()
    assert parser.parse_args(["plan", "c.yaml"]).target_rel_error == 0.01
    assert parser.parse_args(["check"]).bench == "sim"
    assert parser.parse_args(["run", "c.yaml", "--resume"]).resume is True
    assert str(parser.parse_args(["reproduce"]).out) == "runs/paper"


def test_user_error_becomes_one_line_and_exit_2(monkeypatch, capsys):
    def broken(args):
        raise UserError("campaign.yaml: field 'runs' is missing")

    args = cli.build_parser().parse_args(["report", "somewhere"])
    args.func = broken
    monkeypatch.setattr(cli, "build_parser", lambda: _FixedParser(args))
    assert cli.main(["report", "somewhere"]) == cli.EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert "field 'runs' is missing" in err and "Traceback" not in err


class _FixedParser:
    def __init__(self, args):
        self._args = args

    def parse_args(self, argv):
        return self._args


def test_keyboard_interrupt_exit_code(monkeypatch):
    args = cli.build_parser().parse_args(["report", "x"])

    def interrupted(_):
        raise KeyboardInterrupt

    args.func = interrupted
    monkeypatch.setattr(cli, "build_parser", lambda: _FixedParser(args))
    assert cli.main(["report", "x"]) == cli.EXIT_INTERRUPTED


# -- conventions shared by every command ----------------------------------------------------
import json  # noqa: E402
from pathlib import Path  # noqa: E402


from squeezebench import paths  # noqa: E402
from squeezebench.protocols.storage import RunStore  # noqa: E402
from squeezebench.yamlfiles import dump_yaml, load_strict  # noqa: E402


def test_check_json_is_one_document_naming_each_instrument(capsys):
    assert cli.main(["check", "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["passed"] is True and report["bench"] == "sim"
    assert any("33120A" in line for line in report["lines"])
    assert any("TDS 3054B" in line for line in report["lines"])
    # and per instrument, for scripts: role, address, identification, what it showed
    roles = {i["role"]: i for i in report["instruments"]}
    assert set(roles) == {"generator", "scope", "vibrometer", "stage"}   # the simulated bench has a stage
    assert any("NOT REFERENCED" in line for line in roles["stage"]["details"])
    assert all(i["answered"] and i["address"] and i["details"] for i in roles.values())
    assert "33120A" in roles["generator"]["identification"] and "3054B" in roles["scope"]["identification"]
    assert report["disagreements"] == [] and report["electronics"]["shunt_ohm"] > 0
    # settings as typed values, units in the names, for a script to compare
    assert roles["generator"]["settings"]["frequency_hz"] == 1000.0
    assert roles["scope"]["settings"]["ch1"]["probe_gain"] == 0.1
    assert roles["vibrometer"]["settings"]["velocity_range_mps_per_v"] == 1.0
    assert roles["stage"]["settings"]["x"]["travel_high_mm"] > 0


def test_check_without_a_visa_library_exits_2_with_the_cause(capsys):
    # lab_example.yaml names the system VISA library, which this machine does not have
    bench = str(paths.benches_dir() / "lab_example.yaml")
    assert cli.main(["check", "--bench", bench, "-q"]) == cli.EXIT_USER_ERROR
    captured = capsys.readouterr()
    assert captured.out == "" and "VISA" in captured.err and captured.err.count("\n") == 1
    assert cli.main(["check", "--bench", bench, "--json"]) == cli.EXIT_USER_ERROR
    report = json.loads(capsys.readouterr().out)
    assert report["passed"] is False and "VISA" in report["visa_error"] and report["instruments"] == []


def test_a_user_error_under_json_is_also_json(capsys):
    assert cli.main(["check", "--bench", "no_such_bench.yaml", "--json"]) == cli.EXIT_USER_ERROR
    captured = capsys.readouterr()
    assert "no_such_bench.yaml" in json.loads(captured.out)["error"]
    assert captured.err.startswith("squeezebench check: no_such_bench.yaml")


def test_progress_bar_only_on_a_terminal_and_quiet_silences_results(monkeypatch, capsys):
    from squeezebench.protocols import campaign

    seen = []
    monkeypatch.setattr(campaign, "run_campaign", lambda path, **kwargs: seen.append((path, kwargs)) or Path("r"))
    assert cli.main(["run", "quick"]) == 0   # stderr is captured here: not a terminal
    assert seen[-1][0] == paths.campaigns_dir() / "quick.yaml" and seen[-1][1]["progress"] is False
    assert capsys.readouterr().out == "run stored in r\n"
    monkeypatch.setattr(cli.sys.stderr, "isatty", lambda: True, raising=False)
    assert cli.main(["run", "quick"]) == 0 and seen[-1][1]["progress"] is True
    assert cli.main(["run", "quick", "-q"]) == 0 and seen[-1][1]["progress"] is False
    assert capsys.readouterr().out == "run stored in r\n"   # the -q run printed nothing


def test_run_says_which_powers_will_rest_on_an_unmeasured_probe_delay(monkeypatch, capsys, tmp_path):
    """A campaign that reads powers off resonance without a deskew run is told so once it has
    run (on stderr, not with -q: an error before that stays one line); one with the deskew
    run, or without detuned points, is not."""

    from squeezebench.protocols import campaign
    from squeezebench.protocols.variants import calibration_run

    monkeypatch.setattr(campaign, "run_campaign", lambda path, **kwargs: Path("r"))
    assert cli.main(["run", "quick"]) == 0   # ships with its deskew run (issue 46): no caveat
    err = capsys.readouterr().err
    assert "deskew" not in err
    assert "1 scene of this campaign is a declared replay of published points the plate model does not " \
           "predict (one_column_1mm)" in err
    data = load_strict((paths.campaigns_dir() / "quick.yaml").read_text())
    data["runs"] = [r for r in data["runs"] if r["protocol"] != "deskew_calibration"]
    (tmp_path / "mine.yaml").write_text(dump_yaml({**data, "name": "mine"}))
    (tmp_path / "one_column_1mm.yaml").write_text((paths.scenes_dir() / "one_column_1mm.yaml").read_text())
    assert cli.main(["run", str(tmp_path / "mine.yaml")]) == 0   # a user's copy without it
    err = capsys.readouterr().err
    assert "detuning read powers off resonance" in err and "no deskew_calibration run" in err
    assert "--target-rel-error X --write FILE" in err
    assert cli.main(["run", str(tmp_path / "mine.yaml"), "-q"]) == 0 and capsys.readouterr().err == ""
    own = campaign.load_campaign(paths.data_dir() / "examples" / "own_plate_campaign.yaml")
    assert commands._declared_replays(own) == []   # a user's own plate is no replay
    for name, runs in (("deskewed", [calibration_run(37000.0, "one_column_1mm.yaml"), *data["runs"]]),
                       ("resonance_only", [{**r, "parameters": {**r["parameters"], "velocity_ratios": []}}
                                           if r["protocol"] == "detuning" else r for r in data["runs"]])):
        path = tmp_path / f"{name}.yaml"
        path.write_text(dump_yaml({**data, "name": name, "runs": runs}))
        (tmp_path / "one_column_1mm.yaml").write_text((paths.scenes_dir() / "one_column_1mm.yaml").read_text())
        assert campaign.load_campaign(path).powers_off_resonance_without_deskew() == [], name


def test_verbose_logs_each_step_on_stderr_and_removes_its_handler(monkeypatch, capsys):
    import logging

    from squeezebench.protocols import campaign

    def logging_run(path, **kwargs):
        campaign.log.info("run detuning: step resonance")
        campaign.log.warning("said to the operator already")   # warnings reach the terminal once, elsewhere
        return Path("r")

    monkeypatch.setattr(campaign, "run_campaign", logging_run)
    logger = logging.getLogger("squeezebench")
    before = (list(logger.handlers), logger.level)
    assert cli.main(["run", "quick", "-v"]) == 0
    err = capsys.readouterr().err
    assert "squeezebench.protocols.campaign: run detuning: step resonance" in err
    assert "said to the operator" not in err
    assert (logger.handlers, logger.level) == before
    assert cli.main(["run", "quick"]) == 0 and "step resonance" not in capsys.readouterr().err
    with pytest.raises(SystemExit) as usage:
        cli.main(["check", "-v", "-q"])
    assert usage.value.code == cli.EXIT_USER_ERROR   # argparse's usage errors exit 2 as well


def test_plan_json_has_the_numbers_of_the_table(monkeypatch, capsys, tmp_path):
    from squeezebench.protocols import planning

    fake = planning.Plan(0.01, {}, {"detuning": planning.Setting(500, 4), "cutting": planning.Setting(10000, 1)},
                         {"detuning": 0.005, "cutting": 0.004}, {"detuning": 2.0, "cutting": 1.0},
                         {"detuning": 8.0, "cutting": 1.0})
    monkeypatch.setattr(planning, "make_plan", lambda path, target, **parallel: fake)
    out = tmp_path / "planned.yaml"
    assert cli.main(["plan", "quick", "--json", "--write", str(out)]) == 0
    plan = json.loads(capsys.readouterr().out)
    assert plan["runs"][0] == {"run": "detuning", "record_length": 500, "averages": 4, "p95_rel_error": 0.005,
                               "noise_p95_rel_error": 0.005,   # no floors: the noise is the whole error
                               "planned_bench_time_s": 2.0, "baseline_bench_time_s": 8.0}
    assert plan["planned_bench_time_s"] == 3.0 and plan["written"] == str(out) and out.is_file()


def _reproduction_like(run_dir: Path, campaign: Path) -> None:
    RunStore(run_dir).create(campaign)
    (run_dir / "study").mkdir()
    (run_dir / "study" / "trials.parquet").write_bytes(b"x")


def test_reproduce_replaces_its_own_earlier_output(tmp_path, capsys):
    out = tmp_path / "paper"
    _reproduction_like(out, paths.paper_campaign())
    commands._clear_previous_reproduction(cli.build_parser().parse_args(["reproduce"]), out)
    assert [p.name for p in out.iterdir() if p.name != ".squeezebench.lock"] == []
    assert "replacing the previous reproduction" in capsys.readouterr().out


def test_reproduce_never_removes_another_run(tmp_path):
    out = tmp_path / "mine"
    _reproduction_like(out, paths.campaigns_dir() / "quick.yaml")
    with pytest.raises(UserError, match="not a reproduction"):
        commands._clear_previous_reproduction(cli.build_parser().parse_args(["reproduce"]), out)
    assert (out / "study" / "trials.parquet").is_file()


@pytest.mark.parametrize("command", ["check", "run", "report", "reproduce", "plan", "study", "validate"])
def test_version_after_any_subcommand(command, capsys):
    with pytest.raises(SystemExit) as done:
        cli.main([command, "--version"])
    assert done.value.code == 0
    assert capsys.readouterr().out.startswith("squeezebench ")



def test_validate_accepts_shipped_names_as_run_does(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)   # nothing called quick here: the shipped files answer
    assert cli.main(["validate", "quick", "paper.yaml", "one_column_1mm", "lab_example"]) == 0
    out = capsys.readouterr().out
    assert "valid campaign" in out and "valid scene" in out and "valid bench" in out
    assert cli.main(["validate", "no_such_thing"]) == 2


def test_validate_checks_every_shipped_file_of_an_ambiguous_name(capsys, tmp_path, monkeypatch):
    """`validate large_plate` means the shipped scene and the shipped design, each checked and
    the ambiguity said once. Which files are checked is what this asks, not what checking
    them finds: that is the large plate's physics (its solves, tens of seconds of one core),
    which test_design's `validate --scene large_plate` and its design's prediction read."""
    from squeezebench import schemas

    monkeypatch.chdir(tmp_path)
    checked = []
    monkeypatch.setattr(schemas, "validate_file", lambda path: checked.append(path) or
                        {"file": str(path), "kind": path.parent.name, "summary": "", "warnings": []})
    assert cli.main(["validate", "large_plate"]) == 0
    assert checked == [paths.scenes_dir() / "large_plate.yaml", paths.designs_dir() / "large_plate.yaml"]
    assert "2 shipped files are called large_plate: the scene and the design" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["plan", "--json"], ["check", "--json", "--no-such-flag"]])
def test_usage_errors_with_json_are_one_json_document(argv, capsys):
    with pytest.raises(SystemExit) as stopped:
        cli.main(argv)
    assert stopped.value.code == 2
    captured = capsys.readouterr()
    answer = json.loads(captured.out)
    assert answer["command"] == argv[0] and answer["error"] and "--help" in captured.err


def test_piped_output_arrives_line_by_line():
    """A pipe gets each line when it is printed, not a block at exit: `check` prints its
    first line (the VISA library) before it opens an instrument, which takes it about a
    second, so right after that line the pipe holds nothing more; printed in blocks, the
    whole report would arrive at once at exit."""
    import os
    import select
    import subprocess

    shell_env = {name: value for name, value in os.environ.items() if name != "PYTHONUNBUFFERED"}   # as a user's shell has it
    process = subprocess.Popen([sys.executable, "-m", "squeezebench", "check", "--bench", "sim"],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, env=shell_env)
    try:
        fd = process.stdout.fileno()
        first = b""
        while not first.endswith(b"\n"):   # byte by byte: a buffered reader would take what follows too
            first += os.read(fd, 1) or b"\n"
        more_waiting = bool(select.select([fd], [], [], 0)[0])
        rest = process.stdout.read().decode().splitlines()
    finally:
        process.wait(timeout=300)
    assert first.startswith(b"VISA library") and not more_waiting and process.returncode == 0
    assert len(rest) > 10


@pytest.mark.parametrize("command", sorted(cli.EXAMPLES))
def test_every_help_ends_with_examples_that_parse(command, capsys):
    with pytest.raises(SystemExit) as shown:
        cli.main([command, "--help"])
    assert shown.value.code == 0
    assert "examples:\n  squeezebench " + command in capsys.readouterr().out
    parser = cli.build_parser()
    for line in cli.EXAMPLES[command]:
        words = line.split("#")[0].split(">")[0].split()   # a shell redirection is not an argument
        assert words[0] == "squeezebench" and words[1] == command
        parser.parse_args(words[1:])   # an example that does not parse exits 2 here


def test_reproduce_stops_its_study_when_the_campaign_stops(tmp_path, monkeypatch):
    # The study runs beside the campaign (from its first stored step): a stop of the campaign
    # (Ctrl-C, SIGTERM) must end the study too, not leave it running behind exit 130.
    import threading

    from squeezebench.protocols import accuracy_study, campaign
    from squeezebench.report import drawing, run_report

    seen = {}

    def study(out_dir, stop=None, **kwargs):
        seen["started"] = True
        seen["stopped"] = stop.wait(timeout=10)

    def stopped_campaign(path, on_step=None, **kwargs):
        on_step({"run": "fig7_large_plate_map", "step": "rows_000"})
        on_step({"run": "fig8_9_large_plate", "step": "resonance"})   # the map's plate handed out
        raise KeyboardInterrupt

    maps, ahead = object(), object()   # the maps' and the report's plates, solving on its drawing process: stopped too
    stored_map = object()   # the stored map's plate likewise
    stopped_beside = []

    monkeypatch.setattr(accuracy_study, "run_study", study)
    monkeypatch.setattr(campaign, "run_campaign", stopped_campaign)
    monkeypatch.setattr(commands, "_solve_campaign_plates_ahead", lambda workers: maps)
    monkeypatch.setattr(run_report, "solve_ahead", lambda workers: ahead)
    monkeypatch.setattr(drawing, "beside", lambda workers, work: stored_map)
    monkeypatch.setattr(drawing, "stop_beside", stopped_beside.append)
    with pytest.raises(KeyboardInterrupt):
        commands.cmd_reproduce(cli.build_parser().parse_args(["reproduce", "--out", str(tmp_path / "paper"), "-q"]))
    assert seen == {"started": True, "stopped": True} and stopped_beside == [maps, ahead, stored_map]
    assert not [t for t in threading.enumerate() if t.name == "beside"]


# -- habits of other command lines ----------------------------------------------------------

def test_a_usage_error_is_named_against_its_subcommand_with_its_usage(capsys):
    with pytest.raises(SystemExit) as stopped:
        cli.main(["run", "quick", "--no-such-flag"])
    assert stopped.value.code == cli.EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert err.startswith("usage: squeezebench run ")
    assert "squeezebench run: unrecognized arguments: --no-such-flag (see squeezebench run --help)" in err
    with pytest.raises(SystemExit):
        cli.main(["plan", "quick", "--target-rel-error", "abc"])
    err = capsys.readouterr().err
    assert "squeezebench plan: argument --target-rel-error: must be a number between 0 and 1" in err
    assert "_relative_error" not in err   # argparse names a type's failure by its function
    with pytest.raises(SystemExit):
        cli.main(["rnu", "quick"])
    assert "did you mean 'run'?" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["-q", "run", "quick"], ["run", "quick", "-q"], ["run", "-q", "quick"]])
def test_global_options_before_or_after_the_subcommand(argv, monkeypatch, capsys):
    from squeezebench.protocols import campaign

    seen = []
    monkeypatch.setattr(campaign, "run_campaign", lambda path, **kwargs: seen.append(kwargs) or Path("r"))
    monkeypatch.setattr(cli.sys.stderr, "isatty", lambda: True, raising=False)
    assert cli.main(argv) == 0
    assert capsys.readouterr().out == "" and seen[-1]["progress"] is False
    assert cli.build_parser().parse_args(["--json", "check"]).json is True
    with pytest.raises(SystemExit):
        cli.main(["-q", "check", "-v"])   # contradictory, whichever side each is on
    assert "squeezebench check: -q/--quiet and -v/--verbose" in capsys.readouterr().err


def test_an_unknown_campaign_lists_the_shipped_ones(capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "quik"]) == cli.EXIT_USER_ERROR
    err = capsys.readouterr().err
    assert err.startswith("squeezebench run: quik: no such file") and "did you mean 'quick'?" in err
    shipped = [path.stem for path in paths.campaigns_dir().glob("*.yaml")]
    assert len(shipped) >= 4 and all(name in err for name in shipped)
    with pytest.raises(SystemExit):
        cli.main(["run", "--help"])
    shown = capsys.readouterr().out
    assert all(name in shown for name in shipped)   # from the data folder, not a list in the code


def test_list_shows_every_shipped_file_by_kind(capsys):
    assert cli.main(["list", "campaigns", "--json"]) == 0
    listed = json.loads(capsys.readouterr().out)
    assert [entry["name"] for entry in listed["campaigns"]] == sorted(p.stem for p in paths.campaigns_dir().glob("*.yaml"))
    assert all(entry["about"] for entry in listed["campaigns"])   # each says what it is
    assert cli.main(["list"]) == 0
    out = capsys.readouterr().out
    for kind, folder in (("scenes", paths.scenes_dir()), ("designs", paths.designs_dir()), ("benches", paths.benches_dir())):
        assert f"{kind} ({len(list(folder.glob('*.yaml')))}):" in out
    assert "  large_plate " in out and "Fig. 7 (Sec. 5.2): a vibration map" in out


def test_a_progress_bar_on_a_terminal_that_reports_no_size():
    """A pseudo-terminal opened without a size (`script -c`, a CI runner) reports 0 x 0:
    tqdm drew nothing there until given a size."""
    import os
    import select

    from tqdm import tqdm

    from squeezebench import terminal

    master, slave = os.openpty()
    try:
        with open(slave, "w", closefd=False) as stream:
            real = sys.stderr
            sys.stderr = stream
            try:
                assert os.get_terminal_size(slave).columns == 0
                options = terminal.bar_width()
            finally:
                sys.stderr = real
            with tqdm(total=2, file=stream, **options) as bar:
                bar.update(2)
        drawn = ""
        while "100%|" not in drawn and select.select([master], [], [], 1.0)[0]:   # each frame as it came
            drawn += os.read(master, 4096).decode()
    finally:
        os.close(master)
        os.close(slave)
    assert options["ncols"] > 0 and "100%|" in drawn
