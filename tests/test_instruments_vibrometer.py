"""OFV-5000 driver, byte for byte against Polytec's RS-232 line protocol: echo on at
power-on, the controller's own spelling of values, the decoder's range list, `Error` for
a refused line; independent of the simulator."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import CLEAR, expected_protocol
from squeezebench.instruments.errors import GarbledReply, InstrumentError, OutOfRangeError
from squeezebench.instruments.ofv5000 import OFV5000, range_mps_per_v

VD09 = "5mm/s/V,10mm/s/V,20mm/s/V,50mm/s/V,100mm/s/V,200mm/s/V,500mm/s/V,1000mm/s/V"
ECHO_OFF = "Set,Interface,0,Echo,Off"
#: Echo already off: the Get answers Off at once.
QUIET = [(CLEAR, None), (ECHO_OFF, None), ("Get,Interface,0,Echo", "Off"), ("GetDevInfo,VeloDec,0,Range", VD09)]


def test_connect_with_echo_on_reads_the_echo_of_its_own_line():
    script = [(CLEAR, None), (ECHO_OFF, ECHO_OFF), ("Get,Interface,0,Echo", "Off"),
              ("GetDevInfo,VeloDec,0,Range", VD09), ("GetDevInfo,Controller,0,Name", "OFV-5000")]
    with expected_protocol(OFV5000, script) as vibrometer:
        assert vibrometer.identify() == "OFV-5000"


def test_the_ranges_are_the_installed_decoders():
    with expected_protocol(OFV5000, QUIET[:3] + [("GetDevInfo,VeloDec,0,Range", "5mm/s/V,25mm/s/V,125mm/s/V,"
                                                                                 "1000mm/s/V")]) as vibrometer:
        assert vibrometer.ranges_mps_per_v == {"5mm/s/V": 0.005, "25mm/s/V": 0.025, "125mm/s/V": 0.125,
                                               "1000mm/s/V": 1.0}
    with expected_protocol(OFV5000, QUIET) as vibrometer:
        assert list(vibrometer.ranges_mps_per_v) == VD09.split(",")


def test_setting_a_range_reads_it_back():
    with expected_protocol(OFV5000, QUIET + [("Set,VeloDec,0,Range,100mm/s/V", None),
                                             ("Get,VeloDec,0,Range", "100mm/s/V"),
                                             ("Get,VeloDec,0,Range", "100mm/s/V")]) as vibrometer:
        vibrometer.velocity_range_mps_per_v = 0.1
        assert vibrometer.velocity_range_mps_per_v == 0.1


def test_a_range_the_decoder_does_not_have_is_refused_before_sending():
    with expected_protocol(OFV5000, QUIET) as vibrometer:
        with pytest.raises(OutOfRangeError, match="25mm/s/V"):
            vibrometer.velocity_range = "25mm/s/V"


def test_filters_in_the_controllers_spelling():
    with expected_protocol(OFV5000, QUIET + [("Set,VeloFilter,0,LowPassRange,100 kHz", None),
                                             ("Get,VeloFilter,0,LowPassRange", "100 kHz"),
                                             ("Set,VeloFilter,0,HighPassRange,Off", None),
                                             ("Get,VeloFilter,0,HighPassRange", "Off"),
                                             ("Set,TrackingFilter,0,Range,Off", None),
                                             ("Get,TrackingFilter,0,Range", "Off")]) as vibrometer:
        vibrometer.prepare_for_measurement()


def test_a_refused_set_is_reported_and_the_link_stays_in_step():
    # the controller answers Error to the Set; the read-back's own reply follows it
    with expected_protocol(OFV5000, QUIET + [("Set,VeloDec,0,Range,5mm/s/V", "Error"),
                                             ("Get,VeloDec,0,Range", "1000mm/s/V"),
                                             ("Get,OverRange,0,Value", "0")]) as vibrometer:
        with pytest.raises(InstrumentError, match=r"refused 'Set,VeloDec,0,Range,5mm/s/V' \(Error\)"):
            vibrometer.set_range("5mm/s/V")
        assert vibrometer.over_range() is False   # the next exchange is in step


def test_a_refused_get_is_reported():
    with expected_protocol(OFV5000, QUIET + [("Get,SignalLevel,0,Value", "Error")]) as vibrometer:
        with pytest.raises(InstrumentError, match=r"refused 'Get,SignalLevel,0,Value'"):
            vibrometer.signal_level_percent()


def test_live_readings_and_their_garbled_forms():
    with expected_protocol(OFV5000, QUIET + [("Get,OverRange,0,Value", "1"), ("Get,SignalLevel,0,Value", "80"),
                                             ("Get,SignalLevel,0,Value", "140")]) as vibrometer:
        assert vibrometer.over_range() is True
        assert vibrometer.signal_level_percent() == 80.0
        with pytest.raises(GarbledReply, match="0 to 100"):
            vibrometer.signal_level_percent()


def test_volts_to_velocity():
    with expected_protocol(OFV5000, QUIET) as vibrometer:
        assert vibrometer.volts_to_velocity_mps(np.array([1.0, -2.0]), 0.125) == pytest.approx([0.125, -0.25])


@pytest.mark.parametrize("name, mps_per_v", [("5mm/s/V", 0.005), ("1m/s/V", 1.0), ("0.2mm/s/V", 2e-4)])
def test_range_names(name, mps_per_v):
    assert range_mps_per_v(name) == pytest.approx(mps_per_v)
