"""Reduction of a vibration map (Fig. 7): the numbers a plate designer reads off it.

A map is tidy: one row per grid point with its position and the velocity amplitude and
phase against the drive. The phase turns the amplitude into the real mode's signed value
(a standing wave is in phase or in antiphase with the drive), so nodal lines show as sign
changes; the homogeneity numbers are over the touch area's amplitudes; the modal
assurance criterion compares the measured shape with the predicted one (Allemang,
"The modal assurance criterion - twenty years of use and abuse", Sound and Vibration
37(8), 2003, Eq. 1). The stage's move time is the kinematics both the simulated stage and
the map's bench-time estimate use.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Homogeneity:
    """Velocity amplitude over the touch area (the unit of the amplitudes given)."""

    mean: float
    minimum: float
    maximum: float
    coefficient_of_variation: float   # standard deviation / mean, population (ddof 0)
    share_of_peak: float              # the stated share of the peak amplitude
    fraction_above_share: float       # fraction of the points (= of the area on a regular grid) above it
    n_points: int


def signed_amplitude(amplitude: np.ndarray, phase_rad: np.ndarray) -> np.ndarray:
    """amplitude x cos(phase against the drive): the real mode's signed value."""
    return np.asarray(amplitude, dtype=float) * np.cos(np.asarray(phase_rad, dtype=float))


def homogeneity(amplitude: np.ndarray, share_of_peak: float = 0.5) -> Homogeneity:
    """Homogeneity numbers of the amplitudes of the touch area's grid points."""
    values = np.abs(np.asarray(amplitude, dtype=float).ravel())
    if values.size == 0:
        raise ValueError("no map points in the touch area")
    if not 0.0 < share_of_peak < 1.0:
        raise ValueError(f"share_of_peak {share_of_peak!r} must be between 0 and 1")
    mean = float(values.mean())
    return Homogeneity(mean=mean, minimum=float(values.min()), maximum=float(values.max()),
                       coefficient_of_variation=float(values.std() / mean) if mean > 0 else float("inf"),
                       share_of_peak=share_of_peak,
                       fraction_above_share=float(np.mean(values >= share_of_peak * values.max())),
                       n_points=int(values.size))


def modal_assurance(measured: np.ndarray, predicted: np.ndarray) -> float:
    """MAC = |m^H p|^2 / ((m^H m)(p^H p)) of two shapes at the same points, real or complex;
    1 for proportional shapes whatever the scale, 0 for orthogonal ones."""
    m = np.asarray(measured).ravel()
    p = np.asarray(predicted).ravel()
    if m.shape != p.shape or m.size == 0:
        raise ValueError(f"shapes at different points: {m.size} measured, {p.size} predicted")
    norm = np.vdot(m, m).real * np.vdot(p, p).real
    if norm == 0:
        raise ValueError("a shape that is zero everywhere has no modal assurance")
    return float(abs(np.vdot(m, p)) ** 2 / norm)


def move_time_s(distance_mm: float, velocity_mm_per_s: float, acceleration_mm_per_s2: float) -> float:
    """Duration of a point-to-point move with a trapezoidal (or, if short, triangular)
    velocity profile: d/v + v/a when the axis reaches v, else 2 sqrt(d/a)."""
    d = abs(distance_mm)
    if d >= velocity_mm_per_s**2 / acceleration_mm_per_s2:
        return d / velocity_mm_per_s + velocity_mm_per_s / acceleration_mm_per_s2
    return 2.0 * math.sqrt(d / acceleration_mm_per_s2)
