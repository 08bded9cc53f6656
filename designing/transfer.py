"""Does the paper's method carry small plates to a large one? A study on drawn builds.

Each build (seeded) is drawn as a lab might make one, from geometry and datasheets only:
a resonator thickness, the build's mechanical Q, three small plates (one column of four
NCE 41 piezos at one end, as the paper's Table 4 plates; an odd count of antinodes so the
centre moves) and one large
plate (two piezos at each corner). Every plate becomes a predicted scene of the simulated
bench with its noise and the shunt, and is characterised by the paper's protocol. Then:

- route (b), the paper's method: the small plates' Q and tan(theta') carried to the large
  plate by Eqs. 25-29 (`designing.paper_route.predict_from_small_plates`), under each reading;
- route (a), physics: the large plate's design predicted from its geometry (on the
  simulated bench a chain check: the scene follows the same plate model);

against the large plate's own characterisation: the power the target amplitude needs.
A prediction covers a build when the measurement lies within the combined U (k = 2).
"""
from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from squeezebench.designing import design as design_model
from squeezebench.analysis import model
from squeezebench.designing.design_file import DesignFile
from squeezebench.designing.answer import Measured, measured_point
from squeezebench.designing.paper_route import predict_from_small_plates
from squeezebench.designing.workflow import characterised_plates, write_build
from squeezebench.plates import predicted_plates

READINGS = {"paper": model.PAPER_CONVENTION, "physical": model.PHYSICAL_CONVENTION}
TARGET_AMPLITUDE_PP_M = 1e-6


@dataclass(frozen=True)
class Build:
    seed: int
    thickness_mm: float
    mechanical_q: float
    small_lengths_mm: tuple[float, ...]
    large_length_mm: float
    large_width_mm: float

    @staticmethod
    def draw(seed: int) -> "Build":
        rng = np.random.default_rng(seed)
        return Build(seed, round(float(rng.uniform(1.0, 2.0)), 2), round(float(rng.uniform(250, 900))),
                     tuple(round(float(x)) for x in rng.uniform(60, 90, 3)),
                     round(float(rng.uniform(140, 200))), round(float(rng.uniform(100, 140))))


def _odd_antinodes(length_mm: float, thickness_mm: float) -> int:
    """An odd count of antinodes (the centre moves) near a 9 mm half-wave on a 2 mm plate,
    shorter on a thinner one (lambda/2 ~ sqrt(h) at a fixed frequency)."""
    n = int(round(length_mm / (9.0 * math.sqrt(thickness_mm / 2.0))))
    return n if n % 2 else n + 1


def _working(data: dict, antinodes: int) -> DesignFile:
    """The plate of `data` at the odd antinode count nearest `antinodes` whose mode is clean
    and moves at the centre (`design` accepts it): what a designer does when a mode mixes
    with a neighbour is pick the next one of the family."""
    for n in (antinodes, antinodes + 2, antinodes - 2, antinodes + 4, antinodes - 4):
        spec = DesignFile.model_validate({**data, "mode": {"interior_antinodes": n}})
        try:
            design_model.operating_point(spec)
            return spec
        except design_model.DesignError:
            continue
    raise design_model.DesignError(f"plate {data['name']}: no clean working mode within 4 antinodes of {antinodes}")


def designs(build: Build) -> tuple[list[DesignFile], DesignFile]:
    common = {"piezo": {"length_x_mm": 5, "width_y_mm": 9, "thickness_mm": 0.5},
              "target": {"amplitude_pp_m": TARGET_AMPLITUDE_PP_M},
              "damping": {"mechanical_q": build.mechanical_q, "origin": f"drawn build {build.seed}"},
              "amplifier": {"max_output_vpp": 300}}
    small = [_working({
        **common, "name": f"small_{i}", "resonator": {"length_mm": length, "width_mm": 41,
                                                     "thickness_mm": build.thickness_mm},
        "groups": [{"name": "end", "x_mm": 2.5, "y_mm": [7, 16, 25, 34]}]},
        _odd_antinodes(length, build.thickness_mm)) for i, length in enumerate(build.small_lengths_mm)]
    w, x = build.large_width_mm, build.large_length_mm - 2.5
    large = _working({
        **common, "name": "large", "resonator": {"length_mm": build.large_length_mm, "width_mm": w,
                                                 "thickness_mm": build.thickness_mm},
        "groups": [{"name": n, "x_mm": gx, "y_mm": ys} for n, gx, ys in (
            ("NW", 2.5, [4.5, 13.5]), ("SW", 2.5, [w - 13.5, w - 4.5]),
            ("NE", x, [4.5, 13.5]), ("SE", x, [w - 13.5, w - 4.5]))]},
        _odd_antinodes(build.large_length_mm, build.thickness_mm))
    return small, large


def _characterise(spec: DesignFile, values: dict, folder: Path, seed: int) -> Path:
    """The spec built as a predicted scene (from its nominal working point's `values`) and
    characterised on the simulated bench."""
    from squeezebench.protocols.campaign import run_campaign

    _, campaign = write_build(spec, values, folder, seed=seed)
    return run_campaign(campaign, out_dir=folder / f"run_{spec.name}", progress=False, say=lambda m: None,
                        durable=False)   # a temporary folder


#: Draws of one build before giving up (a plate with no clean mode near its family is
#: one a designer would redraw).
MAX_DRAWS = 4


def _clean_build(seed: int):
    for draw in range(MAX_DRAWS):
        build = Build.draw(seed * 100 + draw)
        try:   # a large plate whose mode the placement decides is one a designer would redraw too
            small, large = designs(build)
            physics = design_model.predict_physics(large)
        except design_model.DesignError:
            continue
        return build, small, large, physics, draw
    raise design_model.DesignError(f"build {seed}: no clean working mode in {MAX_DRAWS} draws")


def study_build(seed: int) -> list[dict]:
    """One build's rows: per route (and reading), predicted and measured power for the target."""
    build, small, large, physics, redrawn = _clean_build(seed)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        # the small plates' budgets are not used (route (b) reads their measurements): their nominal points only
        small_runs = [_characterise(spec, design_model.operating_point(spec).values, folder, seed * 10 + i)
                      for i, spec in enumerate(small)]
        large_run = _characterise(large, physics.nominal.values, folder, seed * 10 + 9)
        rows = []
        for reading, convention in READINGS.items():
            built = characterised_plates([large_run], convention)["large"]
            measured = measured_point(physics, built)
            route = predict_from_small_plates(physics, characterised_plates(small_runs, convention),
                                                           convention)
            rows.append(_row(build, f"small plates (b), {reading} reading", route.power_w.nominal_value,
                             2 * route.power_w.std_dev, measured))
        rows.append(_row(build, "physics (a)", physics.nominal.values["power_w"], physics.expanded["power_w"],
                         measured))
    return [{**row, "redrawn": redrawn} for row in rows]


def _row(build: Build, route: str, value: float, u: float, measured: Measured) -> dict:
    m, mu = measured.power_w.nominal_value, 2 * measured.power_w.std_dev
    return {"build": build.seed // 100, "seed": build.seed, "thickness_mm": build.thickness_mm, "mechanical_q": build.mechanical_q,
            "large_length_mm": build.large_length_mm, "route": route, "predicted_power_w": value,
            "predicted_power_w_U": u, "measured_power_w": m, "measured_power_w_U": mu,
            "ratio": value / m, "covered": predicted_plates.within_expanded_interval(m, value, math.hypot(u, mu))}


def run_study(n_builds: int = 20, workers: int = 1, first_seed: int = 1) -> pd.DataFrame:
    from squeezebench.protocols.parallel import map_unordered

    rows = [row for _, result in map_unordered(study_build, range(first_seed, first_seed + n_builds),
                                               workers=workers, description="builds") for row in result]
    return pd.DataFrame(rows).sort_values(["route", "build"]).reset_index(drop=True)


def summary(frame: pd.DataFrame) -> pd.DataFrame:
    """Per route: builds, share covered, and the spread of predicted over measured power."""
    return frame.groupby("route").agg(
        builds=("build", "size"), covered=("covered", "mean"), median_ratio=("ratio", "median"),
        min_ratio=("ratio", "min"), max_ratio=("ratio", "max")).reset_index()


def main(argv: list[str] | None = None) -> int:
    """python -m squeezebench.designing.transfer [--builds N] [--workers N] [--out FILE.csv]"""
    import argparse

    from squeezebench.workers import default_workers

    parser = argparse.ArgumentParser(prog="python -m squeezebench.designing.transfer", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--builds", type=int, default=20)
    parser.add_argument("--workers", type=int, default=None)
    parser.add_argument("--out", type=Path, default=None, help="also write every build's rows to this CSV")
    args = parser.parse_args(argv)
    frame = run_study(args.builds, args.workers or default_workers())
    if args.out:
        frame.to_csv(args.out, index=False)
    with pd.option_context("display.width", 160, "display.max_columns", 10):
        print(summary(frame).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
