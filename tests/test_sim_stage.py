"""The simulated SMC100 stage against the manual's grammar and state, driven through the
real driver over a byte-level link: homing, moves timed on the bench clock, refusals."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from squeezebench.instruments.errors import InstrumentError, OutOfRangeError
from squeezebench.instruments.smc100 import SMC100Stage
from squeezebench.simbench.clock import BUS_TIMINGS, VirtualClock
from squeezebench.analysis.cartography import move_time_s
from squeezebench.simbench.stage import Stage


class Link:
    """Bytes between the driver and the simulated controllers, as a VISA session carries them."""

    resource_name = "ASRL2::INSTR"

    def __init__(self, device: Stage) -> None:
        self.device = device
        self.read_termination = self.write_termination = None
        self.timeout = 2000.0
        self.sent: list[str] = []

    def write(self, message: str) -> None:
        self.sent.append(message)
        self.device.write((message + self.write_termination).encode())

    def read(self) -> str:
        data = b""
        while not data.endswith(self.read_termination.encode()):
            chunk, _ = self.device.read(1024, self.timeout / 1000.0)
            data += chunk
        return data.decode()[:-len(self.read_termination)]

    def query(self, message: str) -> str:
        self.write(message)
        return self.read()


@pytest.fixture
def bench():
    bench = SimpleNamespace(clock=VirtualClock(), effects=SimpleNamespace(bus=()), messages_received=0)
    bench.stage = Stage(bench, BUS_TIMINGS["asrl"], {})
    return bench


def driver(bench):
    link = Link(bench.stage)
    return SMC100Stage(link, poll_interval_s=0.01, sleep=bench.clock.sleep), link


def test_move_times_are_the_trapezoidal_profile():
    assert move_time_s(100.0, 20.0, 80.0) == pytest.approx(100 / 20 + 20 / 80)
    assert move_time_s(2.0, 20.0, 80.0) == pytest.approx(2 * (2.0 / 80) ** 0.5)
    assert move_time_s(-2.0, 20.0, 80.0) == move_time_s(2.0, 20.0, 80.0)


def test_the_stage_powers_on_not_referenced_and_refuses_a_move_with_H(bench):
    stage, link = driver(bench)
    assert stage.travel_mm == {"x": (0.0, 300.0), "y": (0.0, 200.0)}
    assert not stage.homed()
    with pytest.raises(InstrumentError, match="H, command not allowed in NOT REFERENCED"):
        stage.move_to_mm(10.0, 10.0)


def test_homing_then_a_move_costs_its_bench_time_and_lands_on_the_point(bench):
    stage, link = driver(bench)
    stage.home()
    assert stage.homed()
    before = bench.clock.now_s()
    assert stage.move_to_mm(100.0, 2.0) == (100.0, 2.0)
    elapsed = bench.clock.now_s() - before
    assert move_time_s(100.0, 20.0, 80.0) <= elapsed < move_time_s(100.0, 20.0, 80.0) + 0.2
    assert bench.stage.point_mm() == (100.0, 2.0)


def test_a_point_beyond_travel_is_refused_by_the_driver_before_it_is_sent(bench):
    stage, link = driver(bench)
    stage.home()
    sent = len(link.sent)
    with pytest.raises(OutOfRangeError, match=r"x = 310\.000 mm, y = 5\.000 mm"):
        stage.move_to_mm(310.0, 5.0)
    assert len(link.sent) == sent


def test_the_controller_itself_refuses_beyond_its_limits_and_unknown_commands(bench):
    stage, link = driver(bench)
    stage.home()
    for line, letter in (("1PA400", "C"), ("1PX1", "A"), ("2OR", "K"), ("1VA0", "C")):
        link.write(line)
        assert link.query("1TE" if line[0] == "1" else "2TE")[3:] == letter
    assert link.query("1TE") == "1TE@"   # read once, the letter is cleared
    link.write("3TS")                    # no controller at address 3: silence, not a reply
    assert not bench.stage._replies


def test_stop_leaves_the_axis_where_it_was_on_its_way(bench):
    stage, link = driver(bench)
    stage.home()
    link.write("1PA200")
    bench.clock.sleep(move_time_s(200.0, 20.0, 80.0) / 2)
    stage.stop()
    x_mm = stage.position_mm("x")
    assert 0.0 < x_mm < 200.0
    assert link.query("1TS") == "1TS000033"


def test_the_maps_bench_time_estimate_is_what_the_simulated_stage_takes(bench):
    from squeezebench.protocols.cartography import Grid, map_bench_time_s
    stage, link = driver(bench)
    stage.home()
    points = Grid((10.0, 30.0), (10.0, 20.0), step_mm=5.0).points_mm()
    before = bench.clock.now_s()
    for x_mm, y_mm in points:
        stage.move_to_mm(x_mm, y_mm)
    elapsed = bench.clock.now_s() - before
    estimate = map_bench_time_s(points, (0.0, 0.0), 20.0, 80.0, settle_s=0.0, acquisition_s=0.0)
    # the estimate has the moves; the bench also spends the messages and the polling granularity
    assert estimate <= elapsed < estimate + 0.1 * len(points)


def test_on_the_simulated_bench_the_stage_moves_the_laser_spot_over_the_mode():
    import numpy as np
    import pyvisa

    from squeezebench.paths import scenes_dir
    from squeezebench.simbench.modeshape import mode_shape, working_mode

    rm = pyvisa.ResourceManager(f"{scenes_dir() / 'large_plate.yaml'}@simbench")
    try:
        bench = rm.visalib.bench
        untouched = bench.sensor_gains()[2] * bench.vibrometer.range_mps_per_v()
        assert untouched == 1.0                     # a stage that never moved costs nothing
        stage = SMC100Stage(rm.open_resource("ASRL2::INSTR"), poll_interval_s=0.01, sleep=bench.clock.sleep)
        stage.home()
        gains = []
        for x_mm in np.arange(1.0, 198.0, 1.0):
            stage.move_to_mm(x_mm, 69.0)
            gains.append(bench.sensor_gains()[2] * bench.vibrometer.range_mps_per_v())
        assert np.allclose(gains, mode_shape(bench.scene, bench.state, np.arange(1.0, 198.0, 1.0), 69.0))
        modes, k = working_mode(bench.scene, bench.state)
        assert np.count_nonzero(np.diff(np.sign(gains)) != 0) == len(modes.nodal_lines_m(k))
        stage.move_to_mm(250.0, 69.0)               # within travel, beyond the plate's 198 mm
        assert bench.sensor_gains()[2] == 0.0
    finally:
        rm.close()

