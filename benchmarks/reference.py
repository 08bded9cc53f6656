"""The reference unit of speed: a fixed workload every benchmark times in the same run.

A time in seconds says as much about the machine (its clock, its other users) as about
the code; a time in multiples of a fixed workload timed a moment before on the same
machine mostly says about the code. The workload is one core's worth of the two kinds of
work squeezebench does:

- a pure-Python loop (`LOOP_ITERATIONS` additions: the interpreter's speed, which the
  protocols, the simulator and the study's bookkeeping run at), and
- a sparse LU factorisation and solve of a fixed matrix (SciPy's SuperLU on the 5-point
  Laplacian of a `GRID_SIDE` x `GRID_SIDE` grid, shifted to be regular: the compiled
  kernels and memory traffic the plate solves run at).

Each part is timed as the best of `repeat` runs (the least disturbed by other processes);
the reference is their sum: 1.97 s on the 2-core machine of issue 51 at load 3, 11 s there
at load 13 to 17 (eight jobs sharing it). It is one core's work: a parallel command can
take fewer reference units on more cores, which is the point of running it there, and on
an overloaded machine a parallel command's share of it falls faster than one core's, so
its figure in reference units rises.

Run alone: python benchmarks/reference.py
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sparse
from scipy.sparse.linalg import splu

LOOP_ITERATIONS = 25_000_000
GRID_SIDE = 300
REPEAT = 3


def python_loop(iterations: int = LOOP_ITERATIONS) -> int:
    total = 0
    for i in range(iterations):
        total += i
    return total


def _laplacian(side: int) -> sparse.csc_matrix:
    """The 5-point Laplacian of a side x side grid plus the identity (regular, symmetric)."""
    line = sparse.diags([-1.0, 2.0, -1.0], [-1, 0, 1], shape=(side, side))
    eye = sparse.identity(side)
    return (sparse.kron(line, eye) + sparse.kron(eye, line) + sparse.identity(side * side)).tocsc()


def sparse_factorisation(side: int = GRID_SIDE) -> float:
    matrix = _laplacian(side)
    return float(splu(matrix).solve(np.ones(side * side))[0])


def _best_s(repeat: int, work) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        work()
        times.append(time.perf_counter() - start)
    return min(times)


@dataclass(frozen=True)
class Reference:
    """One measurement of the reference workload; `units(seconds)` converts a time."""

    loop_s: float
    factorisation_s: float
    load_before: float

    @property
    def seconds(self) -> float:
        return self.loop_s + self.factorisation_s

    def units(self, seconds: float) -> float:
        return seconds / self.seconds

    def both(self, seconds: float, digits: int = 1) -> str:
        """'12.3 s = 8.1 ref': a time in seconds and in reference units."""
        return f"{seconds:.{digits}f} s = {self.units(seconds):.{digits}f} ref"

    def line(self) -> str:
        return (f"reference unit: {self.seconds:.3f} s (best of {REPEAT}: Python loop {self.loop_s:.3f} s + "
                f"sparse LU {self.factorisation_s:.3f} s; load {self.load_before:.2f} on {os.cpu_count()} cores)")


def measure(repeat: int = REPEAT) -> Reference:
    """Time the reference workload now (about 3 x 1.5 s on the machine of issue 51)."""
    load = os.getloadavg()[0]
    return Reference(_best_s(repeat, python_loop), _best_s(repeat, sparse_factorisation), load)


def mean(before: Reference, after: Reference) -> Reference:
    """The unit of a run timed between two measurements: each part's mean (a load that came
    or went meanwhile shows as their difference, which the run prints)."""
    return Reference((before.loop_s + after.loop_s) / 2, (before.factorisation_s + after.factorisation_s) / 2,
                     before.load_before)


if __name__ == "__main__":
    print(measure().line())
