"""The simulated bench through PyVISA: ideal measurements equal the closed form, bench
time is accounted, timeouts behave like VISA, states and plates switch, noise repeats."""

from __future__ import annotations

import math

import numpy as np
import pytest
import pyvisa

from squeezebench.simbench import physics
from squeezebench.simbench.scene_model import SceneError
from squeezebench.simbench.scope import SCOPE_REARM_S
from test_sim_support import RawBench, sampled_truth, scene_file

F_HZ = 37180.0


@pytest.fixture()
def ideal(tmp_path):
    bench = RawBench(scene_file(tmp_path, effects=[]))
    bench.drive(F_HZ, 1.88)
    bench.configure(F_HZ)
    yield bench
    bench.close()


def test_ideal_measurements_equal_the_closed_form(ideal):
    ideal.acquire()
    truth = ideal.sim.truth()
    time_s, _, _, _ = ideal.fetch("CH1")
    expected = sampled_truth(truth, time_s, ideal.range_mps_per_v)
    # measurements gated on whole periods (the scope rounds its time base to 1-2-4): the
    # MATH mean is the real power to within the gate's one-sample granularity
    assert ideal.measure("MATH", "MEAN") == pytest.approx(truth.power_w, rel=1e-3)
    ideal.scope.write("MEASUREMENT:GATING OFF")   # the rest over the whole record
    for source in ("CH1", "CH2", "CH3"):
        sampled_pp = expected[source].max() - expected[source].min()
        assert ideal.measure(source, "PK2") == pytest.approx(sampled_pp, rel=1e-9)
    assert ideal.measure("CH1", "RMS") == pytest.approx(np.sqrt(np.mean(expected["CH1"] ** 2)), rel=1e-9)
    assert ideal.measure("CH1", "FREQ") == pytest.approx(F_HZ, rel=1e-5)


def test_ideal_truth_is_the_calibrated_plate_at_resonance(ideal):
    truth = ideal.sim.truth()
    state = ideal.sim.state
    divider = 1e6 / (1e6 + 50.0)  # 50-ohm generator into the 1 MOhm amplifier input
    piezo_vpp = 20 * 1.88 * divider
    calibration = state.calibration
    assert truth.piezo_voltage_pp_v == pytest.approx(piezo_vpp, rel=1e-12)
    assert truth.velocity_pp_mps == pytest.approx(calibration.velocity_pp_mps * piezo_vpp / 37.6, rel=1e-9)
    assert truth.power_w == pytest.approx(calibration.power_w * (piezo_vpp / 37.6) ** 2, rel=1e-9)


def test_curve_block_reproduces_the_trace(ideal):
    ideal.acquire()
    truth = ideal.sim.truth()
    for source in ("CH1", "CH2", "CH3"):
        time_s, values, raw, preamble = ideal.fetch(source)
        expected = sampled_truth(truth, time_s, ideal.range_mps_per_v)[source]
        assert np.all(raw == np.round(raw)) and raw.min() >= -32768 and raw.max() <= 32767
        # unquantised record: the block's 16-bit counts are the only rounding
        assert np.max(np.abs(values - expected)) <= 0.5 * preamble["y_mult"] * (1 + 1e-9)
    # the block is IEEE 488.2 definite length, big-endian int16, LF-terminated
    ideal.scope.write("DATA:SOURCE CH1")
    ideal.scope.write_termination = "\n"
    ideal.scope.write("CURVE?")
    block = ideal.scope.read_raw()
    digits = int(block[1:2])
    length = int(block[2:2 + digits])
    assert block[:1] == b"#" and len(block) == 2 + digits + length + 1 and block.endswith(b"\n")
    assert length == 2 * 500


def test_generator_load_50_doubles_the_drive(tmp_path):
    bench = RawBench(scene_file(tmp_path, effects=[]))
    bench.drive(F_HZ, 0.5, load="INF")
    at_inf = bench.sim.truth().piezo_voltage_pp_v
    bench.drive(F_HZ, 0.5, load="50")
    assert bench.sim.truth().piezo_voltage_pp_v == pytest.approx(2.0 * at_inf, rel=1e-12)
    assert at_inf == pytest.approx(20 * 0.5 * 1e6 / (1e6 + 50.0), rel=1e-12)


def test_bench_clock_accounts_for_acquisitions(ideal):
    start_s = ideal.sim.clock.now_s()
    ideal.acquire()
    record_s = 10 * float(ideal.scope.query("HORIZONTAL:MAIN:SCALE?"))
    expected_s = 16 * (record_s + SCOPE_REARM_S)
    spent_s = ideal.sim.clock.now_s() - start_s
    assert expected_s < spent_s < expected_s + 0.02  # plus a few bus messages
    ideal.sim.clock.sleep(2.5)
    assert ideal.sim.clock.now_s() - start_s == pytest.approx(spent_s + 2.5)


def test_opc_times_out_when_the_visa_timeout_is_shorter_than_the_acquisition(ideal):
    ideal.scope.timeout = 50  # ms, the acquisition takes about 170 ms
    ideal.scope.write("ACQUIRE:STATE RUN")
    before_s = ideal.sim.clock.now_s()
    with pytest.raises(pyvisa.VisaIOError) as error:
        ideal.scope.query("*OPC?")
    assert error.value.error_code == pyvisa.constants.VI_ERROR_TMO
    assert ideal.sim.clock.now_s() - before_s == pytest.approx(0.05, abs=0.005)
    ideal.scope.timeout = 5000
    assert ideal.scope.read() == "1"  # the reply came once the acquisition ended


def test_reading_a_silent_instrument_times_out_at_once_in_bench_time(ideal):
    ideal.vibrometer.timeout = 3000
    before_s = ideal.sim.clock.now_s()
    with pytest.raises(pyvisa.VisaIOError):
        ideal.vibrometer.read()
    assert ideal.sim.clock.now_s() - before_s == pytest.approx(3.0, abs=0.01)


def test_each_library_path_token_is_a_fresh_bench(tmp_path):
    scene = scene_file(tmp_path, effects=[])
    first, second = RawBench(scene), RawBench(scene)
    first.drive(F_HZ, 1.0)
    assert first.sim is not second.sim
    assert float(second.generator.query("FREQ?")) != F_HZ
    rm = pyvisa.ResourceManager(f"{scene}@simbench")  # no token works too
    assert rm.visalib.bench.scene.plate.name == "one_column_1mm"


def test_set_state_and_mount(tmp_path):
    bench = RawBench(scene_file(tmp_path, effects=[]))
    bench.drive(37160.0, 1.0)
    bench.sim.set_state("75x41")
    assert bench.sim.truth().velocity_pp_mps == pytest.approx(0.175 * 20.0 * 1e6 / (1e6 + 50.0) / 20.0, rel=1e-9)
    with pytest.raises(SceneError, match="76x41, 75x41, 59x41, 28x41"):
        bench.sim.set_state("80x41")
    bench.sim.mount(scene_file(tmp_path, "two_column_1p2mm.yaml", effects=[]))
    assert bench.sim.state_name == "one_powered"
    assert float(bench.generator.query("FREQ?")) == 37160.0  # instruments keep their settings


def test_steady_state_function_matches_the_bench(ideal):
    sim = ideal.sim
    closed = physics.steady_state(sim.state, sim.scene.electronics, F_HZ, 1.88)
    assert closed.power_w == pytest.approx(sim.truth().power_w, rel=1e-12)
    assert closed.amplitude_pp_m == pytest.approx(closed.velocity_pp_mps / (2 * math.pi * F_HZ), rel=1e-12)


def _noisy_record(bench: RawBench) -> np.ndarray:
    bench.acquire()
    return bench.fetch("CH2")[2]


def test_noise_is_reproducible_from_the_settings_not_from_history(tmp_path):
    scene = scene_file(tmp_path)  # the shipped effects: noise, quantisation...
    uninterrupted, resumed = RawBench(scene), RawBench(scene)
    for bench in (uninterrupted, resumed):
        bench.drive(F_HZ, 1.88)
        bench.configure(F_HZ, averages=4)
    first = _noisy_record(uninterrupted)
    second = _noisy_record(uninterrupted)
    assert not np.array_equal(first, second)  # a new acquisition draws new noise
    # the resumed bench has done other work before reaching the same settings
    resumed.drive(F_HZ + 50.0, 1.0)
    _noisy_record(resumed)
    resumed.drive(F_HZ, 1.88)
    assert np.array_equal(_noisy_record(resumed), first)
    assert np.array_equal(_noisy_record(resumed), second)


def test_a_moved_spot_draws_noise_of_its_own_and_the_same_spot_the_same(tmp_path):
    # A map writes its drive afresh at every step: were the spot not in the stream, a step at
    # an earlier step's setting would draw that step's noise again, point for point. CH2 (the
    # current) does not see the spot, so a difference between its records is the noise alone.
    from squeezebench.instruments.smc100 import SMC100Stage

    bench = RawBench(scene_file(tmp_path))
    try:
        bench.drive(F_HZ, 1.88)
        bench.configure(F_HZ, averages=4)
        stage = SMC100Stage(bench.rm.open_resource("ASRL2::INSTR"), poll_interval_s=0.01, sleep=bench.sim.clock.sleep)
        stage.home()
        records = []
        for x_mm in (10.0, 20.0, 10.0):
            stage.move_to_mm(x_mm, 5.0)
            bench.drive(F_HZ, 1.88)   # the step's drive: the stream's counter starts again
            records.append(_noisy_record(bench))
        assert not np.array_equal(records[0], records[1])
        assert np.array_equal(records[0], records[2])   # what defines it, not what came before
    finally:
        bench.close()
