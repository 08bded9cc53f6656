"""Hard cases of the reduction and the model, and instrument faults: one table (not a test).

Numerical cases (analysis.waveforms, analysis.model): each reduces a synthetic record
with a known truth and says whether the result is within its tolerance, or whether an
input that has no answer is refused with the documented error.

Fault cases: a tiny noise-free campaign on the simulated bench whose scene names one
fault effect (VISA timeout, garbled or truncated reply, an error-queue entry, a
disconnect), which comes back in every session. "pass" means: each session stops with
the expected typed error, the generator's last amplitude is its minimum, the stored
steps are exactly the journalled ones, no NaN/inf is in any stored parquet file, and
resuming until done gives the rows of an undisturbed run.

Prints a table (case, tolerance, outcome, detail); with `--out RUN_DIR` also writes
RUN_DIR/hardcases/summary.csv, which the report's "Hard cases" section shows.

Run: python benchmarks/hardcases_summary.py [--out RUN_DIR] [--no-faults]
"""

from __future__ import annotations

import argparse
import math
import re
import sys
import tempfile
from pathlib import Path
from unittest import mock

import numpy as np
import pandas as pd
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from squeezebench.analysis import model  # noqa: E402
from squeezebench.analysis import waveforms as wf  # noqa: E402

F_HZ = 43_792.0
V_AMP, I_AMP = 12.0, 0.05
SCALE_MPS_PER_V = 0.125
#: The estimate is accepted within 4 stated standard uncertainties (plus a float floor):
#: the uncertainty is part of what is checked, so a tight value with a too-small
#: uncertainty fails.
K_SIGMA = 4.0


def sines(n=4000, periods=23.4, phi=1.0, dc_v=0.0, dc_i=0.0, dtype=np.float64, t0=1e-4):
    dt = periods / F_HZ / n
    t = t0 + np.arange(n) * dt
    w = 2 * np.pi * F_HZ * t
    return (t.astype(dtype), (V_AMP * np.sin(w) + dc_v).astype(dtype),
            (I_AMP * np.sin(w - phi) + dc_i).astype(dtype), (0.8 * np.sin(w + 0.3)).astype(dtype))


def _quantised_average(clean, noise_std, step, averages, rng):
    """`averages` acquisitions, each noisy then quantised to `step`, averaged as the scope
    does: the noise dithers the quantiser so the average resolves below one step."""
    total = np.zeros_like(clean)
    for _ in range(averages):
        total += np.round((clean + rng.normal(0, noise_std, clean.size)) / step) * step
    return total / averages


def _power_case(name, *, y_increments=None, averages=1, **kwargs):
    """Reduce one record; both power estimates must hold the truth within K_SIGMA."""
    phi = kwargs.get("phi", 1.0)
    quantise = kwargs.pop("quantise_bits", None)
    t, v, i, vib = sines(**kwargs)
    rng = np.random.default_rng(3)
    if quantise:
        # 9 bits over 10 divisions sized to the signal (the scope's averaged resolution).
        v_step, i_step = 2.5 * V_AMP / 2**quantise, 2.5 * I_AMP / 2**quantise
        v = _quantised_average(v, 0.01, v_step, averages, rng)
        i = _quantised_average(i, 1e-4, i_step, averages, rng)
        y_increments = {"piezo_voltage_v": v_step, "current_a": i_step}
    else:
        v = v + rng.normal(0, 0.01, v.size).astype(v.dtype)
        i = i + rng.normal(0, 1e-4, i.size).astype(i.dtype)
    r = wf.reduce_point(t, v, i, vib, SCALE_MPS_PER_V, y_increments=y_increments, averages=averages)
    truth = 0.5 * V_AMP * I_AMP * math.cos(phi)
    worst = max(abs(e.value - truth) / e.std_uncertainty for e in (r.power_w, r.power_fit_w))
    ok = all(abs(e.value - truth) <= K_SIGMA * e.std_uncertainty + 1e-6 * abs(truth)
             for e in (r.power_w, r.power_fit_w))
    return (name, f"|P - P_true| <= {K_SIGMA:g} u(P)", "pass" if ok else "FAIL",
            f"P_true={truth:.4g} W, P={r.power_w.value:.4g}+-{r.power_w.std_uncertainty:.2g} W, "
            f"worst {worst:.2f} u")


def _refused(name, tolerance, expected, call):
    """A case with no answer: it must raise `expected`, nothing else and not a number."""
    try:
        value = call()
    except expected as exc:
        return name, tolerance, "pass", f"{type(exc).__name__}: {str(exc)[:90]}"
    except Exception as exc:  # noqa: BLE001 - any other error is the failure being reported
        return name, tolerance, "FAIL", f"{type(exc).__name__} instead of {expected.__name__}: {exc}"
    return name, tolerance, "FAIL", f"returned {value!r} instead of raising {expected.__name__}"


def numerical_cases():
    rows = [
        _power_case("power factor 0.001, 9-bit, noise, 16 averages", phi=math.acos(1e-3),
                    quantise_bits=9, averages=16),
        _power_case("non-integer periods (7.77)", periods=7.77),
        _power_case("large DC offset (500 V, 20 A)", dc_v=500.0, dc_i=20.0),
        _power_case("5 samples per period", n=200, periods=40.0),
        _power_case("float32 record", dtype=np.float32),
    ]
    # Eq. 12 with alpha chosen to cancel the denominator exactly (f0 = 0.3, beta = 0.5),
    # and 1e-14 away from it: cancellation is caught, not turned into a huge 1/a.
    f0, beta = 0.3, 0.5
    bracket = 3 * beta + 3 * beta**2 + beta**3 - 6 * f0 - 3 * beta * f0 + 3 * beta * f0**2
    alpha = (1 - 3 * f0 + 3 * f0**2) / bracket
    rows.append(_refused("Eq. 12 vanishing denominator", "ModelGeometryError",
                         model.ModelGeometryError, lambda: model.inverse_a(f0, alpha, beta)))
    rows.append(_refused("Eq. 12 denominator 1e-14 from zero", "ModelGeometryError",
                         model.ModelGeometryError,
                         lambda: model.inverse_a(f0, alpha * (1 + 1e-14), beta)))
    t, v, *_ = sines(n=4, periods=0.5)
    rows.append(_refused("sine fit on 4 samples", "ValueError (refused)", ValueError,
                         lambda: wf.fit_sine(t, v, F_HZ)))
    t, v, i, vib = sines(n=50, periods=0.8)
    rows.append(_refused("record shorter than one period", "ValueError (refused)", ValueError,
                         lambda: wf.reduce_point(t, v, i, vib, SCALE_MPS_PER_V)))
    return rows


# -- faults on the simulated bench ------------------------------------------------------------
_AMPLITUDE_WRITE = re.compile(r"^VOLT ([-+0-9.eE]+)\s*$")
SEARCH = {"start_hz": 36000, "stop_hz": 38500, "points": 11, "tolerance_hz": 1.0}


def _campaign(tmp: Path, name: str, effects: list) -> Path:
    from squeezebench import paths

    scene = yaml.safe_load((paths.scenes_dir() / "one_column_1mm.yaml").read_text())
    scene["effects"] = effects   # else noise-free: the resumed run must equal an undisturbed one
    (tmp / name).mkdir()
    scene_path = tmp / name / "one_column_1mm.yaml"   # the plate is named after the file
    scene_path.write_text(yaml.safe_dump(scene, sort_keys=False))
    plate = {"n_powered_columns": 1, "n_powered_piezos": 4}
    campaign = {"name": "hardcases", "bench": {"scene": str(scene_path)},
                "acquisition": {"averages": 2, "record_length": 500, "periods_per_record": 10,
                                "settle_s": 0.2},
                "runs": [{"name": "detuning", "protocol": "detuning", "plate": plate,
                          "parameters": {"search": SEARCH, "velocity_levels_pp_mps": [0.2],
                                         "velocity_ratios": [0.8, 0.5]}},
                         # a second run so a mid-campaign fault leaves completed steps behind
                         {"name": "cutting", "protocol": "resonator_cutting", "plate": plate,
                          "parameters": {"search": SEARCH, "lengths": [
                              {"plate_length_mm": 75, "state": "75x41", "n_antinodes": 9},
                              {"plate_length_mm": 59, "state": "59x41", "n_antinodes": 7}]}}]}
    path = tmp / name / "hardcases.yaml"
    path.write_text(yaml.safe_dump(campaign, sort_keys=False))
    return path


class _AmplitudeTap:
    """Records the last amplitude the generator received (PyVISA level, below the drivers)."""

    def __init__(self):
        from pyvisa.resources import MessageBasedResource

        self.last_amplitude_vpp = None
        original_write = MessageBasedResource.write

        def write(resource, message, *args, **kwargs):
            result = original_write(resource, message, *args, **kwargs)
            match = _AMPLITUDE_WRITE.match(message)
            if match:
                self.last_amplitude_vpp = float(match.group(1))
            return result

        self.patch = mock.patch.object(MessageBasedResource, "write", write)

    def __enter__(self):
        self.patch.start()
        return self

    def __exit__(self, *exc):
        self.patch.stop()


def _nonfinite_columns(run_dir: Path) -> list[str]:
    bad = []
    for path in sorted(run_dir.rglob("*.parquet")):
        frame = pd.read_parquet(path)
        for column in frame.columns:
            series = frame[column]
            if pd.api.types.is_bool_dtype(series) or not pd.api.types.is_numeric_dtype(series):
                continue
            if not np.isfinite(series.dropna().to_numpy(dtype=float)).all():
                bad.append(f"{path.name}:{column}")
    return bad


#: Message 2000 of a bench session: past its opening (~80 messages) and after the longest
#: step (~1750), so each session completes a step before the fault comes back.
FAULT_AT_MESSAGE = 2000
MAX_SESSIONS = 20


def fault_cases():
    from squeezebench.instruments.agilent33120a import AMPLITUDE_RANGE_VPP
    from squeezebench.instruments.errors import ConnectionLost, GarbledReply, InstrumentError, InstrumentTimeout
    from squeezebench.protocols.campaign import run_campaign
    from squeezebench.protocols.storage import RunStore, read_measurements

    minima = [low for low, _ in AMPLITUDE_RANGE_VPP.values()]
    tolerance = ("typed error, generator at minimum, journal = stored rows, no NaN/inf; "
                 "resumed (fault recurring) until done: rows equal an undisturbed run")
    cases = [  # name, scene effect, the error the campaign must stop with
        ("VISA timeout (scope)", {"bus_timeout": {"instrument": 2}}, InstrumentTimeout),
        ("garbled reply (scope)", {"garbled_reply": {"instrument": 2}}, GarbledReply),
        ("truncated reply (generator)", {"truncated_reply": {"instrument": 1}}, InstrumentTimeout),
        ("error-queue entry (generator)", {"instrument_error": {"instrument": 1}}, InstrumentError),
        ("disconnect (scope)", {"disconnect": {"instrument": 2}}, ConnectionLost),
    ]
    rows = []
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        expected = read_measurements(run_campaign(_campaign(tmp, "reference", []), out_dir=tmp / "reference" / "run"))
        for i, (name, effect, error) in enumerate(cases):
            (fault_name, parameters), = effect.items()
            campaign = _campaign(tmp, f"case{i}", [{fault_name: {"at_message": FAULT_AT_MESSAGE, **parameters}}])
            run_dir = tmp / f"case{i}" / "run"
            problems, stops = [], []
            for _ in range(MAX_SESSIONS):
                with _AmplitudeTap() as tap:
                    try:
                        run_campaign(campaign, resume=True, out_dir=run_dir)
                        break
                    except error as exc:
                        stops.append(f"{type(exc).__name__}: {str(exc)[:70]}")
                    except Exception as exc:  # noqa: BLE001 - the wrong error is the finding
                        problems.append(f"{type(exc).__name__} instead of {error.__name__}")
                        break
                if tap.last_amplitude_vpp is None or not any(math.isclose(tap.last_amplitude_vpp, m)
                                                             for m in minima):
                    problems.append(f"generator left at {tap.last_amplitude_vpp} Vpp")
                journal = RunStore(run_dir).journal()
                if journal and len(read_measurements(run_dir)) != sum(e["rows"] for e in journal):
                    problems.append("stored rows differ from the journal")
                problems += [f"non-finite {c}" for c in _nonfinite_columns(run_dir)]
            else:
                problems.append(f"not complete after {MAX_SESSIONS} sessions")
            if not stops:
                problems.append("the fault never stopped the campaign")
            try:
                pd.testing.assert_frame_equal(read_measurements(run_dir), expected, check_exact=True)
            except AssertionError:
                problems.append("resumed rows differ from an undisturbed run")
            rows.append((name, tolerance, "FAIL" if problems else "pass",
                         "; ".join(problems) or f"{len(stops)} stops, first {stops[0]}"))
    return rows


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None, help="run directory: writes hardcases/summary.csv")
    parser.add_argument("--no-faults", action="store_true", help="numerical cases only")
    args = parser.parse_args(argv)
    rows = numerical_cases() + ([] if args.no_faults else fault_cases())
    table = pd.DataFrame(rows, columns=["case", "tolerance", "outcome", "detail"])
    with pd.option_context("display.max_colwidth", 70, "display.width", 250):
        print(table.to_string(index=False))
    if args.out is not None:
        folder = Path(args.out) / "hardcases"
        folder.mkdir(parents=True, exist_ok=True)
        table.to_csv(folder / "summary.csv", index=False)
        print(f"written {folder / 'summary.csv'}")
    return 0 if (table["outcome"] == "pass").all() else 1


if __name__ == "__main__":
    sys.exit(main())
