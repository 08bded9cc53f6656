"""Reduction of one stored scope record to power, velocity, amplitude and frequency.

Pure numpy/scipy, no loops over samples. Two independent estimators are kept side by side:

- the integer-period mean of v·i after DC removal (what the paper's scope MATH channel
  did, Sec. 2.1), over the largest whole number of periods the record holds;
- a sine fit (linear least squares on sin/cos/1 at the frequency of the four-parameter
  least-squares fit, found by Gauss-Newton from the spectral peak; the three channels of
  a record share one basis), which also gives peak-to-peak values that are not biased by
  noise the way raw max - min is.

Every reduced number is an `Estimate` (value and standard uncertainty). Uncertainties
come from the fit residuals (covariance of the least-squares parameters) with the
instrument resolution as a floor: a record quantised in steps of `y_increment`, averaged
over `averages` dithered acquisitions, cannot have a per-sample noise variance below
y_increment^2 / (12 averages).
"""

from __future__ import annotations

import functools
import math
from dataclasses import asdict, dataclass
from functools import lru_cache

import numpy as np
from scipy import optimize

#: Relative tolerance on sample spacing: float32 time stamps of a 10k-point record are
#: accurate to ~1e-3 of a sample interval, anything beyond means a non-uniform record.
_UNIFORM_SPACING_RTOL = 1e-2


@dataclass(frozen=True)
class Estimate:
    """A reduced value with its standard uncertainty (k = 1), same unit as the value."""

    value: float
    std_uncertainty: float


@dataclass(frozen=True)
class SineFit:
    """y(t) = amplitude sin(2 pi f (t - t_mid) + phase) + offset, fitted to one channel."""

    frequency_hz: Estimate
    amplitude: Estimate  # zero-to-peak, channel unit
    phase_rad: Estimate
    offset: Estimate
    sin_coefficient: float  # A of A sin + B cos: kept for products of two channels
    cos_coefficient: float
    coefficient_covariance: np.ndarray  # 2x2 covariance of (A, B)
    residual_rms: float
    noise_std: float  # per-sample noise used for the covariance (residuals, resolution floor)

    @property
    def pp(self) -> Estimate:
        """Peak-to-peak of the fitted sine: twice the zero-to-peak amplitude."""
        return Estimate(2.0 * self.amplitude.value, 2.0 * self.amplitude.std_uncertainty)


@dataclass(frozen=True)
class PointReduction:
    """Everything the tables need from one measured point."""

    frequency_hz: Estimate
    n_periods: int  # periods in the integer-period window
    piezo_voltage_vpp: Estimate  # from the sine fit
    power_w: Estimate  # integer-period mean of v i after DC removal (the paper's method), window bias corrected
    power_fit_w: Estimate  # (A_v A_i + B_v B_i)/2 from the sine fits: the cross-check
    reactive_power_var: Estimate  # 0.5 Im(V conj I) from the sine fits: what a CH2 delay turns into power
    velocity_pp_mps: Estimate  # 2 x fitted amplitude
    velocity_raw_pp_mps: float  # max - min, biased upwards by noise; kept for comparison
    amplitude_pp_m: Estimate  # velocity_pp / (2 pi f)
    velocity_phase_rad: Estimate  # velocity's phase against the piezo voltage, (-pi, pi]

    def as_row(self) -> dict[str, float]:
        """Flat columns `<name>` and `<name>_u` for a tidy table."""
        row: dict[str, float] = {}
        for key, value in asdict(self).items():
            if isinstance(value, dict):
                row[key] = value["value"]
                row[f"{key}_u"] = value["std_uncertainty"]
            else:
                row[key] = value
        return row


def as_samples(name: str, values) -> np.ndarray:
    """A finite, non-empty 1-D float64 array, or a ValueError naming the channel."""
    array = np.asarray(values)
    if array.ndim != 1 or array.size == 0:
        raise ValueError(f"{name}: expected a non-empty 1-D record, got shape {array.shape}")
    if not np.issubdtype(array.dtype, np.number):
        raise ValueError(f"{name}: expected numbers, got dtype {array.dtype}")
    array = array.astype(np.float64, copy=False)
    bad = ~np.isfinite(array)
    if bad.any():
        raise ValueError(f"{name}: {int(bad.sum())} NaN/inf sample(s), first at index "
                         f"{int(np.argmax(bad))}")
    return array


def sample_interval_s(time_s: np.ndarray) -> float:
    """The uniform sample interval of a record; ValueError if the time axis is not uniform."""
    if time_s.size < 2:
        raise ValueError(f"time_s: at least 2 samples are needed, got {time_s.size}")
    dt = (time_s[-1] - time_s[0]) / (time_s.size - 1)
    if not dt > 0:
        raise ValueError("time_s: time must increase along the record")
    deviation = np.max(np.abs(np.diff(time_s) - dt))
    if deviation > _UNIFORM_SPACING_RTOL * dt:
        raise ValueError(f"time_s: sampling is not uniform (spacing deviates by {deviation:.3g} s "
                         f"from {dt:.6g} s)")
    return float(dt)


def integer_period_window(n_samples: int, dt_s: float, frequency_hz: float) -> tuple[int, int, float]:
    """(n_periods, whole samples, weight of the next sample) of the longest window holding a
    whole number of periods. The window [0, n_periods/f) generally ends inside a sample;
    that sample enters with its fractional weight so the window length is exact."""
    if not (frequency_hz > 0 and math.isfinite(frequency_hz)):
        raise ValueError(f"frequency_hz must be a finite positive number, got {frequency_hz!r}")
    samples_per_period = 1.0 / (frequency_hz * dt_s)
    n_periods = math.floor(n_samples / samples_per_period * (1 + 1e-12))
    if n_periods < 1:
        raise ValueError(f"the record ({n_samples} samples) is shorter than one period "
                         f"({samples_per_period:.3g} samples)")
    exact = n_periods * samples_per_period
    whole = min(math.floor(exact), n_samples)
    fraction = exact - whole if whole < n_samples else 0.0
    return n_periods, whole, fraction


def integer_period_mean_power_w(voltage_v, current_a, dt_s: float, frequency_hz: float) -> float:
    """Mean of (v - v_mean)(i - i_mean) over the largest integer number of periods (Sec. 2.1).

    The hot path, benchmarked against a bare dot product: three BLAS dot products and
    no temporaries. The channel sums are dot products with the window's weights (1 inside,
    the fraction at the edge sample, 0 after), which also carry any NaN/inf of the samples
    after the window into the result (0 x NaN = NaN), so no separate pass checks them.
    Sum(v i)/M - v_mean i_mean equals the mean of the DC-free product exactly; in float64
    its cancellation error stays ~1e-16 of v_dc i_dc, far below any measurable power even
    at power factor 1e-3 with DC offsets 100x the signal.
    """
    v = np.asarray(voltage_v, dtype=np.float64)
    i = np.asarray(current_a, dtype=np.float64)
    if v.ndim != 1 or v.size == 0 or v.shape != i.shape:
        raise ValueError(f"voltage and current must be non-empty 1-D records of equal length, "
                         f"got shapes {v.shape} and {i.shape}")
    _, whole, fraction = integer_period_window(v.size, dt_s, frequency_hz)
    weights = _window_weights(v.size, whole, fraction)
    sum_v = float(np.dot(v, weights))
    sum_i = float(np.dot(i, weights))
    sum_vi = float(np.dot(v[:whole], i[:whole]))
    if whole < v.size:
        sum_vi += fraction * float(v[whole]) * float(i[whole])
    if not math.isfinite(sum_vi + sum_v + sum_i):
        raise ValueError("voltage/current record contains NaN or inf samples")
    exact = whole + fraction
    return sum_vi / exact - (sum_v / exact) * (sum_i / exact)


@lru_cache(maxsize=8)
def _window_weights(n_samples: int, whole: int, fraction: float) -> np.ndarray:
    """Read-only weights of the integer-period window; cached because a campaign reduces
    many records of one length at one frequency."""
    weights = np.zeros(n_samples)
    weights[:whole] = 1.0
    if whole < n_samples:
        weights[whole] = fraction
    weights.flags.writeable = False
    return weights


#: A time axis this close to uniform (relative to the interval) has its sines computed
#: from the uniform grid, by products of a few exact rotations (float64 stamps are).
_EXACTLY_UNIFORM_RTOL = 1e-9


def _uniform_interval_s(time_s: np.ndarray, dt_s: float) -> float | None:
    """The interval if the stamps are uniform to rounding, else None (float32 stamps)."""
    grid = time_s[0] + dt_s * np.arange(time_s.size)
    return dt_s if np.max(np.abs(time_s - grid)) <= _EXACTLY_UNIFORM_RTOL * dt_s else None


def _phasors(tau_s: np.ndarray, frequency_hz: float, uniform_dt_s: float | None) -> np.ndarray:
    """exp(j 2 pi f tau). On a uniform axis as an outer product of two short vectors of
    exact rotations (~2 sqrt(n) trigonometric calls instead of 2 n, error ~1e-16)."""
    omega = 2.0 * np.pi * frequency_hz
    if uniform_dt_s is None:
        return np.exp(1j * omega * tau_s)
    n = tau_s.size
    width = math.isqrt(n - 1) + 1
    fine = np.exp(1j * omega * uniform_dt_s * np.arange(width))
    coarse = np.exp(1j * omega * (tau_s[0] + uniform_dt_s * width * np.arange(-(-n // width))))
    return (coarse[:, None] * fine[None, :]).ravel()[:n]


class _SineBasis:
    """sin and cos of 2 pi f tau over one record, with the Gram matrix of [sin, cos, 1]:
    every channel of the record is fitted by three dot products and one 3x3 solve (the
    columns are near-orthogonal over a period or more, so the normal equations lose
    nothing), instead of a least-squares factorisation per channel."""

    def __init__(self, tau_s: np.ndarray, frequency_hz: float, uniform_dt_s: float | None) -> None:
        phasors = _phasors(tau_s, frequency_hz, uniform_dt_s)
        self.tau_s = tau_s
        self.frequency_hz = frequency_hz
        self.sin = np.ascontiguousarray(phasors.imag)
        self.cos = np.ascontiguousarray(phasors.real)
        s, c = self.sin, self.cos
        self.gram = np.array([[s @ s, s @ c, s.sum()], [s @ c, c @ c, c.sum()], [s.sum(), c.sum(), s.size]])

    @functools.cached_property
    def gram_inverse(self) -> np.ndarray:
        """(J^T J)^-1 of the three-parameter fit: shared by the channels fitted at this frequency."""
        return _inverse(self.gram)

    def project(self, y: np.ndarray) -> np.ndarray:
        """Dot products of y with the columns sin, cos, 1."""
        return np.array([self.sin @ y, self.cos @ y, y.sum()])

    def coefficients(self, y: np.ndarray) -> np.ndarray:
        """Least-squares A, B, C of A sin + B cos + C."""
        try:
            return np.linalg.solve(self.gram, self.project(y))
        except np.linalg.LinAlgError:
            raise ValueError("the sine fit is degenerate (no oscillation at this frequency?)") from None

    def model(self, coefficients: np.ndarray) -> np.ndarray:
        a_sin, b_cos, c_offset = coefficients
        return a_sin * self.sin + b_cos * self.cos + c_offset

    def d_model_d_frequency(self, a_sin: float, b_cos: float) -> np.ndarray:
        return (2.0 * np.pi) * self.tau_s * (a_sin * self.cos - b_cos * self.sin)


def _inverse(gram: np.ndarray) -> np.ndarray:
    """(J^T J)^-1 through its correlation matrix: scale-free, so a degenerate Jacobian
    (a parameter the record cannot tell from the others) shows whatever the units."""
    scale = np.sqrt(np.diag(gram))
    if not (scale > 0).all():
        raise ValueError("the sine fit is degenerate (no oscillation at this frequency?)")
    correlation = gram / np.outer(scale, scale)
    eigenvalues, eigenvectors = np.linalg.eigh(correlation)
    if eigenvalues[0] <= 1e-12 * eigenvalues[-1]:
        raise ValueError("the sine fit is degenerate (no oscillation at this frequency?)")
    return ((eigenvectors / eigenvalues) @ eigenvectors.T) / np.outer(scale, scale)


def _coarse_frequency_hz(y: np.ndarray, dt_s: float, hint_hz: float | None) -> tuple[float, float]:
    """The strongest spectral line (Hann window against leakage of a non-integer number
    of periods), searched near the hint when one is given: its bin's frequency, and
    that refined by Gaussian interpolation over the neighbouring bins."""
    spectrum = np.abs(np.fft.rfft((y - y.mean()) * _hann(y.size)))
    bins_hz = np.fft.rfftfreq(y.size, dt_s)
    spectrum[0] = 0.0
    if hint_hz is not None:
        near = np.abs(bins_hz - hint_hz) <= max(3.0 * bins_hz[1], 0.05 * hint_hz)
        if near.any():
            spectrum = np.where(near, spectrum, 0.0)
    peak = int(np.argmax(spectrum))
    if spectrum[peak] == 0.0:
        raise ValueError("the record holds no oscillation (constant signal)")
    offset = 0.0
    if 0 < peak < spectrum.size - 1 and spectrum[peak - 1] > 0 and spectrum[peak + 1] > 0:
        below, at, above = np.log(spectrum[peak - 1:peak + 2])
        curvature = below - 2.0 * at + above
        if curvature < 0:
            offset = float(np.clip(0.5 * (below - above) / curvature, -0.5, 0.5))
    return float(bins_hz[peak]), float(bins_hz[peak] + offset * bins_hz[1])


@lru_cache(maxsize=8)
def _hann(n_samples: int) -> np.ndarray:
    window = np.hanning(n_samples)
    window.flags.writeable = False
    return window


#: Gauss-Newton steps allowed before the frequency search falls back to scipy's bounded search.
_MAX_FREQUENCY_STEPS = 12


def estimate_frequency_hz(time_s, signal, frequency_hint_hz: float | None = None) -> float:
    """The frequency minimising the sine-fit residual within +-1 FFT bin of the spectral
    peak (the four-parameter least-squares sine fit)."""
    t = as_samples("time_s", time_s)
    y = as_samples("signal", signal)
    dt = sample_interval_s(t)
    return _estimate_frequency(t - 0.5 * (t[0] + t[-1]), y, dt, _uniform_interval_s(t, dt),
                               frequency_hint_hz).frequency_hz


def _estimate_frequency(tau_s: np.ndarray, y: np.ndarray, dt_s: float, uniform_dt_s: float | None,
                        hint_hz: float | None) -> _SineBasis:
    """The basis at the fitted frequency (its `frequency_hz`, within 1e-9 of a bin of
    the RSS's minimum)."""
    """Gauss-Newton on the frequency with A, B, C eliminated (variable projection,
    Kaufman's step), from the interpolated spectral peak: a step is zero exactly where the
    RSS is stationary, and each costs one basis instead of a least-squares solve per
    trial frequency. If it leaves +-1 bin or does not converge, scipy's bounded search on
    the same RSS decides, on x = (f - f_peak) / bin width (a variable of order one)."""
    y = y - y.mean()  # removes a large DC offset before the fit sees it
    bin_hz = 1.0 / (y.size * dt_s)
    peak_hz, frequency_hz = _coarse_frequency_hz(y, dt_s, hint_hz)
    for _ in range(_MAX_FREQUENCY_STEPS):
        basis = _SineBasis(tau_s, frequency_hz, uniform_dt_s)
        coefficients = basis.coefficients(y)
        residual = y - basis.model(coefficients)
        slope = basis.d_model_d_frequency(coefficients[0], coefficients[1])
        slope = slope - basis.model(basis.coefficients(slope))   # what A, B, C cannot absorb
        norm = float(slope @ slope)
        if not norm > 0:
            break
        step = float(slope @ residual) / norm
        if abs(step) <= 1e-9 * bin_hz:
            return basis
        frequency_hz += step
        if not abs(frequency_hz - peak_hz) <= bin_hz:
            break

    def rss(x: float) -> float:
        basis = _SineBasis(tau_s, peak_hz + x * bin_hz, uniform_dt_s)
        residual = y - basis.model(basis.coefficients(y))
        return float(residual @ residual)

    best = optimize.minimize_scalar(rss, bounds=(-1.0, 1.0), method="bounded", options={"xatol": 1e-7})
    return _SineBasis(tau_s, peak_hz + float(best.x) * bin_hz, uniform_dt_s)


def fit_sine(time_s, signal, frequency_hz: float, y_increment: float = 0.0,
             averages: int = 1, frequency_is_estimated_here: bool = True) -> SineFit:
    """Sine fit at a given frequency. When the frequency was estimated on this very
    signal, the covariance covers all four parameters (A, B, C and the frequency, from
    the Jacobian at the optimum), so the frequency's own uncertainty is part of the
    result; on another channel of the same record the frequency is given and only
    A, B, C are uncertain (and a channel with no oscillation still gets a fit)."""
    t = as_samples("time_s", time_s)
    y = as_samples("signal", signal)
    if y.size != t.size:
        raise ValueError(f"signal has {y.size} samples but time_s has {t.size}")
    if y.size < 5:
        raise ValueError(f"a sine fit needs at least 5 samples, got {y.size}")
    dt = sample_interval_s(t)
    basis = _SineBasis(t - 0.5 * (t[0] + t[-1]), frequency_hz, _uniform_interval_s(t, dt))
    return _fit_on_basis(basis, y, dt, y_increment, averages, frequency_is_estimated_here)


def _fit_on_basis(basis: _SineBasis, y: np.ndarray, dt_s: float, y_increment: float, averages: int,
                  frequency_is_estimated_here: bool) -> SineFit:
    dc = y.mean()
    y = y - dc
    coefficients = basis.coefficients(y)
    a_sin, b_cos, c_offset = coefficients
    residual = y - basis.model(coefficients)
    bin_hz = 1.0 / (y.size * dt_s)
    gram = basis.gram
    if frequency_is_estimated_here:
        # d(model)/d(x) with f = f_fit + x bin_hz: a column of order one (tau bin_hz is in [-1/2, 1/2]).
        d_dx = bin_hz * basis.d_model_d_frequency(a_sin, b_cos)
        cross = basis.project(d_dx)
        gram = np.block([[gram, cross[:, None]], [cross[None, :], np.array([[d_dx @ d_dx]])]])
    dof = y.size - gram.shape[0]
    resolution_var = (y_increment**2 / 12.0) / max(int(averages), 1)
    noise_var = max(float(residual @ residual) / dof, resolution_var)
    covariance = noise_var * (_inverse(gram) if frequency_is_estimated_here else basis.gram_inverse)
    amplitude = math.hypot(a_sin, b_cos)
    if amplitude > 0:
        grad_amp = np.array([a_sin, b_cos]) / amplitude
        grad_phase = np.array([-b_cos, a_sin]) / amplitude**2
    else:
        grad_amp = grad_phase = np.zeros(2)
    cov_ab = covariance[:2, :2]
    return SineFit(
        frequency_hz=Estimate(basis.frequency_hz, bin_hz * math.sqrt(covariance[3, 3])
                              if frequency_is_estimated_here else 0.0),
        amplitude=Estimate(amplitude, math.sqrt(grad_amp @ cov_ab @ grad_amp)),
        phase_rad=Estimate(math.atan2(b_cos, a_sin), math.sqrt(grad_phase @ cov_ab @ grad_phase)),
        offset=Estimate(dc + c_offset, math.sqrt(covariance[2, 2])),
        sin_coefficient=float(a_sin),
        cos_coefficient=float(b_cos),
        coefficient_covariance=cov_ab,
        residual_rms=math.sqrt(float(residual @ residual) / y.size),
        noise_std=math.sqrt(noise_var),
    )


def fitted_sine(fit: SineFit, time_s) -> np.ndarray:
    """The fitted model evaluated on a time axis (same t_mid convention as the fit)."""
    t = np.asarray(time_s, dtype=np.float64)
    tau = t - 0.5 * (t[0] + t[-1])
    phase = 2.0 * np.pi * fit.frequency_hz.value * tau
    return fit.sin_coefficient * np.sin(phase) + fit.cos_coefficient * np.cos(phase) + fit.offset.value


def power_from_fits_w(voltage: SineFit, current: SineFit) -> Estimate:
    """Mean of the product of two sines at one frequency: (A_v A_i + B_v B_i)/2.

    Written on the sin/cos coefficients rather than amplitudes and cos(phase difference):
    it stays accurate when the power factor is 1e-3 (no angle near pi/2 to subtract).
    Noise of the two channels is independent, so their covariances add separately.
    """
    v = np.array([voltage.sin_coefficient, voltage.cos_coefficient])
    i = np.array([current.sin_coefficient, current.cos_coefficient])
    value = 0.5 * float(v @ i)
    variance = 0.25 * (i @ voltage.coefficient_covariance @ i + v @ current.coefficient_covariance @ v)
    return Estimate(value, math.sqrt(float(variance)))


def reactive_power_from_fits_var(voltage: SineFit, current: SineFit) -> Estimate:
    """0.5 Im(V conj I) of two fitted sines (var; negative when the current leads).

    With y = A sin + B cos the phasor is B - jA, so V conj(I) has imaginary part
    B_v A_i - A_v B_i. A delay tau of the current channel moves the mean power by
    -Q w tau (`simbench.effects.ChannelSkew`), which is how a deskew correction uses it.
    """
    v = np.array([voltage.sin_coefficient, voltage.cos_coefficient])
    i = np.array([current.sin_coefficient, current.cos_coefficient])
    d_dv = 0.5 * np.array([-i[1], i[0]])
    d_di = 0.5 * np.array([v[1], -v[0]])
    variance = d_dv @ voltage.coefficient_covariance @ d_dv + d_di @ current.coefficient_covariance @ d_di
    return Estimate(float(d_dv @ v), math.sqrt(float(variance)))


def integer_period_power(time_s, voltage_v, current_a, voltage_fit: SineFit,
                         current_fit: SineFit, *, basis: _SineBasis | None = None) -> tuple[Estimate, int]:
    """The scope's integer-period mean (Sec. 2.1), corrected for its window's discretisation
    bias, with its uncertainty.

    The window's sum of samples is not the product's true mean when a period is not a whole
    number of samples: the product's component at twice the drive frequency leaves a
    remainder, a larger share of the mean the smaller the power factor (a detuned point).
    The fitted model gives that bias exactly (the window sum of the model product minus the
    model's true mean), so it is subtracted as a known systematic effect (GUM 3.2.4) rather
    than counted as an uncertainty; counted, it left every detuned power reading low by a
    fixed share on every bench. What remains is the scatter of the sample products about the
    fitted product (noise, quantisation) over the window length.
    """
    t = as_samples("time_s", time_s)
    v = as_samples("piezo_voltage_v", voltage_v)
    i = as_samples("current_a", current_a)
    dt = sample_interval_s(t)
    frequency = voltage_fit.frequency_hz.value
    n_periods, whole, fraction = integer_period_window(v.size, dt, frequency)
    value = integer_period_mean_power_w(v, i, dt, frequency)
    weights = _window_weights(v.size, whole, fraction)
    exact = whole + fraction
    if basis is None:   # the fits' own sines, unless the caller has them on this axis
        v_model, i_model = fitted_sine(voltage_fit, t), fitted_sine(current_fit, t)
    else:
        v_model, i_model = (basis.model([fit.sin_coefficient, fit.cos_coefficient, fit.offset.value])
                            for fit in (voltage_fit, current_fit))
    v_model_ac = v_model - weights @ v_model / exact
    i_model_ac = i_model - weights @ i_model / exact
    model_window_mean = float(weights @ (v_model_ac * i_model_ac)) / exact
    window_bias = model_window_mean - power_from_fits_w(voltage_fit, current_fit).value
    scatter = (v - weights @ v / exact) * (i - weights @ i / exact) - v_model_ac * i_model_ac
    noise_var = float(weights @ scatter**2) / exact / exact
    return Estimate(value - window_bias, math.sqrt(noise_var)), n_periods


def reduce_point(time_s, piezo_voltage_v, current_a, vibrometer_output_v,
                 vibrometer_scale_mps_per_v: float, *, y_increments: dict[str, float] | None = None,
                 averages: int = 1, frequency_hint_hz: float | None = None) -> PointReduction:
    """Reduce one record (columns of design.md's waveform files) to a `PointReduction`.

    The frequency is estimated on the piezo voltage (the cleanest channel) and shared by
    the three fits, so phases and the fitted power refer to one time origin.
    `y_increments` maps column name to the scope's quantisation step in that column's unit.
    """
    steps = y_increments or {}
    t = as_samples("time_s", time_s)
    channels = {name: as_samples(name, values) for name, values in (
        ("piezo_voltage_v", piezo_voltage_v), ("current_a", current_a),
        ("vibrometer_output_v", vibrometer_output_v))}
    for name, values in channels.items():
        if values.size != t.size:
            raise ValueError(f"{name} has {values.size} samples but time_s has {t.size}")
    if not (math.isfinite(vibrometer_scale_mps_per_v) and vibrometer_scale_mps_per_v > 0):
        raise ValueError(f"vibrometer_scale_mps_per_v must be positive, got {vibrometer_scale_mps_per_v!r}")
    if t.size < 5:
        raise ValueError(f"a sine fit needs at least 5 samples, got {t.size}")
    dt = sample_interval_s(t)
    tau = t - 0.5 * (t[0] + t[-1])
    uniform_dt = _uniform_interval_s(t, dt)
    basis = _estimate_frequency(tau, channels["piezo_voltage_v"], dt, uniform_dt, frequency_hint_hz)
    fits = {name: _fit_on_basis(basis, values, dt, steps.get(name, 0.0), averages,
                                frequency_is_estimated_here=name == "piezo_voltage_v")
            for name, values in channels.items()}
    power, n_periods = integer_period_power(t, channels["piezo_voltage_v"], channels["current_a"],
                                            fits["piezo_voltage_v"], fits["current_a"], basis=basis)
    scale = vibrometer_scale_mps_per_v
    velocity_pp = fits["vibrometer_output_v"].pp
    velocity = Estimate(velocity_pp.value * scale, velocity_pp.std_uncertainty * scale)
    frequency_estimate = fits["piezo_voltage_v"].frequency_hz
    vib = channels["vibrometer_output_v"]
    return PointReduction(
        frequency_hz=frequency_estimate,
        n_periods=n_periods,
        piezo_voltage_vpp=fits["piezo_voltage_v"].pp,
        power_w=power,
        power_fit_w=power_from_fits_w(fits["piezo_voltage_v"], fits["current_a"]),
        reactive_power_var=reactive_power_from_fits_var(fits["piezo_voltage_v"], fits["current_a"]),
        velocity_pp_mps=velocity,
        velocity_raw_pp_mps=float((vib.max() - vib.min()) * scale),
        amplitude_pp_m=amplitude_pp_from_velocity_pp(velocity, frequency_estimate),
        velocity_phase_rad=phase_difference_rad(fits["vibrometer_output_v"], fits["piezo_voltage_v"]),
    )


def phase_difference_rad(signal: SineFit, reference: SineFit) -> Estimate:
    """Phase of `signal` against `reference` (fitted on one time origin), wrapped to
    (-pi, pi]; the two fits' phase uncertainties added in quadrature (their noise is
    independent: different channels)."""
    difference = signal.phase_rad.value - reference.phase_rad.value
    wrapped = math.pi - (math.pi - difference) % (2 * math.pi)
    return Estimate(wrapped, math.hypot(signal.phase_rad.std_uncertainty, reference.phase_rad.std_uncertainty))


def reduce_record(samples, vibrometer_scale_mps_per_v: float, *, y_increments: dict[str, float] | None = None,
                  averages: int = 1, frequency_hint_hz: float | None = None) -> PointReduction:
    """`reduce_point` of a stored record: a table with the columns of design.md's waveform
    files (time_s, piezo_voltage_v, current_a, vibrometer_output_v)."""
    return reduce_point(samples["time_s"], samples["piezo_voltage_v"], samples["current_a"],
                        samples["vibrometer_output_v"], vibrometer_scale_mps_per_v,
                        y_increments=y_increments, averages=averages, frequency_hint_hz=frequency_hint_hz)


def amplitude_pp_from_velocity_pp(velocity_pp_mps: Estimate, frequency_hz: Estimate) -> Estimate:
    """Displacement pp of a sine from its velocity pp: v_pp / (2 pi f); relative
    uncertainties add in quadrature (independent)."""
    value = velocity_pp_mps.value / (2.0 * math.pi * frequency_hz.value)
    rel_v = velocity_pp_mps.std_uncertainty / velocity_pp_mps.value if velocity_pp_mps.value else 0.0
    rel_f = frequency_hz.std_uncertainty / frequency_hz.value
    return Estimate(value, abs(value) * math.hypot(rel_v, rel_f))
