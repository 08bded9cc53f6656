"""The verdict on a design: the neighbour modes a drive also excites, whether their coupling
cancels the working mode's, and feasible / marginal / infeasible against the limits.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from squeezebench.plates import plate_modes, predicted_plates
from squeezebench.designing.design_file import DesignFile
from squeezebench.designing.design import DesignError, MIN_COUPLING_SHARE, PARTIAL_COUPLING_SHARE, PhysicsPrediction, coupling_share, modal_part, operating_point


@dataclass(frozen=True)
class Neighbour:
    """A mode next to the design's by antinode count, as the design would drive it."""

    interior_antinodes: int
    frequency_hz: float
    voltage_vpp: float
    coupling_share: float


def neighbour_modes(design: DesignFile, antinodes: int) -> list[Neighbour]:
    """The modes with one antinode fewer and one more, each solved as the design's working
    mode (a count the plate does not show cleanly is left out)."""
    out = []
    for count in (antinodes - 1, antinodes + 1):
        if count < 1:
            continue
        candidate = DesignFile.model_validate({**design.model_dump(), "mode": {"interior_antinodes": count}})
        try:
            modal = modal_part(candidate, antinodes=count)
            values = operating_point(candidate, modal=modal).values
        except (DesignError, ValueError):
            continue
        if values["interior_antinodes"] == count:
            out.append(Neighbour(count, values["frequency_hz"], values["voltage_vpp"], values["coupling_share"]))
    return out


def better_neighbour(design: DesignFile, neighbours: list[Neighbour]) -> Neighbour | None:
    """Of the neighbours the powered piezos do not cancel on, the one nearest the frequency
    the design asks for (the lower voltage between equals)."""
    usable = [n for n in neighbours if n.coupling_share >= MIN_COUPLING_SHARE]
    return min(usable, key=lambda n: (abs(n.frequency_hz - design.search_hz), n.voltage_vpp)) if usable else None


@dataclass(frozen=True)
class Verdict:
    """Whether the answer is one a lab can build on: 'feasible', 'marginal' (a limit within
    the answer's U) or 'infeasible', why, and the nearest changes that make it feasible."""

    status: str
    reasons: tuple[str, ...] = ()
    changes: tuple[str, ...] = ()


def cancellation(design: DesignFile, modes: plate_modes.PlateModes, k: int,
                 neighbours: list[Neighbour] = ()) -> tuple[str, str] | None:
    """Why mode k is no working mode when the powered piezos cancel on it, and the change to
    make (the better of `neighbours`); None when they add."""
    share = coupling_share(modes.force_factor_n_per_v[k, modes.powered])
    if share >= MIN_COUPLING_SHARE:
        return None
    reason = (f"the powered piezos cancel on the {modes.interior_antinodes(k)}-antinode mode at "
              f"{modes.frequencies_hz[k]:.0f} Hz (net coupling {share:.1%} of their sum), so its voltage hangs on "
              "how unevenly they happen to be placed")
    best = better_neighbour(design, list(neighbours))
    change = (f"the {best.interior_antinodes}-antinode mode at {best.frequency_hz:.0f} Hz, where they add, needs "
              f"about {best.voltage_vpp:.3g} Vpp (mode: {{interior_antinodes: {best.interior_antinodes}}})" if best
              else "power only the groups on one side of the mode's middle, or move them so that they add")
    return reason, change


def _limits(physics: PhysicsPrediction) -> list[tuple[str, str, float, str, int]]:
    """(what, output, limit, unit, power of the drive it grows with) for each stated limit."""
    d = physics.design
    limits = [("the amplifier's output", "voltage_vpp", d.amplifier.max_output_vpp, "Vpp", 1),
              ("the ceramic's field limit", "piezo_field_v_per_mm", d.piezo.max_field_v_per_mm, "V/mm", 1)]
    if d.amplifier.max_current_app:
        limits.append(("the amplifier's current", "current_pp_a", d.amplifier.max_current_app, "A pp", 1))
    if d.amplifier.max_power_w:
        limits.append(("the amplifier's power", "power_w", d.amplifier.max_power_w, "W", 2))
    return limits


def judge(physics: PhysicsPrediction, curve: pd.DataFrame | None = None,
          neighbours: list[Neighbour] = ()) -> Verdict:
    """The design's verdict. Infeasible: the powered piezos cancel on the working mode, or the
    target needs more than a limit allows (amplifier voltage, current or power, the
    ceramic's field); marginal: a limit lies within the answer's U, or the piezos partly
    cancel. The changes named: the
    better neighbouring mode, the largest target the limits allow (voltage, field and current
    grow as the target, power about as its square), and the placement along the length that
    needs the least voltage when `curve` shows one within the limits."""
    d, v, u = physics.design, physics.nominal.values, physics.expanded
    infeasible, marginal, changes = [], [], []
    cancelled = cancellation(d, physics.nominal.modes, physics.nominal.mode_index, neighbours)
    if cancelled:
        infeasible.append(cancelled[0])
        changes.append(cancelled[1])
    elif v["coupling_share"] < PARTIAL_COUPLING_SHARE:
        marginal.append(f"the powered piezos partly cancel on the working mode (net coupling "
                        f"{v['coupling_share']:.0%} of their sum): a small shift of one group moves the voltage much")
    scale = 1.0
    for what, output, limit, unit, power in _limits(physics):
        value = v[output]
        if value > limit:
            infeasible.append(f"needs {value:.3g} {unit}, beyond {what} ({limit:g} {unit})")
            scale = min(scale, (limit / value) ** (1 / power))
        elif value + u[output] > limit:
            # a U past the value is a range (`expanded_interval`): "56 +- 260 Vpp" would hold voltages below zero
            low, high = (float(end) for end in predicted_plates.expanded_interval(value, u[output]))
            needed = (f"{value:.3g} ± {u[output]:.2g} {unit}" if low == value - u[output] else
                      f"{value:.3g} {unit} (×/÷ {high / value:.2g}: up to {high:.3g} {unit})")
            marginal.append(f"{what} ({limit:g} {unit}) lies within the U of the {needed} needed")
    if scale < 1 and v["coupling_share"] >= MIN_COUPLING_SHARE:
        target = d.target
        wanted = (f"{target.amplitude_pp_m * scale * 1e6:.3g} µm pp" if target.amplitude_pp_m is not None
                  else f"{target.velocity_pp_mps * scale:.3g} m/s pp")
        changes.append(f"a target of at most {wanted}")
        if curve is not None and curve["voltage_vpp"].notna().any():
            best = curve.loc[curve["voltage_vpp"].idxmin()]
            drive = best["voltage_vpp"] / v["voltage_vpp"]
            if all(v[output] * drive <= limit for _, output, limit, _, power in _limits(physics) if power == 1):
                changes.append(f"the end piezos {best['edge_gap_mm']:.1f} mm from the edges (about "
                               f"{best['voltage_vpp']:.3g} Vpp)")
    status = "infeasible" if infeasible else "marginal" if marginal else "feasible"
    return Verdict(status, tuple(infeasible or marginal), tuple(changes))
