"""The plate's working mode as a 2-D shape the simulated stage can be scanned over.

One interface, `mode_shape(scene, x_mm, y_mm)`: the normalised out-of-plane displacement
of the working mode at points of the plate (1 at the x = 0 free end, 0 off the plate).
Until the finite-element modal model (issue 22) lands, the shape is a stated analytic
standing wave: the plate's (n, 0) flexural mode taken as a free-free Euler-Bernoulli beam
along the length, uniform across the width (nodal lines along the width, as the scene's
`Mode` says). The number of nodal lines n is that of the scene's own mode shape
cos(pi x / (lambda/2)) over the plate's length, n = round(L / (lambda/2)); the beam
function with n nodes keeps the free-edge hyperbolic terms

    phi(x) = cosh(beta x) + cos(beta x) - sigma (sinh(beta x) + sin(beta x)),
    sigma = (cosh(beta L) - cos(beta L)) / (sinh(beta L) - sin(beta L)),
    cos(beta L) cosh(beta L) = 1   (free-free frequency equation),

(Blevins, Formulas for Natural Frequency and Mode Shape, Table 8-1, free-free beam), whose
root is close to beta L = (n - 1/2) pi (4.730 for n = 2). Its interior half-wavelength
pi / beta = L / (n - 1/2) is slightly longer than the scene's lambda/2: the free ends
carry the difference. The finite-element model replaces this function, not its callers.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq


def free_free_root(nodes: int) -> float:
    """beta L of the free-free beam mode with `nodes` nodal points (>= 2), the root of
    cos(z) cosh(z) = 1 next to (nodes - 1/2) pi (4.730 for 2 nodes), written as cos(z) - 1/cosh(z) = 0
    so it does not overflow."""
    if nodes < 2:
        raise ValueError("a free-free flexural mode has at least 2 nodes")
    guess = (nodes - 0.5) * np.pi
    return brentq(lambda z: np.cos(z) - 1.0 / np.cosh(z), guess - 0.5, guess + 0.5, xtol=1e-14)


def beam_mode(x_m: np.ndarray, length_m: float, nodes: int) -> np.ndarray:
    """phi(x) / phi(0) of the free-free beam mode with `nodes` nodes (module docstring).

    cosh(u) - sigma sinh(u) is evaluated as exp(-u) + (1 - sigma) sinh(u) with 1 - sigma
    in closed form: the difference of two numbers of size exp(beta L) would lose every digit."""
    beta_l = free_free_root(nodes)
    u = beta_l * np.asarray(x_m, dtype=float) / length_m
    denominator = np.sinh(beta_l) - np.sin(beta_l)
    one_minus_sigma = (np.cos(beta_l) - np.sin(beta_l) - np.exp(-beta_l)) / denominator
    sigma = 1.0 - one_minus_sigma
    phi = np.exp(-u) + one_minus_sigma * np.sinh(u) + np.cos(u) - sigma * np.sin(u)
    return phi / 2.0


def mode_shape(scene, x_mm: np.ndarray, y_mm: np.ndarray) -> np.ndarray:
    """Normalised displacement of the scene's working mode at (x, y) in mm from the plate's
    corner (x along the length); 0 where the point is off the plate."""
    plate = scene.plate
    x_mm, y_mm = np.broadcast_arrays(np.asarray(x_mm, dtype=float), np.asarray(y_mm, dtype=float))
    nodes = max(2, round(plate.length_mm / scene.mode.half_wavelength_mm))
    on_plate = (x_mm >= 0) & (x_mm <= plate.length_mm) & (y_mm >= 0) & (y_mm <= plate.width_mm)
    shape = beam_mode(np.clip(x_mm, 0.0, plate.length_mm) * 1e-3, plate.length_mm * 1e-3, nodes)
    return np.where(on_plate, shape, 0.0)
