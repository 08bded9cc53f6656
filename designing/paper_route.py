"""Route (b): the paper's method, the large plate's voltage and power from characterised
small plates through Eqs. 25-29, beside the physics route.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from uncertainties import ufloat

from squeezebench.analysis import model
from squeezebench.designing.design import COVERAGE_FACTOR, DesignError, PhysicsPrediction


@dataclass(frozen=True)
class PaperRoute:
    """Route (b)'s answer: Q and tan(theta') carried to the design, and what they give."""

    q: object   # uncertainties' ufloat
    tan_theta: object
    voltage_vpp: object
    power_w: object
    amplitude_pp_m: float
    template: str
    small_plates: tuple[str, ...]
    convention: model.Convention   # the reading the small plates were characterised and carried under
    geometry: model.PlateGeometry

    def power_at(self, voltage_vpp: np.ndarray, frequency_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """Eq. 25 against voltage: nominal and U (k = 2) from Q and tan(theta')."""
        per_v2 = _eq25_per_v2(self.q, self.tan_theta, frequency_hz, self.geometry, self.convention)
        return (per_v2.nominal_value * np.asarray(voltage_vpp) ** 2,
                COVERAGE_FACTOR * per_v2.std_dev * np.asarray(voltage_vpp) ** 2)


def _eq25_per_v2(q, tan_theta, frequency_hz, geometry: model.PlateGeometry, convention: model.Convention):
    """Eq. 25's power per Vpp^2; linear in Q, tan(theta') and f, so ufloats pass through."""
    return q * tan_theta * frequency_hz * model.power_w(1.0, 1.0, 1.0, 1.0, geometry, convention)


def predict_from_small_plates(physics: PhysicsPrediction, plates: dict,
                              convention: model.Convention | None = None) -> PaperRoute:
    """Route (b) from `plates` (name -> `characterisation.PlateCharacterisation`, the small plates of
    one or more characterisation runs, characterised under `convention`: by default the
    report's reading; a plate as thick as the design is needed)."""
    from squeezebench.analysis.model import REPORT_CONVENTION
    from squeezebench.analysis.characterisation import LARGE_PLATE, mean_over_plates

    design, values = physics.design, physics.nominal.values
    convention = convention or REPORT_CONVENTION
    thickness_m = design.resonator.thickness_mm * 1e-3
    small = {n: p for n, p in plates.items() if n != LARGE_PLATE}
    same = {n: p for n, p in small.items()
            if math.isclose(p.geometry.resonator_thickness_m, thickness_m, rel_tol=1e-6)}
    if not same:
        found = ", ".join(f"{n} ({p.geometry.resonator_thickness_m * 1e3:g} mm)" for n, p in sorted(small.items()))
        raise DesignError(f"route (b) needs a characterised small plate {design.resonator.thickness_mm:g} mm thick "
                          f"like the design's resonator; the runs hold {found or 'none'}")
    b_design = design.piezo.width_y_mm * 1e-3
    template_name = design.from_small_plates.template_plate
    if template_name is not None:
        if template_name not in same:
            raise DesignError(f"from_small_plates.template_plate {template_name!r} is not among the characterised "
                              f"plates as thick as the design: {', '.join(sorted(same))}")
        template = same[template_name]
        q_small = ufloat(template.q.value, template.q.std_uncertainty)
        b_small = template.geometry.piezo_length_m
    else:
        mean_q = mean_over_plates(list(same.values()), "q")
        q_small = ufloat(mean_q.value, mean_q.std_uncertainty)
        b_small = float(np.mean([p.geometry.piezo_length_m for p in same.values()]))
        template_name = "mean of " + ", ".join(sorted(same))
    tan = mean_over_plates(list(same.values()), "tan_theta")
    q = q_small * model.q_large_from_small(1.0, b_design, b_small, as_printed=convention.eq29_as_printed)
    geometry = model.PlateGeometry(
        resonator_thickness_m=thickness_m, piezo_thickness_m=design.piezo.thickness_mm * 1e-3,
        piezo_length_m=b_design, half_wavelength_m=values["half_wavelength_mm"] * 1e-3,
        n_powered_piezos=design.n_powered_piezos, n_powered_groups=design.n_powered_groups)
    frequency = ufloat(values["frequency_hz"], physics.expanded["frequency_hz"] / COVERAGE_FACTOR)
    amplitude = values["amplitude_pp_m"]   # at the centre, where the paper's amplitudes are read
    tan_theta = ufloat(tan.value, tan.std_uncertainty)
    voltage = amplitude / (q * model.amplitude_pp_m(1.0, 1.0, geometry, convention))
    power = _eq25_per_v2(q, tan_theta, frequency, geometry, convention) * voltage**2
    return PaperRoute(q=q, tan_theta=tan_theta, voltage_vpp=voltage, power_w=power, amplitude_pp_m=amplitude,
                      template=template_name, small_plates=tuple(sorted(same)), convention=convention,
                      geometry=geometry)
