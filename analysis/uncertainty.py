"""GUM uncertainty budgets of the stored values: what limits each number, term by term.

A budget lists the standard uncertainties (k = 1) of one value: Type A from the record's
noise (the reduction's fit covariance, `analysis.waveforms`), Type B from the
instruments' specifications (`plates.specifications`, rectangular) and from how the
frequency was set. Terms are independent and add in quadrature (GUM 5.1.2, sensitivity
coefficients evaluated at the measured point); the expanded uncertainty is k times the
combined one, k for 95 % under every error model the budget claims (`analysis.budgets`); the
dominant term is the largest.

What a stored point's value means: the reading the bench would give with ideal
instruments at the point's recorded setting (generator frequency and voltage). The
generator's own frequency error therefore enters through the slope of the resonance
curve at that setting; how well the resonance search put the setting on the resonance
enters the quantities defined at resonance (the resonance frequency, Q, tan theta').

A deskew calibration (`protocols.calibration`) replaces the CH2 delay term by the
calibration's own uncertainty and corrects the power by the delay it measured. Gain
errors stay: a resistive load compares CH2 with CH1, and without a voltage reference the
product of the gains that the power carries is not lowered (see `Deskew`).

Q and tan theta' propagate the budgets' terms (a shared Type B input such as CH1's gain once,
so it cancels where it divides out) and the tolerances of the geometry
and material constants through the paper's Eqs. 25 and 27 with the `uncertainties`
package (linear propagation, numerical derivatives of `analysis.model`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd
import uncertainties

from squeezebench.analysis import dielectric, model, plate_warming, provenance, resonance_drift
from squeezebench.analysis.budgets import P95_FACTOR, Budget, Term
from squeezebench.analysis.calibration import Deskew, deskew_of_run, gain_weight
from squeezebench.analysis.resonance_searches import (PEAK_FIT_SHARE, SEARCH_STOP_SPREAD, SearchSetup,
                                                      mechanical_q_from_sweep, peak_of_readings, reading_scatter_rel,
                                                      search_setups)
from squeezebench.analysis.rundata import RunData
from squeezebench.plates.specifications import SPECIFICATIONS, VOLTAGE_PROBE_POLE_HZ, sheet_thickness_tolerance
from squeezebench.analysis.tables import reduced_points, resonance_search_points, with_scope_fallback

def _spec_term(name: str, key: str, sensitivity: float) -> Term:
    spec = SPECIFICATIONS[key]
    return Term(name, "B", abs(sensitivity) * spec.std_uncertainty, spec.source)


def _noise(u: float) -> Term:
    return Term("noise (record fit)", "A", float(u), "fit covariance of the stored record")


# -- the stored point's values -----------------------------------------------------------------
def delay_std_uncertainty_s() -> float:
    """CH2 delay against CH1 before any deskew, as the budgets carry it: a bias bound, not a
    zero-mean spread. The current probe lags by a delay of known sign up to
    `current_probe_lag` (beyond its +-10 ns specification when its cable is long), and the
    scope's skew adds up to its limit: |tau| <= that sum, uncorrected. Stored as the standard
    uncertainty whose 1.96-fold is the bound (u = bound / 1.96) and budgeted as a bias bound
    (`delay_term`, `budgets.Term.bias`): U holds the value at any delay within the bound, of
    either sign, 95 % of the time whatever the rest (the former +-10 ns rectangle about zero
    missed a 17 ns lag at the Fig. 2c stress point, and the bound in quadrature held a delay
    at the bound, with the rest's errors, about half the time)."""
    bound_s = SPECIFICATIONS["current_probe_lag"].half_width + SPECIFICATIONS["scope_skew"].half_width
    return bound_s / P95_FACTOR


def delay_term(sensitivity: float) -> Term:
    """The uncorrected CH2 delay's bias bound in a budget, `sensitivity` per second."""
    return Term("CH2 delay vs CH1 (skew, TCP202)", "B", abs(sensitivity) * delay_std_uncertainty_s(), DELAY_SOURCE,
                bias=True)


#: Where the uncorrected CH2 delay's bound comes from.
DELAY_SOURCE = ("bias bound (k u = bound): " + SPECIFICATIONS["current_probe_lag"].source + "; "
                + SPECIFICATIONS["scope_skew"].source)


def compensation_phase_per_mismatch(frequency_hz, deskew: Deskew | None = None):
    """CH1's phase lead (rad) per unit of the voltage probe's compensation mismatch d at
    `frequency_hz` (numbers or arrays): f_pole / f, the small-mismatch form of
    `specifications.compensation_phase_rad`. A deskew at f_cal took that phase for part of
    a delay and removes w times phase(f_cal) / w_cal; the residue is
    f_pole / f (1 - (f / f_cal)^2), nothing at f_cal itself. Signed: two points' residues
    come from the same d."""
    per_mismatch = VOLTAGE_PROBE_POLE_HZ / np.asarray(frequency_hz, dtype=float)
    if deskew is not None and deskew.frequency_hz:
        per_mismatch = per_mismatch * (1.0 - (np.asarray(frequency_hz, dtype=float) / deskew.frequency_hz) ** 2)
    return per_mismatch


def compensation_term(power_per_mismatch: float, deskew: Deskew | None) -> Term:
    """The voltage probe's compensation in a power's budget: a CH1 lead phi moves the mean
    power by -Q_r phi (P' = P cos phi - Q_r sin phi), so `power_per_mismatch` is |Q_r| times
    `compensation_phase_per_mismatch` (or a slope's mean of it)."""
    spec = SPECIFICATIONS["voltage_probe_compensation"]
    after = "; a deskew removed it at its own frequency, the residue is budgeted" if deskew is not None else ""
    return Term("voltage probe compensation (CH1 phase)", "B", abs(power_per_mismatch) * spec.std_uncertainty,
                spec.source + after)


#: Without a deskew run, a point's power needs one when the CH2 delay makes more than this
#: share of its variance and its U is beyond DELAY_FLAG_U_REL of the power.
DELAY_FLAG_SHARE = 0.5
DELAY_FLAG_U_REL = 0.05


def needs_deskew(points: pd.DataFrame) -> pd.DataFrame:
    """The budgeted points (`run_uncertainties`, no deskew applied) whose U is mostly the
    CH2 delay's bias bound: its term w |Q'| u(tau) is most of the variance of a U above
    DELAY_FLAG_U_REL. The bound holds the current probe's lag, but a deskew calibration run
    measures it and shrinks such a U to the rest of its budget."""
    if "power_w_U" not in points or "reactive_power_var" not in points:
        return points.iloc[0:0]
    variance = points["power_w_u_combined"] ** 2
    delay_u = 2 * np.pi * points["frequency_hz"] * points["reactive_power_var"].abs() * delay_std_uncertainty_s()
    return points[(delay_u**2 > DELAY_FLAG_SHARE * variance)
                  & (points["power_w_U"] > DELAY_FLAG_U_REL * points["power_w"].abs())]


def generator_sensitivities(slope_per_hz, frequency_hz, dielectric_share, dielectric_voltage_exponent,
                            shunt_share=0.0, cross_share=0.0, cross_slope_per_hz=0.0):
    """(d ln P / d e, d ln P / d a) of an electrical power read at the generator's frequency
    f (1 + e) and amplitude V (1 + a), numbers or arrays. P = M + D + S_C + S_x: the motional
    part M = R v^2 / 2 (with the shunt's R_s |I_m|^2 / 2) follows the velocity, v ~ V along the
    resonance (`detuning_slope_per_hz`: s = d ln v / d f, signed);
    the piezos' dielectric loss D = w C0 V0^2 tan(delta) / 2 goes as f V^m, m = 2 + n for a
    tan(delta) ~ E^n (`analysis.dielectric`, `plates.damping.field_tan_delta`), and not with
    the resonance; nor the shunt's loss from the capacitive current, S_C = R_s (w C0 V0)^2 / 2,
    as f^2 V^2; the cross term S_x = -2 R_s w C0 x P_m as V^2 and, besides the resonance's
    2 s f, as w (its share d_x = S_x / P) and through x = (f - f0) / h, by its slope
    c_x = (dS_x / dx) / (P h) per hertz (`dielectric.shunt_cross_slope_w`; on the slope
    c_x f = d_x f / (f - f0), at the peak, where S_x is 0, not 0). The resonance's part and
    that slope are the power's d ln P / d f along the resonance, `resonance_power_per_hz`.
    With the shares d = D / P, d_C = S_C / P:
        d ln P / d e = f ((1 - d - d_C) 2 s + c_x) + d + 2 d_C + d_x,     d ln P / d a = 2 (1 - d) + m d;
    d = d_C = d_x = c_x = 0 (the whole power on the resonance) gives 2 s f and 2, the form
    without them."""
    resonant = 1.0 - dielectric_share - shunt_share
    return (frequency_hz * resonance_power_per_hz(slope_per_hz, resonant, cross_slope_per_hz) + dielectric_share
            + 2.0 * shunt_share + cross_share,
            2.0 * (1.0 - dielectric_share) + dielectric_voltage_exponent * dielectric_share)


def resonance_power_per_hz(slope_per_hz, resonant_share, cross_slope_per_hz):
    """d ln P / d f of a power along its resonance (numbers or arrays; signed: a resonance
    moved by delta moves ln P read at a setting by minus this times delta, at first order):
    the resonant part's 2 s (its share 1 - d - d_C, s = d ln v / d f) and the series shunt's
    cross term's slope c_x = (dS_x / dx) / (P h) (`generator_sensitivities`), which is not 0
    at the peak, where s and S_x are. The generator's frequency error and the resonance's
    drift move a power through it alike (`_resonance_drift`, `_power_drift_terms`)."""
    return resonant_share * 2.0 * np.asarray(slope_per_hz, dtype=float) + cross_slope_per_hz


def _dielectric_share(points: pd.DataFrame | dict) -> tuple:
    """Each point's dielectric share of its power and its voltage exponent
    (`dielectric.with_dielectric_power`), 0 and 2 where it has no estimate, and whether every
    point has one."""
    power = np.asarray(points["power_w"], dtype=float)
    loss = np.asarray(points.get("dielectric_power_w", np.full_like(power, np.nan)), dtype=float)
    exponent = np.asarray(points.get("dielectric_voltage_exponent", np.full_like(power, 2.0)), dtype=float)
    described = bool(np.all(np.isfinite(loss)))
    return (np.where(np.isfinite(loss), loss / power, 0.0), np.where(np.isfinite(exponent), exponent, 2.0),
            described)


def _shunt_shares(points: pd.DataFrame | dict, inverse_half_width_per_hz=0.0) -> dict[str, np.ndarray]:
    """Each point's shunt shares as `generator_sensitivities` takes them (its keywords): the
    capacitive current's loss and the cross term over the power, and that term's slope per
    hertz at the points' 1 / h (`_cross_slope_share`); 0 where the run stores no shunt (the
    whole shunt loss on the resonance)."""
    power = np.asarray(points["power_w"], dtype=float)
    nothing = np.full_like(power, np.nan)
    values = {column: np.asarray(points.get(column, nothing), dtype=float) for column in dielectric.SHUNT_COLUMNS}
    known = np.isfinite(values["shunt_capacitive_power_w"])
    return {"shunt_share": np.where(known, values["shunt_capacitive_power_w"] / power, 0.0),
            "cross_share": np.where(known, values["shunt_cross_power_w"] / power, 0.0),
            "cross_slope_per_hz": _cross_slope_share(points) * inverse_half_width_per_hz}


def _generator_frequency_term(sensitivity: float, described: bool) -> Term:
    """The generator's frequency error in a budget; where a point on the slope has no
    estimate of its dielectric share, the source says the conservative reading was taken."""
    term = _spec_term("generator frequency", "generator_frequency", sensitivity)
    return term if described or sensitivity == 0 else replace(term, source=f"{term.source}; {dielectric.NOT_DESCRIBED}")


def power_ratio_std_uncertainty(numerator: pd.DataFrame, denominator: pd.DataFrame) -> float:
    """`power_ratio_budget`'s standard uncertainty."""
    return power_ratio_budget(numerator, denominator).std_uncertainty


def power_ratio_budget(numerator: pd.DataFrame, denominator: pd.DataFrame) -> Budget:
    """Budget of R = mean P_t / mean P_0, two powers of one plate on one bench
    (Fig. 2's Pt/P0), from their reduced points.

    The gains (CH1, CH2, current probe, and a deskew's gain correction) multiply both
    powers alike and cancel. The CH2 delay does not: a delay tau adds Q' w tau to each
    power, so dR/R = (w_t Q'_t / P_t - w_0 Q'_0 / P_0) tau, small at resonance (Q' ~ 0)
    and not at a detuned point. Nor does the generator's frequency error e: P_0 sits on the
    resonance's flat top, P_t on its slope, and each power moves by its own
    `generator_sensitivities`, S_e = f ((1 - d - d_C) 2 s + c_x) + d + 2 d_C + d_x with d its
    dielectric share and d_C, d_x the series shunt's loss from the piezos' capacitive current
    and its cross term with the motional one, c_x that term's slope per hertz (`analysis.dielectric`:
    larger at P_t, read at a higher voltage; 0 without an estimate, the conservative reading),
    at P0 too, where S_x is 0 but its slope is not (its 1 / h from P_t's, `_top_curvature`):
    dR/R = (S_e,t - S_e,0) e (1.2 % at r = 0.8 for 20 ppm with no shares).
    The generator's amplitude error a cancels in the motional parts (both go as V^2) but not
    in the dielectric ones (V^(2+n)): dR/R = (S_a,t - S_a,0) a = n (d_t - d_0) a. Nor does the
    resonance's drift: a point read when the plate's resonance had moved by delta from where
    it was mounted reads the curve displaced, a frequency error -delta / f on the part that
    follows it. Its sign is known (the plate warms under its drive, its resonance falls) and
    the run estimates it (`analysis.resonance_drift`: the plate's warming under the run's
    stored powers, scaled by the run's dated readings of its resonance within the heating
    tolerances), so R is corrected for the estimate (GUM 3.2.4; `_resonance_drift`: the part
    of each power that follows the resonance by the Lorentzian's displacement
    (`lorentzian_power_change`), Pt on the slope at its velocity ratio r, about
    -(1 - d_t) 2 s_t delta_t, P0 set on the re-centred resonance and on the flat top by
    (offset / h)^2, 1 / h^2 = s_t^2 / (r^2 (1 - r^2))) and
    the estimate's u is a normal term; where no scene gives the plate, the readings alone
    bound it and that bound is a bias bound (`drift_terms`). The value is still the plate as
    mounted at the recorded settings; the correction brings the reading to it. The noise of
    each mean is its own (Type A):
    u(R)^2 / R^2 = u(P_t)^2 / P_t^2 + u(P_0)^2 / P_0^2 + (w_t Q'_t / P_t - w_0 Q'_0 / P_0)^2 u(tau)^2
                   + (S_e,t - S_e,0)^2 u(e)^2 + (S_a,t - S_a,0)^2 u(a)^2 + u(drift)^2 / R^2,
    with u(tau) the deskew's when the points were corrected, else the specified bound's.
    Points without `resonance_drift.DRIFT_COLUMNS` get them from their own P0 rows (no search:
    a single reading is the Type B rate). NaN terms when a point has no stored record to reduce."""
    applied = Deskew.applied_in(numerator)
    slopes = _slopes_of(numerator, denominator)
    curvature = _top_curvature(slopes.loc[numerator.index].to_numpy(float), _ratios(numerator))
    if not all(column in points for points in (numerator, denominator) for column in resonance_drift.DRIFT_COLUMNS):
        both = resonance_drift.with_resonance_drift(pd.concat([numerator, denominator]))
        numerator, denominator = both.iloc[:len(numerator)], both.iloc[len(numerator):]
    parts, described = [], True
    for points in (numerator, denominator):
        power = float(points["power_w"].mean())
        noise = float(np.sqrt(np.sum(points["power_w_u"] ** 2))) / len(points)
        phase = float((2.0 * math.pi * points["frequency_hz"] * points["reactive_power_var"]).mean()) / power
        lead = float((points["reactive_power_var"]
                      * compensation_phase_per_mismatch(points["frequency_hz"], applied)).mean()) / power
        setting_hz = points["generator_frequency_hz"] if "generator_frequency_hz" in points else points["frequency_hz"]
        share, exponent, known = _dielectric_share(points)
        slope = slopes.loc[points.index].to_numpy(float)
        inverse_h = _inverse_half_width_per_hz(slope, _ratios(points), curvature)
        to_frequency, to_amplitude = generator_sensitivities(slope, setting_hz.to_numpy(float), share, exponent,
                                                             **_shunt_shares(points, inverse_h))
        described &= known or not np.any(slopes.loc[points.index].to_numpy(float))
        parts.append((power, noise / power, phase, lead, float(np.mean(to_frequency)), float(np.mean(to_amplitude))))
    (p_t, noise_t, phase_t, lead_t, pull_t, gain_t), (p_0, noise_0, phase_0, lead_0, pull_0, gain_0) = parts
    correction, drift_rel, drift_bound_rel = _resonance_drift(numerator, denominator, slopes, curvature)
    ratio = p_t / p_0 * correction
    delay = (delay_term(ratio * (phase_t - phase_0)) if applied is None else
             Term("CH2 delay after deskew", "B", abs(ratio * (phase_t - phase_0)) * applied.std_uncertainty_s,
                  applied.source))
    return Budget("power_ratio", "1", ratio, (
        Term("noise of P_t (record fits)", "A", abs(ratio) * noise_t, "fit covariance of the stored records"),
        Term("noise of P_0 (record fits)", "A", abs(ratio) * noise_0, "fit covariance of the stored records"),
        delay,
        _spec_term("voltage probe compensation (CH1 phase)", "voltage_probe_compensation", ratio * (lead_t - lead_0)),
        _generator_frequency_term(ratio * (pull_t - pull_0), described),
        _spec_term("generator amplitude", "generator_amplitude", ratio * (gain_t - gain_0)),
        *drift_terms(ratio * drift_bound_rel, ratio * drift_rel,
                     pd.concat([numerator, denominator])["resonance_drift_source"], always=True)))


def _resonance_drift(numerator: pd.DataFrame, denominator: pd.DataFrame, slopes: pd.Series,
                     curvature: float) -> tuple[float, float, float]:
    """The resonance's drift in R = P_t / P_0 (`power_ratio_budget`) from each point's
    estimate e, its u and a bias bound B (`analysis.resonance_drift.DRIFT_COLUMNS`): the
    factor that corrects R for the estimate (GUM 3.2.4), and the relative u and bias bound it
    leaves. A point read when the resonance had moved by e reads the curve displaced by e:
    its part that follows the resonance, the share 1 - d - d_C of its power, by
    `lorentzian_power_change` at its offset x from the resonance as read (P_t on the slope:
    x from its velocity ratio r on the side its slope s says, 1 / h = |s| / sqrt(r^2 (1 - r^2));
    a P0, whose e is its setting's offset from the mounted plate's resonance: set on the
    re-centred peak, x = 0, with P_t's 1 / h^2 = s_t^2 / (r^2 (1 - r^2)), `curvature`:
    `_top_curvature`), and the shunt's cross term S_x = c x P_m by its first order, -c e / h
    of the power at P_t and at P0 alike (`_cross_slope_share`: S_x is 0 on the peak, its
    slope in x is not; moved at P_t alone it left R high by 2 R_s w C0 e_0 / h). R read =
    R (1 + d_t) / (1 + d_0), so the stored value is R read (1 + d_0) / (1 + d_t). u and B at
    first order: |D| u on the slope (D = 2 (1 - d - d_C) s + c / h, `resonance_power_per_hz`),
    sqrt(4 e^2 u^2 + 2 u^4) / h^2 on the top (the variance of a squared normal) with |c / h| u
    beside it; B: |D| B and (B^2 + 2 |e| B) / h^2. A phase's points (one drift, the same plate)
    average: their terms add linearly."""
    shifts, u_rel, bound_rel = [], 0.0, 0.0
    for points in (numerator, denominator):
        slope = slopes.loc[points.index].to_numpy(float)
        drift_hz, drift_u_hz, drift_bound_hz = (points[c].to_numpy(float) for c in resonance_drift.DRIFT_COLUMNS)
        top = np.where(slope == 0, curvature, 0.0)
        ratio = _ratios(points)
        offset_x = np.where(slope == 0, 0.0, -np.sign(slope) * np.sqrt(1.0 - ratio**2) / ratio)
        inverse_h = _inverse_half_width_per_hz(slope, ratio, curvature)
        # the shunt's cross term S_x = c x P_m at first order: a drift moves x by e / h, P0's too
        resonant, cross_per_hz = _resonant_share(points), _cross_slope_share(points) * inverse_h
        per_hz = resonance_power_per_hz(slope, resonant, cross_per_hz)
        shifts.append(float(np.mean(resonant * lorentzian_power_change(offset_x, drift_hz * inverse_h)
                                    - cross_per_hz * drift_hz)))
        u_rel = math.hypot(u_rel, float(np.mean(np.abs(per_hz) * drift_u_hz
                                                + top * np.sqrt(4 * drift_hz**2 * drift_u_hz**2 + 2 * drift_u_hz**4))))
        bound_rel += float(np.mean(np.abs(per_hz) * drift_bound_hz
                                   + top * (drift_bound_hz**2 + 2 * np.abs(drift_hz) * drift_bound_hz)))
    return (1.0 + shifts[1]) / (1.0 + shifts[0]), u_rel, bound_rel


def _ratios(points: pd.DataFrame | dict) -> np.ndarray:
    """Each point's target velocity ratio r (NaN where it has none)."""
    return np.asarray(points.get("target_velocity_ratio", np.full(len(points["power_w"]), np.nan)), dtype=float)


def _top_curvature(slope_per_hz: np.ndarray, ratio: np.ndarray) -> float:
    """1 / h^2 of the resonance from points on its slope, the mean of s^2 / (r^2 (1 - r^2)) (a
    Lorentzian's velocity ratio r at x = (f - f0) / h, r^2 = 1 / (1 + x^2), has slope s = d ln
    v / d f = -x / ((1 + x^2) h)) over those with 0 < r < 1; 0 where none is."""
    inside = (ratio > 0) & (ratio < 1) & (slope_per_hz != 0)
    return float(np.mean(slope_per_hz[inside] ** 2 / (ratio[inside] ** 2 * (1 - ratio[inside] ** 2)))) \
        if inside.any() else 0.0


def _inverse_half_width_per_hz(slope_per_hz: np.ndarray, ratio: np.ndarray, curvature: float) -> np.ndarray:
    """1 / h at each point: on the slope its own, |s| / sqrt(r^2 (1 - r^2)) (`_top_curvature`);
    on the top (s = 0, where `detuning_slope_per_hz` puts every point not at 0 < r < 1) the
    slope points' `curvature`'s square root."""
    on_slope = slope_per_hz != 0
    spread = np.sqrt(np.where(on_slope, ratio**2 * (1.0 - ratio**2), 1.0))
    return np.where(on_slope, np.abs(slope_per_hz) / spread, math.sqrt(curvature))


def _cross_slope_share(points: pd.DataFrame | dict) -> np.ndarray:
    """Each point's slope of the shunt's cross term in the detuning x over its power,
    (dS_x / dx) / P = -2 R_s w C0 P_m / P (`dielectric.shunt_cross_power_w`; 0 where the run
    stores no shunt). It is the same on the slope and at the peak, where S_x itself is 0."""
    power = np.asarray(points["power_w"], dtype=float)
    slope_w = np.asarray(points.get("shunt_cross_slope_w", np.full_like(power, np.nan)), dtype=float)
    return np.where(np.isfinite(slope_w), slope_w / power, 0.0)


def lorentzian_power_change(offset_x, shift_x):
    """P_read / P_mounted - 1 of the power that follows a resonance (numbers or arrays),
    read at x = 2 Q (f - f_r) / f_r from the resonance f_r as it was then, when the mounted
    plate's lay `shift_x` half-widths h = f_r / (2 Q) below it (the drift delta / h, signed:
    negative where the resonance fell). The motional branch's power at a constant voltage
    goes as |v|^2 = v_0^2 / (1 + x^2) (a series RLC near its resonance, Eq. 1's v ~ V), so
    at the same setting the mounted plate reads at x + delta / h:
        P_read / P_mounted = (1 + (x + delta / h)^2) / (1 + x^2).
    Its first order, -2 x / (1 + x^2) delta / h = 2 s delta (s = d ln v / d f), was the
    correction's; taken as a relative change of P (R (1 + d_t) / (1 + d_0)) it over-corrected
    P_t by nearly d_t^2 (a 6 % shift at r = 0.8: R 0.28 % high), so Fig. 2's ratios read
    high on every plate given the simulated plate's own drift. At x = 0 (P0 on the re-centred
    peak) it is (delta / h)^2, the flat top's term."""
    offset_x = np.asarray(offset_x, dtype=float)
    return ((1.0 + (offset_x + shift_x) ** 2) / (1.0 + offset_x**2)) - 1.0


#: The name of the resonance's drift in a budget.
DRIFT_TERM = "resonance drift (plate warming, room)"
#: Its estimate's u where the estimate itself is carried beside it as a bias (a stored point's value, not corrected).
DRIFT_U_TERM = "resonance drift's estimate (its u)"


def drift_terms(bias_bound: float, std_uncertainty: float, sources, always: bool = False) -> tuple[Term, ...]:
    """The resonance's drift in a budget: a bias bound where the value carries drift it was
    not corrected for (`budgets.Term.bias`: the warming's estimate a stored point keeps, or
    the readings' bound where the run gives no estimate; U holds any drift within it, not a
    spread about zero in quadrature), and the estimate's standard uncertainty as a normal
    term (`analysis.resonance_drift`: the fit's, the time constants' and the room's). Type A
    when every value came from the run's own readings. Named DRIFT_TERM, the u DRIFT_U_TERM
    beside a bias; `always`: a zero term where the run shows no drift."""
    sources = list(dict.fromkeys(sources))
    kind = "A" if all(s.startswith("Type A") for s in sources) else "B"
    terms = []
    if bias_bound:
        terms.append(Term(DRIFT_TERM, kind, abs(bias_bound) / P95_FACTOR,
                          "bias bound (k u = bound): " + "; ".join(sources), bias=True))
    if std_uncertainty or (always and not terms):
        terms.append(Term(DRIFT_U_TERM if terms else DRIFT_TERM, kind, abs(std_uncertainty),
                          "estimate's u, normal: " + "; ".join(sources), rectangular=False))
    return tuple(terms)


def _power_per_resonance_hz(points: pd.DataFrame | dict, slope, inverse_half_width_per_hz) -> np.ndarray:
    """Each point's `resonance_power_per_hz`: its resonant share (`_resonant_share`: the
    dielectric share d and the shunt's capacitive one d_C do not follow the resonance) and
    its shunt's cross slope at its 1 / h (`_cross_slope_share`)."""
    return resonance_power_per_hz(slope, _resonant_share(points),
                                  _cross_slope_share(points) * inverse_half_width_per_hz)


def _resonant_share(points: pd.DataFrame | dict) -> np.ndarray:
    """Each point's share of its power that follows the resonance, 1 - d - d_C (the
    dielectric loss and the shunt's loss from the capacitive current do not)."""
    share, _, _ = _dielectric_share(points)
    return 1.0 - share - _shunt_shares(points)["shunt_share"]


def _point_drift_terms(point: dict, value: float, per_hz: float) -> tuple[Term, ...]:
    """A stored point's drift terms (none where it carries no estimate): `per_hz` |d ln / d f0|.
    A stored value is not corrected for the drift: its estimate is a bias (`drift_terms`)."""
    drift_hz = point.get("resonance_drift_hz")
    if not isinstance(drift_hz, (int, float)) or not math.isfinite(drift_hz):
        return ()
    scale = abs(value * per_hz)
    return drift_terms(scale * (abs(drift_hz) + point.get("resonance_drift_bound_hz", 0.0)),
                       scale * point.get("resonance_drift_u_hz", 0.0), [point["resonance_drift_source"]])


def _slopes_of(numerator: pd.DataFrame, denominator: pd.DataFrame) -> pd.Series:
    """`detuning_slope_per_hz` of both sets of points (their own column if they carry one),
    by index: the detuned points' slopes need the resonance points of their level."""
    both = pd.concat([numerator, denominator])
    both = both[~both.index.duplicated()]
    if "detuning_slope_per_hz" in both:
        return both["detuning_slope_per_hz"].fillna(0.0)
    return detuning_slope_per_hz(both)


def power_budget(point: dict, deskew: Deskew | None = None) -> Budget:
    """Mean power P = <v i>: P ~ g_vprobe g1 g2 g_probe, P' = P - Q_r w tau for a CH2 delay tau."""
    value = float(point["power_w"])
    reactive = abs(float(point["reactive_power_var"]))
    omega_q = 2.0 * math.pi * float(point["frequency_hz"]) * reactive
    if deskew is None:
        delay = delay_term(omega_q)
    else:
        delay = Term("CH2 delay after deskew", "B", omega_q * deskew.std_uncertainty_s, deskew.source)
    if deskew is None or deskew.gain_ratio is None:
        gains = (_spec_term("voltage probe attenuation", "voltage_probe_attenuation", value),
                 _spec_term("CH1 gain", "scope_gain", value), _spec_term("CH2 gain", "scope_gain", value),
                 _spec_term("current probe gain", "current_probe_gain", value))
    else:   # P k^-alpha carries (g_vprobe g1)^(1+alpha) (g2 g_probe)^(1-alpha) and k's own uncertainty
        alpha = gain_weight()
        current_u = math.hypot(SPECIFICATIONS["scope_gain"].std_uncertainty,
                               SPECIFICATIONS["current_probe_gain"].std_uncertainty)
        gains = (_spec_term("voltage probe attenuation (gain-checked)", "voltage_probe_attenuation",
                            (1.0 + alpha) * value),
                 _spec_term("CH1 gain (gain-checked)", "scope_gain", (1.0 + alpha) * value),
                 Term("current path gain (gain-checked)", "B", (1.0 - alpha) * abs(value) * current_u,
                      SPECIFICATIONS["current_probe_gain"].source + "; " + SPECIFICATIONS["scope_gain"].source),
                 Term("gain check", "A", alpha * abs(value) * deskew.gain_ratio_u / deskew.gain_ratio, deskew.source))
    return Budget("power_w", "W", value, (
        _noise(point["power_w_u"]), *gains, delay,
        compensation_term(reactive * float(compensation_phase_per_mismatch(point["frequency_hz"], deskew)), deskew),
        _power_generator_term(point), *_power_drift_terms(point)))


def _power_drift_terms(point: dict) -> tuple[Term, ...]:
    """A stored power's resonance-drift term (`_point_drift_terms`)."""
    one = {key: [point.get(key, math.nan)] for key in ("power_w", *_SHARE_COLUMNS)}
    per_hz = abs(float(_power_per_resonance_hz(one, [point.get("detuning_slope_per_hz", 0.0)],
                                               _stored_inverse_half_width(point))[0]))
    return _point_drift_terms(point, float(point["power_w"]), per_hz)


def _stored_inverse_half_width(point: dict) -> float:
    """A stored point's 1 / h (`detuning_inverse_half_width_per_hz`; 0 where it has none)."""
    value = point.get("detuning_inverse_half_width_per_hz", 0.0)
    return float(value) if isinstance(value, (int, float)) and math.isfinite(value) else 0.0


#: The columns a point's shares are read from (`analysis.dielectric`).
_SHARE_COLUMNS = ("dielectric_power_w", "dielectric_voltage_exponent", *dielectric.SHUNT_COLUMNS)


def _power_generator_term(point: dict) -> Term:
    """A stored power's generator-frequency term: `generator_sensitivities` at the point's
    slope and dielectric share (the whole power on the resonance without an estimate)."""
    one = {key: [point.get(key, math.nan)] for key in ("power_w", *_SHARE_COLUMNS)}
    share, exponent, described = _dielectric_share(one)
    slope = point.get("detuning_slope_per_hz", 0.0)
    shares = _shunt_shares(one, _stored_inverse_half_width(point))
    to_frequency, _ = generator_sensitivities(slope, float(point["frequency_hz"]), float(share[0]), float(exponent[0]),
                                              **{k: float(v[0]) for k, v in shares.items()})
    return _generator_frequency_term(float(point["power_w"]) * to_frequency, described or not slope)


def velocity_budget(point: dict) -> Budget:
    value = float(point["velocity_pp_mps"])
    return Budget("velocity_pp_mps", "m/s", value, (
        _noise(point["velocity_pp_mps_u"]),
        _spec_term("CH3 gain", "scope_gain", value),
        _spec_term("vibrometer decoder scale", "vibrometer_scale", value),
        _spec_term("generator frequency", "generator_frequency",
                   value * point.get("detuning_slope_per_hz", 0.0) * float(point["frequency_hz"])),
        *_point_drift_terms(point, value, abs(point.get("detuning_slope_per_hz", 0.0)))))


def voltage_budget(point: dict) -> Budget:
    value = float(point["piezo_voltage_vpp"])
    return Budget("piezo_voltage_vpp", "V", value, (
        _noise(point["piezo_voltage_vpp_u"]), _spec_term("voltage probe attenuation", "voltage_probe_attenuation", value),
        _spec_term("CH1 gain", "scope_gain", value)))


def frequency_budget(point: dict) -> Budget:
    """The drive frequency as the scope measures it (fit on CH1, scope time base)."""
    value = float(point["frequency_hz"])
    return Budget("frequency_hz", "Hz", value, (
        _noise(point["frequency_hz_u"]),
        _spec_term("scope time base", "scope_timebase", value)))


def search_budgets(rows: pd.DataFrame, setups: dict[str, SearchSetup], history: pd.DataFrame | None = None,
                   scenes: dict[str, dict] | None = None) -> list[tuple[str, str, Budget]]:
    """(run, step, budget) of the resonance frequency of every search in `rows`
    (resonance_search rows, reduced); with `history` (the runs' stored readings, every
    protocol's) and `scenes` (their scene copies), the value corrected for the plate's
    warming when the search read it, with its term (`plate_warming`).

    The search stores where the driven mode's 1/v^2 fitted to its readings on the peak's top
    is least (`resonance_searches.peak_of_readings`): its Type A term is that fit's, from the
    readings' own residuals (their noise, the ADC's step, and what of the peak's shape the
    closed form misses).
    A search stored at one of its readings' frequencies (no top to fit, or a run from before
    the fit) stored its best reading: near the top v/v0 = 1 - x^2/2
    (x = 2 Q (f - f0) / f0, Q from the sweep), so readings that scatter by s (relative,
    `reading_scatter_rel`) stop the golden section at |x| ~ sqrt(s): normal, standard
    deviation SEARCH_STOP_SPREAD sqrt(s) of the half-width f0 / (2 Q), and the final
    bracket holds it. The generator's error moves the setting the search finds by -e f0.
    A plate warmer than at rest reads a resonance lower by |alpha| f dT, where a previous step
    drove the plate shortly before (Table 4's third configuration) and, less, from the search's
    own readings on the peak: the stored value is corrected by the warming estimated at the
    heating constants' nominal values at each of its readings, the vertex fitted again to the
    readings referred to the plate at rest, u from their tolerances (`plate_warming`); and the room's
    drift since the run started moves it by up to f |alpha| of the room's (a rectangle,
    `plate_warming.search_room_term`): a search late in a run reads a plate the room has
    moved.
    """
    budgets = []
    if rows.empty:   # a run that searched nothing stores none of the columns read below
        return budgets
    rows = with_scope_fallback(rows).reset_index(drop=True)   # the sweep kept the scope's velocities only
    # each step's rows by position, read as arrays and dicts: a frame per step (and per row)
    # was most of the budgets' time on a run of many short searches
    steps: dict[tuple[str, str], list[int]] = {}
    for position, key in enumerate(zip(rows["run_name"], rows["step_id"])):
        steps.setdefault(key, []).append(position)
    records = rows.to_dict("records")
    is_sweep = rows["sweep"].astype(bool).to_numpy()
    setting_hz = rows["generator_frequency_hz"].to_numpy(float, na_value=np.nan)
    velocity = rows["velocity_pp_mps"].to_numpy(float, na_value=np.nan)
    time_s = rows["bench_time_s"].to_numpy(float, na_value=np.nan) if "bench_time_s" in rows else None
    scene_files = provenance.scene_files(rows) if history is not None else None
    for (run_name, step_id), positions in steps.items():
        setup = setups.get(run_name)
        in_sweep = [p for p in positions if is_sweep[p]]
        for position in (p for p in positions if not is_sweep[p]):
            found = records[position]
            if setup is None or not _has_reduction(found):
                continue
            frequency_hz, correction_hz = float(found["resonance_frequency_hz"]), 0.0
            terms = [_spec_term("generator frequency", "generator_frequency", frequency_hz)]
            fit = peak_of_readings(setting_hz[in_sweep], velocity[in_sweep]) if in_sweep else None
            if fit is not None and not np.isin(frequency_hz, setting_hz[in_sweep]):
                terms.append(Term("resonance fit on the top", "A", fit.std_uncertainty_hz,
                                  f"the driven mode's 1/v^2 fitted to the readings above {PEAK_FIT_SHARE:.0%} "
                                  "of the peak (resonance_searches.peak_of_readings)"))
            else:
                terms += _best_reading_terms(found, rows.iloc[in_sweep], setup)
            if scene_files is not None and time_s is not None and in_sweep:
                run_history = history[history["run_name"] == run_name]
                read_s = plate_warming.top_readings_time_s(time_s[in_sweep], velocity[in_sweep])
                room = plate_warming.search_room_term(run_history, frequency_hz, read_s)
                warming = plate_warming.search_warming_term(
                    run_history, found["plate"], (scenes or {}).get(scene_files.iloc[position], {}), frequency_hz,
                    time_s[in_sweep], setting_hz[in_sweep], velocity[in_sweep])
                terms += [room] if room is not None else []
                if warming is not None:   # the plate as mounted, at rest: corrected for its warming (GUM 3.2.4)
                    correction_hz = warming[0]
                    terms.append(warming[1])
            budgets.append((run_name, step_id, Budget("resonance_frequency_hz", "Hz", frequency_hz + correction_hz,
                                                      tuple(terms), correction=correction_hz)))
    return budgets


def _best_reading_terms(found: dict, sweep: pd.DataFrame, setup: SearchSetup) -> list[Term]:
    """Where a search stored its best reading: the final bracket, and where the golden
    section stops on the readings' scatter (`search_budgets`)."""
    frequency_hz = float(found["resonance_frequency_hz"])
    terms = [Term("search bracket", "B", 0.5 * setup.tolerance_hz / math.sqrt(3.0),
                  "golden-section search: the final bracket's width (protocols.resonance)")]
    q = mechanical_q_from_sweep(frequency_hz, sweep) if len(sweep) else None
    if q:
        scatter = reading_scatter_rel(sweep)
        source = (f"{scatter:.1e} scatter of the readings on the top" if scatter is not None else
                  "record-fit noise of the velocity at the resonance found")
        if scatter is None:
            scatter = float(found["velocity_pp_mps_u"]) / float(found["velocity_pp_mps"])
        terms.append(Term("velocity readings on the flat top", "A",
                          frequency_hz / (2.0 * q) * SEARCH_STOP_SPREAD * math.sqrt(scatter),
                          f"where the golden section stops: {source}; Q {q:.0f} from the sweep"))
    return terms


def run_search_budgets(run: RunData) -> list[tuple[str, str, Budget]]:
    """`search_budgets` of every resonance search stored in `run`, worked out once per run
    (`RunData.search_budgets`: Tables 3 and 4 and the uncertainty section each read them all)."""
    if run.search_budgets is None:
        run.search_budgets = search_budgets(reduced_points(run, run.protocol("resonance_search")),
                                            search_setups(run), run.measurements, run.scenes)
    return list(run.search_budgets)


POINT_BUDGETS = {"power_w": power_budget, "velocity_pp_mps": velocity_budget,
                 "piezo_voltage_vpp": voltage_budget, "frequency_hz": frequency_budget}


def point_budget(quantity: str, point: dict, deskew: Deskew | None = None) -> Budget:
    """The budget of `quantity` (a key of POINT_BUDGETS) at one reduced point."""
    if quantity == "power_w":
        return power_budget(point, deskew)
    return POINT_BUDGETS[quantity](point)


def detuning_slope_per_hz(points: pd.DataFrame) -> pd.Series:
    """d ln v / d f at each point from the resonance curve of its own run and level
    (signed: negative above the resonance, where the velocity falls as f rises).

    A detuned point at velocity ratio r = v/v0 sits at x = 2 Q (f - f0)/f0 with
    r^2 = 1/(1 + x^2); the Lorentzian's slope there is -x^2/(1 + x^2)/(f - f0) =
    -(1 - r^2)/(f - f0), with f0 the run's resonance at the same velocity level. Points
    at resonance (or without a level) have slope 0 (the curve is flat at its top).
    """
    if "detuning_phase" not in points or "target_velocity_ratio" not in points:
        return pd.Series(0.0, index=points.index)
    at_resonance = points[points["detuning_phase"] == "resonance"]
    f0 = at_resonance.groupby(["run_name", "velocity_level_pp_mps"])["generator_frequency_hz"].first().to_dict()
    slope = []
    # the four columns read, not a pandas row per point: Fig. 2's budgets ask this of every point set they see
    for ratio, run_name, level, frequency_hz in zip(*(points[c] if c in points else [None] * len(points) for c in (
            "target_velocity_ratio", "run_name", "velocity_level_pp_mps", "generator_frequency_hz"))):
        offset_hz = (float(frequency_hz) - float(f0[run_name, level])
                     if isinstance(ratio, (int, float)) and 0 < ratio < 1 and (run_name, level) in f0 else 0.0)
        slope.append(-(1.0 - ratio**2) / offset_hz if offset_hz != 0 else 0.0)
    return pd.Series(slope, index=points.index, dtype=float)


def with_detuning_shape(points: pd.DataFrame) -> pd.DataFrame:
    """`points` with each one's resonance curve as its budgets take it: `detuning_slope_per_hz`
    and `detuning_inverse_half_width_per_hz`, 1 / h (`_inverse_half_width_per_hz`: a point on
    the slope its own, a reading at resonance its run and level's slope points' curvature; 0
    where its level has none, or off the resonance without a slope)."""
    slope = detuning_slope_per_hz(points)
    inverse_h = np.zeros(len(points))
    if {"detuning_phase", "run_name", "velocity_level_pp_mps"} <= set(points) and len(points):
        slopes, ratio = slope.to_numpy(float), _ratios(points)
        at_resonance = (points["detuning_phase"] == "resonance").to_numpy()
        for at in points.groupby(["run_name", "velocity_level_pp_mps"], sort=False).indices.values():
            at = at[(slopes[at] != 0) | at_resonance[at]]
            inverse_h[at] = _inverse_half_width_per_hz(slopes[at], ratio[at], _top_curvature(slopes[at], ratio[at]))
    return points.assign(detuning_slope_per_hz=slope, detuning_inverse_half_width_per_hz=inverse_h)


def with_expanded_uncertainties(points: pd.DataFrame, deskew: Deskew | None = None) -> pd.DataFrame:
    """Reduced points with, per budgeted quantity q, `q_u_combined`, `q_U` (k from the
    budget's distribution, `Budget.coverage_factor`), `q_dominant` and `q_U_coverage`;
    with a deskew the power is corrected (`Deskew.applied_to`), unless the
    points carry that correction already, whose budget is then theirs.
    Rows without a stored record (no reduction) keep NaN."""
    points, deskew = deskewed(points, deskew)
    points = points.copy()
    points = with_detuning_shape(points)
    rows = _rows(points)
    for quantity in POINT_BUDGETS:
        combined, expanded, dominant, coverage = [], [], [], []
        for row in rows:
            if not _has_reduction(row):
                combined.append(math.nan)
                expanded.append(math.nan)
                dominant.append(None)
                coverage.append(math.nan)
                continue
            budget = point_budget(quantity, row, deskew)
            combined.append(budget.std_uncertainty)
            expanded.append(budget.expanded_uncertainty)
            dominant.append(budget.dominant.name)
            coverage.append(budget.coverage_probability(budget.coverage_factor))
        points[f"{quantity}_u_combined"] = combined
        points[f"{quantity}_U"] = expanded
        points[f"{quantity}_dominant"] = dominant
        points[f"{quantity}_U_coverage"] = coverage
    return points


def deskewed(points: pd.DataFrame, deskew: Deskew | None) -> tuple[pd.DataFrame, Deskew | None]:
    """Reduced points with their power corrected by `deskew` (`Deskew.applied_to`), and the
    deskew their budgets take: the correction the points carry already if they do (they
    are then returned as they are)."""
    applied = Deskew.applied_in(points)
    if applied is not None:
        return points, applied
    if deskew is not None and "reactive_power_var" in points:
        return deskew.applied_to(points), deskew
    return points, deskew


def _rows(points: pd.DataFrame) -> list[dict]:
    """Each point as a dict of its values, made once for every quantity's budgets (a
    pandas row per point and quantity was most of the report's budget time)."""
    return points.to_dict("records")   # the values iterrows' rows give, without a Series per row


def _has_reduction(row: dict) -> bool:
    value = row.get("power_w_u")
    return isinstance(value, (int, float)) and math.isfinite(value)


def example_budgets(points: pd.DataFrame, deskew: Deskew | None = None) -> pd.DataFrame:
    """The budget of every quantity for the first stored point of each protocol: what
    the report shows. Columns: protocol, run_name, step_id, point_index, BUDGET_COLUMNS."""
    points = points.copy()
    points = with_detuning_shape(points)
    frames = []
    for protocol, rows in points.groupby("protocol", sort=False):
        stored = [row for row in _rows(rows) if _has_reduction(row)]
        if not stored:
            continue
        row = stored[0]
        for quantity in POINT_BUDGETS:
            frame = point_budget(quantity, row, deskew).as_frame()
            frame.insert(0, "point_index", row.get("point_index"))
            frame.insert(0, "step_id", row.get("step_id"))
            frame.insert(0, "run_name", row.get("run_name"))
            frame.insert(0, "protocol", protocol)
            frames.append(frame)
    return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()


@dataclass(frozen=True)
class RunUncertainties:
    """What the report shows: every stored point with its expanded uncertainties, the
    budgets of one point per protocol, and the deskew applied (None: no calibration)."""

    points: pd.DataFrame
    budgets: pd.DataFrame
    deskew: Deskew | None
    searches: pd.DataFrame   # one row per resonance search: value, expanded U, dominant term


def stored_points(run: RunData) -> tuple[pd.DataFrame | None, Deskew | None]:
    """A run's reduced stored points, its deskew calibration's own left out (None: nothing
    stored), and that calibration (None: the run has none); the powers not corrected yet
    (`deskewed` corrects them)."""
    deskew = deskew_of_run(run)
    rows = run.measurements
    if rows.empty or "waveform_file" not in rows:
        return None, deskew
    points = reduced_points(run, rows[rows["waveform_file"].notna()])
    points = dielectric.with_dielectric_power(points[points["protocol"] != "deskew_calibration"], run.scenes)
    fig2 = points["protocol"] == "detuning"
    if fig2.any():   # a warming plate moves its resonance under Fig. 2's slope (`analysis.resonance_drift`)
        detuning = run.protocol("detuning")   # the closing re-centrings store no power: read them from the rows
        closings = detuning[detuning["detuning_phase"] == "closing"] if "detuning_phase" in detuning else None
        drifts = resonance_drift.with_resonance_drift(points[fig2], resonance_search_points(run), closings,
                                                      run.scenes, search_setups(run))
        points = pd.concat([drifts, points[~fig2]]).loc[points.index]
    return points, deskew


def run_uncertainties(run: RunData) -> RunUncertainties:
    """Budgets of a run's stored points, corrected by its own deskew calibration if any."""
    points, deskew = stored_points(run)
    if points is None:
        return RunUncertainties(pd.DataFrame(), pd.DataFrame(), deskew, pd.DataFrame())
    searches = pd.DataFrame([
        {"run_name": run_name, "step_id": step_id, "resonance_frequency_hz": budget.value,
         "resonance_frequency_hz_U": budget.expanded_uncertainty, "dominant_term": budget.dominant.name}
        for run_name, step_id, budget in run_search_budgets(run)])
    return RunUncertainties(with_expanded_uncertainties(points, deskew), example_budgets(points, deskew), deskew,
                            searches)


# -- the floor: what no averaging removes --------------------------------------------------------
#: Budget terms a calibration protocol of this bench replaces by its own uncertainty.
LIFTED_BY = {"CH2 delay vs CH1 (skew, TCP202)": "deskew_calibration"}
#: What would lift the terms no protocol of this bench calibrates.
REFERENCE_FOR = {
    "current probe gain": "a current reference: a precision DMM reading the calibration resistor's voltage",
    "CH1 gain": "a voltage reference: a precision DMM on the same signal",
    "CH2 gain": "a voltage reference: a precision DMM on the same signal",
    "CH3 gain": "a voltage reference: a precision DMM on the same signal",
    "vibrometer decoder scale": "a reference vibration: a calibrated shaker under the laser",
    "CH1 gain (gain-checked)": "a voltage reference: a precision DMM reading the calibration resistor's voltage",
    "voltage probe attenuation": "a voltage reference: a precision DMM on the same signal, through the probe",
    "voltage probe attenuation (gain-checked)": "a voltage reference: a precision DMM reading the calibration "
                                                "resistor's voltage, through the probe",
    "current path gain (gain-checked)": "a current reference: a precision DMM reading the calibration "
                                        "resistor's voltage",
    "piezo_d31_c_per_n": "the piezo plates' own d31: a resonance-antiresonance measurement of a free plate "
                         "(IEEE 176)",
    "piezo_c11_pa": "the piezo plates' own stiffness: a resonance-antiresonance measurement of a free plate "
                    "(IEEE 176)",
    "resonator_thickness_m": "the plate's own thickness: a micrometer at several places",
    "resonator_young_pa": "the alloy's own modulus: a free plate's bending resonance",
}


def systematic_floor(points: pd.DataFrame, calibration: Deskew | None = None) -> pd.DataFrame:
    """Per (run, quantity): the p95 relative error the instruments' specified errors leave
    when the noise is averaged away (Type A set to zero; the plate's resonance drift, which
    the run's own readings bound and no setting does, left out), at the run's worst point, with
    the term that dominates there and the calibration that would lift it (if any); p95 as
    `Budget.p95_bound` (1.96 u, or U where the uncorrected delay's bias bound widens it).

    `calibration`: the floor after that calibration (its uncertainties; its values do not matter).
    """
    points = points.copy()
    points = with_detuning_shape(points)
    deskew = calibration
    rows = []
    for run_name, run_points in points.groupby("run_name", sort=False):
        run_rows = _rows(run_points)
        for quantity in ("power_w", "velocity_pp_mps"):
            worst = None
            for row in run_rows:
                if not _has_reduction(row):
                    continue
                # the instruments' floor: the plate's drift is the run's, not the settings' (`_point_drift_terms`)
                budget = point_budget(quantity, {**row, f"{quantity}_u": 0.0, "resonance_drift_hz": math.nan}, deskew)
                relative = budget.p95_bound / abs(budget.value)
                if worst is None or relative > worst[0]:
                    worst = (relative, budget)
            if worst is None:
                continue
            relative, budget = worst
            dominant = budget.dominant.name
            rows.append({"run_name": run_name, "quantity": quantity, "floor_p95_rel": relative,
                         "dominant_term": dominant, "lifted_by": LIFTED_BY.get(dominant, "")})
    return pd.DataFrame(rows, columns=["run_name", "quantity", "floor_p95_rel", "dominant_term", "lifted_by"])


def characterisation_floor(run: RunData, calibration: Deskew | None = None,
                           convention: model.Convention = model.PHYSICAL_CONVENTION) -> pd.DataFrame:
    """Per (run, quantity) of Q and tan theta' (the characterisation protocol's plates): the
    p95 relative error their budgets leave without the line fits' own terms (what no number
    of points lowers: the instruments' specifications, the geometry's and materials'
    tolerances), at the run's worst plate, with the term that dominates there; columns of
    `systematic_floor`. `calibration`: after that deskew (its uncertainty)."""
    from squeezebench.analysis.characterisation import characterise_plates   # it imports this module

    columns = ["run_name", "quantity", "floor_p95_rel", "dominant_term", "lifted_by"]
    if run.protocol("characterisation").empty:
        return pd.DataFrame(columns=columns)
    worst: dict[tuple[str, str], tuple[float, Budget]] = {}
    for plate in characterise_plates(run, convention).values():
        run_name = str(plate.points["run_name"].iat[0])
        for budget in characterisation_budgets(plate, convention, calibration, with_fit=False):
            relative = budget.p95_bound / abs(budget.value)
            if relative > worst.get((run_name, budget.quantity), (-1.0, None))[0]:
                worst[(run_name, budget.quantity)] = (relative, budget)
    return pd.DataFrame([{"run_name": run_name, "quantity": quantity, "floor_p95_rel": relative,
                          "dominant_term": budget.dominant.name, "lifted_by": LIFTED_BY.get(budget.dominant.name, "")}
                         for (run_name, quantity), (relative, budget) in worst.items()], columns=columns)


# -- Q and tan theta' through the paper's model ----------------------------------------------
#: Who shares a tolerated input's departure (GUM 5.2: an input common to several results
#: correlates them). A lab builds its plates from stock: the plates of one thickness are cut
#: from one sheet, whose gauge and alloy (its modulus) are one roll's and one melt's, so they
#: depart together (EN 485-4's thickness band is a sheet's against its nominal gauge, not the
#: spread between neighbouring cuts); the piezos are one lot of one product, diced from wafers
#: lapped to the lot's thickness and fired from one powder batch, so the data sheet's +-5 % on
#: d31 and s11^E (and +-10 % on the permittivity) is the lot's offset, shared by every plate it
#: equips. What is cut, diced or set out for each plate is its own: the plate's length (its
#: half-wavelength) and its piezos' length along the nodal lines.
SHEET, PIEZO_LOT, PLATE = "sheet", "piezo lot", "plate"


@dataclass(frozen=True)
class Tolerance:
    half_width_rel: float  # relative, rectangular
    source: str
    shared_by: str   # SHEET, PIEZO_LOT or PLATE: whose departure it is


#: Tolerances of the model's inputs that no measurement gives (relative, rectangular); the
#: resonator's thickness has its sheet's, which depends on the plate (`tolerances_for`).
TOLERANCES: dict[str, Tolerance] = {
    "piezo_thickness_m": Tolerance(0.02, "assumed: lapped piezo plates, +-0.01 mm on 0.5 mm", PIEZO_LOT),
    "piezo_length_m": Tolerance(0.01, "assumed: diced piezo plates, +-0.1 mm on 9 mm", PLATE),
    "half_wavelength_m": Tolerance(0.01, "assumed: plate length / antinodes, +-0.1 mm on 8.4 mm", PLATE),
    "piezo_d31_c_per_n": Tolerance(0.05, "Noliac NCE41 data sheet (ver. 1203): electromechanical tolerance +-5 %",
                                   PIEZO_LOT),
    "piezo_c11_pa": Tolerance(0.05, "Noliac NCE41 data sheet (ver. 1203): physical tolerance +-5 % (s11^E)",
                              PIEZO_LOT),
    "resonator_young_pa": Tolerance(0.03, "assumed: aluminium alloys 67-71 GPa, +-3 %", SHEET),
}
_GEOMETRY_FIELDS = ("resonator_thickness_m", "piezo_thickness_m", "piezo_length_m", "half_wavelength_m")
_MATERIAL_FIELDS = ("piezo_d31_c_per_n", "piezo_c11_pa", "resonator_young_pa")
#: Where the resonator thickness's tolerance comes from.
SHEET_THICKNESS_SOURCE = ("EN 485-4 Table 1, cold-rolled sheet up to 1000 mm wide, alloy group II: +-0.05 mm "
                          "from 0.8 to 1.2 mm, +-0.09 mm at 2 mm (specifications.sheet_thickness_tolerance)")


def with_inputs(geometry: model.PlateGeometry, convention: model.Convention,
                values: dict[str, float]) -> tuple[model.PlateGeometry, model.Convention]:
    """The geometry and convention with the tolerated inputs (`tolerances_for`'s names) at
    `values` (every one of them given)."""
    shape = replace(geometry, **{k: values[k] for k in _GEOMETRY_FIELDS})
    materials = replace(convention.materials, **{k: values[k] for k in _MATERIAL_FIELDS})
    return shape, replace(convention, materials=materials)


def with_deviations(geometry: model.PlateGeometry, convention: model.Convention,
                    deviations_rel: dict[str, float]) -> tuple[model.PlateGeometry, model.Convention]:
    """The plate as it is when its tolerated inputs depart from the nominal ones by
    `deviations_rel` (relative, by `tolerances_for`'s names; a name left out: nominal)."""
    nominal = {name: getattr(geometry, name) for name in _GEOMETRY_FIELDS}
    nominal.update({name: getattr(convention.materials, name) for name in _MATERIAL_FIELDS})
    return with_inputs(geometry, convention, {name: value * (1.0 + deviations_rel.get(name, 0.0))
                                              for name, value in nominal.items()})


def tolerances_for(geometry: model.PlateGeometry) -> dict[str, Tolerance]:
    """`TOLERANCES` and the resonator thickness's, its sheet's at the plate's nominal thickness."""
    return {"resonator_thickness_m": Tolerance(sheet_thickness_tolerance(geometry.resonator_thickness_m),
                                               SHEET_THICKNESS_SOURCE, SHEET), **TOLERANCES}


def plate_own_u(budget: Budget, geometry: model.PlateGeometry) -> float:
    """The part of a plate's Q or tan theta' budget (`model_budgets`' terms, by input name)
    that is the plate's own: its `PLATE` tolerances in quadrature, independent of every other
    plate's. The rest (the bench's instruments, the sheet's and piezo lot's tolerances) the
    plates measured on one bench share."""
    own = {name for name, tolerance in tolerances_for(geometry).items() if tolerance.shared_by == PLATE}
    return math.sqrt(sum(term.std_uncertainty**2 for term in budget.terms if term.name in own))


def model_budgets(amplitude: Budget, power: Budget, voltage: Budget, frequency_hz: float,
                  geometry: model.PlateGeometry, convention: model.Convention,
                  tolerances: dict[str, Tolerance] | None = None) -> tuple[Budget, Budget]:
    """Budgets of Q (Eq. 27 inverted) and tan theta' (Eq. 25 inverted) at one point, with
    `tolerances` (by default `tolerances_for` the geometry).

    Amplitude, power and voltage enter through their budgets' terms, not their combined
    uncertainties: a Type B term of one name is one input shared by every budget that lists
    it (CH1's gain is in both slopes as 1/g_CH1 and cancels in tan theta' ~ slope_P /
    slope_A; it is in a point's power and voltage as g_CH1), with the same sign of
    sensitivity in each (true of every shared term here); a Type A term belongs to its
    budget alone ("power: line fit"). Each tolerance is a separate term. The frequency's
    uncertainty (ppm) is negligible against the others and is not propagated.
    """
    tolerances = tolerances_for(geometry) if tolerances is None else tolerances
    shared: dict[str, uncertainties.UFloat] = {}   # one unit variable per underlying input
    sources: dict[str, str] = {}

    def reading(role: str, budget: Budget):
        value = budget.value   # an exactly known input (the slopes' V = 1 Vpp) stays a plain number
        for term in budget.terms:
            if term.std_uncertainty > 0:
                key = term.name if term.type == "B" else f"{role}: {term.name}"
                unit = shared.setdefault(key, uncertainties.ufloat(0.0, 1.0, key))
                sources[key] = term.source
                value = value + term.std_uncertainty * unit
        return value

    inputs = {role: reading(role, b) for role, b in (("amplitude", amplitude), ("power", power), ("voltage", voltage))}
    nominal = {name: getattr(geometry, name) for name in _GEOMETRY_FIELDS}
    nominal.update({name: getattr(convention.materials, name) for name in _MATERIAL_FIELDS})
    for name, value in nominal.items():
        tolerance = tolerances[name]
        inputs[name] = uncertainties.ufloat(value, abs(value) * tolerance.half_width_rel / math.sqrt(3.0), name)

    def build(values: dict[str, float]) -> tuple[model.PlateGeometry, model.Convention]:
        return with_inputs(geometry, convention, values)

    names = list(inputs)

    def q_of(*values: float) -> float:
        v = dict(zip(names, values))
        shape, conv = build(v)
        return model.q_from_amplitude(v["amplitude"], v["voltage"], shape, conv)

    def tan_of(*values: float) -> float:
        v = dict(zip(names, values))
        shape, conv = build(v)
        q = model.q_from_amplitude(v["amplitude"], v["voltage"], shape, conv)
        return model.tan_theta_from_power(v["power"], v["voltage"], q, frequency_hz, shape, conv)

    sources.update({k: t.source for k, t in tolerances.items()})
    budgets = []
    for quantity, function in (("q", q_of), ("tan_theta", tan_of)):
        result = uncertainties.wrap(function)(*inputs.values())
        components = result.error_components()
        terms = tuple(Term(variable.tag, "A" if ": " in variable.tag else "B", abs(u), sources[variable.tag])
                      for variable, u in components.items())
        budgets.append(Budget(quantity, "1", result.nominal_value, terms))
    return budgets[0], budgets[1]


def characterisation_budgets(plate, convention: model.Convention, deskew: Deskew | None = None,
                             tolerances: dict[str, Tolerance] | None = None,
                             with_fit: bool = True) -> tuple[Budget, Budget]:
    """Budgets of a plate's Q and tan theta' (`analysis.characterisation.PlateCharacterisation`).

    The slopes carry V = 1 Vpp (Eqs. 25 and 27 are linear in V and V^2): the amplitude
    slope reads g_CH3 g_decoder / g_V, the power slope g_CH2 g_probe / g_V (P carries
    g_V once, V^2 twice; g_V = g_vprobe g_CH1, the voltage path), each with its fit's uncertainty and, for the power, the CH2
    delay at the points' mean ratio of reactive to real power. Without `with_fit` the
    line fits' own (Type A) terms are left out: the floor no number of points lowers.
    """
    points = plate.points
    slope_a, slope_p = plate.amplitude_slope.slope, plate.power_slope.slope
    fit = 1.0 if with_fit else 0.0
    amplitude = Budget("amplitude_pp_m_per_vpp", "m/V", slope_a.value, (
        Term("line fit", "A", fit * slope_a.std_uncertainty, "weighted fit of amplitude against voltage"),
        _spec_term("CH3 gain", "scope_gain", slope_a.value),
        _spec_term("vibrometer decoder scale", "vibrometer_scale", slope_a.value),
        _spec_term("voltage probe attenuation", "voltage_probe_attenuation", slope_a.value),
        _spec_term("CH1 gain", "scope_gain", slope_a.value)))
    omega_ratio = float((2.0 * math.pi * points["frequency_hz"] * points["reactive_power_var"].abs()
                         / points["power_w"].abs()).mean())
    delay = (delay_term(slope_p.value * omega_ratio) if deskew is None else
             Term("CH2 delay after deskew", "B", abs(slope_p.value) * omega_ratio * deskew.std_uncertainty_s,
                  deskew.source))
    lead_ratio = float((points["reactive_power_var"].abs() / points["power_w"].abs()
                        * np.abs(compensation_phase_per_mismatch(points["frequency_hz"], deskew))).mean())
    power = Budget("power_w_per_vpp2", "W/V^2", slope_p.value, (
        Term("line fit", "A", fit * slope_p.std_uncertainty, "weighted fit of power against voltage squared"),
        _spec_term("CH2 gain", "scope_gain", slope_p.value),
        _spec_term("current probe gain", "current_probe_gain", slope_p.value),
        _spec_term("voltage probe attenuation", "voltage_probe_attenuation", slope_p.value),
        _spec_term("CH1 gain", "scope_gain", slope_p.value), delay,
        compensation_term(slope_p.value * lead_ratio, deskew)))
    at_one_volt = Budget("piezo_voltage_vpp", "V", 1.0, ())
    return model_budgets(amplitude, power, at_one_volt, plate.frequency_hz, plate.geometry, convention, tolerances)
