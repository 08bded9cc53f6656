"""The scope's ranging on the simulated bench: a current trace off the screen's centre (the
current probe's DC offset) is sized by its extent from the centre, so a sweep ranges each
point from the last one instead of clipping, re-ranging coarser, and refining at every point."""

from __future__ import annotations

import logging

import numpy as np

from squeezebench import paths
from squeezebench.instruments.tds3054b import TDS3054B
from squeezebench.protocols import acquisition as acquisition_module
from squeezebench.protocols.acquisition import CURRENT_CHANNEL, AcquisitionSettings
from squeezebench.protocols.simulated_session import open_simulated

SWEEP = AcquisitionSettings(averages=16, record_length=500, periods_per_record=20.0, settle_s=0.05)


def test_a_sweep_acquires_each_point_about_once_although_the_current_sits_off_centre(monkeypatch, caplog):
    """Counted in re-rangings for a clip or a faint trace: a search's reading is also read
    again when its velocity trace is off the fill it asks for (`SEARCH_FILL_TOLERANCE`), as
    on a sweep's flanks it mostly is, which says nothing about the current's ranging."""
    extremes = []
    measure_many = TDS3054B.measure_many

    def recorded(self, items):
        values = measure_many(self, items)
        extremes.append(dict(zip(items, values)))
        return values

    monkeypatch.setattr(TDS3054B, "measure_many", recorded)
    caplog.set_level(logging.INFO, logger=acquisition_module.__name__)
    with open_simulated(paths.scenes_dir() / "one_column_1mm.yaml", "75x41", SWEEP.settle_s) as session:
        session.drive.set_piezo_voltage(10.0)
        resonance_hz = session.simulated.resonance_truth().frequency_hz
        acquisition = session.acquisition(SWEEP)
        for frequency_hz in np.linspace(resonance_hz - 300.0, resonance_hz + 300.0, 21):
            acquisition.measure_at(frequency_hz)
    high = np.array([e[(CURRENT_CHANNEL, "MAXIMUM")] for e in extremes if e[(CURRENT_CHANNEL, "MAXIMUM")]])
    low = np.array([e[(CURRENT_CHANNEL, "MINIMUM")] for e in extremes if e[(CURRENT_CHANNEL, "MINIMUM")]])
    assert np.median((high + low) / (high - low)) > 0.1   # the trace's centre is off the screen's by a tenth of its pp
    rerangings = [r for r in caplog.records if "re-ranging" in r.getMessage() and "search fill" not in r.getMessage()]
    assert 1 <= len(rerangings) <= 4   # the first point ranges from nothing; the others from the last
