"""The `squeezebench` command's entry point (also `python -m squeezebench`).

Stop signals are taken over before anything heavy is imported, so Ctrl-C, SIGTERM or
SIGHUP at any moment (during import, a run, its bring-down, the final message) ends the
command the same way: exit status 130 and one line, never a traceback or a death by the
signal. A signal the parent ignores (`nohup`, a scheduler) stays ignored.
"""

from __future__ import annotations

import atexit
import gc
import sys

from squeezebench import stops

EXIT_INTERRUPTED = 130


def _interrupted() -> int:
    print("squeezebench: interrupted outside the command (starting or returning)", file=sys.stderr)
    return EXIT_INTERRUPTED


def command(argv: list[str] | None = None) -> int:
    """The command's exit status, 130 if a stop signal came at any moment of it; the
    caller has installed `stops.handled()`."""
    try:
        from squeezebench import cli

        status = cli.main(argv)
    except BaseException as exc:   # a stop before the command's own handler could take it
        if stops.stop_in(exc) is None:
            raise
        status = _interrupted()
    return EXIT_INTERRUPTED if stops.received() else status


def main(argv: list[str] | None = None) -> int:
    # At exit the interpreter's last collections walk every object the command left (numpy,
    # pandas, scipy, the bench's model): a fifth of a second of one core on every command,
    # to free memory the process is about to give back. Frozen at exit, they are skipped;
    # atexit's handlers (logging's flush among them) still run, and files are closed by then.
    atexit.register(gc.freeze)
    try:
        stops.take_over()   # inside: a signal between two of its installs raises here
        status = command(argv)
        stops.hold()   # a signal from here on cannot raise where nothing would catch it
    except BaseException as exc:   # the first signal, outside the command's own handlers
        stops.hold()
        if stops.stop_in(exc) is None:
            raise
        status = _interrupted()
    status = EXIT_INTERRUPTED if stops.received() else status
    # A signal recorded until here makes the status 130; one after it finds the signal
    # ignored (the command's work is done and said), never the default that kills.
    stops.ignore_from_now()
    return EXIT_INTERRUPTED if stops.received() else status


if __name__ == "__main__":
    sys.exit(main())
