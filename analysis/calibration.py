"""What a deskew calibration run measured (`protocols.calibration`), as corrections.

Through a resistor the current is in phase with the voltage, so the phase the scope
shows between CH1 and CH2 is the delay of CH2: with the fitted power P' and reactive
power Q' of the record, w tau = atan2(Q', P') (`analysis.waveforms`). Its uncertainty
combines the records' fit covariance and scatter (Type A) with the resistor's own time
constant L/R (Type B).

The same records compare the current path with the voltage path:
k = 8 P' (R + R_shunt) / V'pp^2 = g_CH2 g_probe / g_V (g_V = g_vprobe g_CH1, the voltage
probe's attenuation error and CH1's gain). The power carries g_V g_CH2 g_probe; dividing
by k entirely would leave g_V^2, no better without a voltage reference, but dividing by
k^alpha with the weight that minimises the remaining variance (`gain_weight`) leaves
g_V^(1+alpha) (g_CH2 g_probe)^(1-alpha).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from squeezebench.analysis.dielectric import SHUNT_TOLERANCE_REL
from squeezebench.analysis.rundata import RunData
from squeezebench.plates.specifications import SPECIFICATIONS, Specification
from squeezebench.analysis.tables import reduced_points
from squeezebench.analysis.waveforms import Estimate

PROTOCOL = "deskew_calibration"
RESISTOR_TIME_CONSTANT = Specification(
    0.5e-9, "s", "assumed: a low-inductance precision resistor, L/R within 0.5 ns (50 nH in 100 ohm)")


#: Weight of the gain check in the power's gain correction (see `Deskew.gain_weight`).
def gain_weight() -> float:
    """alpha minimising the variance of g_V^(1+alpha) (g2 g_probe)^(1-alpha): the power
    corrected by k^-alpha (k = g2 g_probe / g_V) trades the current path's gain errors for
    the voltage path's, (S - V) / (S + V) with S and V the paths' variances."""
    scope = SPECIFICATIONS["scope_gain"].std_uncertainty ** 2
    voltage = scope + SPECIFICATIONS["voltage_probe_attenuation"].std_uncertainty ** 2
    current = scope + SPECIFICATIONS["current_probe_gain"].std_uncertainty ** 2
    return (current - voltage) / (current + voltage)


@dataclass(frozen=True)
class Deskew:
    """What a calibration measured, to be removed from the power: the delay of CH2
    against CH1 and (when known) the gain ratio k = g_CH2 g_probe / g_CH1."""

    delay_s: float
    std_uncertainty_s: float
    source: str
    gain_ratio: float | None = None
    gain_ratio_u: float = 0.0
    #: Where the delay was measured: a phase that is not a pure delay (the voltage probe's
    #: compensation) is removed exactly there only (`uncertainty.compensation_phase_per_mismatch`).
    frequency_hz: float | None = None

    def corrected_power_w(self, power_w, reactive_power_var, frequency_hz):
        """P = (P' + Q' w tau) k^-alpha (arrays or numbers)."""
        deskewed = power_w + reactive_power_var * 2.0 * math.pi * frequency_hz * self.delay_s
        return deskewed if self.gain_ratio is None else deskewed * self.gain_ratio ** -gain_weight()

    def applied_to(self, points: pd.DataFrame) -> pd.DataFrame:
        """Reduced points with their power corrected (`power_w_uncorrected` kept) and the
        correction recorded in columns, so every mean, fit and budget made of them (Q,
        tan theta', Fig. 2's ratios) uses the corrected power and knows it did."""
        points = points.copy()
        points["power_w_uncorrected"] = points["power_w"]
        points["power_w"] = self.corrected_power_w(points["power_w"], points["reactive_power_var"],
                                                   points["frequency_hz"])
        for column, value in zip(APPLIED_COLUMNS, (self.delay_s, self.std_uncertainty_s, self.gain_ratio,
                                                   self.gain_ratio_u, self.frequency_hz)):
            points[column] = math.nan if value is None else value
        points["deskew_source"] = self.source
        return points

    @classmethod
    def applied_in(cls, points: pd.DataFrame) -> Deskew | None:
        """The correction `applied_to` recorded in `points` (None: uncorrected powers)."""
        if "power_w_uncorrected" not in points or points.empty:
            return None
        delay_s, delay_u_s, ratio, ratio_u, frequency_hz = (float(points[column].iloc[0])
                                                           for column in APPLIED_COLUMNS)
        return cls(delay_s, delay_u_s, str(points["deskew_source"].iloc[0]),
                   None if math.isnan(ratio) else ratio, 0.0 if math.isnan(ratio_u) else ratio_u,
                   None if math.isnan(frequency_hz) else frequency_hz)


#: What `Deskew.applied_to` records of the correction beside each corrected point.
APPLIED_COLUMNS = ("deskew_delay_s", "deskew_delay_u_s", "deskew_gain_ratio", "deskew_gain_ratio_u",
                   "deskew_frequency_hz")


def _mean(values: np.ndarray, stated_u: np.ndarray) -> Estimate:
    """Mean of repeated records: stated uncertainties and their scatter, whichever larger."""
    n = values.size
    stated = math.sqrt(float(np.sum(stated_u**2))) / n
    scatter = float(np.std(values, ddof=1)) / math.sqrt(n) if n > 1 else 0.0
    return Estimate(float(values.mean()), max(stated, scatter))


def deskew_from_points(points: pd.DataFrame) -> Deskew:
    """The CH2 delay from reduced calibration records (columns of `PointReduction`)."""
    omega = 2.0 * math.pi * points["frequency_hz"].to_numpy()
    power = points["power_fit_w"].to_numpy()
    reactive = points["reactive_power_var"].to_numpy()
    delay_s = np.arctan2(reactive, power) / omega
    # d(atan2(Q, P)) = (P dQ - Q dP) / (P^2 + Q^2); fit errors of P and Q independent enough
    u_s = np.hypot(power * points["reactive_power_var_u"], reactive * points["power_fit_w_u"]) \
        / (power**2 + reactive**2) / omega
    measured = _mean(delay_s, np.asarray(u_s, dtype=float))
    runs = ", ".join(sorted(set(points["run_name"].astype(str))))
    return Deskew(measured.value, math.hypot(measured.std_uncertainty, RESISTOR_TIME_CONSTANT.std_uncertainty),
                  f"deskew calibration ({runs}: {len(points)} records through a resistor); "
                  + RESISTOR_TIME_CONSTANT.source, frequency_hz=float(points["frequency_hz"].mean()))


def current_gain_ratio(points: pd.DataFrame) -> tuple[Estimate, float]:
    """(k = g_CH2 g_probe / g_CH1 measured, the half-width the specifications allow for it)."""
    total_ohm = points["calibration_load_ohm"] + points["shunt_ohm"]
    ratio = 8.0 * points["power_fit_w"] * total_ohm / points["piezo_voltage_vpp"] ** 2
    u_rel = np.hypot(np.hypot(points["power_fit_w_u"] / points["power_fit_w"],
                              2.0 * points["piezo_voltage_vpp_u"] / points["piezo_voltage_vpp"]),
                     np.hypot(points["calibration_load_ohm"] * points["calibration_load_tolerance_rel"],
                              points["shunt_ohm"] * SHUNT_TOLERANCE_REL) / total_ohm / math.sqrt(3.0))
    measured = _mean(ratio.to_numpy(), (ratio * u_rel).to_numpy())
    allowed = 2.0 * SPECIFICATIONS["scope_gain"].half_width + SPECIFICATIONS["current_probe_gain"].half_width
    return measured, allowed


def deskew_of_run(run: RunData) -> Deskew | None:
    """The delay and gain ratio a run's calibration steps measured, or None when it has none."""
    rows = run.protocol(PROTOCOL)
    if rows.empty:
        return None
    return calibration_from_points(reduced_points(run, rows[rows["waveform_file"].notna()]))


def calibration_from_points(points: pd.DataFrame) -> Deskew:
    """Delay and gain ratio from reduced calibration records (with the protocol's columns)."""
    ratio, _ = current_gain_ratio(points)
    return replace(deskew_from_points(points), gain_ratio=ratio.value, gain_ratio_u=ratio.std_uncertainty)
