"""What a protocol is made of: steps, the plate each step needs, and how a step records.

A protocol turns its parameters into a list of `Step`s. A step is the unit of atomicity
and resume: it starts from a known bench state (drive at minimum, plate and scene state
as the step declares), measures, and ends with its rows and the `context` later steps of
the same run need (e.g. the resonance found). Because a step depends only on that
context and never on what the previous step left in an instrument, a run resumed after
a crash measures exactly what an uninterrupted run would have.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from squeezebench.plates.damping import DIELECTRIC_LOSS_DEFAULTS
from squeezebench.protocols.acquisition import Acquisition, Point
from squeezebench.protocols.safety import DriveController


@dataclass(frozen=True, kw_only=True)
class PiezoLoss:
    """The piezos' dielectric loss as the campaign states it (a real bench: a simulated
    bench's scene describes its own): tan(delta) = tan_delta_at_reference (E / E_ref)^exponent
    at the field amplitude E = V0 / piezo thickness (`plates.damping.field_tan_delta`; the
    exponent 0 is a constant tan(delta), e.g. the datasheet's low-field figure). Stored with
    every row of the plate, so Fig. 2's budget can tell the part of the power that does not
    follow the resonance (`analysis.dielectric`)."""

    piezo_thickness_mm: float
    tan_delta_at_reference: float
    reference_field_amplitude_v_per_mm: float = DIELECTRIC_LOSS_DEFAULTS["reference_field_amplitude_v_per_mm"]
    exponent: float = DIELECTRIC_LOSS_DEFAULTS["exponent"]

    def __post_init__(self) -> None:
        if not (self.piezo_thickness_mm > 0 and self.reference_field_amplitude_v_per_mm > 0):
            raise ValueError("piezo_thickness_mm and reference_field_amplitude_v_per_mm must be positive")
        if not (self.tan_delta_at_reference >= 0 and self.exponent >= 0):
            raise ValueError("tan_delta_at_reference and exponent must be zero or positive")

    def as_row(self) -> dict[str, float]:
        """The stored columns (`analysis.columns`)."""
        return {"piezo_thickness_mm": self.piezo_thickness_mm,
                "piezo_tan_delta_at_reference": self.tan_delta_at_reference,
                "piezo_loss_reference_field_v_per_mm": self.reference_field_amplitude_v_per_mm,
                "piezo_loss_exponent": self.exponent}


@dataclass(frozen=True, kw_only=True)
class Plate:
    """The plate a step measures and how the operator gets it onto the bench.

    `scene` is the scene file to mount (`bench.operator.mount`; on a real bench a prompt)
    or None for the plate the run's bench starts with; `state` is the scene state the step
    needs (e.g. a cut length), reached through `bench.operator.request(instruction, state)`.
    Protocol items that are plates (a Table 4 configuration, a Fig. 5 plate) subclass it.
    """

    name: str = ""   # default: the scene file's stem
    n_powered_columns: int
    n_powered_piezos: int
    scene: Path | None = None
    state: str | None = None
    instruction: str | None = None
    piezo_loss: PiezoLoss | None = None   # None: the scene's (simulated), or not stated

    def __post_init__(self) -> None:
        if not self.name:
            if self.scene is None:
                raise ValueError("a plate needs a name or a scene")
            object.__setattr__(self, "name", Path(self.scene).stem)
        if self.n_powered_columns < 1 or self.n_powered_piezos < 1:
            raise ValueError("n_powered_columns and n_powered_piezos must be at least 1")


@dataclass(frozen=True)
class Step:
    step_id: str
    plate: Plate
    measure: Callable[[StepContext], None]


@dataclass
class StepContext:
    """Handed to a step: the bench, the drive, earlier context, and the recorder."""

    run_name: str
    protocol: str
    step: Step
    bench: Any
    drive: DriveController
    acquisition: Acquisition
    context: dict[str, Any]            # merged context of the run's completed steps
    bench_time_base_s: float           # campaign bench time when the step started
    clock_start_s: float               # bench clock when the step started
    updates: dict[str, Any] = field(default_factory=dict)   # context this step adds
    rows: list[dict[str, Any]] = field(default_factory=list)
    waveforms: dict[int, tuple[Any, dict[str, Any]]] = field(default_factory=dict)
    on_point: Callable[[dict[str, Any]], None] | None = None   # sees each row as it is recorded

    def bench_time_s(self, clock_s: float | None = None) -> float:
        """Campaign bench time at bench clock `clock_s` (default: now).

        Rounded to the nanosecond, the simulated clock's tick: a resumed run adds the same
        durations to a base read back from the journal, and must not differ from an
        uninterrupted run in the last bits of a float sum.
        """
        clock_s = self.bench.clock.now_s() if clock_s is None else clock_s
        return round(self.bench_time_base_s + (clock_s - self.clock_start_s), 9)

    def record(self, point: Point, protocol: str | None = None, **columns: Any) -> dict[str, Any]:
        """Store one measured point as a tidy row (and its waveforms, if it kept them)."""
        point_index = len(self.rows)
        plate = self.step.plate
        waveform_file = None
        if point.waveforms is not None:
            waveform_file = f"waveforms/{self.run_name}/{self.step.step_id}/{point_index:04d}.parquet"
            self.waveforms[point_index] = (point.waveforms, point.waveform_metadata)
        row = {
            "run_name": self.run_name,
            "protocol": protocol or self.protocol,
            "plate": plate.name,
            "scene_file": Path(plate.scene).name if plate.scene is not None else None,
            "scene_state": plate.state,
            "step_id": self.step.step_id,
            "point_index": point_index,
            "generator_frequency_hz": point.generator_frequency_hz,
            "generator_amplitude_vpp": point.generator_amplitude_vpp,
            "amplifier_gain": point.amplifier_gain,
            "piezo_voltage_setpoint_vpp": point.piezo_voltage_setpoint_vpp,
            "n_powered_columns": plate.n_powered_columns,
            "n_powered_piezos": plate.n_powered_piezos,
            "averages": point.averages,
            "record_length": point.record_length,
            "scope_power_w": point.scope_power_w,
            "scope_velocity_pp_v": point.scope_velocity_pp_v,
            "vibrometer_scale_mps_per_v": point.vibrometer_scale_mps_per_v,
            "velocity_pp_mps": point.velocity_pp_mps,
            "scope_piezo_voltage_pp_v": point.scope_piezo_voltage_pp_v,
            "scope_current_pp_a": point.scope_current_pp_a,
            "scope_frequency_hz": point.scope_frequency_hz,
            "waveform_file": waveform_file,
            "bench_time_s": self.bench_time_s(point.clock_s),
            **(plate.piezo_loss.as_row() if plate.piezo_loss is not None else {}),
        }
        row.update(columns)
        self.rows.append(row)
        if self.on_point is not None:
            self.on_point(row)
        return row

