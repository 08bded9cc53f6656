"""The accuracy study at its smallest, which the suite runs once (conftest's `small_study`)
for test_accuracy_study's figures and report and test_systematics_study's whole-campaign
experiment.

Two repeats, the fewest a study takes: each figure test_accuracy_study compares moved by
under 4 % from four repeats' (the sweep's Q by 40 %, still 28 times inside its limit), every
one at least 2.5 times inside its limit. The whole-campaign experiments run quick at 1 and
16 averages, which test_systematics_study compares (the bench time of more averaging, the
calibration's cost): one study for both modules, not a second run of the same 8 campaigns.
"""

from __future__ import annotations

from squeezebench.protocols.accuracy_study import StudySettings
from squeezebench.protocols.systematics_study import SystematicsSettings

SMALL = StudySettings(
    repeats=2, averages=(1, 512), periods_per_record=(2.0, 20.0), record_lengths=(500,),
    search_points=(11,), search_tolerances_hz=(1.0,), search_averages=(16,), settle_s=(0.0, 0.2),
    sweep_voltage_counts=(3,), sweep_averages=(16,), heating_averages=(2, 512), heating_points=4,
    systematics=SystematicsSettings(averages=(4,), sweep_averages=(4,), sweep_voltages=3, search_tolerances_hz=(1.0,),
                                    campaign="quick.yaml", campaign_averages=(1, 16)))
