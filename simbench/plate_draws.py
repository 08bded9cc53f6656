"""A plate as built, not as drawn: its geometry and materials drawn within their tolerances.

The budgets of Q and tan(theta') (`analysis.uncertainty.model_budgets`) claim to cover
the tolerances of the paper model's inputs, the plate's and piezos' dimensions and their
materials' constants, which no measurement on the bench gives. A coverage study can only
test that claim on plates that really depart from their nominal values: the effect
`plate_tolerances` draws, once per bench, each input's relative departure within its
tolerance (`uncertainty.tolerances_for`, and the piezo permittivity's,
`specifications.MODEL_TOLERANCES`) and gives the simulated plate the response that
departure makes.

A lab's plates are built from stock, so a departure is drawn once for whoever shares it
(`uncertainty.SHEET`, `PIEZO_LOT`, `PLATE` say why; every scene of a plate, its cuts and
runs, draws the same):

- the sheet (one per alloy and nominal thickness: the plates as thick as each other are
  cut from one): the resonator's thickness and Young's modulus;
- the piezo lot (one per ceramic and nominal thickness): the piezos' thickness, d31,
  c11 and permittivity;
- the plate itself: its length (the half-wavelength) and its piezos' length.

A mean over plates (`characterisation.mean_over_plates`) keeps the first two whole and
averages the third down, as its budget says. The response:

- the motional branch answers as the paper's model (Eqs. 25 and 27, the physical
  reading) says a plate with those inputs does: amplitude per volt times a, power per volt
  squared times b, at the same Q and tan(theta'), so the force factor goes by b / a and
  the mechanical resistance by b / a^2 (velocity psi V / R, power psi^2 V^2 / 2 R);
- the clamped capacitance goes with eps33 b_p w_p / h_p (the width is not toleranced);
- the resonance stays where the scene puts it: a scene states the frequency a plate was
  measured or predicted at, and the budgets of frequency claim no plate tolerance.

`draw: 1` draws uniformly within each tolerance, as the budgets assume; `draw: 2` as the
world does (`effects.world_draw`: normal, now and then beyond the tolerance). `draw: 0`
puts every input at its tolerance's limit (the largest departure, for tests). Each drawn
departure is `deviations_rel`: what the plate really is, for whoever scores against it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from squeezebench.plates.specifications import MODEL_TOLERANCES
from squeezebench.simbench import physics
from squeezebench.simbench.effects import EFFECTS
from squeezebench.simbench.systematic_effects import SystematicEffect, draw_stream

#: The drawn inputs: the paper model's tolerated inputs (`uncertainty.TOLERANCES` and the
#: resonator's sheet thickness, whose half-width depends on the plate: 0 here means the
#: sheet standard's at the scene's thickness) and the piezo permittivity (C0).
RESONATOR_THICKNESS = "resonator_thickness_m"
PERMITTIVITY = "relative_permittivity_t"


def _model_inputs() -> dict[str, tuple[float, str]]:
    """Each drawn input's (half-width, who shares its departure): the permittivity is the
    ceramic's, the piezo lot's as its d31 and c11 are."""
    from squeezebench.analysis.uncertainty import PIEZO_LOT, SHEET, TOLERANCES   # analysis's budgets: imported here

    return {RESONATOR_THICKNESS: (0.0, SHEET),
            **{name: (t.half_width_rel, t.shared_by) for name, t in TOLERANCES.items()},
            PERMITTIVITY: (MODEL_TOLERANCES[PERMITTIVITY].half_width, PIEZO_LOT)}


_INPUTS = _model_inputs()


class PlateTolerances(SystematicEffect, errors={name: width for name, (width, _) in _INPUTS.items()}):
    """The plate's geometry and materials drawn within their tolerances (module docstring)."""

    name = "plate_tolerances"
    stages = frozenset({"load"})
    #: Whose departure each input is (`uncertainty.SHEET`, `PIEZO_LOT` or `PLATE`).
    shared_by = {name: owner for name, (_, owner) in _INPUTS.items()}

    def __init__(self, scene, **parameters: float) -> None:
        from squeezebench.plates.specifications import sheet_thickness_tolerance

        if not parameters.get(RESONATOR_THICKNESS):
            parameters = {**parameters, RESONATOR_THICKNESS: sheet_thickness_tolerance(scene.plate.thickness_mm * 1e-3)}
        super().__init__(scene, **parameters)
        #: Relative departure of each input from its nominal value.
        self.deviations_rel = dict(self.values)
        self.amplitude_ratio, self.power_ratio = response_ratios(scene, self.deviations_rel)
        piezo = self.deviations_rel
        self.capacitance_ratio = ((1.0 + piezo[PERMITTIVITY]) * (1.0 + piezo["piezo_length_m"])
                                  / (1.0 + piezo["piezo_thickness_m"]))

    def drawn_values(self) -> dict[str, float]:
        """Each input drawn in turn from its owner's stream on this bench (`owner`): every
        plate of one sheet or piezo lot draws the same departures of it, in the same order."""
        streams: dict[str, np.random.Generator] = {}
        values = {}
        for name in self.errors:
            owner = self.owner(self.shared_by[name])
            rng = streams.setdefault(owner, draw_stream(self.parameters["bench_seed"], self.name, owner))
            values[name] = self.drawn(rng, name)
        return values

    def owner(self, shared_by: str) -> str:
        """The stream's name of this plate's sheet, piezo lot or itself."""
        from squeezebench.analysis.uncertainty import PIEZO_LOT, SHEET

        plate, piezo = self.scene.plate, self.scene.actuators.piezo
        if shared_by == SHEET:
            return f"sheet of {plate.material.name}, {plate.thickness_mm:g} mm"
        if shared_by == PIEZO_LOT:
            return f"lot of {piezo.material.name}, {piezo.thickness_mm:g} mm"
        return plate.name

    def load(self, load: physics.PlateLoad) -> physics.PlateLoad:
        if load.capacitance_f == 0.0:   # the calibration resistor in the plate's place: no plate to draw
            return load
        main = load.branches[0]
        drawn = replace(main, force_factor_n_per_v=main.force_factor_n_per_v * self.power_ratio / self.amplitude_ratio,
                        resistance_ns_per_m=main.resistance_ns_per_m * self.power_ratio / self.amplitude_ratio**2)
        return replace(load, capacitance_f=load.capacitance_f * self.capacitance_ratio,
                       branches=(drawn, *load.branches[1:]))


def response_ratios(scene, deviations_rel: dict[str, float]) -> tuple[float, float]:
    """(a, b): the drawn plate's amplitude per volt and power per volt squared over the
    nominal plate's, at the same Q and tan(theta'), by the paper's Eqs. 27 and 25 (the
    physical reading) on the scene's initial state's half-wavelength section."""
    from squeezebench.analysis import model
    from squeezebench.analysis.uncertainty import with_deviations

    convention = model.PHYSICAL_CONVENTION
    geometry = scene.geometry(scene.state(scene.initial_state))
    drawn, drawn_convention = with_deviations(geometry, convention, deviations_rel)
    frequency_hz = scene.state(scene.initial_state).resonance_frequency_hz

    def response(shape, reading) -> tuple[float, float]:
        return (model.amplitude_pp_m(1.0, 1.0, shape, reading),
                model.power_w(1.0, 1.0, 1.0, frequency_hz, shape, reading))

    (a0, p0), (a1, p1) = response(geometry, convention), response(drawn, drawn_convention)
    return a1 / a0, p1 / p0


EFFECTS[PlateTolerances.name] = PlateTolerances
