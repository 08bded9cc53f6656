"""Fig. 5 and Table 5 recomputed from a run: each characterised plate's Q and tan(theta')
(its amplitude and power lines against the drive), the plates' means, and the large plate
estimated from the small ones by the paper's Eqs. 25-29, beside the printed values.

The rows' conventions are `analysis.tables`' (tidy, one row per item and quantity).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import pandas as pd

from squeezebench.analysis import model, provenance
from squeezebench.analysis.budgets import COVERAGE_FACTOR, Budget
from squeezebench.paper import paper_table
from squeezebench.analysis.rundata import RunData
from squeezebench.analysis.waveforms import Estimate
from squeezebench.analysis.tables import (TABLE_COLUMNS, UNITS, LineFit, MissingDataError, compare_with_paper, fit_line,
                                          mean_estimate, protocol_points, relative_difference)


#: Where a scene file (simbench schema) keeps each length of the model geometry, in mm.
_SCENE_GEOMETRY_MM = {
    "resonator_thickness_m": ("plate", "thickness_mm"),
    "piezo_thickness_m": ("actuators", "piezo", "thickness_mm"),
    "piezo_length_m": ("actuators", "piezo", "length_mm"),
    "half_wavelength_m": ("mode", "half_wavelength_mm"),
}


def plate_geometry(run: RunData, plate: str, n_powered_piezos: int,
                   n_powered_groups: int | None = None, scene_file: str | None = None,
                   scene_state: str | None = None) -> model.PlateGeometry:
    """The model geometry of one plate from its scene copy `inputs/<scene_file>` (by
    default `inputs/<plate>.yaml`). Where the scene says how many piezos its state powers,
    a campaign stating another count is refused: n_c enters Q and tan(theta')."""
    scene_file = scene_file or f"{plate}.yaml"
    scene = run.scenes.get(scene_file)
    if scene is None:
        raise MissingDataError(f"no scene copy inputs/{scene_file} in {run.run_dir}: "
                               "the geometry of the plate is unknown")
    _check_powered_piezos(scene, scene_file, scene_state, n_powered_piezos)
    lengths_m = {}
    for name, keys in _SCENE_GEOMETRY_MM.items():
        node = scene
        for key in keys:
            node = node.get(key) if isinstance(node, dict) else None
        if not isinstance(node, (int, float)):
            raise MissingDataError(f"inputs/{plate}.yaml has no number at {'.'.join(keys)}")
        lengths_m[name] = float(node) * 1e-3
    return model.PlateGeometry(**lengths_m, n_powered_piezos=int(n_powered_piezos),
                               n_powered_groups=n_powered_groups)


def _text_or_none(value) -> str | None:
    """A stored text column's value; None, NaN (a column of Nones read back) or '' give None."""
    return value if isinstance(value, str) and value else None


def _check_powered_piezos(scene: dict, scene_file: str, state: str | None, n_powered_piezos: int) -> None:
    states = scene.get("states") if isinstance(scene.get("states"), dict) else {}
    state = state or scene.get("initial_state")
    data = states.get(state) if isinstance(states.get(state), dict) else {}
    actuators = scene.get("actuators") if isinstance(scene.get("actuators"), dict) else {}
    columns, per_column = data.get("powered_columns"), actuators.get("piezos_per_column")
    if isinstance(columns, list) and isinstance(per_column, int) and len(columns) * per_column != n_powered_piezos:
        raise MissingDataError(
            f"the campaign says {n_powered_piezos} powered piezos, but inputs/{scene_file} state {state!r} "
            f"powers {len(columns)} columns x {per_column} = {len(columns) * per_column}: correct the "
            "campaign's plate.n_powered_piezos (n_c scales Q and tan theta')")


@dataclass(frozen=True)
class PlateCharacterisation:
    """Fig. 5 for one plate: Q from Eq. 27 via the slope of amplitude vs voltage, and
    tan(theta') from Eq. 25 via the slope of power vs V^2, divided by Q."""

    plate: str
    geometry: model.PlateGeometry
    frequency_hz: float
    amplitude_slope: LineFit  # amplitude_pp_m per volt pp
    power_slope: LineFit  # W per Vpp^2
    q: Estimate
    tan_theta: Estimate
    points: pd.DataFrame
    origin: str = provenance.NOT_RECORDED   # of the points (simulated / measured)
    calibrated_on: dict[str, str] = field(default_factory=dict)   # provenance.calibrated_on
    #: The part of q's and tan_theta's standard uncertainty the plates measured on one bench
    #: share: the instruments' specifications and the tolerances of the stock they are built
    #: from (the sheet's, the piezo lot's: `uncertainty.SHEET`, `PIEZO_LOT`); 0 until
    #: `with_whole_budget`.
    systematic_u: dict[str, float] = field(default_factory=dict)
    #: The part that is this plate's own: the tolerances of what is cut for it
    #: (`uncertainty.PLATE`: its length, its piezos' length); independent between plates.
    own_u: dict[str, float] = field(default_factory=dict)

    def with_whole_budget(self, q: Budget, tan_theta: Budget) -> "PlateCharacterisation":
        """Q and tan(theta') with their budgets' Type B terms (`uncertainty.characterisation_budgets`
        without the fits) added to the fits' uncertainty, split into the plates' shared part
        and this plate's own (`uncertainty.plate_own_u`): the total is the budget's whatever the split."""
        from squeezebench.analysis import uncertainty   # as in _characterise_plates

        whole = {b.quantity: Estimate(getattr(self, b.quantity).value,
                                      math.hypot(getattr(self, b.quantity).std_uncertainty, b.std_uncertainty))
                 for b in (q, tan_theta)}
        own = {b.quantity: uncertainty.plate_own_u(b, self.geometry) for b in (q, tan_theta)}
        return replace(self, **whole, own_u=own,
                       systematic_u={b.quantity: math.sqrt(max(b.std_uncertainty**2 - own[b.quantity]**2, 0.0))
                                     for b in (q, tan_theta)})

    def fit_u(self, quantity: str) -> float:
        """The fits' own (independent) part of the quantity's standard uncertainty."""
        whole = getattr(self, quantity).std_uncertainty
        return math.sqrt(max(whole**2 - self.systematic_u.get(quantity, 0.0) ** 2 - self.own_u.get(quantity, 0.0) ** 2,
                             0.0))


def characterise_plate(plate: str, points: pd.DataFrame, geometry: model.PlateGeometry,
                       convention: model.Convention) -> PlateCharacterisation:
    """Eqs. 27 and 25 are linear in V and V^2, so a slope at V = 1 Vpp carries them:
    Q = slope_A / (A per Q at 1 Vpp); Q tan(theta') = slope_P / (P per Q tan at 1 Vpp)."""
    amplitude_fit = fit_line(points["piezo_voltage_vpp"], points["amplitude_pp_m"],
                             points["amplitude_pp_m_u"], what=f"{plate}: amplitude vs voltage (Fig. 8)")
    power_fit = fit_line(points["piezo_voltage_vpp"] ** 2, points["power_w"], points["power_w_u"],
                         what=f"{plate}: power vs voltage squared (Fig. 9)")
    frequency = float(points["frequency_hz"].mean())
    q_value = model.q_from_amplitude(amplitude_fit.slope.value, 1.0, geometry, convention)
    q_rel = amplitude_fit.slope.std_uncertainty / abs(amplitude_fit.slope.value)
    tan_value = model.tan_theta_from_power(power_fit.slope.value, 1.0, q_value, frequency, geometry,
                                           convention)
    tan_rel = math.hypot(power_fit.slope.std_uncertainty / abs(power_fit.slope.value), q_rel)
    return PlateCharacterisation(
        plate=plate, geometry=geometry, frequency_hz=frequency, amplitude_slope=amplitude_fit,
        power_slope=power_fit, q=Estimate(q_value, abs(q_value) * q_rel),
        tan_theta=Estimate(tan_value, abs(tan_value) * tan_rel), points=points)


def characterise_plates(run: RunData, convention: model.Convention) -> dict[str, PlateCharacterisation]:
    """Fig. 5 for every plate of the characterisation protocol (small plates and the large
    one), Q and tan(theta') with their whole budgets (`analysis.uncertainty`: the fits, the
    instruments' specifications, the geometry's and materials' tolerances). Computed once
    per run and convention (`RunData.characterisations`); each call gets its own dict."""
    if convention not in run.characterisations:
        run.characterisations[convention] = _characterise_plates(run, convention)
    return dict(run.characterisations[convention])


def _characterise_plates(run: RunData, convention: model.Convention) -> dict[str, PlateCharacterisation]:
    from squeezebench.analysis import uncertainty   # see _expanded
    from squeezebench.analysis.calibration import Deskew

    points = protocol_points(run, "characterisation")
    deskew = Deskew.applied_in(points)
    results = {}
    for plate, group in points.groupby("plate", sort=True):
        first = group.iloc[0]
        geometry = plate_geometry(run, str(plate), int(first["n_powered_piezos"]), int(first["n_powered_columns"]),
                                  scene_file=_text_or_none(first.get("scene_file")),
                                  scene_state=_text_or_none(first.get("scene_state")))
        result = replace(characterise_plate(str(plate), group, geometry, convention),
                         origin=provenance.point_origin(group, run.manifest, run.scenes),
                         calibrated_on=provenance.calibrated_on(run, group))
        q, tan = uncertainty.characterisation_budgets(result, convention, deskew, with_fit=False)
        results[str(plate)] = result.with_whole_budget(q, tan)
    return results


def mean_over_plates(plates: list[PlateCharacterisation], quantity: str) -> Estimate:
    """Mean of a quantity over plates measured on one bench and built from one stock (GUM
    5.2.2): each plate's independent part (its fits and its own cuts' tolerances,
    `PlateCharacterisation.own_u`) averages down as 1/n in quadrature; the part they share
    (the instruments, the sheet's and piezo lot's tolerances: r = 1) is kept whole, as the
    plates' mean of it; beside them the plates' scatter (`tables.mean_estimate`)."""
    return mean_estimate([getattr(p, quantity).value for p in plates],
                         [math.hypot(p.fit_u(quantity), p.own_u.get(quantity, 0.0)) for p in plates],
                         shared=[p.systematic_u.get(quantity, 0.0) for p in plates])


def fig5_table(plates: dict[str, PlateCharacterisation]) -> pd.DataFrame:
    """Q and tan(theta') per plate, then the mean tan(theta') per resonator thickness.
    The paper's per-plate labels of Fig. 5 did not survive; what its text prints (Plate 4's
    Q, the mean tan(theta') per thickness) is set beside."""
    paper = paper_table("small_plates")

    def row(item, quantity, estimate: Estimate, thickness_mm: float, printed_key, calibrated) -> dict:
        printed = paper[(paper["item"] == printed_key[0]) & (paper["quantity"] == printed_key[1])]
        derived = _derived_row("fig5", item, quantity, estimate, calibrated)
        derived["unit"] = "1"
        return {**compare_with_paper(derived, printed), "resonator_thickness_mm": thickness_mm}

    rows = []
    for name, result in plates.items():
        thickness_mm = result.geometry.resonator_thickness_m * 1e3
        for quantity in ("q", "tan_theta"):
            rows.append(row(name, quantity, getattr(result, quantity), thickness_mm, (name, quantity),
                            result.calibrated_on))
    small = {n: p for n, p in plates.items() if n != LARGE_PLATE}
    for thickness_mm in sorted({round(p.geometry.resonator_thickness_m * 1e3, 6) for p in small.values()}):
        same = {n: p for n, p in small.items()
                if math.isclose(p.geometry.resonator_thickness_m * 1e3, thickness_mm, rel_tol=1e-6)}
        mean = mean_over_plates(list(same.values()), "tan_theta")
        calibrated = "; ".join(f"{n}: {p.calibrated_on['tan_theta']}" for n, p in same.items()
                               if "tan_theta" in p.calibrated_on)
        rows.append(row(f"small plates {thickness_mm:g} mm", "tan_theta_mean", mean, thickness_mm,
                        (f"{thickness_mm:g}mm", "tan_theta_mean"), {"tan_theta_mean": calibrated}))
    return pd.DataFrame(rows, columns=TABLE_COLUMNS + ["resonator_thickness_mm"])


LARGE_PLATE = "large_plate"


#: Sec. 5.2: the large plate copies the Plate 4 layout, so Eq. 29 starts from Plate 4's Q.
TEMPLATE_SMALL_PLATE = "small_plate_4"


@dataclass(frozen=True)
class Table5Estimate:
    q: Estimate
    tan_theta: Estimate
    calibrated_on: dict[str, str] = field(default_factory=dict)   # of the small plates used


def estimate_large_from_small(plates: dict[str, PlateCharacterisation],
                              convention: model.Convention) -> Table5Estimate:
    """Table 5's estimate: Q by Eq. 29 from Plate 4; tan(theta') the mean over the small
    plates with the large plate's resonator thickness (Sec. 5.3.2)."""
    missing = [p for p in (LARGE_PLATE, TEMPLATE_SMALL_PLATE) if p not in plates]
    if missing:
        raise MissingDataError(f"Table 5 needs the characterisation of {', '.join(missing)}")
    large, template = plates[LARGE_PLATE], plates[TEMPLATE_SMALL_PLATE]
    ratio = model.q_large_from_small(1.0, large.geometry.piezo_length_m, template.geometry.piezo_length_m,
                                     as_printed=convention.eq29_as_printed)
    same_thickness = as_thick_as_large(plates)
    if not same_thickness:
        raise MissingDataError("Table 5 needs small plates as thick as the large plate")
    tan = mean_over_plates([plates[name] for name in same_thickness], "tan_theta")
    calibrated = {}
    if "q" in template.calibrated_on:
        calibrated["q"] = f"{TEMPLATE_SMALL_PLATE}: {template.calibrated_on['q']}"
    tan_sources = [f"{name}: {plates[name].calibrated_on['tan_theta']}" for name in same_thickness
                   if "tan_theta" in plates[name].calibrated_on]
    if tan_sources:
        calibrated["tan_theta"] = "; ".join(tan_sources)
    return Table5Estimate(q=Estimate(template.q.value * ratio, template.q.std_uncertainty * ratio),
                          tan_theta=tan, calibrated_on=calibrated)


def as_thick_as_large(plates: dict[str, PlateCharacterisation]) -> list[str]:
    """The small plates whose resonator is as thick as the large plate's: Table 5's tan(theta')
    is their mean (Sec. 5.3.2)."""
    large = plates[LARGE_PLATE]
    return [name for name, p in plates.items() if name != LARGE_PLATE and math.isclose(
        p.geometry.resonator_thickness_m, large.geometry.resonator_thickness_m, rel_tol=1e-6)]


def table5(plates: dict[str, PlateCharacterisation], convention: model.Convention) -> pd.DataFrame:
    """Table 5: estimated from the small plates vs measured on the large plate."""
    estimate = estimate_large_from_small(plates, convention)
    measured = plates[LARGE_PLATE]
    paper = paper_table("table5")
    rows = []
    for item, values in (("estimated", estimate), ("measured", measured)):
        for quantity in ("q", "tan_theta"):
            rows.append(compare_with_paper(
                _derived_row("table5", item, quantity, getattr(values, quantity), values.calibrated_on),
                paper[(paper["item"] == item) & (paper["quantity"] == quantity)]))
    frame = pd.DataFrame(rows, columns=TABLE_COLUMNS)
    predicted = predicted_large_plate_q_tan(measured.geometry, convention)
    frame["predicted_value"] = frame["quantity"].map(lambda q: predicted[q][0])
    frame["predicted_expanded_uncertainty"] = frame["quantity"].map(lambda q: predicted[q][1])
    frame["predicted_difference"] = [relative_difference(v, p) for v, p in zip(frame["predicted_value"],
                                                                                frame["paper_value"])]
    return frame


def predicted_large_plate_q_tan(geometry: model.PlateGeometry,
                                convention: model.Convention) -> dict[str, tuple[float, float]]:
    """What physics predicts the large plate's Q and tan theta' read as (`predicted_q_tan` of
    plates.predicted_plates' large plate). Both estimated and measured rows of Table 5 aim
    at this plate."""
    from squeezebench.plates import predicted_plates   # the plate solver: only where a paper table is drawn

    return predicted_q_tan(predicted_plates.large_plate_response(), geometry, convention)


def predicted_q_tan(response: dict[str, float], geometry: model.PlateGeometry,
                    convention: model.Convention) -> dict[str, tuple[float, float]]:
    """The Q and tan theta' a plate the model predicts reads as, each (value, U k = 2): its
    amplitude pp per Vpp and power per Vpp^2 at resonance (`predicted_plates.response_per_volt`,
    no printed result in) through the same inversion of Eqs. 27 and 25, geometry and reading
    as a measured plate. U from the materials' and geometry's tolerances and the build's
    damping spread (`predicted_plates.response_relative_u`), or the response's own
    `amplitude_rel_U` where it carries one (the large plate's, with its placement and bond)."""
    from squeezebench.plates import predicted_plates

    u = predicted_plates.response_relative_u(geometry.resonator_thickness_m)
    q = model.q_from_amplitude(response["amplitude_pp_m_per_vpp"], 1.0, geometry, convention)
    tan = model.tan_theta_from_power(response["power_w_per_vpp2"], 1.0, q, response["frequency_hz"], geometry,
                                     convention)
    u_amplitude = response.get("amplitude_rel_U", u["amplitude_pp_m"])
    return {"q": (q, abs(q) * u_amplitude), "tan_theta": (tan, abs(tan) * u["tan_theta"])}


def _derived_row(table: str, item: str, quantity: str, value: Estimate, calibrated: dict[str, str]) -> dict:
    """A derived value (Q, tan theta'): its expanded uncertainty is k times its standard
    uncertainty (the whole budget when the plates were characterised from a run)."""
    return {"table": table, "item": item, "quantity": quantity, "unit": UNITS[quantity],
            "value": value.value, "std_uncertainty": value.std_uncertainty,
            "expanded_uncertainty": COVERAGE_FACTOR * value.std_uncertainty, "scope_value": math.nan,
            "origin": provenance.DERIVED, "calibrated_on": calibrated.get(quantity, ""), "status": "measured"}


def estimated_large_plate_power_w(plates: dict[str, PlateCharacterisation],
                                  convention: model.Convention) -> pd.DataFrame:
    """Fig. 9's estimate: Eq. 25 with Table 5's estimated Q and tan(theta') at each
    measured voltage of the large plate (NaN without the small plates), beside the measured
    power and what physics predicts (the plate model's power per Vpp^2, with its U, k = 2)."""
    large = plates[LARGE_PLATE]
    voltages = large.points["piezo_voltage_vpp"].to_numpy()
    if TEMPLATE_SMALL_PLATE in plates:
        estimate = estimate_large_from_small(plates, convention)
        estimated = [model.power_w(estimate.q.value, estimate.tan_theta.value, v, large.frequency_hz,
                                   large.geometry, convention) for v in voltages]
    else:   # no small plate to estimate from: the measured and predicted lines alone
        estimated = [math.nan] * len(voltages)
    from squeezebench.plates import predicted_plates   # the plate solver: only where a paper table is drawn

    response = predicted_plates.large_plate_response()
    predicted = response["power_w_per_vpp2"] * voltages**2
    return pd.DataFrame({"piezo_voltage_vpp": voltages, "power_measured_w": large.points["power_w"].to_numpy(),
                         "power_estimated_w": estimated, "power_predicted_w": predicted,
                         "power_predicted_U_w": predicted * response["power_rel_U"]})
