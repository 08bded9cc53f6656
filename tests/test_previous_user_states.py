"""Whatever state a previous user left the bench in, a run measures what it measures from
power-on: 25 states drawn at random among the settings the instruments' manuals allow
(`simbench.devices.previous_user_start`: input impedance, offsets, verbose off, math,
trigger, modulation, filters, the stage), each through a small campaign of the quick
campaign's two kinds of step (and a fifth of them through `check`), compared row for row
with the power-on run, with no command refused on the way. Among these 25 every one of the
instruments' 76 settings takes each value it takes among the first 50 states, but for two
of the scope's settings' rarest values (an averaging count, a measurement type) and the
continuous ones. `benchmarks/bench_previous_users.py` runs 50 states (or as many as asked)
through the whole quick and paper campaigns the same way."""

from __future__ import annotations

import functools

import pandas as pd
import pytest
import pyvisa

import small_quick
from squeezebench import paths
from squeezebench.instruments.bench import check_bench, sim_bench_config
from squeezebench.protocols import campaign
from squeezebench.simbench import scpi_device

STATES = 25
CHUNKS = 5   # the states split so that parallel workers share them
COLUMNS = ["run_name", "step_id", "point_index", "generator_frequency_hz", "generator_amplitude_vpp",
           "scope_piezo_voltage_pp_v", "scope_power_w", "scope_velocity_pp_v", "vibrometer_scale_mps_per_v"]
CAMPAIGN = small_quick.HEADER + small_quick.MEASURING_RUNS   # quick's two kinds of measuring step


def measure(start: str, tmp_path, monkeypatch) -> pd.DataFrame:
    monkeypatch.setattr(campaign, "sim_bench_config", functools.partial(sim_bench_config, start=start))
    path = tmp_path / f"{start}.yaml"
    path.write_text(CAMPAIGN, encoding="utf-8")
    run_dir = campaign.run_campaign(path, out_dir=tmp_path / start, progress=False)
    return pd.concat([pd.read_parquet(p) for p in sorted((run_dir / "measurements").rglob("*.parquet"))]
                     )[COLUMNS].reset_index(drop=True)


@pytest.fixture(scope="module")
def power_on(tmp_path_factory) -> pd.DataFrame:
    with pytest.MonkeyPatch.context() as patch:
        return measure("power_on", tmp_path_factory.mktemp("power_on"), patch)


def test_the_drawn_states_differ_in_what_a_measurement_depends_on():
    """The draw is not a near-copy of power-on: across the states each risky setting
    takes several values (otherwise the comparison below could not fail)."""
    seen: dict[str, set] = {}
    for seed in range(1, STATES + 1):
        bench = _bench(f"previous-{seed}")
        scope = bench.scope
        for name, value in {"CH1 impedance": scope.state["impedance", 1], "CH3 impedance": scope.state["impedance", 3],
                            "CH1 offset": scope.state["offset", 1], "acquire mode": scope.state["acquire_mode"],
                            "trigger source": scope.state["trigger_source"], "verbose": scope.verbose,
                            "modulation": bench.generator.state["modulation"],
                            "low-pass": bench.vibrometer.state["low_pass"],
                            "tracking": bench.vibrometer.state["tracking"]}.items():
            seen.setdefault(name, set()).add(value)
    assert all(len(values) >= 2 for values in seen.values()), seen
    assert len(seen["modulation"]) == 6 and len(seen["CH1 offset"]) > 10


def _bench(start: str):
    """A simulated bench started in `start`, as the VISA library builds it."""
    manager = pyvisa.ResourceManager(sim_bench_config(paths.default_scene(), start=start).visa_library)
    try:
        return manager.visalib.bench
    finally:
        manager.close()


@pytest.mark.parametrize("chunk", range(CHUNKS))
def test_a_run_from_a_previous_users_state_measures_what_one_from_power_on_does(chunk, power_on, tmp_path,
                                                                                  monkeypatch):
    for seed in range(1 + chunk, STATES + 1, CHUNKS):
        start = f"previous-{seed}"
        with scpi_device.recorded_refusals() as refused:
            if seed % CHUNKS == 1:   # a tenth of them through `check` too (it opens as a run does)
                lines: list[str] = []
                assert check_bench(sim_bench_config(paths.default_scene(), start=start), out=lines.append) == 0, \
                    "\n".join(lines)
            rows = measure(start, tmp_path, monkeypatch)
        pd.testing.assert_frame_equal(rows, power_on, obj=f"rows measured from {start}")
        assert not refused, f"{start}: {refused}"
