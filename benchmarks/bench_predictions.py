"""CPU time of the plate model's predictions a report computes, from an empty plate cache.

    .venv/bin/python benchmarks/bench_predictions.py [--repeat 3]

What `report` asks of `plates.predicted_plates` and `plates.damping` (Tables 3 and 4's
predicted columns, the predicted section, the damping fit and its cross-check, the large
plate's response), each repeat in a fresh process with an empty disk cache of its own, the
libraries imported before the clock starts: the finite-element solves of the paper's seven
plates and of the edge-gap ends of four of them. Printed: each repeat's CPU seconds
(user + system of that process: a shared machine's other users slow its wall clock more
than its CPU time) and wall seconds, their medians in seconds and in reference units
(`reference.py`, measured before and after in the same run), the load average, and the
plate solves each repeat did.
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

import reference  # benchmarks/, the script's own folder


def predict() -> None:
    """One repeat (the child process): prints its CPU and wall seconds and the solves done."""
    import scipy.sparse.linalg  # noqa: F401  the libraries, imported before the clock starts
    import skfem  # noqa: F401

    from squeezebench.plates import damping, plate_modes, predicted_plates

    solves = []
    solve = plate_modes._solve
    plate_modes._solve = lambda *args: solves.append(args[4]) or solve(*args)   # args[4]: n_modes
    usage, start = resource.getrusage(resource.RUSAGE_SELF), time.perf_counter()
    for table in ("Table 3", "Table 4"):
        predicted_plates.tidy(table)
    predicted_plates.predictions()
    predicted_plates.what_would_agree()
    predicted_plates.large_plate_response()
    damping.fit_and_check()
    damping.terms_table()
    damping.cross_check()
    end = resource.getrusage(resource.RUSAGE_SELF)
    print(json.dumps({"cpu_s": end.ru_utime - usage.ru_utime + end.ru_stime - usage.ru_stime,
                      "wall_s": time.perf_counter() - start, "modes_per_solve": solves}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        predict()
        return
    before = reference.measure()
    runs = []
    for _ in range(args.repeat):
        with tempfile.TemporaryDirectory(prefix="bench_predictions_") as cache:
            child = subprocess.run([sys.executable, __file__, "--child"], capture_output=True, text=True, check=True,
                                   env={**os.environ, "SQUEEZEBENCH_CACHE": cache})
        runs.append(json.loads(child.stdout.strip().splitlines()[-1]))
    unit = reference.mean(before, reference.measure())
    print(unit.line())
    for i, run in enumerate(runs, 1):
        print(f"repeat {i}: {run['cpu_s']:.2f} CPU-s, {run['wall_s']:.2f} s wall, "
              f"{len(run['modes_per_solve'])} plate solves (modes asked: {run['modes_per_solve']})")
    cpu_s, wall_s = (statistics.median(run[name] for run in runs) for name in ("cpu_s", "wall_s"))
    print(f"report's plate predictions from an empty cache: {unit.both(cpu_s, 2)} CPU (median of {len(runs)}), "
          f"{unit.both(wall_s, 2)} wall; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
