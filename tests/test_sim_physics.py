"""The single-mode plate model obeys the paper's scaling laws (Eqs. 1, 25, 27, 28)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from squeezebench.simbench import physics

F_HZ = 37180.0
IDEAL_AMPLIFIER = physics.Amplifier(gain=20.0, input_ohm=math.inf)


def plate(n_powered: int = 4, force_per_piezo: float = 0.0142, resistance: float = 5.69):
    branch = physics.MotionalBranch(F_HZ, 310.0, n_powered * force_per_piezo, resistance)
    capacitance = physics.piezo_capacitance_f(n_powered, 45e-6, 0.5e-3, 1350.0)
    return physics.PlateLoad(capacitance_f=capacitance, branches=(branch,))


def solve(load, generator_vpp, frequency_hz=F_HZ, amplifier=IDEAL_AMPLIFIER):
    generator = physics.GeneratorSettings(frequency_hz=frequency_hz, amplitude=generator_vpp)
    return physics.solve_steady_state(load, physics.amplifier_output(generator, amplifier), frequency_hz)


def test_calibrated_branch_reproduces_velocity_and_power_at_resonance():
    branch = physics.calibrate_branch(F_HZ, 310.0, 37.6, 0.375, 0.100)
    capacitance = physics.piezo_capacitance_f(4, 45e-6, 0.5e-3, 1350.0)
    steady = solve(physics.PlateLoad(capacitance, (branch,)), 37.6 / 20.0)
    assert steady.velocity_pp_mps == pytest.approx(0.375, rel=1e-12)
    assert steady.power_w == pytest.approx(0.100, rel=1e-12)  # C0 is lossless


def test_amplitude_grows_with_n_c_times_v():
    """Eq. 1 / Eq. 27: A proportional to n_c V (same piezos, same plate)."""
    one, two = solve(plate(4), 1.0), solve(plate(8), 0.5)
    assert two.amplitude_pp_m == pytest.approx(one.amplitude_pp_m, rel=1e-12)
    assert solve(plate(4), 2.0).amplitude_pp_m == pytest.approx(2 * one.amplitude_pp_m, rel=1e-12)


def test_power_grows_with_v_squared():
    """Eq. 25 at a fixed plate."""
    assert solve(plate(), 2.0).power_w == pytest.approx(4 * solve(plate(), 1.0).power_w, rel=1e-12)


def test_power_at_a_given_amplitude_does_not_depend_on_n_c():
    """Eq. 28: twice the piezos at half the voltage give the same amplitude and power."""
    one, two = solve(plate(4), 1.0), solve(plate(8), 0.5)
    assert two.power_w == pytest.approx(one.power_w, rel=1e-12)


def test_resonance_and_q_mech():
    load = plate()
    peak = solve(load, 1.0).velocity_pp_mps
    half_bandwidth_hz = F_HZ / (2 * 310.0)
    edge = solve(load, 1.0, F_HZ + half_bandwidth_hz).velocity_pp_mps
    assert edge / peak == pytest.approx(1 / math.sqrt(2), rel=1e-3)
    assert load.branches[0].ring_time_constant_s == pytest.approx(310.0 / (math.pi * F_HZ))


def test_generator_and_amplifier_input():
    assert physics.generator_emf_vpp(1.0, 50.0) == 2.0
    assert physics.generator_emf_vpp(1.0, math.inf) == 1.0
    assert physics.divider_vpp(1.0, 50.0, 10e3) == pytest.approx(10e3 / 10050)
    rms = physics.GeneratorSettings(F_HZ, 1.0, voltage_unit="VRMS")
    assert rms.amplitude_vpp == pytest.approx(2 * math.sqrt(2))
    dbm = physics.GeneratorSettings(F_HZ, 10.0, voltage_unit="DBM")  # 10 mW into 50 ohm
    assert dbm.amplitude_vpp == pytest.approx(2 * math.sqrt(2) * math.sqrt(0.5))


def test_clipped_drive_keeps_its_fundamental_and_power_balance():
    amplifier = physics.Amplifier(gain=20.0, input_ohm=math.inf, max_output_vpp=300.0)
    steady = solve(plate(), 20.0, amplifier=amplifier)  # 400 Vpp asked
    assert len(steady.orders) > 1
    assert steady.output_voltage_pp_v == pytest.approx(300.0, rel=5e-3)
    phase = np.linspace(0, 2 * np.pi, 4096, endpoint=False)
    v = np.real(steady.output_voltage_phasors_v @ np.exp(1j * np.outer(steady.orders, phase)))
    i = np.real(steady.current_phasors_a @ np.exp(1j * np.outer(steady.orders, phase)))
    assert np.mean(v * i) == pytest.approx(steady.power_w, rel=1e-9)


def test_shunt_divides_the_drive():
    shunted = physics.PlateLoad(plate().capacitance_f, plate().branches, series_ohm=2.0)
    steady = solve(shunted, 1.0)
    assert steady.power_w - steady.plate_power_w == pytest.approx(abs(steady.current_phasor) ** 2, rel=1e-9)
    # 1 Vpp from the generator is 10 V amplitude at the amplifier output
    assert steady.piezo_voltage_phasor == pytest.approx(10.0 - 2.0 * steady.current_phasor, rel=1e-12)


def _lossy_surroundings(n_powered: int = 8, tan_delta_at_reference: float = 0.01) -> physics.PlateLoad:
    """C0 behind the 2-ohm shunt, lossy: a strong case (8 piezos, tan delta 4x the default)."""
    dielectric = physics.DielectricLoss(tan_delta_at_reference, 240e3, 1.0, 0.5e-3)
    return physics.PlateLoad(physics.piezo_capacitance_f(n_powered, 45e-6, 0.5e-3, 1350.0), (),
                             series_ohm=2.0, dielectric=dielectric)


def _at_resonance(load: physics.PlateLoad, output_vpp: float) -> physics.SteadyState:
    """Driven at the branch's resonance with exactly `output_vpp` at the amplifier output."""
    drive = physics.Drive(np.array([1]), np.array([output_vpp / 2.0 + 0j]), 0.0)
    return physics.solve_steady_state(load, drive, load.branches[0].frequency_hz)


def test_branch_calibrated_through_shunt_and_dielectric_loss_reads_the_calibration():
    """CH1 Vpp, CH1 x CH2 power and velocity pp at the calibration point are the targets,
    though the shunt and the lossy C0 take part of the power and of the voltage."""
    surroundings = _lossy_surroundings()
    branch = physics.calibrate_branch_as_measured(surroundings, 44720.0, 250.0, 12.0, 0.27, 0.100)
    steady = _at_resonance(replace(surroundings, branches=(branch,)), 12.0)
    assert steady.output_voltage_pp_v == pytest.approx(12.0, rel=1e-12)
    assert steady.power_w == pytest.approx(0.100, rel=1e-9)
    assert steady.velocity_pp_mps == pytest.approx(0.27, rel=1e-9)
    # the effects matter here: the plate alone would read well off
    plain = physics.calibrate_branch(44720.0, 250.0, 12.0, 0.27, 0.100)
    naive = _at_resonance(replace(surroundings, branches=(plain,)), 12.0)
    assert abs(naive.power_w / 0.100 - 1.0) > 5e-3
    assert abs(naive.velocity_pp_mps / 0.27 - 1.0) > 5e-3
    assert steady.plate_power_w < steady.power_w  # the shunt's loss is in the reading


def test_branch_calibrated_without_shunt_or_loss_is_calibrate_branch():
    plain = physics.PlateLoad(physics.piezo_capacitance_f(4, 45e-6, 0.5e-3, 1350.0), ())
    assert physics.calibrate_branch_as_measured(plain, F_HZ, 310.0, 37.6, 0.375, 0.100) == \
        physics.calibrate_branch(F_HZ, 310.0, 37.6, 0.375, 0.100)


def test_calibration_through_losses_larger_than_the_power_is_refused():
    with pytest.raises(physics.CalibrationError, match="does not cover the shunt"):
        physics.calibrate_branch_as_measured(_lossy_surroundings(tan_delta_at_reference=1.0),
                                             44720.0, 250.0, 120.0, 0.27, 0.100)
    with pytest.raises(physics.CalibrationError, match="did not converge"):
        physics.calibrate_branch_as_measured(_lossy_surroundings(), 44720.0, 250.0, 12.0, 0.27, 0.100,
                                             max_iterations=1)


# -- the electromechanical branch from datasheet constants ---------------------------------

def test_clamped_permittivity_is_the_free_one_reduced_by_k31():
    assert physics.clamped_relative_permittivity(physics.NCE41) == pytest.approx(1350 * (1 - 0.33**2))


def test_neutral_axis_of_equal_layers_is_their_interface():
    assert physics.neutral_axis_from_piezo_face_m(1e-3, 70e9, 1e-3, 70e9) == pytest.approx(1e-3)
    # a resonator with no stiffness leaves it at the piezo's mid-plane
    assert physics.neutral_axis_from_piezo_face_m(0.5e-3, 77e9, 2e-3, 1e-3) == pytest.approx(0.25e-3, rel=1e-6)


def test_a_patch_across_a_whole_half_wavelength_from_an_antinode_pushes_nothing():
    """phi' vanishes at both antinodes: the two end moments cancel (pin-force model)."""
    half = 8.44e-3
    assert physics.piezo_force_factor_n_per_v(physics.NCE41, 9e-3, 0.5e-3, 0.0, half, half) == pytest.approx(
        0.0, abs=1e-15)
    quarter = physics.piezo_force_factor_n_per_v(physics.NCE41, 9e-3, 0.5e-3, 0.0, half / 2, half)
    e31 = 130e-12 / 13e-12
    assert quarter == pytest.approx(e31 * 9e-3 * 0.5e-3 * math.pi / half, rel=1e-12)


def test_mean_square_of_the_mode_over_whole_half_wavelengths_is_one_half():
    assert physics.mean_square_mode(0.0, 3 * 8.44e-3, 8.44e-3) == pytest.approx(0.5, rel=1e-12)
    assert physics.mean_square_mode(0.0, 1e-9, 8.44e-3) == pytest.approx(1.0, rel=1e-9)


def test_branch_from_physics_has_the_modal_mass_it_was_given():
    branch = physics.branch_from_physics(F_HZ, 250.0, 4.6e-3, 0.06)
    assert physics.modal_mass_kg(branch) == pytest.approx(4.6e-3, rel=1e-12)


def test_effective_coupling_is_the_resonance_antiresonance_spacing():
    """k_eff^2 = (f_a^2 - f_r^2) / f_a^2: with little loss, the |Y| maximum and minimum."""
    branch = physics.branch_from_physics(F_HZ, 1e6, 4.6e-3, 0.2)
    capacitance = 4e-9
    frequency = np.linspace(0.99 * F_HZ, 1.05 * F_HZ, 400_001)
    omega = 2 * np.pi * frequency
    admittance = np.abs(1j * omega * capacitance + branch.force_factor_n_per_v**2 / branch.impedance(omega))
    f_r, f_a = frequency[np.argmax(admittance)], frequency[np.argmin(admittance)]
    assert physics.effective_coupling(branch, capacitance) == pytest.approx(
        math.sqrt((f_a**2 - f_r**2) / f_a**2), rel=1e-3)


def test_motional_elements_resonate_at_the_branch_frequency_with_its_q():
    branch = physics.branch_from_physics(F_HZ, 250.0, 4.6e-3, 0.06)
    r_ohm, l_h, c_f = physics.motional_elements(branch)
    assert 1 / (2 * math.pi * math.sqrt(l_h * c_f)) == pytest.approx(F_HZ, rel=1e-12)
    assert 2 * math.pi * F_HZ * l_h / r_ohm == pytest.approx(250.0, rel=1e-12)
