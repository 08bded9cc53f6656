"""The reduced model of a layout sweep: exact patch integrals on any rectangle, the full
solve reproduced on the full solve's own mesh, and the sweep's check and fall-back."""
from __future__ import annotations

import collections
import json

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench import cli
from squeezebench.designing import design, layout_sweep, layouts
from squeezebench.plates import plate_modes, reduced_layouts
from squeezebench.designing.workflow import sweep_layouts
from squeezebench.paths import design_file
from squeezebench.schemas import load_design_file
from squeezebench.yamlfiles import dump_yaml
from test_design import STRIP, strip   # Table 3's plate as a design: 75 x 41 x 1 mm, four piezos mid-length


def _area(polygon: np.ndarray) -> float:
    x, y = polygon[:, 0], polygon[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


@settings(max_examples=80, deadline=None)
@given(x0=st.floats(-1, 2), y0=st.floats(-1, 2), w=st.floats(0.01, 3), h=st.floats(0.01, 3))
def test_a_clipped_right_triangle_has_the_area_of_its_overlap(x0, y0, w, h):
    """The triangle (0,0), (1,0), (0,1) cut to a rectangle: its area is the integral of the
    overlap, here by a fine midpoint sum (the overlap's closed form has many cases)."""
    triangle = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    piece = reduced_layouts.clip_to_rectangle(triangle, x0, x0 + w, y0, y0 + h)
    n = 400
    centres = (np.arange(n) + 0.5) / n
    gx, gy = np.meshgrid(centres, centres, indexing="ij")
    inside = (gx + gy <= 1) & (gx >= x0) & (gx <= x0 + w) & (gy >= y0) & (gy <= y0 + h)
    expected = inside.sum() / n**2
    found = _area(piece) if len(piece) >= 3 else 0.0
    assert found == pytest.approx(expected, abs=4 / n)


def test_a_triangle_inside_the_rectangle_is_kept_whole():
    triangle = np.array([[0.2, 0.2], [0.8, 0.3], [0.4, 0.9]])
    piece = reduced_layouts.clip_to_rectangle(triangle, 0, 1, 0, 1)
    assert _area(piece) == pytest.approx(_area(triangle), rel=1e-12)


@pytest.fixture(scope="module")
def strip_model():
    spec = strip()
    geometry = spec.geometry()
    bare = design.bare_plate(spec).with_edges_of([geometry])
    return spec, geometry, bare


def test_on_the_full_solves_own_mesh_the_reduced_model_is_the_full_solve(strip_model):
    """Meshed on one layout's patch edges, the reduced model's mesh is that layout's full
    solve's: its refined working mode is the same eigenpair (frequency to 1e-6, the
    coupling and the patches' strain-energy share, which sets Q from physics, to 0.1 %,
    the settling criterion), with the same thick-plate correction and bond."""
    spec, geometry, bare = strip_model
    reduced = reduced_layouts.reduced_plate(bare).solve(geometry)
    full = plate_modes.solve_plate(geometry, bare.resonator, bare.piezo, near_hz=bare.near_hz,
                                   mesh_half_wave_m=bare.mesh_half_wave_m, band_rel=bare.band_rel)
    k, j = full.working_mode(bare.near_hz), reduced.working_mode(bare.near_hz)
    assert reduced.frequencies_hz[j] == pytest.approx(full.frequencies_hz[k], rel=1e-6)
    assert reduced.force_factor_n_per_v[j].sum() == pytest.approx(full.force_factor_n_per_v[k].sum(), rel=1e-3)
    assert reduced.interior_antinodes(j) == full.interior_antinodes(k)
    assert reduced.piezo_energy_share[j] == pytest.approx(full.piezo_energy_share[k], rel=1e-3)
    assert reduced.kirchhoff_frequencies_hz[j] == pytest.approx(full.kirchhoff_frequencies_hz[k], rel=1e-6)
    assert reduced.frequencies_hz[j] < reduced.kirchhoff_frequencies_hz[j]   # Mindlin's branch is lower
    np.testing.assert_allclose(reduced.bond_effectiveness, full.bond_effectiveness)
    np.testing.assert_allclose(reduced.bond_energy_ratio, full.bond_energy_ratio)


@settings(max_examples=6, deadline=None, derandomize=True)
@given(share=st.floats(0.05, 0.95))
def test_a_patch_off_the_mesh_lines_is_integrated_exactly(strip_model, share):
    """A patch's integrals do not depend on how the mesh cuts it: its rectangle split in two
    anywhere along a line through elements integrates to the same matrices as the whole."""
    _, _, bare = strip_model
    model = reduced_layouts.reduced_plate(bare)
    x0, x1, y0, y1 = 0.0101, 0.0163, 0.0052, 0.0219
    split = x0 + share * (x1 - x0)
    whole = model.patch_forms((x0, x1, y0, y1))
    left, right = model.patch_forms((x0, split, y0, y1)), model.patch_forms((split, x1, y0, y1))
    # curvature products are of degree 6, exact under the order-8 rule; the mass's degree 10
    # is not, as in the full solve's own elements (a part in 10^5)
    for name, rel in (("stiffness", 1e-9), ("laplacian", 1e-9), ("mass", 1e-4)):
        np.testing.assert_allclose(getattr(left, name) + getattr(right, name), getattr(whole, name),
                                   rtol=rel, atol=rel * np.abs(getattr(whole, name)).max())


def test_a_patch_on_the_mesh_lines_has_the_full_solves_matrices(strip_model):
    """A patch covering whole elements: its local forms are the full solve's assembled
    stiffness and mass (`plate_modes.stiffness_and_mass`) with rigidity and mass 1 on its
    elements and 0 elsewhere, on the dofs it touches and nowhere else."""
    _, geometry, bare = strip_model
    model = reduced_layouts.reduced_plate(bare)
    patch = geometry.patches[0]
    forms = model.patch_forms(tuple(float(b) for b in patch.bounds))
    x0, x1, y0, y1 = patch.bounds
    centres = model.mesh.p[:, model.mesh.t].mean(axis=1)
    inside = ((centres[0] > x0) & (centres[0] < x1) & (centres[1] > y0) & (centres[1] < y1)).astype(float)
    stiffness, mass = plate_modes.stiffness_and_mass(model.basis, inside, inside, bare.resonator.poisson)
    on = np.ix_(forms.dofs, forms.dofs)
    np.testing.assert_allclose(forms.local_stiffness, stiffness[on].toarray(), rtol=0,
                               atol=1e-9 * abs(stiffness).max())
    np.testing.assert_allclose(forms.local_mass, mass[on].toarray(), rtol=0, atol=1e-9 * abs(mass).max())
    assert abs(stiffness).sum() == pytest.approx(abs(stiffness[on]).sum(), rel=1e-12)


def test_the_solver_answers_other_plates_by_the_full_solve(strip_model):
    spec, geometry, bare = strip_model
    solve = reduced_layouts.Solver(bare)
    thicker = plate_modes.PlateGeometry(geometry.length_m, geometry.width_m, 1.1 * geometry.thickness_m,
                                        geometry.patches)
    solve(thicker, bare.resonator, bare.piezo, near_hz=bare.near_hz, mesh_half_wave_m=bare.mesh_half_wave_m,
          band_rel=bare.band_rel)
    assert solve.full_solves == 1
    solve(geometry, bare.resonator, bare.piezo, near_hz=bare.near_hz, mesh_half_wave_m=bare.mesh_half_wave_m,
          band_rel=bare.band_rel)
    assert solve.full_solves == 1


@pytest.fixture(scope="module")
def strip_layouts():
    """The strip's sweep: those of its 216 layouts whose piezos fit on it."""
    spec = strip()
    values = design.operating_point(spec).values
    antinodes = int(values["interior_antinodes"])
    grid = []
    for layout in layouts.grid(values["half_wavelength_mm"], spec.piezo.length_x_mm):
        try:
            layouts.layout_design(layout, spec, antinodes)
        except ValueError:   # piezos that overlap or leave the plate
            continue
        grid.append(layout)
    return spec, antinodes, grid


@settings(max_examples=5, deadline=None, derandomize=True)
@given(st.data())
def test_on_a_layouts_own_mesh_the_reduced_model_is_within_the_checks_limits(strip_layouts, data):
    """Any layout of the sweep, answered by the reduced model on that layout's own mesh, is
    within the check's limits of its full solve (frequency 0.2 %, force factor 2 %), or
    both refuse it (layouts drawn at random, seeded: `derandomize`). On the sweep's mesh,
    a line on every edge of the sweep's layouts, the full solve itself moves: by 0.24 % in
    frequency and 2.7 % in force factor for some of the strip's layouts, which is why a
    sweep checks a sample and falls back."""
    spec, antinodes, grid = strip_layouts
    layout = data.draw(st.sampled_from(grid))
    geometry = layouts.layout_design(layout, spec, antinodes).geometry()
    solve = reduced_layouts.Solver(design.bare_plate(spec).with_edges_of([geometry]))
    full = layout_sweep._working_point(layout, spec, antinodes)
    reduced = layout_sweep._working_point(layout, spec, antinodes, solve)
    assert (full is None) == (reduced is None)
    if full is not None:
        assert reduced["frequency_hz"] == pytest.approx(full["frequency_hz"],
                                                        rel=reduced_layouts.FREQUENCY_TOLERANCE_REL)
        assert reduced["force_factor_n_per_v"] == pytest.approx(full["force_factor_n_per_v"],
                                                                rel=reduced_layouts.FORCE_TOLERANCE_REL)
    assert solve.full_solves == 0


def test_a_sweeps_chunks_hold_every_layout_once_and_share_the_end_columns(strip_layouts):
    """Two workers' chunks: every layout in exactly one, the layouts with the same end
    columns (place, piezos per column, arrangement; with or without a centre column) in one
    chunk, as many layouts in each, and layouts with a centre column in both."""
    spec, antinodes, grid = strip_layouts
    _, chunks = layout_sweep.tasks(grid, spec, antinodes, chunks=2)
    assert len(chunks) == 2
    assert collections.Counter(layout for chunk in chunks for layout in chunk.layouts) == collections.Counter(grid)
    ends = [{(layout.edge_offset_mm, layout.piezos_per_column, layout.arrangement) for layout in chunk.layouts}
            for chunk in chunks]
    assert not ends[0] & ends[1]
    assert abs(len(chunks[0].layouts) - len(chunks[1].layouts)) <= max(len(chunk.layouts) for chunk in chunks) // 10
    assert all(any(layout.columns == "ends_and_centre" for layout in chunk.layouts) for chunk in chunks)


def test_the_check_fails_on_one_deviation_and_agrees_on_two_refusals():
    layout = layouts.Layout("ends", 3.0, 2, "centred", 0.5)
    point = {"frequency_hz": 40e3, "force_factor_n_per_v": 0.1}
    close = {"frequency_hz": 40e3 * 1.001, "force_factor_n_per_v": 0.1 * 1.01}
    far = {"frequency_hz": 40e3, "force_factor_n_per_v": 0.1 * 1.03}
    assert layout_sweep.check([{"layout": layout, "full": point, "reduced": close},
                               {"layout": layout, "full": None, "reduced": None}]).passed
    assert not layout_sweep.check([{"layout": layout, "full": point, "reduced": far}]).passed
    assert not layout_sweep.check([{"layout": layout, "full": point, "reduced": None}]).passed


def test_the_sample_is_fixed_and_grows_with_the_sweep():
    assert layout_sweep.sample(300) == layout_sweep.sample(300)
    assert len(layout_sweep.sample(300)) == 9 and len(layout_sweep.sample(3000)) == 23
    assert layout_sweep.sample(5) == [0, 1, 2, 3, 4]


def _small_sweep(spec):
    values = design.operating_point(spec).values
    grid = [layout for layout in layouts.grid(values["half_wavelength_mm"], spec.piezo.length_x_mm)
            if layout.columns == "ends" and layout.piezos_per_column == 2 and layout.arrangement == "centred"
            and layout.edge_offset_mm < 6][:6]
    return values, grid


def test_a_sweep_whose_check_fails_is_solved_in_full_and_says_so(monkeypatch):
    spec = strip()
    values, grid = _small_sweep(spec)
    monkeypatch.setattr(reduced_layouts, "FORCE_TOLERANCE_REL", 0.0)
    frame, note = sweep_layouts(spec, values, workers=1, grid=grid)
    full, full_note = sweep_layouts(spec, values, workers=1, grid=grid, reduced=False)
    assert "each by the full solve" in note and "missed its check" in note
    assert "each by the full solve" in full_note
    assert frame.equals(full)


def test_a_sweep_whose_check_passes_is_the_reduced_models(monkeypatch):
    """With limits it meets, the sweep is the reduced model's: every layout, each within
    1 % in frequency of its full solve (the layouts' own meshes against the sweep's, which
    has a line on every patch edge of the six: 0.3 % apart at most on the strip)."""
    spec = strip()
    values, grid = _small_sweep(spec)
    monkeypatch.setattr(reduced_layouts, "FORCE_TOLERANCE_REL", 1.0)
    monkeypatch.setattr(reduced_layouts, "FREQUENCY_TOLERANCE_REL", 1.0)
    frame, note = sweep_layouts(spec, values, workers=1, grid=grid)
    full, _ = sweep_layouts(spec, values, workers=1, grid=grid, reduced=False)
    assert note.startswith(f"{len(grid)} layouts by the reduced model")
    assert list(frame["piezo_thickness_mm"]) == list(full["piezo_thickness_mm"])
    answered = full["frequency_hz"].notna()
    np.testing.assert_allclose(frame["frequency_hz"][answered], full["frequency_hz"][answered], rtol=1e-2)


def test_design_without_layouts_builds_no_reduced_model(tmp_path, capsys, monkeypatch):
    """`design --no-layouts` pays nothing for the sweep: no reduced model, no sample check."""
    def refused(*args, **kwargs):
        raise AssertionError("the reduced model was built without a sweep")

    monkeypatch.setattr(reduced_layouts.ReducedPlate, "__init__", refused)
    monkeypatch.setattr(layout_sweep, "tasks", refused)
    path = tmp_path / "strip.yaml"
    path.write_text(dump_yaml(STRIP))
    assert cli.main(["design", str(path), "--no-layouts", "--out", str(tmp_path / "out"), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["layouts"] is None


@pytest.fixture(scope="module")
def large_plate_placements():
    """The large plate's end columns flush with the ends and 4 mm in, two piezos a column
    in either arrangement, on one sweep mesh (a line near every patch edge of the four)."""
    spec = load_design_file(design_file("large_plate"))
    antinodes = spec.mode.interior_antinodes
    flush = spec.piezo.length_x_mm / 2
    grid = [layouts.Layout("ends", offset_mm, 2, arrangement, 0.5)
            for offset_mm in (flush, flush + 4.0) for arrangement in layouts.ARRANGEMENTS]
    return spec, antinodes, grid, layout_sweep.bare_plate(spec, grid, antinodes)


@pytest.mark.parametrize("index", [0, 3], ids=["flush-corners", "inset-centred"])
def test_on_a_sweeps_mesh_flush_and_inset_patches_are_within_the_checks_limits(large_plate_placements, index):
    """A patch flush with the plate's end and one 4 mm in, answered by the reduced model
    on the sweep's mesh (not the layout's own), against the full solve on the layout's
    own mesh: frequency within 0.2 %, force factor within 2 %, what the sweep's check asks.
    Each placement in one arrangement, each arrangement once (the mesh has the lines of
    all four; the other two pairings take the same path, at a full solve of the large
    plate each)."""
    spec, antinodes, grid, bare = large_plate_placements
    layout = grid[index]
    solve = reduced_layouts.Solver(bare)
    full = layout_sweep._working_point(layout, spec, antinodes)
    reduced = layout_sweep._working_point(layout, spec, antinodes, solve)
    assert full is not None and reduced is not None
    assert reduced["frequency_hz"] == pytest.approx(full["frequency_hz"], rel=reduced_layouts.FREQUENCY_TOLERANCE_REL)
    assert reduced["force_factor_n_per_v"] == pytest.approx(full["force_factor_n_per_v"],
                                                            rel=reduced_layouts.FORCE_TOLERANCE_REL)
    assert solve.full_solves == 0


def test_a_sweep_on_a_dask_cluster_is_the_local_sweep():
    """The reduced model's sweep through `--scheduler`'s route (a Dask cluster in this
    process) gives the table of the local one."""
    distributed = pytest.importorskip("distributed")
    spec = strip()
    values, grid = _small_sweep(spec)
    local, note = sweep_layouts(spec, values, workers=1, grid=grid)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        on_cluster, cluster_note = sweep_layouts(spec, values, workers=2, scheduler=cluster, grid=grid)
    assert cluster_note == note
    pd.testing.assert_frame_equal(on_cluster, local)
