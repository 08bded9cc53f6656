"""Stop signals: SIGINT (Ctrl-C), SIGTERM and SIGHUP stop a run one way, and nothing
interrupts the bring-down of the generator.

The first stop signal raises KeyboardInterrupt, which takes the run down its safe path
(`protocols.safety.DriveController` brings the generator to its minimum on the way out).
Every later signal is only recorded: a second KeyboardInterrupt raised while the first one
is being handled would skip the bring-down. A signal that arrives while the bench is being
opened (`deferred()`) or while the generator is brought down (code registered with
`protect`) is recorded too, and honoured by `raise_if_stopped` once the generator is at its
minimum. A signal the parent process ignores (`nohup`, a scheduler) stays ignored.

This module imports nothing heavy: the command's entry point installs it before anything
else is imported, so a stop during import ends the same way (exit 130, no traceback).
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Callable, Iterator
from types import CodeType

#: Signals that stop a run as Ctrl-C does (SIGINT is Ctrl-C itself).
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)

#: Stop signals received (their names), in order.
_received: list[str] = []
#: Nesting of `handled()` and of `deferred()`; the stop signals that count as a first one
#: (all but those an import lock's callback would have swallowed, `_swallowed_here`).
_depth = {"handled": 0, "deferred": 0, "counted": 0}
#: Code (functions) during which a stop signal is only recorded: the generator's bring-down.
_PROTECTED: set[CodeType] = set()
#: What the generator was last told, for the final message (see `generator_state`).
_generator: dict[str, str | None] = {"state": None}


def protect(function: Callable) -> Callable:
    """Decorator: while `function` runs (anywhere on the stack), a stop signal is recorded
    and does not raise. Checked on the stack, not with a flag set on entry, so a signal that
    arrives at the function's first bytecode cannot slip in before the protection."""
    _PROTECTED.add(function.__code__)
    return function


def _protected(frame) -> bool:
    while frame is not None:
        if frame.f_code in _PROTECTED:
            return True
        frame = frame.f_back
    return False


def _swallowed_here(frame) -> bool:
    """The signal arrived in an import lock's weakref callback (importlib's `cb`), where the
    interpreter swallows an exception and prints it as "Exception ignored": raising there
    would print a traceback and raise nothing. Recorded only: the next signal, or
    `raise_if_stopped`, raises."""
    return frame is not None and frame.f_code.co_name == "cb" and "importlib" in frame.f_code.co_filename


def _on_stop(signum, frame) -> None:
    _received.append(signal.Signals(signum).name)
    if _swallowed_here(frame):
        return
    _depth["counted"] += 1
    if _depth["counted"] == 1 and not _depth["deferred"] and not _protected(frame):
        raise KeyboardInterrupt(f"stopped by {_received[0]}")


def received() -> list[str]:
    """The stop signals received inside `handled()` so far (names)."""
    return list(_received)


def raise_if_stopped() -> None:
    """Raise KeyboardInterrupt if a stop signal came: it may have been recorded without
    raising (deferred, or during a bring-down), or its KeyboardInterrupt swallowed by code
    that catches everything (a `__del__`, a library's catch-all); the run must still stop
    before the drive goes up again or the next step starts."""
    if _received:
        raise KeyboardInterrupt(f"stopped by {_received[0]}")


def stop_in(exc: BaseException | None) -> KeyboardInterrupt | None:
    """The stop's KeyboardInterrupt that `exc` is or wraps, else None: the interpreter re-raises an
    exception from a descriptor's `__set_name__` as RuntimeError (Python 3.11; a class body
    run by an import, such as numpy's `finfo`, can take the signal there, its cause the
    stop), so the stop is looked for down the causes. Not the contexts: an error raised while
    a stop was being handled (the generator lost during its bring-down) is that error. Except
    an ImportError: a stop that cut an extension module's import short leaves it unloadable in
    this process (numpy 2: "cannot load module more than once per process"), so the
    bring-down's own import of it fails because of the stop, and is the stop's."""
    seen: set[int] = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or (exc.__context__ if isinstance(exc, ImportError) else None)
    return None


def _install() -> dict[signal.Signals, object]:
    """Every stop signal the process does not ignore to `_on_stop`; the dispositions replaced."""
    previous = {}
    if _depth["handled"] == 0:
        _received.clear()
        _depth["counted"] = 0
        _generator["state"] = None
        for sig in STOP_SIGNALS:
            if signal.getsignal(sig) is not signal.SIG_IGN:   # nohup, a scheduler: the parent's choice stands
                previous[sig] = signal.signal(sig, _on_stop)
    _depth["handled"] += 1
    return previous


@contextlib.contextmanager
def handled() -> Iterator[None]:
    """Inside, every stop signal the process does not ignore goes to the handler above;
    outside (the outermost exit), the dispositions found on entry come back and what was
    received is forgotten. Only the main thread gets signals; elsewhere this does nothing."""
    import threading   # here, not at the top: the entry point imports this module first thing

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    previous = _install()
    try:
        yield
    finally:
        _depth["handled"] -= 1
        if _depth["handled"] == 0:
            for sig, handler in previous.items():
                signal.signal(sig, handler)
            _received.clear()
            _depth["counted"] = 0


def take_over() -> None:
    """For a command's whole process (its entry point, main thread): as `handled()`, never undone."""
    _install()


def hold() -> None:
    """From now on a stop signal is only recorded (the command is returning its status)."""
    _depth["deferred"] += 1


def ignore_from_now() -> None:
    """For a command's whole process (its entry point), about to exit with its status:
    every stop signal is ignored from now on. Interpreter shutdown puts back the default disposition of every
    signal that has a Python handler (a later signal of a burst would then kill the
    process, status -2 or -15, not 130) but leaves an ignored one ignored; blocking them
    instead would hold only the main thread, and the kernel hands a signal to any thread
    that does not block it."""
    for sig in STOP_SIGNALS:
        signal.signal(sig, signal.SIG_IGN)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Inside, a stop signal is recorded and raised only on leaving (while the bench opens
    and until the generator is known to be at its minimum)."""
    _depth["deferred"] += 1
    try:
        yield
    finally:
        _depth["deferred"] -= 1
    raise_if_stopped()


def record_generator(state: str) -> None:
    """What the generator was last told, said when the run stops (see `generator_state`)."""
    _generator["state"] = state


def generator_state() -> str | None:
    """The generator's last commanded state as the bring-down left it (None if no
    generator was driven inside `handled()`)."""
    return _generator["state"]
