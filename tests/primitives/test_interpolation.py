"""Bilinear interpolation (eqs. 16-18) and the better generaliser."""

import math

import numpy as np
import pytest

from primitives.generalise import Generaliser
from primitives.interpolation import (
    bilinear,
    interpolate_entries,
    interpolate_in_shape,
    quadrant_of,
)
from primitives.library import load_bundled
from sim.rollout import rollout

LIB = load_bundled()


def end_error(ip) -> float:
    return math.dist(rollout(ip.control()).end[0, :2], ip.goal)


def test_bilinear_reproduces_corners_origin_and_bilinear_functions() -> None:
    fx, fy, fxy = np.array([1.0, 2]), np.array([3.0, 5]), np.array([7.0, 11])
    assert bilinear((2, 0), fx, fy, fxy, 2, 2) == pytest.approx(fx)
    assert bilinear((0, 2), fx, fy, fxy, 2, 2) == pytest.approx(fy)
    assert bilinear((2, 2), fx, fy, fxy, 2, 2) == pytest.approx(fxy)
    assert bilinear((0, 0), fx, fy, fxy, 2, 2) == pytest.approx([0, 0])  # f(O) = 0

    # f(x, y) = a x + b y + c x y (f(O) = 0) is reproduced exactly anywhere in the quadrant
    def f(x: float, y: float) -> np.ndarray:
        return np.array([0.3 * x - 0.2 * y + 0.1 * x * y, x * y])

    got = bilinear((-1.3, 0.4), f(-2, 0), f(0, 2), f(-2, 2), -2, 2)
    assert got == pytest.approx(f(-1.3, 0.4))


def test_quadrants_follow_fig6() -> None:
    assert [quadrant_of(g) for g in [(1, 1), (-1, 1), (-1, -1), (1, -1)]] == ["A", "B", "C", "D"]
    assert interpolate_in_shape(LIB, (1.0, 1.5), "straight").sources == ("P8s", "P2s", "P1s")


def test_fig8_cross_shape_interpolation_reaches_near_the_goal() -> None:
    # Fig. 8: P1s (straight), P12 and P13 (semi-zigzag) -> goal (2, 1)
    ip = interpolate_entries([LIB.get("P1s"), LIB.get("P12"), LIB.get("P13")], (2.0, 1.0))
    assert ip.joints == pytest.approx(0.5 * np.array(LIB.get("P13").joints))  # x = x2: P13 & P1s
    assert end_error(ip) < 0.25


def test_interpolation_rejects_periodic_and_misplaced_primitives() -> None:
    with pytest.raises(ValueError, match="periodic"):
        interpolate_entries([LIB.get("P1s"), LIB.get("P2s"), LIB.get("P4pe")], (1, 1))
    with pytest.raises(ValueError, match="axis"):
        interpolate_entries([LIB.get("P1s"), LIB.get("P3s"), LIB.get("P7s")], (1, 1))


def test_generaliser_beats_bilinear_on_held_out_goals() -> None:
    rng = np.random.default_rng(7)
    goals = [tuple(g) for g in rng.uniform(-2, 2, (20, 2))]
    gen = Generaliser(LIB)
    bilinear_errors = [end_error(interpolate_in_shape(LIB, g, "zigzag")) for g in goals]
    refined = [gen.refine(g, "zigzag") for g in goals]
    refined_errors = [end_error(ip) for ip in refined]
    assert np.median(refined_errors) < 0.01 < np.median(bilinear_errors)
    assert max(refined_errors) < 0.05
    assert all(ip.extra["rollouts"] <= 35 for ip in refined)
    assert refined[0].extra["error"] == pytest.approx(refined_errors[0], abs=1e-9)


def test_pi2_refinement_seeded_by_the_prediction() -> None:
    ip = Generaliser(LIB).refine((1.2, -0.7), "straight", method="pi2", budget=10, threshold=0.02)
    assert end_error(ip) < 0.05 and ip.method == "blend+pi2"
