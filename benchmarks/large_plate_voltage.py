"""The large plate's voltage for 1 um pp taken apart beside issue 45's review: force factor and
modal mass at the centre, Q, amplitude convention, at the review's five edge gaps
(`designing.paper_placement.voltage_decomposition`), and the factor that separates the model's
least voltage from the paper's printed 32 Vpp.

    python benchmarks/large_plate_voltage.py          (about a minute: five solves of the plate)
"""
from __future__ import annotations

import pandas as pd

from squeezebench.designing.paper_placement import voltage_decomposition
from squeezebench.paper import paper_value


def main() -> None:
    frame = voltage_decomposition()
    printed_vpp = paper_value("large_plate", "large_plate", "voltage_vpp")
    with pd.option_context("display.width", 250, "display.max_columns", 30, "display.float_format", "{:.4g}".format):
        print(frame.to_string(index=False))
    least = frame.loc[frame["voltage_vpp"].idxmin()]
    print(f"least: {least['voltage_vpp']:.3g} Vpp at {least['edge_gap_mm']:g} mm; reaching the printed "
          f"{printed_vpp:g} Vpp there needs Q A / M {least['voltage_vpp'] / printed_vpp:.3g} times larger "
          f"(Q {least['design_q'] * least['voltage_vpp'] / printed_vpp:.0f}; the loss physics' Q "
          f"{least['physics_q']:.0f} gives {least['voltage_vpp_physics_q']:.3g} Vpp)")


if __name__ == "__main__":
    main()
