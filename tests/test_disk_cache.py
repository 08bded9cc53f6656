"""Results kept on disk are read back exactly, and only when whole and theirs (principle 5:
a corrupt or foreign file is computed again, never trusted)."""

from __future__ import annotations

import numpy as np
import pytest

from squeezebench.disk_cache import CACHE_VARIABLE, ArrayStore, arrays_digest
from squeezebench.plates import damping, plate_modes, predicted_plates

KEY = "a" * 64


def counted(calls: list, arrays: dict):
    """A build that leaves a trace of being run."""
    def build():
        calls.append(1)
        return arrays
    return build


@pytest.fixture
def arrays():
    rng = np.random.default_rng(51)
    return {"vectors": rng.normal(size=(40, 7)), "eigenvalues": np.sort(rng.uniform(1, 2, 7)),
            "count": np.arange(5)}


def test_a_second_store_reads_identical_arrays(tmp_path, arrays):
    calls = []
    first = ArrayStore(tmp_path, 2**20).get(KEY, counted(calls, arrays))
    again = ArrayStore(tmp_path, 2**20).get(KEY, counted(calls, arrays))
    assert len(calls) == 1 and sorted(again) == sorted(arrays)
    for name in arrays:
        assert again[name].dtype == arrays[name].dtype and np.array_equal(again[name], first[name])
    assert [path.name for path in tmp_path.iterdir()] == [f"{KEY}.npz"]   # no temporary file left


@pytest.mark.parametrize("damage", ["truncated", "flipped byte", "empty", "another key's file"])
def test_a_damaged_or_foreign_file_is_computed_again(tmp_path, arrays, damage):
    store, calls = ArrayStore(tmp_path, 2**20), []
    store.get(KEY, counted(calls, arrays))
    path = store.path(KEY)
    data = path.read_bytes()
    if damage == "truncated":
        path.write_bytes(data[: len(data) // 2])
    elif damage == "flipped byte":   # inside the vectors' bytes: the zip is whole, the digest is not
        start = data.index(arrays["vectors"].tobytes()[:16])
        path.write_bytes(data[:start + 9] + bytes([data[start + 9] ^ 0x40]) + data[start + 10:])
    elif damage == "empty":
        path.write_bytes(b"")
    else:
        other = "b" * 64
        store.get(other, lambda: {name: value + 1 for name, value in arrays.items()})
        path.write_bytes(store.path(other).read_bytes())
    assert store.read(KEY) is None
    again = store.get(KEY, counted(calls, arrays))
    assert len(calls) == 2 and arrays_digest(again) == arrays_digest(arrays)
    assert arrays_digest(store.read(KEY)) == arrays_digest(arrays)   # the rebuilt file replaced the bad one


def test_off_keeps_nothing(arrays):
    store, calls = ArrayStore(None, 2**20), []
    store.get(KEY, counted(calls, arrays))
    store.get(KEY, counted(calls, arrays))
    assert len(calls) == 2


def test_the_folder_stays_under_its_limit_the_least_recently_used_going(tmp_path, arrays):
    sizing = ArrayStore(tmp_path / "sizing", 2**20)
    sizing.get(KEY, lambda: arrays)
    store = ArrayStore(tmp_path / "kept", int(2.5 * sizing.path(KEY).stat().st_size))
    for key in ("1" * 64, "2" * 64, "3" * 64):
        store.get(key, lambda: arrays)
        store.read("1" * 64)   # used again after each write: the oldest is "2"
    assert sorted(path.name[0] for path in (tmp_path / "kept").glob("*.npz")) == ["1", "3"]


def test_a_plate_solve_is_read_back_identical_and_a_corrupt_one_solved_again(tmp_path, monkeypatch):
    """The 28 mm cut plate (a small mesh): solved, then read by a process that has not solved
    it (the in-process cache emptied, the eigen-solve forbidden), with its face integral
    (`damping`, stored with the solve), then solved again after its file is damaged."""
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path))
    geometry = predicted_plates.table3_plate("28")

    def solve():
        plate_modes._CACHE.clear()
        return plate_modes.solve_plate(geometry, near_hz=37e3, band_rel=0.3)

    solved = solve()
    k = solved.working_mode(37e3)
    face = damping.face_integral_m2_per_kg(solved, k)
    real_eigenpairs = plate_modes._eigenpairs

    def forbidden(*args):
        raise AssertionError("computed again, not read")

    monkeypatch.setattr(plate_modes, "_eigenpairs", forbidden)
    read = solve()
    with monkeypatch.context() as patch:   # the face integral is read, not integrated over the shape
        patch.setattr(plate_modes.PlateModes, "shape_at", forbidden)
        assert damping.face_integral_m2_per_kg(read, k) == face
    for name in ("frequencies_hz", "shapes", "modal_mass_kg", "force_factor_n_per_v", "uniformity",
                 "piezo_energy_share", "kirchhoff_frequencies_hz"):
        assert np.array_equal(getattr(read, name), getattr(solved, name)), name
    assert read.referred_to(k, 0.014, 0.02)[0] == solved.referred_to(k, 0.014, 0.02)[0]

    stored = plate_modes.stored_solves().path(read.stored_key)
    stored.write_bytes(stored.read_bytes()[:1000])
    calls = []
    monkeypatch.setattr(plate_modes, "_eigenpairs", lambda *args: calls.append(1) or real_eigenpairs(*args))
    again = solve()
    assert calls == [1] and np.array_equal(again.frequencies_hz, solved.frequencies_hz)
    assert np.array_equal(again.shapes, solved.shapes)


def test_other_solver_code_is_another_key(tmp_path, monkeypatch):
    """A solve stored by other plate-model code (another source fingerprint) is not read."""
    monkeypatch.setenv(CACHE_VARIABLE, str(tmp_path))
    geometry = predicted_plates.table3_plate("28")
    plate_modes._CACHE.clear()
    first = plate_modes.solve_plate(geometry, near_hz=37e3, band_rel=0.3)
    monkeypatch.setattr(plate_modes, "solver_fingerprint", lambda: "other code")
    plate_modes._CACHE.clear()
    other = plate_modes.solve_plate(geometry, near_hz=37e3, band_rel=0.3)
    assert len(list((tmp_path / "plates").glob("*.npz"))) == 2 and other.stored_key != first.stored_key
