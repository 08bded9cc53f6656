"""The audit: each inconsistency of the paper, computed from its printed values.

Only printed values (data/paper/, with their source) and the model's equations enter;
every number shown is computed here. `analysis.readings` goes further: it evaluates the
large plate's published operating point (Sec. 5.3.2, Table 5) and the Table 4 loss
tangent under every combination of the readings the paper leaves open, and says which
readings reproduce which published number.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from squeezebench.analysis import model, readings
from squeezebench.paper import paper_source, paper_value

MATCH_REL = readings.MATCH_REL


@dataclass(frozen=True)
class Finding:
    """One audited point: what was computed, the printed value it is compared with."""

    topic: str
    quantity: str
    computed: float
    printed: float | None
    source: str
    comment: str

    def as_row(self) -> dict:
        rel = (self.computed - self.printed) / abs(self.printed) if self.printed else None
        return {"topic": self.topic, "quantity": self.quantity, "computed": self.computed,
                "printed": self.printed, "relative_difference": rel, "source": self.source,
                "comment": self.comment}


# --- the printed plates as model geometries ----------------------------------------------

def large_plate_geometry() -> model.PlateGeometry:
    """The large plate of Sec. 5.2 under the text's own reading."""
    return readings.PRINTED_READING.large_plate_geometry()


def _large_operating_point() -> dict[str, float]:
    return {"q": paper_value("table5", "measured", "q"),
            "tan_theta": paper_value("table5", "measured", "tan_theta"),
            "voltage_vpp": paper_value("large_plate", "large_plate", "voltage_vpp"),
            "frequency_hz": paper_value("large_plate", "large_plate", "frequency_hz"),
            "power_w": paper_value("large_plate", "large_plate", "power_w"),
            "amplitude_m": paper_value("large_plate", "large_plate", "amplitude_m")}


# --- the findings ------------------------------------------------------------------------

def eq29_findings() -> list[Finding]:
    """Eq. 29 printed (b_large/b_small) vs the text's reading (b_small/b_large)."""
    q_small = paper_value("small_plates", "small_plate_4", "q")
    b_large = paper_value("large_plate", "large_plate", "piezo_length_mm")
    b_small = paper_value("small_plates", "plate", "piezo_length_mm")
    printed = paper_value("table5", "estimated", "q")
    source = paper_source("table5", "estimated", "q")
    as_printed = model.q_large_from_small(q_small, b_large, b_small, as_printed=True)
    inverted = model.q_large_from_small(q_small, b_large, b_small, as_printed=False)
    return [
        Finding("Eq. 29 inverted", "Q_large, Eq. 29 as printed (b_large/b_small)", as_printed, printed,
                source, "the printed ratio makes Q grow with piezo length, against the text"),
        Finding("Eq. 29 inverted", "Q_large with b_small/b_large", inverted, printed, source,
                "the inverse ratio reproduces Table 5 (to the rounding of Q_small)"),
        Finding("Eq. 29 inverted", "Q_small that would print Table 5's estimate",
                printed / (b_small / b_large), q_small, "Sec. 5.3.2",
                "Table 5's last digit needs Q_small slightly above its printed rounding"),
    ]


def eq28_findings() -> list[Finding]:
    """Eq. 27 substituted into Eq. 25 vs Eq. 28 as printed: the ratio is pi."""
    op = _large_operating_point()
    geometry = large_plate_geometry()
    convention = model.PAPER_CONVENTION
    amplitude = model.amplitude_pp_m(op["q"], op["voltage_vpp"], geometry, convention)
    eq25 = model.power_w(op["q"], op["tan_theta"], op["voltage_vpp"], op["frequency_hz"], geometry, convention)
    printed28 = model.power_from_amplitude_w(amplitude, op["q"], op["tan_theta"], op["frequency_hz"], geometry,
                                             replace(convention, eq28_with_pi=False))
    return [Finding("Eq. 28 missing pi", "Eq. 25 / Eq. 28 as printed, same Q, V, A", eq25 / printed28, None,
                    "Eqs. 25, 27, 28", f"equals pi = {math.pi:.5f}: Eq. 28 lost a factor pi")]


def sign_findings() -> list[Finding]:
    """The sign of a (Eq. 12) and what it does to Eqs. 25 and 27 at the large plate."""
    op = _large_operating_point()
    geometry = large_plate_geometry()
    findings = []
    for convention, label in ((model.PAPER_CONVENTION, "E_i as printed"),
                              (model.PHYSICAL_CONVENTION, "E_i = 67 GPa")):
        a = model.a_factor(geometry, convention)
        amplitude = model.amplitude_pp_m(op["q"], op["voltage_vpp"], geometry, convention)
        power = model.power_w(op["q"], op["tan_theta"], op["voltage_vpp"], op["frequency_hz"], geometry,
                              convention)
        q_needed = model.q_from_amplitude(op["amplitude_m"], op["voltage_vpp"], geometry, convention)
        findings += [
            Finding("sign of Eq. 25", f"a (Eq. 12), 2 mm large plate, {label}", a, None, "Eq. 12, Table 2",
                    "negative a makes Q > 0 with d31 < 0 give A > 0, and tan theta' < 0 give P > 0"),
            Finding("sign of Eq. 25", f"A pp at the published point, Q=1.48, {label}", amplitude,
                    op["amplitude_m"], "Sec. 5.3.2", "Eq. 27"),
            Finding("sign of Eq. 25", f"P at the published point, Q=1.48, tan=-1.24, {label}", power,
                    op["power_w"], "Sec. 5.3.2", "Eq. 25; negative power is unphysical"),
            Finding("Table 5 under E_i", f"Q from Eq. 27 for the published 1 um at 32 Vpp, {label}",
                    q_needed, paper_value("table5", "measured", "q"), "Table 5",
                    "the Q a reader obtains from the published amplitude"),
            Finding("Table 5 under E_i", f"tan theta' from Eq. 25 for 1.3 W at 32 Vpp with that Q, {label}",
                    model.tan_theta_from_power(op["power_w"], op["voltage_vpp"], q_needed, op["frequency_hz"],
                                               geometry, convention),
                    paper_value("table5", "measured", "tan_theta"), "Table 5",
                    "the loss tangent the published power implies"),
        ]
    return findings


def table4_findings(convention: model.Convention = model.PAPER_CONVENTION) -> list[Finding]:
    """Table 4: amplitude pp = velocity pp / (2 pi f), and tan theta' from Eqs. 25/27."""
    findings = []
    tangents = []
    for configuration in ("1-column", "2-columns 1 powered", "2-columns 2 powered"):
        velocity = paper_value("table4", configuration, "velocity_pp_mps")
        frequency = paper_value("table4", configuration, "frequency_hz")
        amplitude = paper_value("table4", configuration, "amplitude_pp_m")
        findings.append(Finding("Table 4 amplitude", f"v_pp/(2 pi f), {configuration}",
                                velocity / (2 * math.pi * frequency), amplitude, "Table 4",
                                "the printed amplitude is the velocity divided by 2 pi f"))
        tangents.append(readings.table4_tan_theta(configuration, convention,
                                                  readings.PRINTED_READING.table4_geometry(configuration)))
    findings.append(Finding("Table 4 loss tangent", f"mean tan theta' from Table 4 ({convention.name})",
                            float(np.mean(tangents)), paper_value("small_plates", "1.2mm", "tan_theta_mean"),
                            "Sec. 4", "Q from Eq. 27, then tan theta' from Eq. 25 divided by Q"))
    return findings


def neutral_plane_findings() -> list[Finding]:
    """a and the published-point amplitude under each choice of z0, for both E_i."""
    op = _large_operating_point()
    geometry = large_plate_geometry()
    findings = []
    for materials_label, base in (("E_i printed", model.PAPER_CONVENTION),
                                  ("E_i 67 GPa", model.PHYSICAL_CONVENTION)):
        for plane in ("stack_middle", "resonator_middle", "bending_neutral"):
            convention = replace(base, neutral_plane=plane)
            z0 = model.neutral_plane_m(geometry, convention)
            try:
                a = model.a_factor(geometry, convention)
                amplitude = model.amplitude_pp_m(op["q"], op["voltage_vpp"], geometry, convention)
                comment = f"z0 = {z0 * 1e3:.4g} mm; A pp at the published point {amplitude * 1e6:.4g} um"
            except model.ModelGeometryError as exc:
                a, comment = math.nan, f"z0 = {z0 * 1e3:.4g} mm: {exc}"
            findings.append(Finding("neutral plane", f"a, {plane}, {materials_label}", a, None,
                                    "Sec. 3.2, Eq. 12", comment))
    return findings


def power_estimate_findings() -> list[Finding]:
    """Eq. 25 is linear in Q tan theta': Table 5's estimate vs measurement in power."""
    ratio = (paper_value("table5", "estimated", "q") * paper_value("table5", "estimated", "tan_theta")) / (
        paper_value("table5", "measured", "q") * paper_value("table5", "measured", "tan_theta"))
    return [Finding("Table 5 power", "P estimated / P measured from Table 5 (Eq. 25)", ratio, 1.0,
                    "Table 5, Sec. 5.3.2", "the paper reports an average error below 10 %")]


def print_slip_findings() -> list[Finding]:
    """Eq. 14 writes 3 d31 (z0-z)/(2 h_p a); Eqs. 20-21 write (3/2) d31 (z0-z)/(2 h_p a)."""
    eq14 = 3.0 / 2.0
    eq20 = (3.0 / 2.0) / 2.0
    return [Finding("Eqs. 20-21 factor", "Eq. 14 coefficient / Eq. 20 coefficient", eq14 / eq20, None,
                    "Eqs. 14, 20, 21", "a factor 2 lost between the strain and its rate"),
            Finding("Table 3 label", "uncut plate length (mm), Fig. 2 caption vs Table 3",
                    paper_value("table3", "plate", "resonator_length_mm"), 75.0, "Table 3, Fig. 2",
                    "Table 3 heads the uncut plate 75 x 41; the caption says 76 mm")]


def audit_findings() -> pd.DataFrame:
    findings = (eq29_findings() + eq28_findings() + sign_findings() + power_estimate_findings()
                + table4_findings() + neutral_plane_findings() + print_slip_findings())
    return pd.DataFrame([f.as_row() for f in findings])


# --- the reading search (kept under the names the report uses) ----------------------------

GRID_AXES = readings.AXES
convention_grid = readings.search_readings
grid_summary = readings.search_summary


# --- Table 5 and Fig. 9 of a run under the physical reading, the text's and the inferred one ---

#: The readings Table 5 and Fig. 9 are shown under: the physical one (the report's), the
#: text's own (E_i as printed), and the search's best.
TABLE5_READINGS = (model.PHYSICAL_CONVENTION, model.PAPER_CONVENTION, model.INFERRED_CONVENTION)


def table5_under_readings(run, conventions=TABLE5_READINGS) -> pd.DataFrame:
    """Table 5 (estimated and measured Q, tan theta') and Fig. 9's mean estimate-vs-measured
    power difference, recomputed from the run's characterisation under each reading.

    One row per (reading, item, quantity) with the run's value, the printed one and their
    relative difference; `item` "fig9" / quantity "mean_power_difference" is the mean of
    (P_estimated - P_measured) / P_measured over the large plate's voltages; its `printed`
    is the bound the paper claims for its size (below 10 %), not a value.
    """
    from squeezebench.analysis import characterisation  # it reads runs; the audit's findings do not

    rows = []
    for convention in conventions:
        plates = characterisation.characterise_plates(run, convention)
        for row in characterisation.table5(plates, convention).to_dict("records"):
            rows.append({"reading": convention.name, "item": row["item"], "quantity": row["quantity"],
                         "value": row["value"], "printed": row["paper_value"],
                         "relative_difference": row["relative_difference"]})
        power = characterisation.estimated_large_plate_power_w(plates, convention)
        difference = float(np.mean(power["power_estimated_w"] / power["power_measured_w"] - 1.0))
        rows.append({"reading": convention.name, "item": "fig9", "quantity": "mean_power_difference",
                     "value": difference, "printed": MATCH_REL, "relative_difference": math.nan})
    return pd.DataFrame(rows)


def table5_verdicts(frame: pd.DataFrame) -> list[str]:
    """In words: under each reading, which published number breaks which claim."""
    words = []
    for reading, group in frame.groupby("reading", sort=False):
        value = {(r.item, r.quantity): r for r in group.itertuples(index=False)}
        fig9 = value[("fig9", "mean_power_difference")].value
        measured_tan = value[("measured", "tan_theta")]
        estimated_tan = value[("estimated", "tan_theta")]
        claim = "holds" if abs(fig9) <= MATCH_REL else "fails"
        text = (f"Under the {reading} reading the estimate from the small plates differs from the large "
                f"plate's measured power by {fig9:+.1%} on average: the paper's 'below 10 %' claim {claim}. ")
        factor = measured_tan.value / measured_tan.printed
        if abs(factor - 1.0) > MATCH_REL:
            text += (f"The published 1.3 W at 32 Vpp with Q = {value[('measured', 'q')].value:.3g} gives "
                     f"tan theta' = {measured_tan.value:.3g}, not the printed {measured_tan.printed:.3g} "
                     f"(a factor {1 / factor:.3g}); ")
        else:
            text += (f"The published 1.3 W at 32 Vpp gives tan theta' = {measured_tan.value:.3g} against the "
                     f"printed {measured_tan.printed:.3g} ({measured_tan.relative_difference:+.1%}); ")
        text += (f"the small plates give {estimated_tan.value:.3g} against the printed "
                 f"{estimated_tan.printed:.3g}.")
        printed_reading = _PRINTED_NUMBERS_READINGS.get(reading)
        if printed_reading is not None:
            predicted = printed_estimate_power_w(printed_reading)
            published = paper_value("large_plate", "large_plate", "power_w")
            verdict = ("within" if abs(predicted / published - 1.0) <= MATCH_REL else "outside")
            text += (f" From printed numbers alone: Table 5's estimate (Q {paper_value('table5', 'estimated', 'q'):g}, "
                     f"tan theta' {paper_value('table5', 'estimated', 'tan_theta'):g}) through Eq. 25 under this "
                     f"reading gives {predicted:.3g} W at 32 Vpp against the published {published:g} W, a factor "
                     f"{predicted / published:.3g}: {verdict} the paper's 10 %.")
        words.append(text)
    return words


#: The search's Reading (with its lambda and n_c) behind each convention Table 5 is shown under.
_PRINTED_NUMBERS_READINGS = {model.PAPER_CONVENTION.name: readings.PRINTED_READING,
                             model.INFERRED_CONVENTION.name: readings.INFERRED_READING}


def printed_estimate_power_w(reading: readings.Reading) -> float:
    """Eq. 25 at the published 32 Vpp and 52.4 kHz with Table 5's printed estimate of Q and
    tan theta', on the large plate as `reading` reads it: what the paper's Fig. 9 estimate
    is under that reading, computed from printed numbers only."""
    return model.power_w(paper_value("table5", "estimated", "q"), paper_value("table5", "estimated", "tan_theta"),
                         paper_value("large_plate", "large_plate", "voltage_vpp"),
                         paper_value("large_plate", "large_plate", "frequency_hz"),
                         reading.large_plate_geometry(), reading.convention())


def plates_under_readings(run, conventions=TABLE5_READINGS) -> pd.DataFrame:
    """Q and tan theta' of every characterised plate of a run (the paper's, or a user's own)
    under each reading: one row per (plate, reading)."""
    from squeezebench.analysis import characterisation

    rows = []
    for convention in conventions:
        for name, plate in characterisation.characterise_plates(run, convention).items():
            rows.append({"plate": name, "reading": convention.name, "frequency_hz": plate.frequency_hz,
                         "q": plate.q.value, "q_u": plate.q.std_uncertainty,
                         "tan_theta": plate.tan_theta.value, "tan_theta_u": plate.tan_theta.std_uncertainty})
    return pd.DataFrame(rows)
