"""How a progress bar fits the terminal it is drawn on."""

from __future__ import annotations

import os
import shutil
import sys


def bar_width() -> dict:
    """tqdm's width options for a bar on stderr: follow the terminal's width, except on a
    terminal that reports 0 columns (a pseudo-terminal opened without a size, as `script -c`
    or a CI runner's pty opens one), on which tqdm draws an empty line: there the size
    `shutil` falls back to ($COLUMNS and $LINES, else 80 x 24)."""
    try:
        columns = os.get_terminal_size(sys.stderr.fileno()).columns
    except (AttributeError, OSError, ValueError):   # not a terminal, or a stream without a descriptor
        columns = 0
    if columns:
        return {"dynamic_ncols": True}
    fallback = shutil.get_terminal_size()
    return {"ncols": fallback.columns, "nrows": fallback.lines}
