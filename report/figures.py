"""The paper's figures from a run (matplotlib, Agg backend: no display needed).

Each function takes reduced data and writes one PNG, returning its path.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from squeezebench.paper import paper_table, paper_value
from squeezebench.analysis.study import systematics_point
from squeezebench.analysis.tables import LineFit
from squeezebench.analysis.characterisation import PlateCharacterisation
from squeezebench.plates.predicted_plates import expanded_interval

#: Fixed metadata so that re-running the report gives byte-identical PNG files.
_PNG_METADATA = {"Software": None}


def pyplot():
    """matplotlib's pyplot on the Agg backend (no display needed), imported by the first figure
    drawn: a report's main process hands its figures to drawing processes (`report.drawing`)
    and would spend some 0.3 CPU-s importing a plotting library it never draws with."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig, path: Path) -> Path:
    plt = pyplot()
    fig.tight_layout()
    fig.savefig(path, dpi=100, metadata=_PNG_METADATA)
    plt.close(fig)
    return path


#: Widest figure, in inches at the PNG's 100 dpi: fits a 1280-px window beside the margins.
MAX_WIDTH_IN = 11.5
#: The marker of a value printed in the paper, on every figure.
PAPER_STYLE = dict(marker="*", markersize=16, color="crimson", markerfacecolor="none", markeredgewidth=1.5,
                   linestyle="none", zorder=5)   # hollow: this run's point stays visible inside


def _grid(n: int, columns: int, panel_w: float, panel_h: float, **kwargs):
    plt = pyplot()
    columns = max(1, min(columns, n))
    rows = -(-n // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(min(MAX_WIDTH_IN, panel_w * columns), panel_h * rows),
                             squeeze=False, **kwargs)
    for ax in list(axes.flat)[n:]:
        ax.set_visible(False)
    return fig, list(axes.flat)[:n]


def fig2_power_ratio(detuning: pd.DataFrame, path: Path) -> Path:
    """Fig. 2: Pt/P0 against the velocity ratio reached before regaining v0, one line per
    velocity level, one panel per campaign run; the paper's Fig. 2c stress point (100 mW
    at resonance, 120 mW at the stress point, at the printed voltage ratio) as a star in
    the panels of runs with a stress phase; bars: the ratio's U (k = 2) where known. Columns:
    run_name, plate, velocity_level_pp_mps, target_velocity_ratio, detuning_phase,
    power_ratio (and power_ratio_U)."""
    runs = sorted(detuning["run_name"].unique())
    fig, axes = _grid(len(runs), 3, 3.8, 3.2, sharey=True)
    stress_ratio = paper_value("detuning", "stress", "resonance_voltage_v") / paper_value(
        "detuning", "stress", "stress_voltage_v")
    stress_power = paper_value("detuning", "stress", "stress_power_w") / paper_value(
        "detuning", "stress", "resonance_power_w")
    for ax, run in zip(axes, runs):
        series = detuning[detuning["run_name"] == run]
        for level, group in series.groupby("velocity_level_pp_mps"):
            group = group.sort_values("target_velocity_ratio", ascending=False)
            ax.errorbar(group["target_velocity_ratio"], group["power_ratio"], yerr=group.get("power_ratio_U"),
                        fmt="o-", capsize=2, label=f"v0 = {level:g} m/s pp")
        if (series["detuning_phase"] == "stress").any():
            ax.plot([stress_ratio], [stress_power], label="paper, Fig. 2c", **PAPER_STYLE)
        ax.set_title(f"{run} ({series['plate'].iloc[0]})", fontsize=9)
        ax.set_xlabel("velocity fraction before regaining v0")
        ax.invert_xaxis()
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[0].set_ylabel("Pt / P0")
    return save_figure(fig, path)


def resonance_curves(sweeps: pd.DataFrame, path: Path) -> Path:
    """Velocity pp against frequency, one panel per plate, one line per resonance search
    (run and step) in a sequential colour map so many searches stay apart.
    Columns: run_name, step_id, plate, generator_frequency_hz, velocity_pp_mps."""
    plt = pyplot()
    plates = sorted(sweeps["plate"].unique())
    fig, axes = _grid(len(plates), 3, 3.8, 3.0)
    for ax, plate in zip(axes, plates):
        searches = list(sweeps[sweeps["plate"] == plate].groupby(["run_name", "step_id"], sort=True))
        colours = plt.cm.viridis(np.linspace(0.0, 0.85, len(searches)))
        for colour, ((run, step), group) in zip(colours, searches):
            group = group.sort_values("generator_frequency_hz")
            ax.plot(group["generator_frequency_hz"] / 1e3, group["velocity_pp_mps"], ".-", color=colour,
                    label=f"{run} / {step}")
        ax.set_title(plate, fontsize=9)
        ax.set_xlabel("frequency (kHz)")
        ax.set_ylabel("velocity (m/s pp)")
        ax.grid(alpha=0.3)
        if len(searches) <= 6:
            ax.legend(fontsize=7)
        else:
            ax.text(0.02, 0.97, f"{len(searches)} searches", transform=ax.transAxes, va="top", fontsize=8)
    return save_figure(fig, path)


def _fit_panel(ax, res_ax, x, y, y_u, fit: LineFit, scale: float, xlabel: str, ylabel: str,
               stats_unit: str | None = None) -> None:
    """Points with their uncertainties, the fitted line (intercept kept) and, beneath, the
    residuals in units of each point's standard uncertainty; with `stats_unit`, the
    intercept and chi2/dof written in the panel (small multiples leave them to the table)."""
    x, y, y_u = (np.asarray(a, dtype=float) for a in (x, y, y_u))
    ax.errorbar(x, y * scale, yerr=y_u * scale, fmt="o", ms=4, capsize=2)
    grid = np.linspace(0.0, x.max() * 1.05, 50)
    ax.plot(grid, (fit.slope.value * grid + fit.intercept.value) * scale, "-", lw=1)
    if stats_unit is not None:
        chi2 = f", χ²/dof {fit.chi2_per_dof:.2f}" if np.isfinite(fit.chi2_per_dof) else ""
        ax.text(0.02, 0.97, f"fit intercept {fit.intercept.value * scale:.2g} ± "
                f"{fit.intercept.std_uncertainty * scale:.2g} {stats_unit}{chi2}", transform=ax.transAxes,
                va="top", fontsize=8)
    ax.set_ylabel(ylabel, fontsize=8)
    ax.tick_params(labelsize=7)
    residual = (y - (fit.slope.value * x + fit.intercept.value)) / np.where(y_u > 0, y_u, np.nan)
    res_ax.axhline(0.0, color="grey", lw=0.8)
    res_ax.plot(x, residual, "o", ms=3)
    res_ax.set_xlabel(xlabel, fontsize=8)
    res_ax.set_ylabel("resid./u", fontsize=7)
    res_ax.tick_params(labelsize=7)


def plate_fits(plates: dict[str, PlateCharacterisation], path: Path) -> Path:
    """Every plate's two fits (amplitude vs V, power vs V^2), each with its residuals."""
    plt = pyplot()
    names = list(plates)
    columns = min(4, len(names))
    rows = -(-len(names) // columns)
    fig = plt.figure(figsize=(min(MAX_WIDTH_IN, 2.9 * columns), 5.6 * rows))
    outer = fig.add_gridspec(rows, columns, hspace=0.3, wspace=0.5)
    for k, name in enumerate(names):
        plate = plates[name]
        inner = outer[k // columns, k % columns].subgridspec(4, 1, height_ratios=(3, 1.2, 3, 1.2), hspace=0.8)
        axes = [fig.add_subplot(inner[i]) for i in range(4)]
        points = plate.points
        v = points["piezo_voltage_vpp"]
        _fit_panel(axes[0], axes[1], v, points["amplitude_pp_m"], points["amplitude_pp_m_u"],
                   plate.amplitude_slope, 1e6, "voltage (Vpp)", "amplitude (µm pp)")
        _fit_panel(axes[2], axes[3], v**2, points["power_w"], points["power_w_u"], plate.power_slope, 1e3,
                   "voltage² (Vpp²)", "power (mW)")
        axes[0].set_title(name, fontsize=9)
    # savefig(bbox_inches="tight") draws the figure once unseen before it measures it, for a
    # layout engine this figure has none of: its own tight box, measured here, is the same
    # (and so the PNG's bytes) for 12 % less of the 28 panels' drawing
    box = fig.get_tightbbox(fig.canvas.get_renderer()).padded(plt.rcParams["savefig.pad_inches"])
    fig.savefig(path, dpi=100, metadata=_PNG_METADATA, bbox_inches=box)
    plt.close(fig)
    return path


def fig5_q_tan(plates: dict[str, PlateCharacterisation], path: Path) -> Path:
    """Fig. 5: Q and tan(theta') per plate with expanded (k = 2) uncertainties, and what
    the paper prints: Plate 4's Q, the mean tan(theta') per resonator thickness."""
    plt = pyplot()
    names = list(plates)
    x = np.arange(len(names))
    fig, (ax_q, ax_t) = plt.subplots(1, 2, figsize=(10, 3.8))
    printed = paper_table("small_plates")
    for ax, attribute, label in ((ax_q, "q", "Q (Eq. 27)"), (ax_t, "tan_theta", "tan θ′ (Eq. 25)")):
        values = [getattr(plates[n], attribute) for n in names]
        ax.errorbar(x, [v.value for v in values], yerr=[2 * v.std_uncertainty for v in values], fmt="o",
                    capsize=3, label="this run (± U, k = 2)")
        ax.set_xticks(x, names, rotation=30, ha="right", fontsize=8)
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    for row in printed[printed["quantity"] == "q"].itertuples(index=False):
        if row.item in names:
            ax_q.plot([names.index(row.item)], [row.value], "D", color="crimson", ms=8, mfc="none",
                      label=f"paper: {row.item} ({row.source})")
    for row in printed[printed["quantity"] == "tan_theta_mean"].itertuples(index=False):
        ax_t.axhline(row.value, ls="--", color="crimson", lw=1, label=f"paper: mean, {row.item} plates")
    ax_q.legend(fontsize=7)
    ax_t.legend(fontsize=7)
    return save_figure(fig, path)


PHYSICS_STYLE = {"color": "tab:green", "lw": 1.2}


def _physics_band(ax, x, y, u, label: str) -> None:
    """What the plate model predicts, a line with its U (k = 2) as a band, the interval each
    point stands for (`predicted_plates.expanded_interval`: never through zero where U passes
    the value, which would draw negative powers and amplitudes)."""
    order = np.argsort(np.asarray(x))
    x, y, u = (np.asarray(a, dtype=float)[order] for a in (x, y, u))
    ax.plot(x, y, "-", label=label, **PHYSICS_STYLE)
    ax.fill_between(x, *expanded_interval(y, u), color=PHYSICS_STYLE["color"], alpha=0.15, lw=0)


def fig8_amplitude(large: PlateCharacterisation, path: Path, physics_m_per_vpp: tuple[float, float] | None = None) -> Path:
    """Fig. 8: amplitude pp against voltage pp with the fitted line, its residuals, and
    the paper's published point (about 1 um at 32 Vpp, Sec. 5.3.2); with
    `physics_m_per_vpp` (slope, its relative U), the plate model's line and band."""
    plt = pyplot()
    points = large.points
    fig, (ax, res) = plt.subplots(2, 1, figsize=(6.5, 4.8), sharex=True, gridspec_kw={"height_ratios": (3, 1)})
    _fit_panel(ax, res, points["piezo_voltage_vpp"], points["amplitude_pp_m"], points["amplitude_pp_m_u"],
               large.amplitude_slope, 1e6, "voltage (Vpp)", "amplitude (µm pp)", stats_unit="µm pp")
    if physics_m_per_vpp is not None:
        slope, rel_u = physics_m_per_vpp
        v = np.linspace(0.0, float(points["piezo_voltage_vpp"].max()), 20)
        _physics_band(ax, v, slope * v * 1e6, rel_u * slope * v * 1e6, "physics: plate model, U (k = 2)")
    ax.plot([paper_value("large_plate", "large_plate", "voltage_vpp")],
            [paper_value("large_plate", "large_plate", "amplitude_m") * 1e6], label="paper, Sec. 5.3.2", **PAPER_STYLE)
    ax.legend(fontsize=8, loc="lower right")
    ax.grid(alpha=0.3)
    return save_figure(fig, path)


def fig9_power(power: pd.DataFrame, path: Path) -> Path:
    """Fig. 9: power against V^2, measured and estimated from the small plates, what the
    plate model predicts (with its U band) and the paper's published point (1.3 W at 32
    Vpp). Columns: piezo_voltage_vpp, power_measured_w, power_estimated_w,
    power_predicted_w, power_predicted_U_w."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    v2 = power["piezo_voltage_vpp"] ** 2
    ax.plot(v2, power["power_measured_w"], "o", label="this run: large plate's sweep")
    if power["power_estimated_w"].notna().any():
        ax.plot(v2, power["power_estimated_w"], "s--", label="this run: estimated from small plates (Eqs. 25, 29)")
    _physics_band(ax, v2, power["power_predicted_w"], power["power_predicted_U_w"], "physics: plate model, U (k = 2)")
    ax.plot([paper_value("large_plate", "large_plate", "voltage_vpp") ** 2],
            [paper_value("large_plate", "large_plate", "power_w")], label="paper, Sec. 5.3.2", **PAPER_STYLE)
    ax.set_xlabel("voltage squared (Vpp²)")
    ax.set_ylabel("power (W)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="upper left")   # the paper's point sits upper right
    return save_figure(fig, path)


def study_fronts(summary: pd.DataFrame, path: Path) -> Path:
    """Accuracy study: p95 |relative error| against bench time per trial, one panel per
    quantity, every configuration as a dot and each experiment's Pareto front as a line.
    Columns: see analysis.study.summarise."""
    plt = pyplot()
    from matplotlib.ticker import NullFormatter
    quantities = sorted(summary["quantity"].unique())
    columns = min(3, len(quantities))
    rows = -(-len(quantities) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(min(MAX_WIDTH_IN, 3.8 * columns), 3.4 * rows), squeeze=False)
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
    return save_figure(fig, path)


def systematics_fronts(summary: pd.DataFrame, path: Path) -> Path:
    """Total error on benches erring within spec against bench time per trial, one panel
    per quantity: each point's averaging series as the bench is (solid) and after the
    deskew calibration (dashed, its bench time included). Rows: the systematics
    experiments of analysis.study.summarise."""
    plt = pyplot()
    from matplotlib.ticker import FormatStrFormatter, NullFormatter
    data = summary.assign(point=[systematics_point(e)[0] for e in summary["experiment"]],
                          calibrated=[systematics_point(e)[1] for e in summary["experiment"]])
    quantities = [q for q in ("power_w", "velocity_pp_mps", "q", "tan_theta", "resonance_frequency_hz")
                  if q in set(data["quantity"])]
    columns = min(3, len(quantities))
    rows = -(-len(quantities) // columns)
    fig, axes = plt.subplots(rows, columns, figsize=(min(MAX_WIDTH_IN, 3.8 * columns), 3.2 * rows), squeeze=False)
    for ax in list(axes.flat)[len(quantities):]:
        ax.set_visible(False)
    colours = dict(zip(sorted(data["point"].unique()), plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    for ax, quantity in zip(axes.flat, quantities):
        for (point, calibrated), group in data[data["quantity"] == quantity].groupby(["point", "calibrated"]):
            group = group.sort_values("bench_time_s")
            ax.semilogx(group["bench_time_s"], 100.0 * group["p95_abs_rel_error"], "o--" if calibrated else "o-",
                        color=colours[point], markersize=3,
                        label=f"{point}{' calibrated' if calibrated else ''}")
        ax.set_ylim(bottom=0.0)   # a floor is a level, not a slope: linear in %
        ax.set_title(quantity, fontsize=9)
        low, high = ax.get_xlim()
        # a decade's label in view is enough; within one decade, plain minor labels are all there is
        ax.xaxis.set_minor_formatter(NullFormatter() if high / low > 10 else FormatStrFormatter("%g"))
        ax.set_xlabel("bench time per trial (s)")
        ax.set_ylabel("p95 |relative error| over benches (%)")
        ax.legend(fontsize=7, loc="lower left")
    return save_figure(fig, path)


def heating_drift(heating: pd.DataFrame, path: Path) -> Path:
    """Power error against averaging on a heating plate, at the frequency found cold and
    with the resonance tracked before each point. Columns: analysis.study.heating_table."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(5.5, 3.6))
    for column, label in (("p95_abs_rel_error_fixed_frequency", "frequency found cold"),
                          ("p95_abs_rel_error_tracked", "resonance tracked")):
        if column in heating:
            ax.loglog(heating["averages"], heating[column], "o-", label=label)
    ax.set_xlabel("scope averages per point")
    ax.set_ylabel("p95 |relative error| of power")
    ax.legend(fontsize=8)
    return save_figure(fig, path)
