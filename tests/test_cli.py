"""The command line keeps the names users script against."""

from squeezebench import cli
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
