"""The plate model (plates.plate_modes) against closed forms and against the paper's printed
resonances (data/paper/table3.csv, table4.csv), from one shared parameter set: the paper's
Table 2 aluminium (67.109 GPa, nu 0.34, 2790 kg/m^3) and NCE 41 (80 GPa, nu 0.33, 7900 kg/m^3),
no per-plate parameter. The printed frequency only centres the mode search; the (n, 0)
neighbours are about 2/n (>= 20 %) apart, so the mode found does not depend on it within 3 %."""
import dataclasses

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from squeezebench.plates.plate_modes import (ALUMINIUM_TABLE2, NCE41, Isotropic, PlateGeometry, beam_frequencies_hz, column,
                                  flexural_half_wavelength_m, free_free_beam_roots, laminate,
                                  solve_plate)
from squeezebench.plates import plate_modes, predicted_plates
from squeezebench.plates.laminate import RIGID_BOND, relative_tolerances, shear_lag_effectiveness
from squeezebench.paths import paper_values_dir

MM = 1e-3


def test_bare_laminate_is_the_plate_formula():
    d, mass, _ = laminate(ALUMINIUM_TABLE2, 1e-3, NCE41, 0.0)
    assert d == pytest.approx(67.109e9 * 1e-9 / (12 * (1 - 0.34**2)))
    assert mass == pytest.approx(2.79)


def test_identical_layers_put_the_neutral_axis_at_the_interface():
    _, _, z_m = laminate(ALUMINIUM_TABLE2, 1e-3, ALUMINIUM_TABLE2, 1e-3)
    assert z_m == pytest.approx(0.5e-3)


def test_a_strip_without_poisson_coupling_rings_at_the_free_free_beam_frequencies():
    """With nu = 0 a deflection w(x) satisfies every free-edge condition of the plate exactly,
    so the (n, 0) modes are Euler-Bernoulli's: f = (bL)^2 / (2 pi L^2) sqrt(E h^2 / 12 rho)."""
    metal = Isotropic(70e9, 0.0, 2700.0)
    length, width, h = 100 * MM, 6 * MM, 1 * MM
    roots = free_free_beam_roots(6)
    closed = [r**2 / (2 * np.pi * length**2) * np.sqrt(70e9 * h**2 / (12 * 2700.0)) for r in roots]
    modes = solve_plate(PlateGeometry(length, width, h), metal, near_hz=closed[4], n_modes=8, thick_plate=False)
    found = modes.frequencies_hz[modes.uniformity > 0.9]
    for f in closed[3:6]:
        assert np.min(abs(found - f)) / f < 2e-3


def test_the_default_mesh_is_converged_to_a_tenth_of_a_percent():
    plate = PlateGeometry(76 * MM, 41 * MM, 1.2 * MM, column(2.5 * MM, 41 * MM, 5 * MM, 9 * MM, 0.5 * MM, 4))
    coarse = solve_plate(plate, near_hz=44e3)
    fine = solve_plate(plate, near_hz=44e3, elements_per_half_wave=3.0)
    f_coarse = coarse.frequencies_hz[coarse.working_mode(44e3)]
    f_fine = fine.frequencies_hz[fine.working_mode(44e3)]
    assert abs(f_coarse / f_fine - 1) < 1e-3


def test_a_solution_is_cached_by_geometry_and_materials():
    plate = PlateGeometry(40 * MM, 20 * MM, 1 * MM)
    assert solve_plate(plate, near_hz=30e3) is solve_plate(plate, near_hz=30e3)
    stiffer = dataclasses.replace(ALUMINIUM_TABLE2, young_pa=70e9)
    assert solve_plate(plate, stiffer, near_hz=30e3) is not solve_plate(plate, near_hz=30e3)


def test_a_kept_solve_holds_about_what_it_says_and_not_its_basis_functions(monkeypatch):
    """What a solve kept in memory holds once its mesh's basis has left the basis cache is
    its `held_bytes` (the cache's weight: 32 large plates held 1.5 GB when each kept its
    basis' evaluated functions), measured by tracemalloc, which NumPy reports to."""
    import gc
    import tracemalloc

    monkeypatch.setenv("SQUEEZEBENCH_CACHE", "off")
    plate = _one_column_1mm(75)
    plate_modes.solve_plate(plate, near_hz=40e3, n_modes=12, elements_per_half_wave=1.2)   # imports, first calls
    plate_modes._discretisation.cache_clear()
    tracemalloc.start()
    try:
        before = tracemalloc.get_traced_memory()[0]
        modes = plate_modes.solve_plate(plate, near_hz=40e3, n_modes=12, elements_per_half_wave=1.4)
        plate_modes._discretisation.cache_clear()
        gc.collect()
        held = tracemalloc.get_traced_memory()[0] - before
    finally:
        tracemalloc.stop()
    assert 0.7 * modes.held_bytes < held < 1.5 * modes.held_bytes + 2**20
    assert modes.shape_at(0, [0.01], [0.01]).shape == (1,)   # its probe still answers


def test_a_solve_read_from_the_disk_cache_assembles_nothing_and_is_the_assembled_one_to_the_bit(monkeypatch,
                                                                                                  tmp_path):
    """A process reading a solve another stored (`stored_solves`: reproduce's report, the
    campaign's maps) probes it and assembles nothing: no basis at the assembly's quadrature
    (most of a discretisation's time) is built, and every frequency and shape is the
    assembling solve's, bit for bit."""
    import skfem

    monkeypatch.setenv("SQUEEZEBENCH_CACHE", str(tmp_path))
    plate = _one_column_1mm(75)

    def fresh_process():
        plate_modes._CACHE.clear()
        plate_modes._discretisation.cache_clear()
        return solve_plate(plate, near_hz=40e3, n_modes=12, elements_per_half_wave=1.3)

    assembled = fresh_process()
    bases = []
    monkeypatch.setattr(skfem, "Basis", lambda *args, **kwargs: bases.append(kwargs) or skfem.CellBasis(*args, **kwargs))
    read = fresh_process()
    assert bases and not any("intorder" in kwargs for kwargs in bases)
    x_m, y_m = np.meshgrid(np.linspace(0.0, 75 * MM, 31), np.linspace(0.0, plate.width_m, 7))
    assert np.array_equal(read.frequencies_hz, assembled.frequencies_hz)
    for k in range(len(read.frequencies_hz)):
        assert np.array_equal(read.shape_at(k, x_m, y_m), assembled.shape_at(k, x_m, y_m))


def test_a_solve_and_its_map_table_run_at_one_blas_thread_whatever_the_callers_pool(monkeypatch):
    """Wherever a solve runs (a study's task at one thread, the report's drawing process at
    the machine's), its eigenproblem and the map's spline table run at one BLAS thread: the
    same bits in every process, and no OpenBLAS thread spinning beside the campaign (a cold
    `reproduce`'s solves and tables took 14.2 CPU-s at two threads, 6.1 at one)."""
    from threadpoolctl import threadpool_info, threadpool_limits

    from squeezebench.simbench import modeshape

    monkeypatch.setenv("SQUEEZEBENCH_CACHE", "off")
    seen = {}

    def recording(name, function):
        def call(*args, **kwargs):
            seen[name] = max(pool["num_threads"] for pool in threadpool_info())
            return function(*args, **kwargs)
        return call

    monkeypatch.setattr(plate_modes, "eigsh", recording("eigsh", plate_modes.eigsh))
    monkeypatch.setattr(modeshape, "RegularGridInterpolator",
                        recording("spline", modeshape.RegularGridInterpolator))
    with threadpool_limits(limits=2):
        modes = solve_plate(_one_column_1mm(59), near_hz=38e3, n_modes=6, elements_per_half_wave=1.1)
        modeshape._table(modes, 0)
    assert seen == {"eigsh": 1, "spline": 1}


def test_plates_differing_only_in_what_is_powered_share_one_solve(monkeypatch):
    """Which patches a drive is wired to, and their names, change no eigenpair: one solve,
    each plate keeping its own powered set (so its own summed force factor), each cached."""
    solves = []
    solve = plate_modes._solve
    monkeypatch.setattr(plate_modes, "_solve", lambda *args: solves.append(args[0]) or solve(*args))
    columns = (column(4.5 * MM, 41 * MM, 5 * MM, 9 * MM, 0.5 * MM, 4, name="one")
               + column(71.5 * MM, 41 * MM, 5 * MM, 9 * MM, 0.5 * MM, 4, powered=False, name="two"))
    one = PlateGeometry(76 * MM, 41 * MM, 1.2 * MM, columns)
    both = dataclasses.replace(one, patches=tuple(dataclasses.replace(p, powered=True) for p in columns))
    first, second = solve_plate(one, near_hz=43e3, n_modes=6), solve_plate(both, near_hz=43e3, n_modes=6)
    assert len(solves) == 1 and all(p.powered and not p.name for p in solves[0].patches)
    assert list(first.powered) == [True] * 4 + [False] * 4 and second.powered.all()
    assert np.array_equal(first.force_factor_n_per_v, second.force_factor_n_per_v)
    k = first.working_mode(43e3)
    assert first.coupling(k)["force_factor_n_per_v"] != second.coupling(k)["force_factor_n_per_v"]
    assert solve_plate(one, near_hz=43e3, n_modes=6) is first and solve_plate(both, near_hz=43e3, n_modes=6) is second


def test_the_nodal_line_spacing_is_the_flexural_half_wavelength():
    plate = PlateGeometry(76 * MM, 41 * MM, 1.2 * MM)
    modes = solve_plate(plate, near_hz=44e3)
    k = modes.working_mode(44e3)
    expected = flexural_half_wavelength_m(ALUMINIUM_TABLE2, 1.2 * MM, modes.frequencies_hz[k])
    assert modes.half_wavelength_m(k) == pytest.approx(expected, rel=0.03)


def _printed(name):
    table = pd.read_csv(paper_values_dir() / name)
    return {(r.item, r.quantity): float(r.value) for r in table.itertuples()}


def _one_column_1mm(length_mm):
    return predicted_plates.table3_plate(f"{length_mm:g}")


def _table4_plate(n_columns):
    return predicted_plates.table4_plate(("1-column", "2-columns 2 powered")[n_columns - 1])


def test_the_coupling_of_a_powered_column_is_physical():
    """k_eff below the material's k31, and the modal mass (referred to the point of largest
    deflection) is the plate's mass weighted by the mode's mean square, plus the piezos'."""
    modes = solve_plate(_table4_plate(1), near_hz=43792)
    k = modes.working_mode(43792)
    coupling = modes.coupling(k)
    assert 0.01 < coupling["k_eff"] < NCE41.k31
    mean_square = np.trapezoid(np.trapezoid(modes.shapes[k] ** 2, modes.y_m), modes.x_m) / (
        modes.x_m[-1] * modes.y_m[-1])
    bare = modes.plate_mass_kg * mean_square   # on the shape grid (4 points per half-wave): to about 1 %
    assert 0.98 * bare < modes.modal_mass_kg[k] < 1.3 * bare


def test_the_beam_cross_check_reproduces_the_free_free_closed_form():
    metal = Isotropic(70e9, 0.0, 2700.0)
    length, h = 100 * MM, 1 * MM
    closed = [r**2 / (2 * np.pi * length**2) * np.sqrt(70e9 * h**2 / (12 * 2700.0))
              for r in free_free_beam_roots(6)]
    found = beam_frequencies_hz(PlateGeometry(length, 6 * MM, h), metal, f_min_hz=500, f_max_hz=closed[-1] * 1.01)
    assert found == pytest.approx(closed, rel=1e-6)


@settings(max_examples=30, deadline=None)
@given(t=st.floats(0.1e-3, 5e-3), modulus=st.floats(1e9, 200e9), shear=st.floats(0.5e9, 80e9),
       density=st.floats(1000, 9000), split=st.floats(0.1, 0.9))
def test_a_homogeneous_sections_shear_stiffness_is_five_sixths_g_h_however_it_is_split(t, modulus, shear, density,
                                                                                         split):
    """Jourawski's shear flow in one layer gives kappa = 5/6 and J = rho h^3 / 12; the same
    layer cut in two at any depth is the same section."""
    layer = (t, modulus, shear, density)
    s_one, j_one = plate_modes.section_shear_and_rotary([layer])
    assert s_one == pytest.approx(5 / 6 * shear * t, rel=1e-4)
    assert j_one == pytest.approx(density * t**3 / 12, rel=1e-9)
    s_two, j_two = plate_modes.section_shear_and_rotary([(split * t, modulus, shear, density),
                                                         ((1 - split) * t, modulus, shear, density)])
    assert s_two == pytest.approx(s_one, rel=1e-4) and j_two == pytest.approx(j_one, rel=1e-9)


@pytest.mark.parametrize("length_mm, antinodes", [(28, 3), (75, 9)])
def test_a_bare_timoshenko_beam_is_the_thin_beam_moved_onto_mindlins_branch(length_mm, antinodes):
    """The solver's thick-plate correction (Mindlin's dispersion at the mode's equivalent
    wavenumber) against Timoshenko's free-free beam with its free-end conditions, for Table
    3's bare 1 mm plates: 0.1 %, so the correction's form is not what f28/f75 misses."""
    plate = PlateGeometry(length_mm * MM, 41 * MM, 1 * MM)
    thin = beam_frequencies_hz(plate, f_min_hz=100, f_max_hz=60e3)[antinodes - 1]
    thick = beam_frequencies_hz(plate, f_min_hz=100, f_max_hz=60e3, thick=True)[antinodes - 1]
    assert thick < thin
    assert plate_modes.thick_plate_frequency_hz(thin, ALUMINIUM_TABLE2, 1 * MM) == pytest.approx(thick, rel=1e-3)


@pytest.mark.parametrize("n_columns", [1, 2])
def test_the_beam_and_the_plate_agree_on_table4s_plates(n_columns):
    """Two independent models of the same plate: the 2-D one's (9, 0) mode within 2 % of the
    beam's nearest mode (the free long edges' anticlastic relief is the difference), both thin
    (Euler-Bernoulli against Kirchhoff) with the same bonded sections. With both end columns on
    their first half-wave the beam's symmetric and antisymmetric modes near 46 kHz lie within a
    few hertz of each other (the ends' stiff patches couple them weakly), so the roots are
    bracketed on a 1 Hz grid: the default 50 Hz one steps over the pair."""
    plate = _table4_plate(n_columns)
    modes = solve_plate(plate, near_hz=44e3)
    f_plate = modes.kirchhoff_frequencies_hz[modes.working_mode(44e3)]
    beam = beam_frequencies_hz(plate, f_min_hz=40e3, f_max_hz=50e3, step_hz=1.0)
    assert np.min(abs(beam - f_plate)) / f_plate < 0.02


def test_flexural_frequency_and_half_wavelength_are_inverse():
    from squeezebench.plates.plate_modes import (ALUMINIUM_TABLE2, flexural_frequency_hz,
                                                   flexural_half_wavelength_m)

    for thickness_m, half_m in ((1e-3, 8e-3), (2e-3, 9.2e-3), (1.2e-3, 8.44e-3)):
        frequency = flexural_frequency_hz(ALUMINIUM_TABLE2, thickness_m, half_m)
        assert flexural_half_wavelength_m(ALUMINIUM_TABLE2, thickness_m, frequency) == pytest.approx(half_m, rel=1e-9)


def test_the_one_pass_argyris_basis_is_skfems_own_to_the_bit():
    """plates.argyris only reorders the work of skfem's global basis: every value, gradient
    and Hessian, at quadrature points and at probed points, is bit-identical, and so is its
    values-only probe."""
    from skfem import Basis, ElementTriArgyris, MeshTri

    from squeezebench.plates.argyris import Argyris, probes

    mesh = MeshTri.init_tensor(np.linspace(0, 0.05, 6), np.array([0.0, 0.004, 0.02, 0.03]))
    ours, theirs = Basis(mesh, Argyris(), intorder=8), Basis(mesh, ElementTriArgyris(), intorder=8)
    for mine, skfems in zip(ours.basis, theirs.basis):
        for part in (0, 1, 4):   # value, grad, hess (DiscreteField.get: .value is deprecated)
            assert np.array_equal(mine[0].get(part), skfems[0].get(part))
    points = np.random.default_rng(3).uniform([0, 0], [0.05, 0.03], (40, 2)).T
    assert (ours.probes(points) != theirs.probes(points)).nnz == 0
    assert (probes(ours, points) != theirs.probes(points)).nnz == 0


def test_the_tensor_finder_finds_skfems_elements_and_one_for_a_point_on_their_edges():
    """Off the mesh lines a point lies in one element, the one skfem's finder names; on a
    line, a vertex or the plate's edge (and a hair outside it) in an element that holds it,
    so the probe is skfem's there to roundoff (the element is C1)."""
    from skfem import Basis, MeshTri

    from squeezebench.plates.argyris import Argyris, probes

    x, y = np.array([0.0, 0.004, 0.011, 0.03, 0.05]), np.array([0.0, 0.004, 0.02, 0.03])
    mesh = MeshTri.init_tensor(x, y)
    basis = Basis(mesh, Argyris(), intorder=8)
    find = plate_modes.tensor_finder(mesh, basis.mapping, x, y)
    inside = np.random.default_rng(5).uniform([0, 0], [0.05, 0.03], (200, 2)).T
    assert np.array_equal(find(inside), mesh.element_finder(mapping=basis.mapping)(*inside))
    on_lines = np.array(np.meshgrid(np.linspace(0, 0.05, 21), np.linspace(0, 0.03, 13), indexing="ij")).reshape(2, -1)
    on_lines = np.hstack([on_lines, [[0.05 + 1e-15, 0.002], [0.01, -1e-15]]])
    reference = basis.mapping.invF(on_lines[:, :, None], tind=find(on_lines))[:, :, 0]
    assert (np.minimum(np.minimum(*reference), 1 - reference.sum(axis=0)) > -1e-9).all()
    vector = np.random.default_rng(6).normal(size=basis.N)
    on_plate = np.clip(on_lines.T, 0, [0.05, 0.03]).T   # skfem's finder refuses a point outside
    np.testing.assert_allclose(probes(basis, on_lines, find(on_lines)) @ vector, basis.probes(on_plate) @ vector,
                               rtol=1e-9, atol=1e-9 * np.abs(vector).max())


def test_the_batched_plate_matrices_are_skfems_assembly_to_roundoff():
    """`stiffness_and_mass` integrates the plate's two bilinear forms as skfem's `asm` does,
    element by element with a coefficient that varies between elements (a laminate)."""
    from skfem import Basis, BilinearForm, MeshTri, asm
    from skfem.helpers import dd, ddot, trace

    from squeezebench.plates.argyris import Argyris

    mesh = MeshTri.init_tensor(np.linspace(0, 0.05, 7), np.array([0.0, 0.004, 0.02, 0.03]))
    basis = Basis(mesh, Argyris(), intorder=8)
    rng = np.random.default_rng(11)
    rigidity, mass_per_area, nu = rng.uniform(5, 50, mesh.nelements), rng.uniform(2, 9, mesh.nelements), 0.34

    @BilinearForm
    def stiffness(u, v, w):
        return w.d * ((1 - nu) * ddot(dd(u), dd(v)) + nu * trace(dd(u)) * trace(dd(v)))

    @BilinearForm
    def mass(u, v, w):
        return w.m * u * v

    points = basis.X.shape[1]
    k_skfem = asm(stiffness, basis, d=np.repeat(rigidity[:, None], points, axis=1))
    m_skfem = asm(mass, basis, m=np.repeat(mass_per_area[:, None], points, axis=1))
    k_mat, m_mat = plate_modes.stiffness_and_mass(basis, rigidity, mass_per_area, nu)
    for ours, theirs in ((k_mat, k_skfem), (m_mat, m_skfem)):
        assert abs(ours - theirs).max() <= 1e-14 * abs(theirs).max()


def test_the_sheet_thickness_tolerance_follows_en_485_4():
    from squeezebench.plates.specifications import SHEET_THICKNESS_TOLERANCE_MM, sheet_thickness_tolerance

    # the paper's sheets: 1, 1.2 and 2 mm
    assert sheet_thickness_tolerance(1e-3) == pytest.approx(0.05)
    assert sheet_thickness_tolerance(1.2e-3) == pytest.approx(0.05 / 1.2)
    assert sheet_thickness_tolerance(2e-3) == pytest.approx(0.045)
    # a thickness on a row's upper bound belongs to that row ("over ... up to and including")
    assert sheet_thickness_tolerance(1.2001e-3) == pytest.approx(0.07 / 1.2001)
    rows = np.array(SHEET_THICKNESS_TOLERANCE_MM)
    assert (rows[1:, 0] == rows[:-1, 1]).all() and (np.diff(rows[:, 2]) > 0).all()   # contiguous, widening
    with pytest.raises(ValueError, match="state the plate's thickness tolerance"):
        sheet_thickness_tolerance(8e-3)
    assert relative_tolerances(1e-3)["thickness_m"] == sheet_thickness_tolerance(1e-3)


def test_a_rigid_bond_transfers_everything_and_a_compliant_one_less():
    stiff = dataclasses.replace(plate_modes.EPOXY, shear_modulus_pa=1e15)
    args = (ALUMINIUM_TABLE2, 1 * MM, NCE41, 0.5 * MM)
    assert shear_lag_effectiveness(*args, RIGID_BOND, 5 * MM) == 1.0
    assert shear_lag_effectiveness(*args, stiff, 5 * MM) == pytest.approx(1.0, abs=1e-3)
    assert plate_modes.bond_energy_ratio(*args, stiff, 5 * MM) == pytest.approx(0.0, abs=1e-3)
    nominal = shear_lag_effectiveness(*args, plate_modes.EPOXY, 5 * MM)
    assert 0.5 < nominal < 0.9   # a 40 um epoxy under a 5 mm patch: about three quarters
    assert shear_lag_effectiveness(*args, plate_modes.EPOXY, 14 * MM) > nominal   # longer: less end loss
    thick = dataclasses.replace(plate_modes.EPOXY, thickness_m=80e-6)
    assert shear_lag_effectiveness(*args, thick, 5 * MM) < nominal


@given(length_mm=st.floats(1.0, 20.0), g_over_t=st.floats(1e12, 1e14))
@settings(max_examples=30, deadline=None)
def test_the_shear_lag_closed_forms_are_their_integrals(length_mm, g_over_t):
    """eta and the bond's energy ratio against a quadrature of the shear-lag strain profile
    eps_p / eps0 = 1 - cosh(Gamma x) / cosh(Gamma l / 2) and the bond stress it implies."""
    bond = plate_modes.Bond(40e-6, g_over_t * 40e-6, 0.03, 1050.0)
    args = (ALUMINIUM_TABLE2, 1 * MM, NCE41, 0.5 * MM, bond, length_mm * MM)
    ep_tp, er_tr = NCE41.plate_modulus_pa * 0.5 * MM, ALUMINIUM_TABLE2.plate_modulus_pa * 1 * MM
    gamma = np.sqrt(g_over_t * (1 / ep_tp + 6 / er_tr))
    x = np.linspace(-length_mm * MM / 2, length_mm * MM / 2, 20001)
    strain = 1 - np.cosh(gamma * x) / np.cosh(gamma * x[-1])
    eta = np.trapezoid(strain, x) / x[-1] / 2
    assert shear_lag_effectiveness(*args) == pytest.approx(eta, rel=1e-5)
    tau = ep_tp * np.gradient(strain, x)
    bond_energy = np.trapezoid(tau**2 / (2 * g_over_t), x)
    # over the rigid bond's piezo energy E_p' t_p l / 2, then over eta (the piezo's own energy)
    expected = bond_energy / (ep_tp * x[-1]) / eta
    assert plate_modes.bond_energy_ratio(*args) == pytest.approx(expected, rel=1e-3)


@pytest.mark.parametrize("gap_mm", [0.0, 3.0, 6.0])
def test_a_thin_patch_drives_a_poisson_free_strip_as_the_free_free_beam_closed_form(gap_mm):
    """With nu = 0 the (n, 0) mode is the free-free beam's exactly, and a piezo a few micrometres
    thick leaves it so: the centre-referred modal mass and force factor the solver gives (the
    quantities the design's voltage is made of, V = w^2 M x / (Q A)) are the closed form's
    (`free_free_beam_centre_drive`), at the free edge and inward, where the curvature grows."""
    metal = Isotropic(70e9, 0.0, 2700.0)
    length, width, h, piezo_h, patch = 100 * MM, 6 * MM, 1 * MM, 2e-6, 5 * MM
    spans = [(gap_mm * MM, gap_mm * MM + patch), (length - gap_mm * MM - patch, length - gap_mm * MM)]
    geometry = PlateGeometry(length, width, h, tuple(plate_modes.Patch((a + b) / 2, width / 2, patch, width, piezo_h)
                                                      for a, b in spans))
    _, _, z_m, eta = plate_modes.bonded_section(metal, h, NCE41, piezo_h, RIGID_BOND, patch)
    mass, force = plate_modes.free_free_beam_centre_drive(metal, h, width, length, 5, spans, width,
                                                         NCE41.plate_e31_c_per_m2 * z_m * eta)
    near = free_free_beam_roots(5)[-1] ** 2 / (2 * np.pi * length**2) * np.sqrt(70e9 * h**2 / (12 * 2700.0))
    modes = solve_plate(geometry, metal, near_hz=near, n_modes=8, thick_plate=False, bond=RIGID_BOND)
    k = predicted_plates.mode_with_antinodes(modes, 5, near)
    solved_mass, forces = modes.referred_to(k, length / 2, width / 2)
    assert solved_mass == pytest.approx(mass, rel=2e-3)
    assert abs(forces.sum()) == pytest.approx(force, rel=0.015)


def test_the_free_free_beam_shape_is_normalised_and_free_at_its_ends():
    """integral w^2 = L and |w| = 2 at a free end, for a low and a high mode (the scaled
    exponentials keep the 21-antinode mode's digits)."""
    for antinodes in (3, 21):
        beta_l = free_free_beam_roots(antinodes)[-1]
        x = np.linspace(0, 0.2, 40001)
        w, _ = plate_modes.free_free_beam_shape(beta_l, 0.2, x)
        assert np.trapezoid(w**2, x) / 0.2 == pytest.approx(1.0, rel=1e-4)
        assert abs(w[0]) == pytest.approx(2.0, rel=1e-9) and abs(w[-1]) == pytest.approx(2.0, rel=1e-9)
