"""The plate near its working mode, seen from the piezo terminals: small pure functions.

Model (Butterworth-Van Dyke, one motional branch per vibration mode):

- the powered piezos push the modal coordinate with force F = n_c psi V; unpowered piezos
  are not connected, so they add neither force nor loss (the paper's Table 4 finding);
- the mode is a mass-spring-damper, Z_mech(w) = R_mech + j(w M - K/w) with w_r^2 = K/M
  and q_mech = w_r M / R_mech (sharpness of the resonance; not the paper's Q of Eq. 14);
- modal velocity v = n_c psi V / Z_mech; it drives a motional current n_c psi v;
- the clamped capacitance C0 of the powered piezos sits in parallel.

At resonance v is proportional to n_c V (the paper's Eq. 1 and Eq. 27) and the real power
0.5 R_mech |v|^2 is proportional to V^2 (Eq. 25) and, at fixed velocity, independent of
n_c (Eq. 28). Phasors use x(t) = Re(X exp(j k w t)); V, I and v are amplitudes inside
the phasors, and every name says pp or amplitude.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, replace

import numpy as np

from squeezebench.plates import damping

EPSILON_0_F_PER_M = 8.8541878128e-12

#: Orders of the harmonics a clipped amplifier output is expanded into (odd and even: a
#: DC offset makes the clipping asymmetric). Beyond 31 the plate's C0 current is tiny.
CLIPPED_HARMONIC_ORDERS = np.arange(1, 32)
_SAMPLES_PER_PERIOD = 512


# -- the generator and the amplifier ----------------------------------------------------
GENERATOR_SOURCE_OHM = 50.0


@dataclass(frozen=True)
class GeneratorSettings:
    """What the 33120A is programmed to, in the units the instrument reports."""

    frequency_hz: float
    amplitude: float
    voltage_unit: str = "VPP"  # VPP | VRMS | DBM
    offset_v: float = 0.0
    load_ohm: float = math.inf  # the OUTP:LOAD setting: 50 or inf (INF)
    shape: str = "SIN"

    @property
    def amplitude_vpp(self) -> float:
        """Programmed amplitude as Vpp, as the 33120A converts its units (sine only)."""
        if self.voltage_unit == "VRMS":
            return self.amplitude * 2.0 * math.sqrt(2.0)
        if self.voltage_unit == "DBM":
            rms_v = math.sqrt(50.0 * 1e-3 * 10.0 ** (self.amplitude / 10.0))
            return rms_v * 2.0 * math.sqrt(2.0)
        return self.amplitude


def generator_emf_vpp(programmed_vpp: float, load_setting_ohm: float) -> float:
    """Open-circuit output of the 33120A: it assumes the load it was told about.

    With OUTP:LOAD 50 it doubles its internal source so that 50 ohm would see the
    programmed value; into a high-impedance input that doubles the real voltage.
    """
    return programmed_vpp * (2.0 if math.isfinite(load_setting_ohm) else 1.0)


def divider_vpp(source_vpp: float, source_ohm: float, load_ohm: float) -> float:
    """Voltage across `load_ohm` fed through `source_ohm` (an infinite load takes it all)."""
    return source_vpp / (1.0 + source_ohm / load_ohm)


@dataclass(frozen=True)
class Amplifier:
    """The power amplifier: gain, optional first-order bandwidth and output swing."""

    gain: float
    input_ohm: float
    bandwidth_hz: float = math.inf  # inf: flat response
    max_output_vpp: float = math.inf  # inf: never clips

    def transfer(self, frequency_hz: float) -> complex:
        """Gain G / (1 + j f / f_bw): a first-order low-pass."""
        return self.gain / (1.0 + 1j * frequency_hz / self.bandwidth_hz)


@dataclass(frozen=True)
class Drive:
    """Amplifier output: harmonic phasors (volts, amplitude) and its DC level."""

    orders: np.ndarray
    phasors_v: np.ndarray
    dc_v: float


def amplifier_output(generator: GeneratorSettings, amplifier: Amplifier) -> Drive:
    """Harmonic content of the amplifier output driven by the generator.

    Only the sine shape drives the plate; any other shape (the 33120A has no output
    switch, so "off" is DC at 0 V or the minimum amplitude) leaves only its offset.
    """
    input_scale = divider_vpp(1.0, GENERATOR_SOURCE_OHM, amplifier.input_ohm)
    emf_scale = generator_emf_vpp(1.0, generator.load_ohm)
    dc_v = generator.offset_v * emf_scale * input_scale * amplifier.gain
    if generator.shape != "SIN":
        return Drive(np.array([1]), np.zeros(1, complex), dc_v)
    amplitude_v = generator.amplitude_vpp * emf_scale * input_scale / 2.0
    fundamental = amplitude_v * amplifier.transfer(generator.frequency_hz)
    limit_v = amplifier.max_output_vpp / 2.0
    if abs(fundamental) + abs(dc_v) <= limit_v:
        return Drive(np.array([1]), np.array([fundamental]), dc_v)
    return _clipped_drive(fundamental, dc_v, limit_v)


def _clipped_drive(fundamental: complex, dc_v: float, limit_v: float) -> Drive:
    """Harmonics of a sine clipped at +-limit_v (the output stage saturates)."""
    phase = np.arange(_SAMPLES_PER_PERIOD) * (2.0 * np.pi / _SAMPLES_PER_PERIOD)
    wave = np.clip(np.real(fundamental * np.exp(1j * phase)) + dc_v, -limit_v, limit_v)
    spectrum = np.fft.rfft(wave) / _SAMPLES_PER_PERIOD
    orders = CLIPPED_HARMONIC_ORDERS
    return Drive(orders, 2.0 * spectrum[orders], float(spectrum[0].real))


# -- materials: what a datasheet gives ----------------------------------------------------
@dataclass(frozen=True)
class PiezoMaterial:
    """Datasheet constants of a piezoceramic and their relative tolerances."""

    name: str
    relative_permittivity_free: float  # eps33^T / eps0
    d31_c_per_n: float
    k31: float
    s11e_m2_per_n: float
    tan_delta: float  # dielectric loss factor at low field
    tan_delta_high_field: float  # at `high_field_v_per_m`
    high_field_v_per_m: float
    mechanical_q: float
    density_kg_m3: float
    tolerances: dict[str, float]  # constant name -> relative tolerance (+-)
    source: str


#: Noliac "Piezo ceramics" data sheet (ver. 1203), column NCE41: eps33^T/eps0 1350 and tan
#: delta 40e-4 (200e-4 at 400 V/mm), dielectric tolerance +-10 %; k31 0.33, -d31 130 pC/N,
#: electromechanical tolerance +-5 %; Qm 1400, density 7.90 g/cm3, s11^E 13e-12 m2/N,
#: physical tolerance +-5 %.
NCE41 = PiezoMaterial(
    name="NCE 41", relative_permittivity_free=1350.0, d31_c_per_n=-130e-12, k31=0.33,
    s11e_m2_per_n=13e-12, tan_delta=0.0040, tan_delta_high_field=0.020, high_field_v_per_m=400e3,
    mechanical_q=1400.0, density_kg_m3=7900.0,
    tolerances={"relative_permittivity_free": 0.10, "tan_delta": 0.10, "d31_c_per_n": 0.05, "k31": 0.05,
                "mechanical_q": 0.05, "density_kg_m3": 0.05, "s11e_m2_per_n": 0.05},
    source="Noliac, Piezo ceramics data sheet ver. 1203, NCE41")


@dataclass(frozen=True)
class ResonatorMaterial:
    name: str
    young_pa: float
    poisson: float
    density_kg_m3: float
    source: str
    #: Mechanical quality factors a plate of this material, free on a cushion in air, can
    #: have: a scene whose q_mech lies outside describes another build (or a fit gone wrong).
    q_mech_range: tuple[float, float]
    q_mech_source: str


#: The paper's Table 2 aluminium, with E_i read as 67 GPa (the print lost the exponent).
ALUMINIUM = ResonatorMaterial(
    "aluminium", young_pa=67e9, poisson=0.34, density_kg_m3=2790.0,
    source="paper, Table 2 (E_i = 67 GPa; printed 67109 N/m2)",
    q_mech_range=(100.0, 2000.0),
    q_mech_source="assumed: aluminium plates with bonded piezos in air, free on a cushion, ring with a Q of "
                  "hundreds to about two thousand (the paper's own Fig. 2c stress case gives 310, Sec. 2.2)")

PIEZO_MATERIALS = {m.name: m for m in (NCE41,)}
RESONATOR_MATERIALS = {m.name: m for m in (ALUMINIUM,)}


# -- the plate ---------------------------------------------------------------------------
def piezo_capacitance_f(n_piezos: int, area_m2: float, thickness_m: float,
                        relative_permittivity: float) -> float:
    """Parallel-plate capacitance of n identical piezos: n eps_r eps_0 A / t."""
    return n_piezos * relative_permittivity * EPSILON_0_F_PER_M * area_m2 / thickness_m


def clamped_relative_permittivity(material: PiezoMaterial) -> float:
    """eps33 of a patch whose length the plate holds: eps33^T (1 - k31^2).

    IEEE Std 176 (the eps33 at constant strain S1): a piezo bonded to a plate many times
    stiffer than itself cannot stretch along its length, so its permittivity falls from
    the free (datasheet) value by the transverse coupling. With k31 = 0.33, 0.89 eps33^T.
    """
    return material.relative_permittivity_free * (1.0 - material.k31**2)


def neutral_axis_from_piezo_face_m(piezo_thickness_m: float, piezo_young_pa: float,
                                   resonator_thickness_m: float, resonator_young_pa: float) -> float:
    """Bending neutral axis of a piezo layer bonded on a resonator (composite beam),
    measured from the piezo's free face: the stiffness-weighted centroid of the layers."""
    h_p, h_i = piezo_thickness_m, resonator_thickness_m
    return ((piezo_young_pa * h_p * h_p / 2.0 + resonator_young_pa * h_i * (h_p + h_i / 2.0))
            / (piezo_young_pa * h_p + resonator_young_pa * h_i))


def mode_slope_per_m(x_m: float, half_wavelength_m: float) -> float:
    """d(phi)/dx of the free plate's (n, 0) mode phi(x) = cos(pi x / (lambda/2)), unit at
    the free ends (antinodes) and, for an odd n, at the centre."""
    k = math.pi / half_wavelength_m
    return -k * math.sin(k * x_m)


def piezo_force_factor_n_per_v(material: PiezoMaterial, length_along_nodal_lines_m: float,
                               lever_arm_m: float, x_start_m: float, x_end_m: float,
                               half_wavelength_m: float) -> float:
    """Force on the modal coordinate per volt of one patch (magnitude), N/V.

    The patch (electrodes on its faces, field E3 = V/h_p) pulls with the stress e31 E3,
    e31 = d31 / s11^E, on the plate at `lever_arm_m` (z_m) from the neutral axis: a bending
    moment e31 V b z_m (b its length along the nodal lines) acting as two line moments at
    its ends, so the generalised force on phi is e31 b z_m [phi'(x_end) - phi'(x_start)] V
    (Crawley & de Luis, AIAA J. 25 (1987): the pin-force model of a bonded patch).
    """
    e31 = material.d31_c_per_n / material.s11e_m2_per_n
    slope_change = mode_slope_per_m(x_end_m, half_wavelength_m) - mode_slope_per_m(x_start_m, half_wavelength_m)
    return abs(e31 * length_along_nodal_lines_m * lever_arm_m * slope_change)


def mean_square_mode(x_start_m: float, x_end_m: float, half_wavelength_m: float) -> float:
    """Mean of phi^2 = cos^2(k x) over [x_start, x_end]: a patch's share of the modal mass."""
    k = math.pi / half_wavelength_m
    width = x_end_m - x_start_m
    return 0.5 + (math.sin(2 * k * x_end_m) - math.sin(2 * k * x_start_m)) / (4.0 * k * width)


def branch_from_physics(frequency_hz: float, q_mech: float, modal_mass_kg: float,
                        force_factor_n_per_v: float) -> MotionalBranch:
    """The motional branch of a mode of known modal mass: R_mech = w_r M / q_mech."""
    resistance = 2.0 * math.pi * frequency_hz * modal_mass_kg / q_mech
    return MotionalBranch(frequency_hz, q_mech, force_factor_n_per_v, resistance)


def modal_mass_kg(branch: MotionalBranch) -> float:
    """M = q_mech R_mech / w_r: the mass the calibrated branch implies (velocity at the
    measurement point as the modal coordinate)."""
    return branch.q_mech * branch.resistance_ns_per_m / (2.0 * math.pi * branch.frequency_hz)


def motional_capacitance_f(branch: MotionalBranch) -> float:
    """C_m = (n_c psi)^2 / K with K = w_r^2 M: the branch's series capacitance."""
    omega = 2.0 * math.pi * branch.frequency_hz
    return branch.force_factor_n_per_v**2 / (omega**2 * modal_mass_kg(branch))


def motional_elements(branch: MotionalBranch) -> tuple[float, float, float]:
    """The branch seen from the terminals, (R_m ohm, L_m H, C_m F) of the Butterworth-Van
    Dyke circuit: R_mech, M and 1/K divided by (n_c psi)^2 (the force factor is the
    electromechanical transformer's turns ratio)."""
    turns_squared = branch.force_factor_n_per_v**2
    return (branch.resistance_ns_per_m / turns_squared, modal_mass_kg(branch) / turns_squared,
            motional_capacitance_f(branch))


def effective_coupling(branch: MotionalBranch, capacitance_f: float) -> float:
    """k_eff = sqrt(C_m / (C0 + C_m)) = sqrt((f_a^2 - f_r^2) / f_a^2) of the lossless
    Butterworth-Van Dyke circuit (IEEE Std 176); a bonded patch stays below its k31."""
    c_m = motional_capacitance_f(branch)
    return math.sqrt(c_m / (capacitance_f + c_m))


@dataclass(frozen=True)
class MotionalBranch:
    """One vibration mode as a motional branch (mass-spring-damper behind n_c psi)."""

    frequency_hz: float
    q_mech: float
    force_factor_n_per_v: float  # n_c psi: force on the modal coordinate per volt
    resistance_ns_per_m: float  # R_mech
    visibility: float = 1.0  # velocity at the measurement point per unit modal velocity

    def impedance(self, omega: np.ndarray) -> np.ndarray:
        """Z_mech = R + j(wM - K/w) = R (1 + j q (w/w_r - w_r/w))."""
        ratio = omega / (2.0 * np.pi * self.frequency_hz)
        return self.resistance_ns_per_m * (1.0 + 1j * self.q_mech * (ratio - 1.0 / ratio))

    @property
    def ring_time_constant_s(self) -> float:
        """Amplitude time constant of ring-up/down: 2M/R = q_mech / (pi f_r)."""
        return self.q_mech / (math.pi * self.frequency_hz)


def calibrate_branch(frequency_hz: float, q_mech: float, voltage_vpp: float,
                     velocity_pp_mps: float, power_w: float) -> MotionalBranch:
    """The branch that, at resonance, moves at `velocity_pp_mps` and takes `power_w`
    from `voltage_vpp` (a lossless C0 takes no real power).

    P = 0.5 R |v|^2 gives R_mech; v = n_c psi V / R gives n_c psi.
    """
    velocity_amplitude = velocity_pp_mps / 2.0
    resistance = 2.0 * power_w / velocity_amplitude**2
    force_factor = resistance * velocity_amplitude / (voltage_vpp / 2.0)
    return MotionalBranch(frequency_hz, q_mech, force_factor, resistance)


class CalibrationError(ValueError):
    """No motional branch makes the bench read the calibration values."""


def calibrate_branch_as_measured(surroundings: PlateLoad, frequency_hz: float, q_mech: float,
                                 voltage_vpp: float, velocity_pp_mps: float, power_w: float,
                                 *, rtol: float = 1e-13, max_iterations: int = 50) -> MotionalBranch:
    """The branch that makes the scope read the calibration values at resonance when
    the amplifier drives it through `surroundings` (C0, a series shunt, a lossy C0;
    its `branches` must be empty).

    Why: a published measurement was taken at the amplifier output (CH1, before the
    shunt) and its power is CH1 x CH2, which includes the shunt's R_s |I|^2 / 2 and C0's
    dielectric loss. The piezos see only V_p = V_out / (1 + R_s Y) and the mode must
    dissipate only what is left, P - P_shunt - P_dielectric. Both losses depend on the
    branch (through I and V_p), so the branch is recalibrated until it stops changing:
    R_s |Y| is a few per cent on the shipped plates, so about six passes reach `rtol`.
    Without shunt and dielectric loss the first pass is `calibrate_branch` exactly.
    """
    if surroundings.branches:
        raise ValueError("surroundings must hold no motional branch (only C0, shunt, dielectric)")
    omega = 2.0 * math.pi * frequency_hz
    output_v = voltage_vpp / 2.0  # amplitude, phase reference
    branch = calibrate_branch(frequency_hz, q_mech, voltage_vpp, velocity_pp_mps, power_w)
    piezo_v = complex(output_v)
    for _ in range(max_iterations):
        # At resonance Z_mech = R_mech: the branch is a real admittance (n_c psi)^2 / R.
        capacitive = complex(surroundings.capacitive_admittance(omega, abs(piezo_v)))
        admittance = capacitive + branch.force_factor_n_per_v**2 / branch.resistance_ns_per_m
        piezo_v = output_v / (1.0 + surroundings.series_ohm * admittance)
        current_a = admittance * piezo_v
        shunt_w = 0.5 * surroundings.series_ohm * abs(current_a) ** 2
        dielectric_w = 0.5 * abs(piezo_v) ** 2 * capacitive.real
        motional_w = power_w - shunt_w - dielectric_w
        if motional_w <= 0.0:
            raise CalibrationError(
                f"power {power_w:.4g} W at {voltage_vpp:.4g} Vpp does not cover the shunt "
                f"({shunt_w:.4g} W) and dielectric ({dielectric_w:.4g} W) losses")
        updated = calibrate_branch(frequency_hz, q_mech, 2.0 * abs(piezo_v), velocity_pp_mps, motional_w)
        converged = (math.isclose(updated.resistance_ns_per_m, branch.resistance_ns_per_m, rel_tol=rtol)
                     and math.isclose(updated.force_factor_n_per_v, branch.force_factor_n_per_v, rel_tol=rtol))
        branch = updated
        if converged:
            return branch
    raise CalibrationError(f"the branch behind the shunt and dielectric loss did not converge in "
                           f"{max_iterations} passes (losses too large against {power_w:.4g} W?)")


def velocity_pp_from_amplitude_pp(amplitude_pp_m: float, frequency_hz: float) -> float:
    """Sinusoidal motion: velocity pp = 2 pi f x amplitude pp (Table 4 obeys it)."""
    return 2.0 * math.pi * frequency_hz * amplitude_pp_m


@dataclass(frozen=True)
class DielectricLoss:
    """tan(delta) of C0 growing with the field: tan = tan_ref (E / E_ref)^exponent.

    A loss tangent linear in the field is the Rayleigh law of ferroelectric hysteresis
    (loss per cycle growing as E^3): negligible at low drive, visible at high voltage,
    which is what the paper saw in Fig. 2c.
    """

    tan_delta_at_reference: float
    reference_field_amplitude_v_per_m: float
    exponent: float
    piezo_thickness_m: float

    def tan_delta(self, voltage_amplitude_v: float) -> float:
        return damping.field_tan_delta(voltage_amplitude_v, self.piezo_thickness_m, self.tan_delta_at_reference,
                                       self.reference_field_amplitude_v_per_m, self.exponent)


@dataclass(frozen=True)
class PlateLoad:
    """What the amplifier drives: optional series shunt, then C0 parallel to the modes."""

    capacitance_f: float
    branches: tuple[MotionalBranch, ...]
    series_ohm: float = 0.0
    dielectric: DielectricLoss | None = None

    def capacitive_admittance(self, omega: np.ndarray, voltage_amplitude_v: float) -> np.ndarray:
        """j w C0 (1 - j tan delta): a lossy capacitor."""
        tan_delta = 0.0 if self.dielectric is None else self.dielectric.tan_delta(voltage_amplitude_v)
        return 1j * omega * self.capacitance_f * (1.0 - 1j * tan_delta)

    def with_branch_frequencies_scaled(self, factor: float) -> "PlateLoad":
        return replace(self, branches=tuple(
            replace(b, frequency_hz=b.frequency_hz * factor) for b in self.branches))


def resistor_load(resistance_ohm: float) -> PlateLoad:
    """A calibration resistor in the plate's place: no C0, one branch whose admittance is
    1/R at every frequency (q_mech ~ 0 leaves no reactance; nothing moves, visibility 0)."""
    return PlateLoad(capacitance_f=0.0, branches=(MotionalBranch(
        frequency_hz=1.0, q_mech=1e-12, force_factor_n_per_v=1.0, resistance_ns_per_m=resistance_ohm,
        visibility=0.0),))


@dataclass(frozen=True)
class SteadyState:
    """The plate and bench in sinusoidal steady state at one drive (all phasors are
    amplitudes per harmonic order; the fundamental is index 0)."""

    frequency_hz: float
    orders: np.ndarray
    output_voltage_phasors_v: np.ndarray  # amplifier output: what CH1 measures
    output_dc_v: float
    piezo_voltage_phasors_v: np.ndarray  # across the piezos (after the shunt)
    capacitive_current_phasors_a: np.ndarray
    branch_velocity_phasors_mps: np.ndarray  # (n_branches, n_orders), modal velocity
    branches: tuple[MotionalBranch, ...] = field(repr=False)

    @property
    def current_phasors_a(self) -> np.ndarray:
        forces = np.array([b.force_factor_n_per_v for b in self.branches])
        return self.capacitive_current_phasors_a + forces @ self.branch_velocity_phasors_mps

    @property
    def velocity_phasors_mps(self) -> np.ndarray:
        """Velocity at the measurement point: each mode weighted by its visibility there."""
        visibility = np.array([b.visibility for b in self.branches])
        return visibility @ self.branch_velocity_phasors_mps

    @property
    def piezo_voltage_phasor(self) -> complex:
        return complex(self.piezo_voltage_phasors_v[0])

    @property
    def current_phasor(self) -> complex:
        return complex(self.current_phasors_a[0])

    @property
    def velocity_phasor(self) -> complex:
        return complex(self.velocity_phasors_mps[0])

    @property
    def power_w(self) -> float:
        """Real power measured at the amplifier output (includes a series shunt)."""
        return _real_power_w(self.output_voltage_phasors_v, self.current_phasors_a)

    @functools.cached_property
    def plate_power_w(self) -> float:
        """Real power dissipated in the plate itself (heats it). Kept: a warming plate asks
        its steady state for it at every advance of the bench clock."""
        return _real_power_w(self.piezo_voltage_phasors_v, self.current_phasors_a)

    @property
    def output_voltage_pp_v(self) -> float:
        return waveform_pp(self.orders, self.output_voltage_phasors_v)

    @property
    def piezo_voltage_pp_v(self) -> float:
        return waveform_pp(self.orders, self.piezo_voltage_phasors_v)

    @property
    def current_pp_a(self) -> float:
        return waveform_pp(self.orders, self.current_phasors_a)

    @property
    def velocity_pp_mps(self) -> float:
        return waveform_pp(self.orders, self.velocity_phasors_mps)

    @property
    def amplitude_pp_m(self) -> float:
        """Displacement pp of the fundamental: velocity pp / (2 pi f)."""
        return 2.0 * abs(self.velocity_phasor) / (2.0 * math.pi * self.frequency_hz)


def _real_power_w(voltage_phasors: np.ndarray, current_phasors: np.ndarray) -> float:
    """Mean of v(t) i(t) over a period: 0.5 sum Re(V I*) (harmonics are orthogonal)."""
    return float(0.5 * np.sum(np.real(voltage_phasors * np.conj(current_phasors))))


def waveform_pp(orders: np.ndarray, phasors: np.ndarray) -> float:
    """Peak-to-peak of sum_k Re(X_k exp(j k phase)): 2|X| for a pure sine."""
    if len(orders) == 1:
        return 2.0 * float(abs(phasors[0]))
    phase = np.arange(_SAMPLES_PER_PERIOD) * (2.0 * np.pi / _SAMPLES_PER_PERIOD)
    wave = np.real(phasors @ np.exp(1j * np.outer(orders, phase)))
    return float(wave.max() - wave.min())


def solve_steady_state(load: PlateLoad, drive: Drive, frequency_hz: float) -> SteadyState:
    """Currents and velocities of `load` driven by `drive` at `frequency_hz`.

    The shunt and C0 form a divider; with a voltage-dependent dielectric loss the
    divider depends on the piezo voltage, solved by fixed-point iteration (the shunt is
    two ohms against hundreds of ohms of C0 reactance, so it converges in a few steps).
    """
    omega = 2.0 * np.pi * frequency_hz * drive.orders
    forces = np.array([b.force_factor_n_per_v for b in load.branches])
    impedances = np.array([b.impedance(omega) for b in load.branches])  # (n_b, n_k)
    motional_admittance = np.sum(forces[:, None] ** 2 / impedances, axis=0)
    piezo_v = drive.phasors_v
    for _ in range(50):
        capacitive = load.capacitive_admittance(omega, float(abs(piezo_v[0])))
        updated = drive.phasors_v / (1.0 + load.series_ohm * (capacitive + motional_admittance))
        # np.allclose(updated, piezo_v, rtol=1e-13, atol=0) without its overhead, which is
        # most of a solve on these few harmonics (and a solve runs per message of a drifting plate)
        converged = load.dielectric is None or bool(np.all(np.abs(updated - piezo_v) <= 1e-13 * np.abs(piezo_v)))
        piezo_v = updated
        if converged:
            break
    capacitive = load.capacitive_admittance(omega, float(abs(piezo_v[0])))
    return SteadyState(
        frequency_hz=frequency_hz,
        orders=drive.orders,
        output_voltage_phasors_v=drive.phasors_v,
        output_dc_v=drive.dc_v,
        piezo_voltage_phasors_v=piezo_v,
        capacitive_current_phasors_a=capacitive * piezo_v,
        branch_velocity_phasors_mps=forces[:, None] * piezo_v[None, :] / impedances,
        branches=load.branches,
    )


def steady_state(scene_state, electronics, frequency_hz: float, generator_vpp: float,
                 effects=None, *, generator_load_ohm: float = math.inf,
                 generator_offset_v: float = 0.0) -> SteadyState:
    """Closed-form steady state of a scene state on the bench, for tests and studies.

    `scene_state` is a `simbench.scene.State`, `electronics` a `simbench.scene.Electronics`
    and `effects` a `simbench.effects.EffectPipeline` (None: all effects off).
    """
    generator = GeneratorSettings(frequency_hz=frequency_hz, amplitude=generator_vpp,
                                  offset_v=generator_offset_v, load_ohm=generator_load_ohm)
    amplifier, load = electronics.amplifier(), scene_state.load()
    if effects is not None:
        amplifier = effects.amplifier(amplifier)
        load = effects.load(load)
    return solve_steady_state(load, amplifier_output(generator, amplifier), frequency_hz)
