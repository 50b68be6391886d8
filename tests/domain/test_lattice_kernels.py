"""The compiled grid Dijkstra gives scipy's distance maps, value for value."""

from __future__ import annotations

import numpy as np
import pytest

from domain import lattice_distances, lattice_kernels
from domain.lattice import LatticeGrid, LatticeSettings
from sim.world import Bounds

pytestmark = pytest.mark.skipif(not lattice_kernels.AVAILABLE, reason="numba kernels are off")


def scipy_geodesic(
    ok: np.ndarray, sources: list[tuple[int, int]], r: float, monkeypatch: pytest.MonkeyPatch
) -> np.ndarray:
    with monkeypatch.context() as m:
        m.setattr(lattice_kernels, "AVAILABLE", False)
        return lattice_distances.geodesic(ok, sources, r)


@pytest.mark.parametrize("shape", [(1, 9), (7, 1), (40, 33), (120, 90)])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_grid_dijkstra_equals_scipy(
    shape: tuple[int, int], seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    rng = np.random.default_rng(seed)
    ok = rng.random(shape) > 0.25
    sources = [(int(rng.integers(shape[0])), int(rng.integers(shape[1]))) for _ in range(1 + seed)]
    got = lattice_distances.geodesic(ok, sources, 0.05)
    want = scipy_geodesic(ok, sources, 0.05, monkeypatch)
    assert np.isfinite(want).sum() >= len(set(sources))
    assert np.array_equal(got, want)  # inf where cut off, and the same floats elsewhere


def test_a_blocked_source_reaches_nothing_but_itself(monkeypatch: pytest.MonkeyPatch) -> None:
    ok = np.ones((5, 6), dtype=bool)
    ok[2, 3] = False
    got = lattice_distances.geodesic(ok, [(2, 3), (2, 3)], 0.1)
    assert got[2, 3] == 0.0 and np.isinf(np.delete(got.ravel(), 2 * 6 + 3)).all()
    assert np.array_equal(got, scipy_geodesic(ok, [(2, 3)], 0.1, monkeypatch))


def test_distances_go_round_a_wall() -> None:
    ok = np.ones((9, 9), dtype=bool)
    ok[4, :8] = False  # a wall with a gap at j = 8
    d = lattice_distances.geodesic(ok, [(0, 0)], 1.0)
    assert d[8, 0] > 8 * 1.0  # round the end of the wall, not through it
    assert np.isclose(d[3, 0], 3.0) and np.isclose(d[2, 2], 2 * np.sqrt(2))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_motions_free_equals_the_numpy_check(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(seed)
    clear = rng.uniform(0.0, 0.3, 50)
    inverse = rng.integers(0, 50, 400).astype(np.intp)
    need = rng.uniform(0.0, 0.12, 400)
    segments = np.sort(rng.choice(np.arange(1, 400), 21, replace=False)).astype(np.int64)
    segments = np.concatenate([[0], segments])
    got = lattice_kernels.motions_free(clear, inverse, need, segments)
    with monkeypatch.context() as m:
        m.setattr(lattice_kernels, "AVAILABLE", False)
        want = lattice_kernels.motions_free(clear, inverse, need, segments)
    assert got.dtype == bool and np.array_equal(got, want)
    assert 0 < want.sum() < len(want)  # some motions free, some blocked: both paths tested


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_cells_within_finds_what_a_scan_of_every_cell_finds(seed: int) -> None:
    """The box search round a point returns exactly the cells a scan of the grid returns,
    points off the grid and radii below a cell included."""
    rng = np.random.default_rng(seed)
    for _ in range(100):
        x0, y0 = rng.uniform(-6.0, -1.0, 2)
        x1, y1 = rng.uniform(1.0, 6.0, 2)
        bounds = Bounds(float(x0), float(x1), float(y0), float(y1))
        grid = LatticeGrid(
            bounds, LatticeSettings(resolution=float(rng.choice([0.033, 0.05, 0.1])))
        )
        point = (float(rng.uniform(x0 - 1, x1 + 1)), float(rng.uniform(y0 - 1, y1 + 1)))
        radius = float(rng.choice([0.0, 0.01, rng.uniform(0, 1.5)]))
        c = grid.centres
        want = np.flatnonzero(np.hypot(c[:, 0] - point[0], c[:, 1] - point[1]) <= radius)
        np.testing.assert_array_equal(lattice_distances.cells_within(grid, point, radius), want)


def test_several_sources_never_fill_a_bucket_past_the_cells(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A bucket holds one entry per cell. A row of sources lowers each cell beside it twice
    within one bucket (diagonally, then straight: 10 entries in a 3 x 3 grid); the kernel's
    own loop run as Python raises IndexError where, compiled, it wrote past the bucket."""
    ok = np.ones((3, 3), dtype=bool)
    sources = [(1, 0), (1, 1), (1, 2)]
    want = scipy_geodesic(ok, sources, 0.05, monkeypatch)
    monkeypatch.setattr(lattice_kernels, "_dijkstra", lattice_kernels._dijkstra.py_func)
    assert np.array_equal(lattice_distances.geodesic(ok, sources, 0.05), want)


@pytest.mark.parametrize("seed", [0, 1])
def test_many_sources_equal_scipy_run_as_python(seed: int, monkeypatch: pytest.MonkeyPatch) -> None:
    rng = np.random.default_rng(seed)
    cases = []
    for _ in range(60):
        shape = (int(rng.integers(1, 8)), int(rng.integers(1, 8)))
        ok = rng.random(shape) > 0.15
        n = shape[0] * shape[1]
        picks = rng.integers(0, n, int(rng.integers(1, n + 1)))
        sources = [divmod(int(s), shape[1]) for s in picks]
        cases.append((ok, sources, scipy_geodesic(ok, sources, 0.05, monkeypatch)))
    monkeypatch.setattr(lattice_kernels, "_dijkstra", lattice_kernels._dijkstra.py_func)
    for ok, sources, plain in cases:
        assert np.array_equal(lattice_distances.geodesic(ok, sources, 0.05), plain)
