"""Bench descriptions that lie, drawn at random: 200 pairs of a simulated bench (amplifier
gain, generator load setting, voltage probe, coded or not) and a bench file describing
another or the same (164 distinct pairs: the scenes are noise-free, so a pair drawn twice
runs once). Whatever the lie, no stored piezo voltage is above the limit or away
from its setpoint beyond the stated tolerance, a run stops with one clean message (a
BenchMismatch at open or the measured-against-commanded check at the first point) or
completes, and never with a traceback; a truthful description always completes."""

from __future__ import annotations

import random
from dataclasses import replace

import pytest

from squeezebench.errors import UserError
from squeezebench.instruments.bench import sim_bench_config
from squeezebench.protocols import campaign as campaign_module
from squeezebench.protocols.safety import SafetyLimits
from squeezebench.protocols.storage import read_measurements
from squeezebench.yamlfiles import dump_yaml, load_strict
from test_protocols_support import ONE_COLUMN_PLATE, noise_free_scene, write_campaign

LIMIT_VPP = 100.0
DRAWS, CHUNKS = 200, 4
GAINS, LOADS, PROBES = (10.0, 20.0, 40.0), ("50", "INF"), (10.0, 100.0)


def draw(rng: random.Random) -> tuple[dict, dict]:
    hardware = {"amplifier_gain": rng.choice(GAINS), "generator_load": rng.choice(LOADS),
                "voltage_probe_attenuation": rng.choice(PROBES), "voltage_probe_coded": rng.random() < 0.5,
                "amplifier_input_ohm": rng.choice((50.0, 1e6))}
    told = {"amplifier_gain": rng.choice(GAINS), "generator_load": rng.choice(LOADS),
            "voltage_probe_attenuation": rng.choice(PROBES)}
    if rng.random() < 0.15:   # some benches are described truthfully
        told = {k: hardware[k] for k in told}
    return hardware, told


def distinct_draws() -> list[tuple[dict, dict]]:
    """The DRAWS pairs, each once: a pair drawn again would make the same noise-free run again."""
    rng = random.Random(20261126)
    pairs: dict[tuple, tuple[dict, dict]] = {}
    for hardware, told in (draw(rng) for _ in range(DRAWS)):
        pairs.setdefault((tuple(hardware.items()), tuple(told.items())), (hardware, told))
    return list(pairs.values())


@pytest.mark.parametrize("chunk", range(CHUNKS))
def test_no_misdescription_stores_a_voltage_beyond_its_setpoint_or_the_limit(chunk, tmp_path, monkeypatch):
    draws = distinct_draws()[chunk::CHUNKS]
    tolerance = SafetyLimits().commanded_tolerance
    outcomes = {}
    for i, (hardware, told) in enumerate(draws):
        folder = tmp_path / f"bench{i}"
        folder.mkdir()
        scene = noise_free_scene(folder, "one_column_1mm.yaml")
        data = load_strict(scene.read_text())
        data.setdefault("electronics", {}).update(hardware)
        scene.write_text(dump_yaml(data))
        campaign = write_campaign(folder, [{"name": "sweep", "protocol": "characterisation", "plate": ONE_COLUMN_PLATE,
                                            "parameters": {"search": {"start_hz": 36000, "stop_hz": 38500, "points": 5,
                                                                      "tolerance_hz": 5.0},
                                                           "voltages_vpp": [20, 60, 90], "track_resonance": False}}],
                                  bench={"scene": str(scene)}, safety={"max_piezo_voltage_vpp": LIMIT_VPP},
                                  acquisition={"averages": 1, "record_length": 500, "periods_per_record": 10,
                                               "settle_s": 0.01})

        def described(path, told=told):
            config = sim_bench_config(path)
            return replace(config, electronics=replace(config.electronics, **told))

        monkeypatch.setattr(campaign_module, "sim_bench_config", described)
        try:
            campaign_module.run_campaign(campaign, out_dir=folder / "run", progress=False, say=lambda m: None)
            outcome = "completed"
        except UserError as stop:   # one clean message; anything else is a traceback and fails
            outcome = type(stop).__name__
            assert str(stop).count("\n") == 0, str(stop)
        outcomes[outcome] = outcomes.get(outcome, 0) + 1
        rows = read_measurements(folder / "run")
        if not rows.empty:
            measured = rows["scope_piezo_voltage_pp_v"]
            assert measured.max() <= LIMIT_VPP * (1 + SafetyLimits().measured_tolerance), (hardware, told)
            assert (measured <= rows["piezo_voltage_setpoint_vpp"] * (1 + tolerance) * 1.0001).all(), (hardware, told)
        if all(hardware[k] == v for k, v in told.items()):   # the truth: the run must not stop
            assert outcome == "completed", (hardware, told, outcome)
    assert sum(outcomes.values()) == len(draws)
