"""Safe from the first message: a generator a previous user left driving (an amplitude and a
2 V offset, which the x20 amplifier turns into some 40 V DC on the piezos) is at its
minimum, offset 0, before the driver reads anything from it. On the simulated bench, whose
33120A follows its guide, not our driver."""

from __future__ import annotations

import itertools

import pyvisa

from squeezebench import paths
from squeezebench.instruments.agilent33120a import Agilent33120A

_TOKENS = itertools.count()


class Recorder:
    """The PyVISA resource, noting with every message what the generator's output was as it arrived."""

    def __init__(self, resource, generator_state) -> None:
        self._resource, self._state, self.log = resource, generator_state, []

    def __getattr__(self, name):
        return getattr(self._resource, name)

    def _note(self, message: str) -> None:
        self.log.append((message, self._state["offset"], self._state["amplitude_vpp"]))

    def write(self, message: str):
        self._note(message)
        return self._resource.write(message)

    def query(self, message: str):
        self._note(message)
        return self._resource.query(message)


def test_a_generator_left_at_2_v_offset_is_at_rest_before_anything_is_read():
    rm = pyvisa.ResourceManager(f"{paths.default_scene()}#safe{next(_TOKENS)}@simbench")
    try:
        state = rm.visalib.bench.generator.state
        state.update({"offset": 2.0, "amplitude_vpp": 5.0})   # what a previous user left on
        resource = rm.open_resource("GPIB0::10::INSTR", read_termination="\n", write_termination="\n")
        recorder = Recorder(resource, state)
        generator = Agilent33120A(recorder)
        generator.identify()
        first_read = next(i for i, (message, *_) in enumerate(recorder.log) if "?" in message)
        # the output after each message: at rest within the first three, before anything is read
        states_after = [(offset_v, amplitude_vpp) for _, offset_v, amplitude_vpp in recorder.log[1:]] + \
            [(state["offset"], state["amplitude_vpp"])]
        rest_index = next(i for i, (offset_v, amplitude_vpp) in enumerate(states_after)
                          if offset_v == 0.0 and amplitude_vpp <= 0.1)
        assert rest_index <= 2, recorder.log[:4]          # at most three messages with the offset on
        assert first_read > rest_index, recorder.log[:first_read + 1]
        assert generator.offset_v == 0.0 and generator.amplitude_vpp == generator.min_amplitude_vpp
        assert generator.read_errors() == []
    finally:
        rm.close()
