"""Readings of the paper's Eqs. 12, 25, 27 and 29 as data, and the search over them.

The paper leaves open (or prints damaged) what its symbols mean: whether V is peak-to-peak,
zero-to-peak or rms; whether Eq. 27's A is peak-to-peak; what n_c counts; which side of the
piezo is b_p; which lambda; where z0 lies; whether E_i is the printed 67109 Pa or 67 GPa;
whether Eq. 25 keeps its pi, its c'11 and its 3/4. A `Reading` records one answer to each
question, and so does every number derived under it (`Reading.convention()` is what the
model functions take).

`search_readings` evaluates every combination of `AXES` against the published numbers
that do not depend on Fig. 5's lost data:

- `amplitude`: the amplitude Eq. 27 gives for Table 5's measured Q = 1.48 at 32 Vpp,
  against the "about 1 um" of Sec. 5.3.2 (itself read as pp or zero-to-peak);
- `tan_theta`: tan(theta') from Eq. 25 for the published 1.3 W at 32 Vpp with Q = 1.48,
  against Table 5's measured -1.24;
- `table4_tan`: the mean tan(theta') of Table 4's three 1.2 mm plates (Q from Eq. 27 with
  their pp amplitudes, then Eq. 25 with their powers), against Sec. 4's mean -1.64.

A number is reproduced when the ratio computed / printed lies within `MATCH_REL` of 1.
The best reading overall (least RMS of log10 ratios among those reproducing all three) is
`model.INFERRED_CONVENTION`; the test suite checks that the search still finds it.
`look_elsewhere` says how much that is worth: how often the same search fits targets moved
at random.
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import asdict, dataclass

import numpy as np
import pandas as pd

from squeezebench.analysis import model
from squeezebench.paper import paper_value

MM = 1e-3
#: A published number counts as reproduced within this relative difference (the paper
#: itself calls estimate vs measurement within 10 % a match; its numbers have 2-3 digits).
MATCH_REL = 0.10
#: Looser bands the summary also counts, to show how isolated the best reading is.
SUMMARY_RELS = (0.10, 0.15, 0.25)
TABLE4_CONFIGURATIONS = ("1-column", "2-columns 1 powered", "2-columns 2 powered")
TARGETS = {
    "amplitude": "about 1 um at 32 Vpp with Q = 1.48 (Sec. 5.3.2, Table 5)",
    "tan_theta": "tan theta' = -1.24 from 1.3 W at 32 Vpp with Q = 1.48 (Sec. 5.3.2, Table 5)",
    "table4_tan": "mean tan theta' -1.64 of the 1.2 mm plates, from Table 4 (Sec. 4)",
}

#: Every axis of the search and its values; the first value is the text's own reading.
AXES: dict[str, tuple] = {
    "materials": ("printed", "physical"),           # E_i = 67109 Pa as printed, or 67 GPa
    "voltage": ("pp", "amplitude", "rms"),         # V in Eqs. 25/27
    "eq27_amplitude": ("pp", "amplitude"),         # A in Eq. 27
    "published_amplitude": ("pp", "amplitude"),    # the published "about 1 um"
    "n_c": ("piezos", "actuating", "groups"),      # 8 / 7 (one senses) / 4 corner pairs
    "b_p": ("length", "width"),                    # piezo side along the nodal lines
    "wavelength": ("printed", "from_mode", "half"),  # lambda/2 = 9 mm, 198/21 mm, or lambda = 9 mm
    "neutral_plane": ("stack_middle", "resonator_middle", "bending_neutral", "interface"),
    "c11_reduced": (True, False),                  # c'11 = c11/(1-nu^2) or c11
    "eq25_with_pi": (True, False),
    "eq25_coefficient": (0.75, 0.375),             # 3/4 as printed, 3/8 with the Eq. 20 slip
}


@dataclass(frozen=True)
class Reading:
    """One answer to each question of `AXES`; defaults are the text's own definitions."""

    materials: str = "printed"
    voltage: str = "pp"
    eq27_amplitude: str = "pp"
    published_amplitude: str = "pp"
    n_c: str = "piezos"
    b_p: str = "length"
    wavelength: str = "printed"
    neutral_plane: str = "stack_middle"
    c11_reduced: bool = True
    eq25_with_pi: bool = True
    eq25_coefficient: float = 0.75

    @property
    def label(self) -> str:
        return ", ".join(f"{k}={v}" for k, v in asdict(self).items())

    def convention(self, name: str | None = None) -> model.Convention:
        """The model's Convention for this reading (n_c 'actuating' is a geometry choice)."""
        materials = {"printed": model.MATERIALS_AS_PRINTED, "physical": model.MATERIALS_PHYSICAL}
        return model.Convention(
            name=name or self.label, materials=materials[self.materials], voltage=self.voltage,
            amplitude=self.eq27_amplitude, neutral_plane=self.neutral_plane,
            n_c="groups" if self.n_c == "groups" else "piezos", eq25_with_pi=self.eq25_with_pi,
            eq28_with_pi=self.eq25_with_pi, c11_reduced=self.c11_reduced,
            eq25_coefficient=self.eq25_coefficient)

    def large_plate_geometry(self) -> model.PlateGeometry:
        """The large plate (Sec. 5.2) under this reading's n_c, b_p and lambda."""
        return _large_plate_geometry(self.n_c, self.b_p, self.wavelength)

    def table4_geometry(self, configuration: str) -> model.PlateGeometry:
        """A Table 4 plate (76 x 41 x 1.2 mm, (9,0) mode) under this reading."""
        return _table4_geometry(configuration, self.b_p, self.wavelength)


# The search builds each geometry for thousands of readings that share it: built once.
@functools.cache
def _large_plate_geometry(n_c: str, b_p: str, wavelength: str) -> model.PlateGeometry:
    printed_half = paper_value("large_plate", "large_plate", "half_wavelength_mm") * MM
    half = {"printed": printed_half,
            "from_mode": paper_value("large_plate", "large_plate", "resonator_length_mm") * MM / 21.0,
            "half": printed_half / 2.0}[wavelength]
    n = int(paper_value("large_plate", "large_plate", "n_piezos"))
    sensors = int(paper_value("large_plate", "large_plate", "n_sensor_piezos"))
    return model.PlateGeometry(
        resonator_thickness_m=paper_value("large_plate", "large_plate", "resonator_thickness_mm") * MM,
        piezo_thickness_m=paper_value("large_plate", "large_plate", "piezo_thickness_mm") * MM,
        piezo_length_m=paper_value("large_plate", "large_plate", f"piezo_{b_p}_mm") * MM,
        half_wavelength_m=half,
        n_powered_piezos=n - sensors if n_c == "actuating" else n,
        n_powered_groups=int(paper_value("large_plate", "large_plate", "n_corner_groups")))


@functools.cache
def _table4_geometry(configuration: str, b_p: str, wavelength: str) -> model.PlateGeometry:
    half = (paper_value("table4", "plate", "resonator_length_mm")
            / paper_value("table4", "plate", "n_antinodes")) * MM
    columns = int(paper_value("table4", configuration, "n_powered_columns"))
    return model.PlateGeometry(
        resonator_thickness_m=paper_value("table4", "plate", "resonator_thickness_mm") * MM,
        piezo_thickness_m=paper_value("table4", "plate", "piezo_thickness_mm") * MM,
        piezo_length_m=paper_value("table4", "plate", f"piezo_{b_p}_mm") * MM,
        half_wavelength_m=half / 2.0 if wavelength == "half" else half,
        n_powered_piezos=columns * int(paper_value("table4", "plate", "piezos_per_column")),
        n_powered_groups=columns)


#: The text's own definitions (Sec. 3, Table 2 as printed).
PRINTED_READING = Reading()
#: The best consistent reading the search finds (see the module docstring); its
#: convention is `model.INFERRED_CONVENTION`.
INFERRED_READING = Reading(eq27_amplitude="amplitude", n_c="groups", wavelength="from_mode",
                           eq25_with_pi=False)


def evaluate(reading: Reading) -> dict:
    """The three published numbers under `reading`: computed values and ratios to print."""
    convention = reading.convention(name="search")   # the name is a label; building the reading's costs a third of the search
    q = paper_value("table5", "measured", "q")
    voltage = paper_value("large_plate", "large_plate", "voltage_vpp")
    frequency = paper_value("large_plate", "large_plate", "frequency_hz")
    row: dict = {axis: getattr(reading, axis) for axis in AXES}
    try:
        large = reading.large_plate_geometry()
        amplitude_pp = model.amplitude_pp_m(q, voltage, large, convention)
        published_pp = paper_value("large_plate", "large_plate", "amplitude_m") * (
            2.0 if reading.published_amplitude == "amplitude" else 1.0)
        tan = model.tan_theta_from_power(paper_value("large_plate", "large_plate", "power_w"), voltage, q,
                                         frequency, large, convention)
        table4 = _table4_tan_theta_mean(convention, tuple(reading.table4_geometry(c) for c in TABLE4_CONFIGURATIONS))
    except model.ModelGeometryError:
        return {**row, "defined": False}
    row.update(defined=True, amplitude_pp_m=amplitude_pp, tan_theta=tan, table4_tan_theta_mean=table4,
               amplitude_ratio=amplitude_pp / published_pp,
               tan_theta_ratio=tan / paper_value("table5", "measured", "tan_theta"),
               table4_tan_ratio=table4 / paper_value("small_plates", "1.2mm", "tan_theta_mean"))
    for target in TARGETS:
        ratio = row[f"{target}_ratio"]
        row[f"matches_{target}"] = bool(ratio > 0 and abs(ratio - 1.0) <= MATCH_REL)
    row["log_misfit"] = _log_misfit(row)
    return row


def table4_tan_theta(configuration: str, convention: model.Convention,
                     geometry: model.PlateGeometry) -> float:
    """tan(theta') of one Table 4 plate: Q from Eq. 27 with its amplitude, then Eq. 25."""
    voltage = paper_value("table4", configuration, "voltage_vpp")
    q = model.q_from_amplitude(paper_value("table4", configuration, "amplitude_pp_m"), voltage, geometry,
                               convention)
    return model.tan_theta_from_power(paper_value("table4", configuration, "power_w"), voltage, q,
                                      paper_value("table4", configuration, "frequency_hz"), geometry,
                                      convention)


@functools.lru_cache(maxsize=None)
def _table4_tan_theta_mean(convention: model.Convention, geometries: tuple[model.PlateGeometry, ...]) -> float:
    """The mean tan(theta') of the Table 4 plates: the same for every reading that differs
    only in what the large plate's numbers depend on (a sixth of the search's readings)."""
    return sum(table4_tan_theta(c, convention, g) for c, g in zip(TABLE4_CONFIGURATIONS, geometries)) \
        / len(TABLE4_CONFIGURATIONS)


def _log_misfit(row: dict) -> float:
    """RMS of log10 |computed / printed| over the targets (a wrong sign counts as a miss)."""
    ratios = [row[f"{t}_ratio"] for t in TARGETS]
    if any(r <= 0 for r in ratios):
        return math.inf
    return float(np.sqrt(np.mean([math.log10(r) ** 2 for r in ratios])))


@functools.cache
def _search() -> pd.DataFrame:
    rows = [evaluate(Reading(**dict(zip(AXES, values)))) for values in itertools.product(*AXES.values())]
    frame = pd.DataFrame(rows)
    frame["all_within"] = _worst_rel(frame)
    return frame.sort_values(["defined", "log_misfit"], ascending=[False, True],
                             kind="stable").reset_index(drop=True)


def search_readings() -> pd.DataFrame:
    """Every reading of `AXES`, one row each, best (least misfit) first.

    Columns: the axes, `defined` (False where Eq. 12 has no value), the computed values,
    `<target>_ratio` = computed / printed, `matches_<target>`, `log_misfit` and
    `all_within`, the largest |ratio - 1| over the three targets.
    """
    return _search().copy()


def _worst_rel(frame: pd.DataFrame) -> np.ndarray:
    """Each reading's largest |ratio - 1| over the targets; inf where Eq. 12 has no value or
    a ratio has the wrong sign."""
    ratios = frame[[f"{t}_ratio" for t in TARGETS]].to_numpy(dtype=float)
    fits = frame["defined"].to_numpy(dtype=bool) & (ratios > 0).all(axis=1)
    return np.where(fits, np.abs(ratios - 1.0).max(axis=1), math.inf)


def search_summary(grid: pd.DataFrame | None = None) -> pd.DataFrame:
    """How many readings reproduce each published number (and all three) within each band
    of `SUMMARY_RELS`, and the best reading for each."""
    grid = search_readings() if grid is None else grid
    defined = grid[grid["defined"]]
    rows = []
    for target, label in TARGETS.items():
        ratios = defined[f"{target}_ratio"]
        best = defined.loc[(np.log10(ratios.where(ratios > 0)).abs()).idxmin()]
        rows.append({"published": label, "readings": len(defined),
                     **{f"within_{rel:.0%}": int(((ratios > 0) & ((ratios - 1).abs() <= rel)).sum())
                        for rel in SUMMARY_RELS},
                     "best_reading": _reading(best).label, "best_ratio": best[f"{target}_ratio"]})
    best = defined.iloc[0]
    rows.append({"published": "all three at once", "readings": len(defined),
                 **{f"within_{rel:.0%}": int((defined["all_within"] <= rel).sum()) for rel in SUMMARY_RELS},
                 "best_reading": _reading(best).label, "best_ratio": best["all_within"]})
    return pd.DataFrame(rows)


def _reading(row: pd.Series) -> Reading:
    return Reading(**{axis: (row[axis].item() if hasattr(row[axis], "item") else row[axis]) for axis in AXES})


def best_reading(grid: pd.DataFrame | None = None, *, eq25_as_printed: bool = False) -> tuple[Reading, float]:
    """The reading reproducing all three numbers with the least misfit, and its worst
    |ratio - 1|; with `eq25_as_printed`, only readings keeping Eq. 25's pi and 3/4."""
    grid = search_readings() if grid is None else grid
    candidates = grid[grid["defined"]]
    if eq25_as_printed:
        candidates = candidates[candidates["eq25_with_pi"] & (candidates["eq25_coefficient"] == 0.75)]
    candidates = candidates.sort_values(["all_within", "log_misfit"], kind="stable")
    row = candidates.iloc[0]
    return _reading(row), float(row["all_within"])


#: The look-elsewhere test: how far each printed target is moved (relative, uniform
#: +-), how many times, from which seed.
LOOK_ELSEWHERE_SPREAD = 0.20
LOOK_ELSEWHERE_DRAWS = 4000
LOOK_ELSEWHERE_SEED = 22


def look_elsewhere(grid: pd.DataFrame | None = None, draws: int = LOOK_ELSEWHERE_DRAWS,
                   spread: float = LOOK_ELSEWHERE_SPREAD, seed: int = LOOK_ELSEWHERE_SEED) -> dict:
    """How often a reading of the grid reproduces all three targets within MATCH_REL when the
    printed targets are moved at random (each by a factor uniform in 1 +- `spread`): the
    chance that a search this wide finds a fitting reading for numbers it does not describe.
    A fraction far from zero means one fitting reading is what chance gives, not evidence
    that the authors computed so. Returns draws, spread, the fraction with a fit and its
    Wilson 95 % interval."""
    from scipy import stats

    grid = search_readings() if grid is None else grid
    defined = grid[grid["defined"]]
    ratios = defined[[f"{t}_ratio" for t in TARGETS]].to_numpy(dtype=float)   # computed / printed
    ratios = ratios[(ratios > 0).all(axis=1)]   # a wrong sign fits no moved target either
    # |r / f - 1| <= MATCH_REL needs (1 - MATCH_REL) f <= r <= (1 + MATCH_REL) f, f within 1 +- spread:
    # a reading outside those bounds on any target fits no draw (the margin keeps rounding's borderline ones)
    low, high = (1 - spread) * (1 - MATCH_REL) * (1 - 1e-9), (1 + spread) * (1 + MATCH_REL) * (1 + 1e-9)
    ratios = ratios[((ratios >= low) & (ratios <= high)).all(axis=1)]
    factors = np.random.default_rng(seed).uniform(1 - spread, 1 + spread, size=(draws, len(TARGETS)))
    hits = 0
    for chunk in np.array_split(factors, max(1, draws // 250)):   # (draws, readings, targets) in pieces
        moved = ratios[None, :, :] / chunk[:, None, :]
        hits += int((np.abs(moved - 1.0) <= MATCH_REL).all(axis=2).any(axis=1).sum())
    interval = stats.binomtest(hits, draws).proportion_ci(method="wilson")
    return {"draws": draws, "spread": spread, "fraction_with_a_fit": hits / draws,
            "interval_low": float(interval.low), "interval_high": float(interval.high)}


def search_words(grid: pd.DataFrame | None = None) -> list[str]:
    """The search's result in words: how isolated the inferred reading is, and how close
    a reading keeping Eq. 25 as printed (with pi and 3/4) comes."""
    grid = search_readings() if grid is None else grid
    summary = search_summary(grid).set_index("published").loc["all three at once"]
    best, worst = best_reading(grid)
    printed, printed_worst = best_reading(grid, eq25_as_printed=True)
    return [
        f"Of {int(summary['readings'])} readings, {int(summary['within_10%'])} reproduce all three published "
        f"numbers within 10 % ({int(summary['within_15%'])} within 15 %, {int(summary['within_25%'])} within "
        f"25 %). The best, worst number off by {worst:.1%}: {best.label}.",
        f"Keeping Eq. 25 as printed (with pi and 3/4), the best reading is off by {printed_worst:.1%}: "
        f"{printed.label}.",
        _look_elsewhere_words(look_elsewhere(grid)),
    ]


def _look_elsewhere_words(found: dict) -> str:
    return (f"Look-elsewhere test: with the three printed targets each moved at random by up to "
            f"+-{found['spread']:.0%}, {found['fraction_with_a_fit']:.0%} of {found['draws']} draws still find a "
            f"reading reproducing all three within {MATCH_REL:.0%} (95 % interval "
            f"{found['interval_low']:.0%} to {found['interval_high']:.0%}). A search this wide fits numbers "
            "it does not describe that often, so the inferred reading is a hypothesis about what the authors "
            "computed, not evidence of it (the plate model's predictions do not use it).")
