"""The paper's figures from a run (matplotlib, Agg backend: no display needed).

Each function takes reduced data and writes one PNG, returning its path.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402  (the backend must be chosen first)
import numpy as np  # noqa: E402
from matplotlib.ticker import NullFormatter  # noqa: E402
import pandas as pd  # noqa: E402

from squeezebench.analysis.tables import PlateCharacterisation  # noqa: E402

#: Fixed metadata so that re-running the report gives byte-identical PNG files.
_PNG_METADATA = {"Software": None}


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    fig.savefig(path, dpi=100, metadata=_PNG_METADATA)
    plt.close(fig)
    return path


def fig2_power_ratio(detuning: pd.DataFrame, path: Path) -> Path:
    """Fig. 2: Pt/P0 against the velocity ratio reached before regaining v0, one line per
    velocity level, one panel per campaign run. Columns: run_name, plate,
    velocity_level_pp_mps, target_velocity_ratio, power_ratio."""
    runs = sorted(detuning["run_name"].unique())
    fig, axes = plt.subplots(1, len(runs), figsize=(4 * len(runs), 3.2), squeeze=False, sharey=True)
    for ax, run in zip(axes[0], runs):
        series = detuning[detuning["run_name"] == run]
        for level, group in series.groupby("velocity_level_pp_mps"):
            group = group.sort_values("target_velocity_ratio", ascending=False)
            ax.plot(group["target_velocity_ratio"], group["power_ratio"], "o-", label=f"{level:g} m/s pp")
        ax.set_title(f"{run}\n{series['plate'].iloc[0]}", fontsize=8)
        ax.set_xlabel("velocity ratio before regaining v0")
        ax.invert_xaxis()
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("Pt / P0")
    return _save(fig, path)


def resonance_curves(sweeps: pd.DataFrame, path: Path) -> Path:
    """Velocity pp against frequency, one curve per resonance search (run and step).
    Columns: run_name, step_id, plate, generator_frequency_hz, velocity_pp_mps."""
    fig, ax = plt.subplots(figsize=(8, 4))
    for (run, step), group in sweeps.groupby(["run_name", "step_id"], sort=True):
        group = group.sort_values("generator_frequency_hz")
        ax.plot(group["generator_frequency_hz"] / 1e3, group["velocity_pp_mps"], ".-",
                label=f"{run} / {step} ({group['plate'].iloc[0]})")
    ax.set_xlabel("frequency (kHz)")
    ax.set_ylabel("velocity pp (m/s)")
    ax.legend(fontsize=5, loc="upper left", bbox_to_anchor=(1.0, 1.0))
    return _save(fig, path)


def fig5_q_tan(plates: dict[str, PlateCharacterisation], path: Path) -> Path:
    """Fig. 5: Q and tan(theta') per plate with their standard uncertainties."""
    names = list(plates)
    x = np.arange(len(names))
    fig, (ax_q, ax_t) = plt.subplots(1, 2, figsize=(9, 3.5))
    for ax, attribute, label in ((ax_q, "q", "Q (Eq. 27)"), (ax_t, "tan_theta", "tan theta' (Eq. 25)")):
        values = [getattr(plates[n], attribute) for n in names]
        ax.errorbar(x, [v.value for v in values], yerr=[v.std_uncertainty for v in values], fmt="o", capsize=3)
        ax.set_xticks(x, names, rotation=45, ha="right", fontsize=7)
        ax.set_ylabel(label)
    return _save(fig, path)


def fig8_amplitude(large: PlateCharacterisation, path: Path) -> Path:
    """Fig. 8: amplitude pp against voltage pp with the fitted line."""
    points = large.points
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.errorbar(points["piezo_voltage_vpp"], points["amplitude_pp_m"] * 1e6,
                yerr=points["amplitude_pp_m_u"] * 1e6, fmt="o", label="measured")
    v = np.linspace(0.0, points["piezo_voltage_vpp"].max() * 1.05, 50)
    fit = large.amplitude_slope
    ax.plot(v, (fit.slope.value * v + fit.intercept.value) * 1e6, "-", label="line fit")
    ax.set_xlabel("voltage (V pp)")
    ax.set_ylabel("amplitude (um pp)")
    ax.legend()
    return _save(fig, path)


def fig9_power(power: pd.DataFrame, path: Path) -> Path:
    """Fig. 9: power against V^2, measured and estimated from the small plates.
    Columns: piezo_voltage_vpp, power_measured_w, power_estimated_w."""
    fig, ax = plt.subplots(figsize=(5, 3.5))
    v2 = power["piezo_voltage_vpp"] ** 2
    ax.plot(v2, power["power_measured_w"], "o", label="measured")
    ax.plot(v2, power["power_estimated_w"], "s--", label="estimated from small plates (Eqs. 25, 29)")
    ax.set_xlabel("voltage squared (V pp^2)")
    ax.set_ylabel("power (W)")
    ax.legend(fontsize=7)
    return _save(fig, path)


def study_fronts(summary: pd.DataFrame, path: Path) -> Path:
    """Accuracy study: p95 |relative error| against bench time per trial, one panel per
    quantity, every configuration as a dot and each experiment's Pareto front as a line.
    Columns: see analysis.study.summarise."""
    quantities = sorted(summary["quantity"].unique())
    columns = min(3, len(quantities))
    rows = -(-len(quantities) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(4.2 * columns, 3.4 * rows), squeeze=False)
    # one colour per experiment across the panels
    colours = dict(zip(sorted(summary["experiment"].unique()), plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for ax, quantity in zip(axes.flat, quantities):
        data = summary[summary["quantity"] == quantity]
        for experiment, group in data.groupby("experiment"):
            colour = colours.get(experiment, "black")
            ax.loglog(group["bench_time_s"], group["p95_abs_rel_error"].clip(lower=1e-9), ".", alpha=0.4,
                      color=colour)
            front = group[group["on_front"]].sort_values("bench_time_s")
            ax.step(front["bench_time_s"], front["p95_abs_rel_error"].clip(lower=1e-9), "-", where="post",
                    color=colour, label=experiment)
        ax.set_title(quantity, fontsize=9)
        ax.xaxis.set_minor_formatter(NullFormatter())   # log minor labels overlap
        ax.set_xlabel("bench time per trial (s)")
        ax.set_ylabel("p95 |relative error|")
        ax.legend(fontsize=7)
    for ax in list(axes.flat)[len(quantities):]:
        ax.set_visible(False)
    return _save(fig, path)


def heating_drift(heating: pd.DataFrame, path: Path) -> Path:
    """Power error against averaging on a heating plate, at the frequency found cold and
    with the resonance tracked before each point. Columns: analysis.study.heating_table."""
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for column, label in (("p95_abs_rel_error_fixed_frequency", "frequency found cold"),
                          ("p95_abs_rel_error_tracked", "resonance tracked")):
        if column in heating:
            ax.loglog(heating["averages"], heating[column], "o-", label=label)
    ax.set_xlabel("scope averages per point")
    ax.set_ylabel("p95 |relative error| of power")
    ax.legend(fontsize=8)
    return _save(fig, path)
