"""What every effect of a scene is: a name, default parameters, the stages it acts at,
and what an acquisition tells the stages (`simbench.effects` lists the stages).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

#: Screen channels: CH1 piezo voltage (V), CH2 current (A), CH3 vibrometer output (V).
CHANNELS = ("CH1", "CH2", "CH3")
VIBROMETER_CHANNEL = 2  # index of CH3 in CHANNELS


@dataclass
class AcquisitionContext:
    """What the stages need to know about one acquisition."""

    record_times_s: np.ndarray  # sample times from the trigger (s)
    start_s: float  # bench time when the first averaged acquisition starts
    acquisition_period_s: float  # from one averaged acquisition to the next
    averages: int  # 1 in sample mode
    scale_per_div: np.ndarray  # channel units per division, per channel
    display_gain: np.ndarray  # channel units per physical unit (probe settings)
    vibrometer_range_mps_per_v: float


class Effect:
    """Base of all effects: a name, default parameters and the stages it acts at."""

    name: ClassVar[str]
    defaults: ClassVar[dict[str, float]] = {}
    #: Allowed (low, high) of a parameter, checked when the scene is read.
    limits: ClassVar[dict[str, tuple[float, float]]] = {}
    stages: ClassVar[frozenset[str]] = frozenset()
    #: True when two acquisitions at the same settings differ (the record cannot be reused).
    varies_per_acquisition: ClassVar[bool] = False
    #: True when its signals depend on the channels' vertical scales (`ctx.scale_per_div`):
    #: a re-ranged acquisition cannot keep the signals of the last one (`traces.placed_anew`).
    reads_vertical_scale: ClassVar[bool] = False
    #: A fault (issue 7) rather than a property of a healthy bench.
    fault: ClassVar[bool] = False

    def __init__(self, scene, **parameters: float) -> None:
        self.scene = scene
        self.parameters = {**self.defaults, **parameters}

    def attach(self, bench) -> None:
        """Called once when a simulated bench starts using this effect."""

    def detach(self, bench) -> None:
        """Called when the bench swaps the scene (mount) or closes."""

    def state_key(self):
        """What of the effect's own state the steady state depends on (None: nothing)."""
        return None
