"""The accuracy study on the simulated bench (small settings, seeded) and its analysis."""

import dataclasses
import shutil

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.analysis import study
from squeezebench.report.run_report import write_report
from squeezebench import paths
from squeezebench.protocols import accuracy_study
from squeezebench.protocols.accuracy_study import AccuracyStudy, StudySettings, run_study
from squeezebench.cli import main
from squeezebench.commands import STUDY_EXPERIMENTS, STUDY_REPEATS
from small_study import SMALL
from test_analysis_synthetic import build_run


@pytest.fixture(scope="module")
def summary(small_study):
    return study.summarise(study.load_trials(small_study))


def p95(summary, experiment, quantity, **knobs):
    rows = summary[(summary["experiment"] == experiment) & (summary["quantity"] == quantity)]
    for knob, value in knobs.items():
        rows = rows[rows[knob] == value]
    assert len(rows) == 1, rows
    return float(rows["p95_abs_rel_error"].iloc[0])


def test_trials_are_tidy_and_complete(small_study):
    trials = study.load_trials(small_study)
    assert set(trials["experiment"]) == set(STUDY_EXPERIMENTS)
    assert {*study.KNOBS, "repeat", "bench_time_s", "quantity", "measured_value", "true_value", "rel_error"} <= set(trials)
    numbers = trials.select_dtypes("number")
    assert np.isfinite(numbers.to_numpy()).all()
    assert (trials["bench_time_s"] > 0).all()
    assert set(trials["quantity"]) == {"power_w", "velocity_pp_mps", "amplitude_pp_m",
                                       "resonance_frequency_hz", "q", "tan_theta"}
    # the scenes as run are stored beside the trials
    assert (small_study / "study" / "inputs" / "one_column_1mm+heating_drift.yaml").is_file()


def test_averaging_buys_accuracy_with_bench_time(summary):
    assert p95(summary, "averages", "power_w", averages=512) < 0.2 * p95(summary, "averages", "power_w", averages=1)
    cost = summary[(summary["experiment"] == "averages") & (summary["quantity"] == "power_w")]
    assert cost.set_index("averages")["bench_time_s"].is_monotonic_increasing


def test_a_short_settling_wait_reads_the_ringing_plate(summary):
    # ring time ~40 ms on the sharpened plate: no wait reads the old amplitude fading out
    assert p95(summary, "settle", "velocity_pp_mps", settle_s=0.0) > 0.01
    assert p95(summary, "settle", "velocity_pp_mps", settle_s=0.2) < 0.002


def test_heating_longer_averaging_drifts_off_resonance_and_tracking_fixes_it(summary):
    fixed_long = p95(summary, "heating", "power_w", averages=512, tracking=False)
    assert fixed_long > 5 * p95(summary, "heating", "power_w", averages=2, tracking=False)
    assert p95(summary, "heating", "power_w", averages=512, tracking=True) < 0.2 * fixed_long


def test_search_and_sweep_recover_the_truth(summary):
    assert p95(summary, "search", "resonance_frequency_hz") * 37160 < 5.0   # within 5 Hz
    assert p95(summary, "sweep", "q") < 1e-3
    assert p95(summary, "sweep", "tan_theta") < 1e-3


def test_report_shows_the_study(small_study, tmp_path):
    campaign_run = build_run(tmp_path / "run", protocols=("powered_columns", "resonator_cutting"))
    shutil.copytree(small_study / "study", campaign_run / "study")
    text = write_report(campaign_run).read_text()
    assert "Settings on each Pareto front" in text and "Heating drift" in text
    report_dir = campaign_run / "report"
    # one floor: the budgets', at the run's own Table 3 point; the study's beside it as its check
    floors = pd.read_csv(report_dir / "study_floors.csv")
    table3 = floors[(floors["point"] == "table3") & (floors["quantity"] == "power_w")]
    assert len(table3) == 1 and 0 < table3["budget_floor_p95_rel"].iat[0] < 0.2
    assert floors.loc[floors["point"] == "campaign", "budget_floor_p95_rel"].isna().all()   # another campaign
    assert "One floor per quantity: the budgets'." in text and "power at the table3 point, budget" in text
    assert (report_dir / "study_fronts.png").is_file() and (report_dir / "study_heating.png").is_file()
    fronts = pd.read_csv(report_dir / "study_fronts.csv")
    assert set(fronts["quantity"]) == {"power_w", "velocity_pp_mps", "amplitude_pp_m",
                                       "resonance_frequency_hz", "q", "tan_theta"}


def test_resume_keeps_stored_experiments_and_other_settings_start_over(tmp_path):
    tiny = dataclasses.replace(SMALL, averages=(2, 4))
    run_study(tmp_path, tiny, experiments=("averages",), progress=lambda message: None)
    stored = tmp_path / "study" / "averages.parquet"
    before = stored.stat().st_mtime_ns
    run_study(tmp_path, tiny, experiments=("averages", "record"), resume=True, progress=lambda message: None)
    assert stored.stat().st_mtime_ns == before
    assert (tmp_path / "study" / "record.parquet").is_file()
    run_study(tmp_path, dataclasses.replace(tiny, repeats=tiny.repeats + 1), experiments=("settle",), resume=True,
              progress=lambda message: None)
    assert sorted(p.name for p in (tmp_path / "study").glob("*.parquet")) == ["settle.parquet"]


def test_cli_study_runs_one_experiment_and_report_shows_it(tmp_path, capsys):
    assert STUDY_EXPERIMENTS == AccuracyStudy.EXPERIMENTS   # spelled twice: keep them one
    assert STUDY_REPEATS == StudySettings().repeats
    assert main(["study", "--out", str(tmp_path), "--repeats", "2", "--experiment", "settle"]) == 0
    assert (tmp_path / "study" / "settle.parquet").is_file()
    assert main(["report", str(tmp_path)]) == 0   # what `study` tells the user to run
    text = (tmp_path / "report" / "index.html").read_text()
    assert "Settings on each Pareto front" in text and "settle_s=" in text
    assert main(["study", "--out", str(tmp_path), "--repeats", "1"]) == 2
    assert "at least 2" in capsys.readouterr().err


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(1e-3, 1e3), st.floats(1e-9, 1.0)), min_size=1, max_size=30))
def test_front_holds_exactly_the_undominated_configurations(points):
    group = pd.DataFrame(points, columns=["bench_time_s", "p95_abs_rel_error"])
    front = set(study.front_index(group))
    assert front <= set(group.index)
    # [i, j]: configuration j against configuration i, every pair at once
    time_s, error = (group[c].to_numpy()[:, None] for c in ("bench_time_s", "p95_abs_rel_error"))
    other = ~np.eye(len(group), dtype=bool)
    dominated = ((time_s.T <= time_s) & (error.T <= error) & ((time_s.T < time_s) | (error.T < error))
                 & other).any(axis=1)
    kept = group.index.isin(list(front))
    duplicate_kept = ((time_s.T == time_s) & (error.T == error) & other & kept[None, :]).any(axis=1)
    assert (kept == (~dominated & ~duplicate_kept)).all()


PARALLEL = dataclasses.replace(SMALL, repeats=2, averages=(1, 16), settle_s=(0.0, 0.05))
PARALLEL_EXPERIMENTS = ("averages", "settle")


def stored(out):
    return {path.name: pd.read_parquet(path) for path in sorted((out / "study").glob("*.parquet"))}


@pytest.fixture(scope="module")
def serial(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    run_study(out, PARALLEL, PARALLEL_EXPERIMENTS, progress=lambda message: None)
    return stored(out)


def test_trials_do_not_depend_on_order_or_workers(serial, tmp_path):
    run_study(tmp_path / "loky", PARALLEL, PARALLEL_EXPERIMENTS, progress=lambda message: None, workers=2)
    parallel = stored(tmp_path / "loky")
    assert list(parallel) == ["averages.parquet", "settle.parquet"]
    for name, frame in serial.items():
        pd.testing.assert_frame_equal(parallel[name], frame)
    # One experiment alone, its configurations in reverse: the same trials.
    study_run = AccuracyStudy(dataclasses.replace(PARALLEL, averages=PARALLEL.averages[::-1]),
                              paths.scenes_dir(), tmp_path / "reversed")
    study_run.run(("averages",))
    reversed_frame = pd.read_parquet(tmp_path / "reversed" / "study" / "averages.parquet")
    pd.testing.assert_frame_equal(reversed_frame.sort_values(["averages", "repeat", "quantity"], ignore_index=True),
                                  serial["averages.parquet"].sort_values(["averages", "repeat", "quantity"],
                                                                          ignore_index=True))


def test_trials_on_a_dask_cluster_match_the_serial_run(serial, tmp_path):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        run_study(tmp_path, PARALLEL, PARALLEL_EXPERIMENTS, progress=lambda message: None, scheduler=cluster)
    for name, frame in stored(tmp_path).items():
        pd.testing.assert_frame_equal(frame, serial[name])


def test_an_interrupted_study_resumes_with_the_tasks_it_lacks(serial, tmp_path, monkeypatch):
    original = accuracy_study.EXPERIMENTS["settle"]

    def interrupted(run):
        if run.knobs["settle_s"] == PARALLEL.settle_s[-1]:
            raise KeyboardInterrupt
        original.run(run)

    monkeypatch.setitem(accuracy_study.EXPERIMENTS, "settle", dataclasses.replace(original, run=interrupted))
    with pytest.raises(KeyboardInterrupt):
        run_study(tmp_path, PARALLEL, PARALLEL_EXPERIMENTS, progress=lambda message: None)
    task_files = sorted(p.name for p in (tmp_path / "study" / "trials" / "settle").glob("*.parquet"))
    assert task_files == ["settle_s=0.0.parquet"]   # the finished task kept, nothing half-written
    monkeypatch.setitem(accuracy_study.EXPERIMENTS, "settle", original)
    ran = []
    original_run_task = accuracy_study.run_task
    monkeypatch.setattr(accuracy_study, "run_task", lambda task: ran.append(task.key) or original_run_task(task))
    run_study(tmp_path, PARALLEL, PARALLEL_EXPERIMENTS, resume=True, progress=lambda message: None)
    assert ran == ['{"settle_s": 0.05}']
    for name, frame in stored(tmp_path).items():
        pd.testing.assert_frame_equal(frame, serial[name])


def test_a_stopped_study_keeps_the_task_it_stored_and_resumes_to_the_same_trials(serial, tmp_path):
    # `reproduce` runs the study beside the campaign and stops it when the campaign stops.
    import threading

    stop = threading.Event()
    stop.set()
    run_study(tmp_path, PARALLEL, PARALLEL_EXPERIMENTS, progress=lambda message: None, stop=stop, bar=False)
    assert len(list((tmp_path / "study" / "trials").rglob("*.parquet"))) == 1
    assert not list((tmp_path / "study").glob("*.parquet"))   # nothing assembled from part of it
    run_study(tmp_path, PARALLEL, PARALLEL_EXPERIMENTS, resume=True, progress=lambda message: None)
    for name, frame in stored(tmp_path).items():
        pd.testing.assert_frame_equal(frame, serial[name])


def test_configurations_sharing_calibrations_go_to_one_worker_first():
    # A calibrated experiment's configurations share each bench's calibration, which a
    # worker keeps: together, on one worker, no bench is calibrated twice; after its plain
    # twin's, whose readings the worker keeps for them to correct.
    names = ("averages", "systematics_table3_calibrated", "systematics_table3", "systematics_sweep_calibrated")
    tasks = AccuracyStudy(SMALL, paths.scenes_dir(), "unused").tasks(names)
    units = accuracy_study.work_units(tasks)
    assert [[task.experiment for task in unit] for unit in units[:2]] == [
        ["systematics_table3"] * len(SMALL.systematics.averages)
        + ["systematics_table3_calibrated"] * len(SMALL.systematics.averages),
        ["systematics_sweep_calibrated"] * len(SMALL.systematics.sweep_averages)]
    assert all(len(unit) == 1 for unit in units[2:])
    every = [task for unit in units for task in unit]
    assert len(every) == len(tasks) and set(every) == set(tasks)   # each task once


@pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")
def test_warmed_workers_run_the_map_and_a_failed_warming_costs_it_nothing():
    # `study` starts its workers importing while it reads its inputs; the
    # map waits for that first (two joblib calls on one executor die together), and a
    # warming that fails is the map's to meet, not an error of its own.
    from squeezebench.protocols import parallel

    parallel._wait_for_warming()   # a command an earlier test refused may have left one starting
    parallel.warm(2, "no_such_module_anywhere")
    parallel.warm(2, "json")
    assert len(parallel._warming) == 2
    assert sorted(parallel.map_unordered(abs, [-3, -1, 2], workers=2)) == [(-3, 3), (-1, 1), (2, 2)]
    assert parallel._warming == []   # waited for before the map started
    parallel.warm(1, "json")   # one worker: this process, nothing to start
    assert parallel._warming == []


def test_beside_hands_back_what_its_thread_raised_and_runs_when_never_started():
    from squeezebench.protocols.parallel import Beside

    seen = []
    Beside(lambda stop: seen.append(stop.is_set())).finish()   # never started: finish runs it
    assert seen == [False]
    failing = Beside(lambda stop: 1 / 0)
    failing.start()
    with pytest.raises(ZeroDivisionError):
        failing.finish()
    waiting = Beside(lambda stop: stop.wait() and 1 / 0)
    waiting.start()
    waiting.cancel()   # it sees the stop; what it raises then is dropped: the caller raises its own
    assert waiting.stop.is_set() and not waiting._thread.is_alive()


def _synthetic_trials(scale: float, seed: int) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    rows = [{"experiment": "averages", "scene": "s.yaml", "state": "", **{k: 0 for k in study.KNOBS},
             "averages": averages, "quantity": "power_w", "repeat": repeat, "bench_time_s": 1.0 + averages,
             "rel_error": scale * rng.normal() / np.sqrt(averages)}
            for averages in (1, 4, 16, 64) for repeat in range(8)]
    return pd.DataFrame(rows)


def test_a_p95s_monte_carlo_uncertainty_scales_with_the_errors_and_vanishes_without_spread():
    errors = np.abs(np.random.default_rng(3).normal(size=8))
    assert study.p95_standard_error(np.full(8, 0.01)) == 0.0
    assert study.p95_standard_error(10 * errors) == pytest.approx(10 * study.p95_standard_error(errors))
    assert 0 < study.p95_standard_error(errors) < np.ptp(errors)


def test_figures_of_the_same_distributions_agree_within_their_monte_carlo_uncertainty_and_a_shift_does_not():
    reference = study.figures(_synthetic_trials(0.01, seed=1))
    again = study.compare_figures(study.figures(_synthetic_trials(0.01, seed=1)), reference)
    assert again["within"].all() and (again["z"] == 0).all() and (again["bench_time_rel_change"] == 0).all()
    redrawn = study.compare_figures(study.figures(_synthetic_trials(0.01, seed=2)), reference)
    assert len(redrawn) == 4 and redrawn["within"].mean() >= 0.75   # other draws, the same distributions
    tenfold = study.compare_figures(study.figures(_synthetic_trials(0.1, seed=2)), reference)
    assert not tenfold["within"].any() and (tenfold["z"] > 2).all()
