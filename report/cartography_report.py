"""The map section of the report (Fig. 7): the vibration map drawn, its homogeneity
numbers, and the map against the plate model's working mode."""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import pandas as pd

from squeezebench.analysis import cartography
from squeezebench.plates import predicted_plates
from squeezebench.report.presentation import fold, grid_correction_note, with_uncertainty
from squeezebench.report.section import ReportContext, Section, html_table


def map_figure(points: pd.DataFrame, path: Path, plate: str) -> None:
    """Velocity amplitude and signed velocity (m/s pp) over the plate, axes in mm, with the
    plate's outline and piezos when the model knows the plate."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grid = points.pivot_table(index="y_m", columns="x_m", values=["velocity_pp_mps", "signed_velocity_pp_mps"])
    x_mm, y_mm = grid.columns.levels[1].to_numpy() * 1e3, grid.index.to_numpy() * 1e3
    geometry = predicted_plates.GEOMETRIES[plate]() if plate in predicted_plates.GEOMETRIES else None
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2), constrained_layout=True)
    signed = grid["signed_velocity_pp_mps"].to_numpy()
    limit = float(np.nanmax(np.abs(signed)))
    for ax, values, cmap, label, lows in (
            (axes[0], grid["velocity_pp_mps"].to_numpy(), "viridis", "velocity amplitude (m/s pp)", 0.0),
            (axes[1], signed, "RdBu_r", "signed velocity (m/s pp, sign: phase against the drive)", -limit)):
        image = ax.pcolormesh(x_mm, y_mm, values, cmap=cmap, vmin=lows, vmax=limit, shading="nearest")
        fig.colorbar(image, ax=ax, label=label, shrink=0.9)
        if geometry is not None:
            ax.add_patch(plt.Rectangle((0, 0), geometry.length_m * 1e3, geometry.width_m * 1e3, fill=False,
                                       edgecolor="k", linewidth=1.0))
            for patch in predicted_plates.modes_patches(geometry):
                ax.add_patch(plt.Rectangle(*patch, fill=False, edgecolor="k", linewidth=0.6))
            ax.set_xlim(-2, geometry.length_m * 1e3 + 2)
            ax.set_ylim(-2, geometry.width_m * 1e3 + 2)
        ax.set_aspect("equal")
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
    fig.savefig(path, dpi=90)
    plt.close(fig)


def _drive_frequency_hz(points: pd.DataFrame) -> float:
    """The frequency a map was driven at (the model's mode is looked for near it)."""
    return float(points["generator_frequency_hz"].median())


def solve_ahead(context: ReportContext) -> None:
    """Hand the model's solve of each mapped plate to the drawing processes (`Drawing.ahead`)
    from the stored rows alone, before the map's points are reduced: it is kept in the disk
    cache, where `map_summaries` reads it instead of solving it here (none without the cache)."""
    for plate, frequency_hz in _mapped_plates(context.run.protocol("cartography")):
        context.draw.ahead(predicted_plates.known_plate_modes, plate, frequency_hz)


def _mapped_plates(rows: pd.DataFrame) -> list[tuple[str, float]]:
    """(plate, drive frequency) of each map in the map rows whose plate the model knows:
    the solves `map_summaries` reads."""
    if rows.empty:
        return []
    return [(plate, _drive_frequency_hz(one)) for (_, plate), one in rows.groupby(["run_name", "plate"], sort=False)
            if plate in predicted_plates.GEOMETRIES]


def solve_stored_map(run_dir: Path, run_name: str) -> None:
    """On a drawing process while a campaign goes on (`reproduce`): the model's solve of a map
    run's plate, from the rows it stored, left in the disk cache for the report's
    `solve_ahead`, which then reads it instead of solving it while the figures wait."""
    from squeezebench.analysis.rundata import read_measurements

    rows = read_measurements(sorted((Path(run_dir) / "measurements" / run_name).glob("*.parquet")))
    for plate, frequency_hz in _mapped_plates(rows):
        predicted_plates.known_plate_modes(plate, frequency_hz)


def map_summaries(run) -> tuple[pd.DataFrame, dict[str, pd.DataFrame]]:
    """One summary row per mapped run (cartography.summarise_map, with the model's
    prediction where it knows the plate), and each run's reduced points."""
    points = cartography.map_points(run)
    rows, maps = [], {}
    for (run_name, plate), one in points.groupby(["run_name", "plate"], sort=False):
        one = one.reset_index(drop=True)
        frequency_hz = _drive_frequency_hz(one)
        predicted = predicted_plates.working_shape(plate, frequency_hz, one["x_m"].to_numpy(), one["y_m"].to_numpy())
        summary = cartography.summarise_map(one, None if predicted is None else predicted[0],
                                             resonance_q=cartography.map_resonance_q(run, run_name))
        voltage_vpp = float(one["piezo_voltage_setpoint_vpp"].median())
        amplitude = cartography.amplitude_pp_m(summary["mean_velocity_pp_mps"], frequency_hz)
        rows.append({"run_name": run_name, "plate": plate, "drive_frequency_hz": frequency_hz,
                     "piezo_voltage_vpp": voltage_vpp,
                     "predicted_mode_frequency_hz": np.nan if predicted is None else predicted[1], **summary,
                     "mean_amplitude_pp_m": amplitude,
                     "mean_amplitude_pp_m_U": cartography.amplitude_pp_m(summary["mean_velocity_pp_mps_U"], frequency_hz),
                     "criterion_amplitude_pp_m": cartography.HAPTICS_AMPLITUDE_PP_M,
                     # the response is linear in the drive: the voltage that brings the mean to the criterion
                     "voltage_for_criterion_vpp": voltage_vpp * cartography.HAPTICS_AMPLITUDE_PP_M / amplitude})
        maps[run_name] = one
    return pd.DataFrame(rows), maps


CRITERION_HEADER = f"V pp for {1e6 * cartography.HAPTICS_AMPLITUDE_PP_M:g} µm pp"
#: The column of the corrections the CV and the area took for where the grid fell (percentage points).
GRID_CORRECTION_HEADER = "grid correction, CV / area (points of %)"


def cartography_section(context: ReportContext) -> Section | None:
    """Vibration map (Fig. 7)"""
    if context.run.protocol("cartography").empty:
        return None
    context.draw.wait_ahead()   # the plates `solve_ahead` handed out: read, not solved twice
    summaries, maps = map_summaries(context.run)
    body = ""
    if context.bench() == "simulated":
        body = ("<p class='banner'>On the simulated bench the map is drawn from the same plate model it is "
                "compared with: a modal assurance criterion near 1 shows the chain (stage, acquisition, phase) "
                "keeps the shape, not that the model is right. A real plate's map is the test.</p>")
    # per map, a sentence with the answer and the figure; then the numbers of every map
    for row in summaries.itertuples(index=False):
        path = context.out_dir / f"map_{row.run_name}.png"
        context.draw(map_figure, maps[row.run_name], path, row.plate)
        mac = (f"; against the plate model's working mode ({row.predicted_mode_frequency_hz / 1e3:.2f} kHz, "
               f"predicted from geometry and datasheets) the modal assurance criterion is {row.mac_with_predicted:.3f}"
               if np.isfinite(row.mac_with_predicted) else "; the plate model does not know this plate")
        body += (f"<p><b>{html.escape(row.run_name)}</b> ({html.escape(row.plate)}): {row.n_points} points at "
                 f"{row.drive_frequency_hz / 1e3:.3f} kHz and {row.piezo_voltage_vpp:g} V pp. Over the touch area "
                 f"the velocity is {with_uncertainty(row.mean_velocity_pp_mps, row.mean_velocity_pp_mps_U)} m/s pp on "
                 f"average, a displacement of {with_uncertainty(1e6 * row.mean_amplitude_pp_m, 1e6 * row.mean_amplitude_pp_m_U)} "
                 f"µm pp against the {1e6 * row.criterion_amplitude_pp_m:g} µm pp a fingertip needs (about "
                 f"{row.voltage_for_criterion_vpp:.0f} V pp reaches it); coefficient of variation "
                 f"{with_uncertainty(100 * row.coefficient_of_variation, 100 * row.coefficient_of_variation_U, unit='%')}"
                 f"{grid_correction_note(row.coefficient_of_variation, row.coefficient_of_variation_grid_correction)}, "
                 f"{with_uncertainty(100 * row.fraction_above_share, 100 * row.fraction_above_share_U, unit='%')} "
                 f"of the area above {row.share_of_peak:.0%} of the peak"
                 f"{grid_correction_note(row.fraction_above_share, row.fraction_above_share_grid_correction)}, with "
                 f"{row.n_nodal_lines} nodal lines {row.nodal_line_spacing_m * 1e3:.2f} mm apart; "
                 f"{row.width_uniformity:.1%} of the map's mean square is uniform across the width "
                 f"(the paper's \"uniform across the plate\", Sec. 5.2){mac}.</p>")
        body += context.figure(path, f"Vibration map of {html.escape(row.plate)} (run {html.escape(row.run_name)}): "
                                     "velocity amplitude (left) and signed velocity (right: the phase against the piezo "
                                     "voltage gives the sign, so nodal lines are where the colour changes); outline and "
                                     "rectangles: the plate and its piezos. Measured; the paper's Fig. 7.")
    shown = summaries.assign(**{
        "mean velocity (m/s pp)": [with_uncertainty(m, u) for m, u in zip(summaries["mean_velocity_pp_mps"],
                                                                           summaries["mean_velocity_pp_mps_U"])],
        "mean amplitude (µm pp)": [with_uncertainty(1e6 * m, 1e6 * u) for m, u in zip(
            summaries["mean_amplitude_pp_m"], summaries["mean_amplitude_pp_m_U"])],
        CRITERION_HEADER: [f"{v:.0f}" for v in summaries["voltage_for_criterion_vpp"]],
        "coefficient of variation (%)": [with_uncertainty(100 * c, 100 * u) for c, u in zip(
            summaries["coefficient_of_variation"], summaries["coefficient_of_variation_U"])],
        "area above share of peak (%)": [with_uncertainty(100 * f, 100 * u) for f, u in zip(
            summaries["fraction_above_share"], summaries["fraction_above_share_U"])],
        GRID_CORRECTION_HEADER: [f"{100 * c:+.2f} / {100 * f:+.2f}".replace("-", "−") for c, f in zip(
            summaries["coefficient_of_variation_grid_correction"], summaries["fraction_above_share_grid_correction"])],
        "min / max (m/s pp)": [f"{a:.3f} / {b:.3f}" for a, b in zip(summaries["min_velocity_pp_mps"],
                                                                    summaries["max_velocity_pp_mps"])],
        "width uniformity": [f"{w:.1%}" for w in summaries["width_uniformity"]],
        "nodal-line spacing (mm)": [f"{s * 1e3:.2f}" for s in summaries["nodal_line_spacing_m"]],
        "MAC with model": [f"{m:.3f}" if np.isfinite(m) else "no model" for m in summaries["mac_with_predicted"]],
    })[["run_name", "n_points", "mean velocity (m/s pp)", "mean amplitude (µm pp)", CRITERION_HEADER, "min / max (m/s pp)", "coefficient of variation (%)",
        "area above share of peak (%)", GRID_CORRECTION_HEADER, "width uniformity", "nodal-line spacing (mm)", "MAC with model"]]
    body += fold("Homogeneity of each map as numbers, with the voltage that reaches the haptics criterion",
                 html_table(shown.rename(columns={"run_name": "map", "n_points": "points"}),
                            "homogeneity of each map's touch area, ± U (k for 95 % under its budget): the points' noise, the generator's "
                            "frequency error through the level steps between the map's re-tuned steps, for velocities "
                            "the scale all points share (CH3 gain, decoder), and for the coefficient of variation and "
                            "the area, which are the vibration's over the touch area (the points' figures corrected "
                            "for where the grid fell on the mode, read between the points), that correction's own "
                            "error (the reading's misfit) and the cells' quadrature"))
    context.tables["map_summary"] = summaries
    context.tables["map_points"] = pd.concat(maps.values(), ignore_index=True)
    body += ("<p class='csv'>Machine-readable: <a href='map_summary.csv'>map_summary.csv</a>, "
             "<a href='map_points.csv'>map_points.csv</a> (every point, reduced from its record).</p>")
    return Section("Vibration map (Fig. 7)", body, "map")
