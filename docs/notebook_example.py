# %% [markdown]
# # squeezebench from a notebook: a resonance search and a characterisation
#
# This file is a notebook in the percent format (Jupyter opens it with jupytext; VS Code
# and Spyder run its cells as they are); `tests/test_api.py` executes it. It runs on the
# simulated bench: give `bench_file="my_bench.yaml"` instead of `scene=` and the same
# calls drive the real instruments.

# %%
from pathlib import Path

import numpy as np

from squeezebench import api
from squeezebench.liveplot import LivePlot

OUT = Path("runs/notebook")
PLATE = {"n_powered_columns": 1, "n_powered_piezos": 4}            # the Table 3 one-column plate
SEARCH = {"start_hz": 36000, "stop_hz": 38500, "points": 26}        # bracket the 37 kHz mode
FAST = {"averages": 4, "record_length": 500, "periods_per_record": 10}   # a quick look, not the paper's

# %% [markdown]
# ## The resonance search
# A coarse sweep, then a golden-section search around its largest velocity
# (`protocols/resonance.py`). Every measured point is one row; `sweep` marks the search's.
# A `LivePlot` draws them as they arrive (`%matplotlib widget` makes it live in Jupyter).

# %%
plot = LivePlot()
search = api.resonance_search(OUT / "search", plate=PLATE, search=SEARCH, scene="one_column_1mm.yaml",
                              acquisition=FAST, on_point=plot.on_point, on_step=plot.on_step)
points = search.points()
sweep = points[points["sweep"]]
at_resonance = points[~points["sweep"]].iloc[0]
print(f"{len(sweep)} search points, resonance at {at_resonance.resonance_frequency_hz:.1f} Hz, "
      f"{at_resonance.velocity_pp_mps * 1e3:.1f} mm/s peak-to-peak at "
      f"{at_resonance.piezo_voltage_setpoint_vpp:g} Vpp on the piezos")
sweep[["generator_frequency_hz", "velocity_pp_mps"]].sort_values("generator_frequency_hz").tail()

# %% [markdown]
# ## The characterisation
# At the resonance (found again before each voltage), one point per piezo voltage: the
# velocity grows in proportion to the voltage, the power with its square (Sections 4-5).

# %%
char = api.characterisation(OUT / "characterisation", plate=PLATE, search=SEARCH,
                            voltages_vpp=[20, 40, 60], scene="one_column_1mm.yaml", acquisition=FAST)
rows = char.points()   # the first search's points too (protocol "resonance_search")
table = rows[rows.protocol == "characterisation"][["piezo_voltage_setpoint_vpp", "resonance_frequency_hz",
                                                   "velocity_pp_mps", "scope_power_w"]]
velocity_per_volt = np.polyfit(table.piezo_voltage_setpoint_vpp, table.velocity_pp_mps, 1)[0]
power_exponent = np.polyfit(np.log(table.piezo_voltage_setpoint_vpp), np.log(table.scope_power_w), 1)[0]
print(f"velocity per piezo volt: {velocity_per_volt * 1e3:.2f} mm/s/Vpp; "
      f"power grows as V^{power_exponent:.2f}")
table

# %% [markdown]
# ## Everything stored, as DataFrames
# The raw scope records of the points (one row per sample), the settings the run started
# with (one row per setting), and the report regenerated from the stored data.

# %%
waveforms = char.waveforms()
settings = char.settings()
print(waveforms.groupby("point_index").size().to_dict(), "samples per kept record")
print(settings[settings.setting.str.startswith("acquisition.")].to_string(index=False))
print("report:", char.report())
