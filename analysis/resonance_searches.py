"""A stored run's resonance searches as the uncertainty budgets read them: how each was
set (RUN_DIR/settings/<run>.json) and how sharp the resonance its sweep shows is
(`analysis.uncertainty.search_budgets`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from squeezebench.analysis.rundata import RunData


def mechanical_q_from_sweep(frequency_hz: float, sweep: pd.DataFrame) -> float | None:
    """The resonance's sharpness from the search's points around it (sweep and refinement).

    On v = v0 / sqrt(1 + k^2 d^2) (d = f - f0, k = 2 Q / f0), 1/v^2 is a straight line
    in d^2 with slope/intercept k^2: fitted on the points above a third of the peak
    (where one mode dominates). None with fewer than three such points or no rise."""
    near = sweep[sweep["velocity_pp_mps"] > sweep["velocity_pp_mps"].max() / 3.0]
    if len(near) < 3:
        return None
    d2 = (near["generator_frequency_hz"].to_numpy() - frequency_hz) ** 2
    slope, intercept = np.polyfit(d2, near["velocity_pp_mps"].to_numpy() ** -2.0, 1)
    if not (slope > 0 and intercept > 0):
        return None
    return math.sqrt(slope / intercept) * frequency_hz / 2.0


@dataclass(frozen=True)
class SearchSetup:
    """What a run's resonance search was set to (RUN_DIR/settings/<run>.json)."""

    tolerance_hz: float
    samples_per_period: float   # of the records the search read the velocity from


def search_setups(run: RunData) -> dict[str, SearchSetup]:
    """The search settings of every run of `run` that searched a resonance."""
    setups = {}
    for path in sorted((run.run_dir / "settings").glob("*.json")):
        settings = json.loads(path.read_text(encoding="utf-8"))
        search = settings.get("parameters", {}).get("search")
        if search:
            acquisition = settings["acquisition"]
            setups[settings["run"]] = SearchSetup(float(search["tolerance_hz"]),
                                                  acquisition["record_length"] / acquisition["periods_per_record"])
    return setups
