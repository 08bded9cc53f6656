"""Public drivers of the bench's instruments, written by others, as clients of the
simulated bench: what a user's own script meets in the dry run. A peer's failure is
judged by the manual: where the peer is wrong, the test says so and the simulator stays
on the manual's side.

Peers checked on the registries: PyMeasure's `HP33120A` (below). No other public driver of
the 33120A, the TDS 3000 series, the OFV-5000 or the SMC100 installs from PyPI and talks
VISA: PyMeasure has the TDS 2000 only, QCoDeS and InstrumentKit other Keysight and
Tektronix models, hvl-ccb's SMC100PP driver opens its own serial port."""

from __future__ import annotations

import warnings

import pytest
from pymeasure.instruments.hp import HP33120A

from test_sim_support import scene_file

#: (property, value) in the order a user sets them; each is read back at once.
SETTINGS = [("shape", "square"), ("shape", "sinusoid"), ("frequency", 12345.6), ("amplitude", 0.5),
            ("offset", 0.25), ("amplitude_units", "Vrms"), ("amplitude", 0.3), ("amplitude_units", "dBm"),
            ("amplitude_units", "Vpp"), ("burst_count", 7), ("burst_rate", 250.0), ("burst_phase", -45.0),
            ("burst_source", "EXT"), ("burst_source", "INT"), ("burst_enabled", True), ("burst_enabled", False)]


@pytest.fixture
def generator(tmp_path):
    with warnings.catch_warnings():   # PyMeasure asks whether the 33120A speaks SCPI: it does (UG Ch. 4)
        warnings.simplefilter("ignore", FutureWarning)
        peer = HP33120A("GPIB0::10::INSTR", visa_library=f"{scene_file(tmp_path)}#peer@simbench", timeout=2000)
    yield peer
    peer.adapter.close()


def test_pymeasure_hp33120a_sets_and_reads_back_every_property(generator):
    """Shape, frequency, amplitude, amplitude unit, offset and the burst settings, each
    set then read back equal, the limits PyMeasure asks for answered, and an empty error
    queue afterwards."""
    for name, value in SETTINGS:
        setattr(generator, name, value)
        assert getattr(generator, name) == pytest.approx(value) if isinstance(value, float) \
            else getattr(generator, name) == value, name
    assert generator.min_frequency == pytest.approx(100e-6) and generator.max_frequency == pytest.approx(15e6)
    assert generator.min_burst_count == 1 and generator.max_burst_count == 50000
    assert generator.min_burst_phase == -360 and generator.max_burst_phase == 360
    assert generator.min_amplitude < generator.amplitude < generator.max_amplitude
    assert generator.min_offset < generator.offset < generator.max_offset
    generator.beep()
    assert generator.ask("SYST:ERR?").strip() == '+0,"No error"'


def test_pymeasure_default_amplitude_unit_reads_back_as_the_manual_says(generator):
    """PyMeasure maps 'default' to `VOLT:UNIT DEF`; the 33120A's default unit is Vpp
    (UG Ch. 4 VOLTage:UNIT), so the read-back is 'Vpp', not 'default': the manual's
    answer, not a simulator defect."""
    generator.amplitude_units = "default"
    assert generator.amplitude_units == "Vpp"
    assert generator.ask("SYST:ERR?").strip() == '+0,"No error"'


def test_the_burst_pymeasure_sets_reaches_the_drive(generator):
    """BM:STATe is modelled (the drive is burst-modulated); the burst count, rate and
    phase are state only (`state_only`): the modulation keeps its *RST parameters."""
    bench = generator.adapter.connection.visalib.bench
    amplitude_vpp = bench.generator.settings().amplitude
    generator.frequency = 10e3
    generator.burst_enabled = True
    assert bench.generator.settings().amplitude < amplitude_vpp
