"""No generator command of any campaign puts more than the run's limit on the piezos.

Every amplitude reaching the instrument bus (PyVISA writes, below the drivers) is recorded
across randomized campaign settings: limits, ramp steps, velocity targets beyond reach,
voltage sweeps partly above the limit. A requested voltage above the limit is refused when
the campaign is loaded (CampaignError naming the field), before any bench opens; voltages
a protocol derives while running (a detuning's regain) are held by the DriveController.
"""

from __future__ import annotations

import re

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from pyvisa.resources import MessageBasedResource

from squeezebench.instruments.bench import sim_bench_config
from squeezebench.protocols.campaign import CampaignError, run_campaign
from test_protocols_support import ONE_COLUMN_PLATE, noise_free_scene, write_campaign

AMPLITUDE_COMMAND = re.compile(r"^VOLT\s+([-+0-9.eE]+)\s*$")


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    return noise_free_scene(tmp_path_factory.mktemp("scene"), "one_column_1mm.yaml")


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(limit_vpp=st.floats(15.0, 150.0), ramp_step_vpp=st.floats(1.0, 60.0),
       level_pp_mps=st.sampled_from([0.05, 0.2, 0.4, 0.8]),
       voltages_vpp=st.lists(st.floats(2.0, 200.0), min_size=1, max_size=3))
def test_no_amplitude_above_the_limit(tmp_path_factory, monkeypatch, scene, limit_vpp, ramp_step_vpp,
                                      level_pp_mps, voltages_vpp):
    tmp_path = tmp_path_factory.mktemp("safety")
    search = {"start_hz": 36000, "stop_hz": 38500, "points": 11, "tolerance_hz": 2.0,
              "piezo_voltage_vpp": min(10.0, limit_vpp)}
    campaign = write_campaign(tmp_path, [
        {"name": "detuning", "protocol": "detuning", "plate": ONE_COLUMN_PLATE,
         "parameters": {"search": search, "velocity_levels_pp_mps": [level_pp_mps], "velocity_ratios": [0.5]}},
        {"name": "sweep", "protocol": "characterisation", "plate": ONE_COLUMN_PLATE,
         "parameters": {"search": search, "voltages_vpp": voltages_vpp, "track_resonance": False}},
    ], bench={"scene": str(scene)},
        safety={"max_piezo_voltage_vpp": limit_vpp, "ramp_step_vpp": ramp_step_vpp})
    sent_vpp = []
    original = MessageBasedResource.write

    def recording_write(resource, message, *args, **kwargs):
        match = AMPLITUDE_COMMAND.match(message.strip())
        if match:
            sent_vpp.append(float(match.group(1)))
        return original(resource, message, *args, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(MessageBasedResource, "write", recording_write)
        if max(voltages_vpp) > limit_vpp:
            # refused when the campaign is loaded, naming the field: nothing is sent at all
            with pytest.raises(CampaignError, match=r"voltages_vpp\[\d\]'.*above the run's limit"):
                run_campaign(campaign, out_dir=tmp_path / "run")
            assert sent_vpp == [] and not (tmp_path / "run").exists()
            return
        run_campaign(campaign, out_dir=tmp_path / "run")
    # Piezo Vpp per generator Vpp through the scene's chain (load setting, 50 ohm into the
    # amplifier input, gain): 20 x 1 MOhm / (1 MOhm + 50 ohm) here.
    gain = sim_bench_config(scene).electronics.piezo_vpp_per_generator_vpp
    assert sent_vpp, "no amplitude command recorded: the recorder missed the bus"
    assert max(sent_vpp) * gain <= limit_vpp * (1 + 1e-9)
    # Rises come in ramp steps (falls may be a drop to the minimum, on error).
    rises_vpp = [(b - a) * gain for a, b in zip(sent_vpp, sent_vpp[1:]) if b > a]
    assert max(rises_vpp, default=0.0) <= ramp_step_vpp * (1 + 1e-6) + 1e-6
