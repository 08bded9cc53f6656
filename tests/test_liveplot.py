"""`squeezebench run --plot` draws from the campaign's watchers: every point, every step."""

import matplotlib

matplotlib.use("Agg")   # the test draws in memory

import pandas as pd  # noqa: E402
import pytest  # noqa: E402

from squeezebench import cli, liveplot  # noqa: E402
from squeezebench.protocols.storage import RunStore  # noqa: E402


@pytest.fixture(scope="module")
def watched_quick_run(tmp_path_factory):
    plots = []

    class Recording(liveplot.LivePlot):
        def __init__(self):
            super().__init__()
            self.rows, self.entries = [], []
            plots.append(self)

        def on_point(self, row):
            self.rows.append(dict(row))
            super().on_point(row)

        def on_step(self, entry):
            self.entries.append(entry)
            super().on_step(entry)

    run_dir = tmp_path_factory.mktemp("plot") / "quick"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(liveplot, "LivePlot", Recording)
        assert cli.main(["run", "quick", "--out", str(run_dir), "--plot", "-q"]) == 0
    (plot,) = plots
    return plot, run_dir


def test_callbacks_fired_for_every_point_and_step_of_the_quick_campaign(watched_quick_run):
    plot, run_dir = watched_quick_run
    stored = pd.concat(pd.read_parquet(f) for f in sorted(run_dir.glob("measurements/*/*.parquet")))
    seen = pd.DataFrame(plot.rows)
    assert plot.points_seen == len(stored) == len(seen) > 0
    key = ["run_name", "step_id", "point_index"]
    pd.testing.assert_frame_equal(seen.sort_values(key)[key].reset_index(drop=True),
                                  stored.sort_values(key)[key].reset_index(drop=True))
    journal = RunStore(run_dir).journal()
    assert plot.steps_seen == len(journal) and [e["step"] for e in plot.entries] == [e["step"] for e in journal]


def test_the_panels_hold_what_was_measured(watched_quick_run):
    plot, _ = watched_quick_run
    sweep_rows = [r for r in plot.rows if r.get("sweep")]
    last = [r for r in sweep_rows if (r["run_name"], r["step_id"]) == (sweep_rows[-1]["run_name"],
                                                                     sweep_rows[-1]["step_id"])]
    frequencies, velocities = plot._sweep.get_data()
    assert sorted(frequencies) == sorted(r["generator_frequency_hz"] for r in last)
    # the peak is bracketed: the resonance line lies inside the drawn sweep
    assert min(frequencies) < plot._peak.get_xdata()[0] < max(frequencies)
    drawn = sum(len(line.get_xdata()) for line in plot.points_ax.get_lines())
    assert drawn == sum(1 for r in plot.rows if not r.get("sweep"))
    assert len(plot._drift.get_xdata()) >= 1 and not plot.interactive


def test_off_screen_the_plot_is_drawn_once_into_a_png(watched_quick_run):
    """No display: no drawing per point (what made --plot 8x slower), one PNG at the end."""
    plot, run_dir = watched_quick_run
    assert plot.redraws == 1 and plot.points_seen > 50
    png = run_dir / "live_plot.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000


def test_a_failing_watcher_never_stops_the_run(tmp_path, caplog):
    from squeezebench import api

    def broken(row):
        raise RuntimeError("plot window gone")

    run = api.resonance_search(tmp_path / "run", plate={"n_powered_columns": 1, "n_powered_piezos": 4},
                               search={"start_hz": 36000, "stop_hz": 38500, "points": 5},
                               scene="one_column_1mm.yaml", acquisition={"averages": 1, "record_length": 500},
                               on_point=broken, on_step=broken)
    assert len(RunStore(run.run_dir).journal()) == 1 and len(run.points()) > 5
    failures = [r for r in caplog.records if r.getMessage().startswith("a watcher of the run failed")]
    assert len(failures) == len(run.points()) + 1 and "plot window gone" in caplog.text
