"""Watching a run as it goes: the resonance sweep, the measured points, the resonance drift.

What a lab judges by eye while a campaign runs: is the peak bracketed by the search's
sweep, do the points fall where the previous ones did, is the resonance walking away
(a heating plate)? `LivePlot` is a pair of campaign watchers (`run_campaign(...,
on_point=plot.on_point, on_step=plot.on_step)`, also what `squeezebench run --plot`
does); in a notebook the same object draws into an interactive figure (`%matplotlib
widget`) or is shown once the run ends.

A resonance search records its sweep when it has found the peak, so a sweep appears at
once, at the end of each search.

Drawing costs more than a simulated point: on a screen the figure is repainted at most
every `REDRAW_INTERVAL_S` of wall time (a person sees no difference), and off-screen
(no display: Agg) it is drawn once, when `save` writes it as a PNG at the end.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

REDRAW_INTERVAL_S = 0.5


class LivePlot:
    """Three panels drawn from the rows a run records (tidy rows, see protocols.steps)."""

    def __init__(self, figure=None):
        if figure is None:
            import matplotlib.pyplot as plt

            figure = plt.figure(figsize=(13, 4), layout="constrained")
        self.figure = figure
        self.sweep_ax, self.points_ax, self.drift_ax = figure.subplots(1, 3)
        self.sweep_ax.set(title="resonance search", xlabel="generator frequency (Hz)",
                          ylabel="velocity (m/s peak-to-peak)")
        self.points_ax.set(title="measured points", xlabel="velocity (m/s peak-to-peak)",
                           ylabel="power from the scope (W)")
        self.drift_ax.set(title="resonance found", xlabel="bench time (s)", ylabel="frequency (Hz)")
        (self._sweep,) = self.sweep_ax.plot([], [], "o-", markersize=3)
        self._peak = None   # the line at the resonance the search found
        self._points: dict[str, Any] = {}   # run name -> its markers
        (self._drift,) = self.drift_ax.plot([], [], "o-", markersize=3)
        self._sweep_of: tuple[str, str] | None = None
        self.points_seen = 0
        self.steps_seen = 0
        self.redraws = 0
        self._drawn_at_s = -float("inf")
        self._status = ""

    def on_point(self, row: dict[str, Any]) -> None:
        self.points_seen += 1
        if row.get("sweep"):
            self._add_sweep_point(row)
        else:
            self._add_point(row)
        self._redraw(f"{row['run_name']}: {row['step_id']}, point {row['point_index']}")

    def on_step(self, entry: dict[str, Any]) -> None:
        self.steps_seen += 1
        self._redraw(f"{entry['run']}: {entry['step']} stored ({entry['rows']} points), "
                     f"bench time {entry['campaign_bench_time_s']:.0f} s")

    def _add_sweep_point(self, row: dict[str, Any]) -> None:
        search = (row["run_name"], row["step_id"], row.get("resonance_frequency_hz"))
        if search != self._sweep_of:   # a new search: its own sweep
            self._sweep_of = search
            self._sweep.set_data([], [])
            if self._peak is None:
                self._peak = self.sweep_ax.axvline(row["resonance_frequency_hz"], color="tab:red", linewidth=1)
            self._peak.set_xdata([row["resonance_frequency_hz"]] * 2)
            self._add_drift(row)
        frequencies, velocities = (list(values) for values in self._sweep.get_data())
        frequencies.append(row["generator_frequency_hz"])
        velocities.append(row["velocity_pp_mps"])
        order = sorted(range(len(frequencies)), key=frequencies.__getitem__)
        self._sweep.set_data([frequencies[i] for i in order], [velocities[i] for i in order])

    def _add_point(self, row: dict[str, Any]) -> None:
        run = row["run_name"]
        if run not in self._points:
            (self._points[run],) = self.points_ax.plot([], [], "o", markersize=4, label=run)
            self.points_ax.legend(loc="upper left", fontsize="small")
        markers = self._points[run]
        x, y = (list(values) for values in markers.get_data())
        markers.set_data([*x, row["velocity_pp_mps"]], [*y, row["scope_power_w"]])
        if row.get("resonance_frequency_hz") is not None:
            self._add_drift(row)

    def _add_drift(self, row: dict[str, Any]) -> None:
        times, frequencies = (list(values) for values in self._drift.get_data())
        if frequencies and frequencies[-1] == row["resonance_frequency_hz"]:
            return   # the same resonance, recorded again with the point measured there
        self._drift.set_data([*times, row["bench_time_s"]], [*frequencies, row["resonance_frequency_hz"]])

    def _redraw(self, status: str) -> None:
        self._status = status
        now_s = time.monotonic()
        if not self.interactive or now_s - self._drawn_at_s < REDRAW_INTERVAL_S:
            return
        self._drawn_at_s = now_s
        self._draw()
        self.figure.canvas.flush_events()   # an interactive window repaints now

    def _draw(self) -> None:
        for ax in (self.sweep_ax, self.points_ax, self.drift_ax):
            ax.relim()
            ax.autoscale_view()
        self.figure.suptitle(self._status, fontsize="medium")
        self.figure.canvas.draw_idle()
        self.redraws += 1

    def save(self, path: Path | str) -> Path:
        """The figure as it stands (every point seen so far) written as a PNG."""
        self._draw()
        self.figure.savefig(path, dpi=100)
        return Path(path)

    @property
    def interactive(self) -> bool:
        """Whether the figure is on a screen (a GUI backend), not only in memory (Agg)."""
        return type(self.figure.canvas).required_interactive_framework is not None
