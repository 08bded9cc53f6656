"""The shipped quick and paper campaigns from many previous users' states (prints figures;
not a test: the whole paper campaign takes half a minute of one core per state).

Each state is `simbench.devices.previous_user_start` with its seed: every setting of the
simulated instruments drawn among the values their manuals allow. A state passes when the
campaign's rows equal those measured from power-on and neither the generator nor the scope
refused a command on the way. tests/test_previous_user_states.py runs 25 states through a
small campaign of the same steps on every test run; this is the full-size check.

Run: python benchmarks/bench_previous_users.py [--states 50] [--campaigns quick paper]
"""

from __future__ import annotations

import argparse
import functools
import os
import sys
import tempfile
import time
from pathlib import Path

import pandas as pd

from reference import measure as measure_reference   # benchmarks/, the script's own folder

from squeezebench import paths
from squeezebench.instruments.bench import sim_bench_config
from squeezebench.protocols import campaign
from squeezebench.protocols.parallel import map_unordered
from squeezebench.workers import default_workers
from squeezebench.simbench import scpi_device

COLUMNS = ["run_name", "step_id", "point_index", "generator_frequency_hz", "generator_amplitude_vpp",
           "scope_piezo_voltage_pp_v", "scope_power_w", "scope_velocity_pp_v", "vibrometer_scale_mps_per_v"]


def measured(task: tuple[str, str]) -> tuple[str, str, pd.DataFrame | str, list[str]]:
    """(campaign, start, its rows or why it failed, the commands refused) of one run."""
    name, start = task
    campaign.sim_bench_config = functools.partial(sim_bench_config, start=start)
    with tempfile.TemporaryDirectory() as out, scpi_device.recorded_refusals() as refused:
        try:
            run_dir = campaign.run_campaign(paths.campaigns_dir() / f"{name}.yaml", out_dir=Path(out) / "run",
                                            progress=False)
        except Exception as exc:   # reported, not raised: one bad state must not hide the others
            return name, start, f"{type(exc).__name__}: {exc}", list(refused)
        rows = pd.concat([pd.read_parquet(p) for p in sorted((run_dir / "measurements").rglob("*.parquet"))])
    return name, start, rows[COLUMNS].reset_index(drop=True), refused


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--states", type=int, default=50)
    parser.add_argument("--campaigns", nargs="+", default=["quick", "paper"])
    args = parser.parse_args(argv)
    tasks = [(name, start) for name in args.campaigns
             for start in ("power_on", *(f"previous-{seed}" for seed in range(1, args.states + 1)))]
    workers = default_workers()
    unit = measure_reference()
    print(unit.line())
    begin = time.perf_counter()
    results = {(name, start): (rows, refused) for _, (name, start, rows, refused)
               in map_unordered(measured, tasks, workers=workers)}
    failed = 0
    for name in args.campaigns:
        reference = results[name, "power_on"][0]
        if isinstance(reference, str):
            print(f"{name}: the power-on run failed: {reference}")
            return 2
        bad = []
        for seed in range(1, args.states + 1):
            rows, refused = results[name, f"previous-{seed}"]
            if isinstance(rows, str) or not rows.equals(reference) or refused:
                why = rows if isinstance(rows, str) else "refused: " + "; ".join(refused) if refused \
                    else "rows differ"
                bad.append(f"previous-{seed}: {why}")
        failed += len(bad)
        print(f"{name}: {args.states - len(bad)} of {args.states} previous users' states give the power-on run's "
              f"{len(reference)} rows with no command refused")
        for line in bad:
            print(f"    {line}")
    print(f"{len(tasks)} runs in {unit.both(time.perf_counter() - begin, 0)} on {workers} workers; "
          f"load average (1 min) {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
