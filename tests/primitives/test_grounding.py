"""A move's grounding: the blend's weights solve the same least squares numpy's solver does,
and a grounded move lands where its basis says it does."""

from __future__ import annotations

import numpy as np
import pytest

from primitives import grounding
from primitives.grounding import _small_least_squares, correction_basis, ground
from primitives.library import load_bundled

LIB = load_bundled()


@pytest.mark.parametrize("columns", [1, 2, 3])
def test_the_closed_form_weights_are_numpy_s_least_squares(columns: int) -> None:
    rng = np.random.default_rng(columns)
    for _ in range(2000):
        a, b = rng.normal(size=(3, columns)), rng.normal(size=3)
        got = _small_least_squares([a[:, i] for i in range(columns)], (b[0], b[1], b[2]))
        assert got is not None
        want = np.linalg.lstsq(a, b, rcond=None)[0]
        assert np.allclose(got, want, rtol=1e-9, atol=1e-12)


def test_dependent_or_many_columns_are_left_to_numpy() -> None:
    u = np.array([0.05, 0.0, 0.0])
    assert _small_least_squares([u, 2 * u], (1.0, 0.0, 0.0)) is None
    assert _small_least_squares([u, -u, np.array([0.0, 0.0, 0.1])], (1.0, 0.0, 0.0)) is None
    assert _small_least_squares([np.zeros(3)], (1.0, 0.0, 0.0)) is None
    four = [np.eye(3)[i] for i in range(3)] + [u]
    assert _small_least_squares(four, (1.0, 0.0, 0.0)) is None


@pytest.mark.parametrize("shape", LIB.lattice_shapes())
def test_a_grounded_move_is_the_one_numpy_s_solver_grounds(
    shape: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every lattice primitive of the shape, asked to land off its own end: the blend (its
    speeds, duration and predicted end) is numpy's, to rounding."""
    entries = LIB.lattice(shape)
    basis = correction_basis(entries)
    rng = np.random.default_rng(7)
    asks = [
        (entry, np.asarray(entry.end_pose) + rng.normal(scale=(0.02, 0.02, 0.05)))
        for entry in entries
        for _ in range(4)
    ]
    closed = [ground(offset, basis, entry) for entry, offset in asks]
    monkeypatch.setattr(grounding, "_small_least_squares", lambda columns, b: None)
    for got, (entry, offset) in zip(closed, asks, strict=True):
        want = ground(offset, basis, entry)
        assert got.primitives == want.primitives and got.method == want.method
        assert got.duration == pytest.approx(want.duration) and got.cycles == want.cycles
        assert np.allclose(got.theta, want.theta, rtol=1e-9, atol=1e-12)
        assert np.allclose(got.expected, want.expected, rtol=1e-9, atol=1e-12)
