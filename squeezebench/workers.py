"""How many local processes a command uses when none is asked for: one answer for the
trials (`protocols.parallel`) and the report's figures (`report.drawing`)."""

from __future__ import annotations

import os

from squeezebench.errors import UserError

WORKERS_VARIABLE = "SQUEEZEBENCH_WORKERS"


def default_workers() -> int:
    """Local processes to use when none is asked for: $SQUEEZEBENCH_WORKERS, else the
    cores this process may run on (its affinity mask, which a scheduler or `taskset` may
    have narrowed, not the machine's core count)."""
    text = os.environ.get(WORKERS_VARIABLE, "").strip()
    if text:
        try:
            count = int(text)
        except ValueError:
            count = 0
        if count < 1:
            raise UserError(f"{WORKERS_VARIABLE} must be a whole number of at least 1, got {text!r}")
        return count
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:   # macOS and Windows have no affinity call
        return os.cpu_count() or 1
