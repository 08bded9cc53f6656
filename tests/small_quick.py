"""quick's three kinds of step at a fraction of its messages, for the tests that run a
campaign through real processes or a real transport, where every message is paid for
(a round trip over a socket or a pty, a process's bench opening).

The runs are quick's, in its order: the deskew with its 10,000-point averaged records, a
detuning and a resonator cut, at 4 search points and a 50 Hz search tolerance (1,704
messages where quick sends 3,744), on quick's scene and acquisition. Without the deskew
(`MEASURING_RUNS`) it is the previous users' campaign (test_previous_user_states).
"""

from __future__ import annotations

from pathlib import Path

#: The campaign's settings: quick's.
HEADER = """
name: small_quick
bench: {scene: one_column_1mm.yaml}
acquisition: {averages: 4, record_length: 500, periods_per_record: 10, settle_s: 0.5}
safety: {max_piezo_voltage_vpp: 100, ramp_step_vpp: 10, ramp_dwell_s: 0.01}
runs:
"""
DESKEW_RUN = """
  - name: deskew_calibration
    protocol: deskew_calibration
    plate: {n_powered_columns: 1, n_powered_piezos: 1}
    acquisition: {averages: 16, record_length: 10000}
    parameters: {frequency_hz: 37000.0}
"""
#: quick's two kinds of measuring step, one each.
MEASURING_RUNS = """
  - name: detuning
    protocol: detuning
    plate: {n_powered_columns: 1, n_powered_piezos: 4}
    parameters:
      search: {start_hz: 36000, stop_hz: 38500, points: 4, tolerance_hz: 50}
      velocity_levels_pp_mps: [0.25]
      velocity_ratios: [0.5]
  - name: cutting
    protocol: resonator_cutting
    plate: {n_powered_columns: 1, n_powered_piezos: 4}
    parameters:
      piezo_voltage_vpp: 20
      search: {start_hz: 36000, stop_hz: 38500, points: 4, tolerance_hz: 50}
      lengths:
        - {plate_length_mm: 75, state: 75x41, n_antinodes: 9}
"""
SMALL_QUICK = HEADER + DESKEW_RUN + MEASURING_RUNS
#: The steps it stores: the deskew's, the detuning's four (its closing re-centring last), the cut's.
SMALL_QUICK_STEPS = 6


def small_quick(folder: Path) -> Path:
    """The campaign written in `folder` (one of its own: its scene is the shipped one only
    where the folder holds no file of that name)."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "small_quick.yaml"
    path.write_text(SMALL_QUICK)
    return path
