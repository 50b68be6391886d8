"""Learned shapes (primitives/shape_learning.py): names from joints, the lattice tolerance
measured, a full set learned deterministically within the library's bar, cancel and budget."""

from __future__ import annotations

import math

import numpy as np
import pytest

from primitives.coverage import JOINT_TOLERANCE, LATTICE_TOLERANCE
from primitives.lattice import LATTICE_STOP
from primitives.library import load_bundled
from primitives.params import ParameterSpace
from primitives.shape_learning import LearningCancelled, LearningOverBudget, learn_shape
from primitives.shapes import is_shape, learned_joints, learned_name, shape_named, shape_seed
from sim.rollout import rollout

LIB = load_bundled()
CELL, BIN = 0.05, 2 * math.pi / 64  # the lattice's resolution and heading bin (defaults)


def test_a_learned_shape_is_named_by_its_rounded_joints() -> None:
    name = learned_name((0.9, -0.3, 0.6004))
    assert name == "body-p090-m030-p060" and learned_joints(name) == (0.9, -0.3, 0.6)
    assert shape_named(name).joints == (0.9, -0.3, 0.6) and not shape_named(name).periodic
    assert is_shape(name) and not is_shape("body-p090") and not is_shape("wiggly")
    assert learned_name((-0.004, 0.0, 1.52)) == "body-p000-p000-p152"
    assert (
        shape_seed(name) == shape_seed("body-p090-m030-p060") != shape_seed("body-p090-m030-p061")
    )
    with pytest.raises(ValueError, match="joints"):
        learned_name((0.0, math.nan, 0.0))


def worst_landing(offset: float) -> tuple[float, float]:
    """Where every library lattice motion lands when its body's joints are ``offset`` rad off
    (six directions) against its recorded end: the worst (metres, radians)."""
    worst_xy = worst_psi = 0.0
    directions = np.array([[1, 1, 1], [1, -1, 1], [-1, 1, 1], [1, 1, -1], [-1, -1, 1], [1, -1, -1]])
    for shape in LIB.lattice_shapes():
        if shape_named(shape).periodic:
            continue  # a gait's joints follow its clock, not a fixed vector
        for e in LIB.lattice(shape):
            assert e.joints is not None and e.end_pose is not None
            joints = np.asarray(e.joints) + offset * directions
            ends = np.array(
                [
                    rollout(
                        ParameterSpace("U1", tuple(j)).control(np.asarray(e.theta)[None]),
                        config=e.rollout.config(),
                    ).end[0, :3]
                    for j in joints
                ]
            )
            worst_xy = max(worst_xy, float(np.max(np.hypot(*(ends[:, :2] - e.end_pose[:2]).T))))
            worst_psi = max(worst_psi, float(np.max(np.abs(ends[:, 2] - e.end_pose[2]))))
    return worst_xy, worst_psi


def test_motions_on_joints_within_the_lattice_tolerance_land_within_a_cell_and_a_bin() -> None:
    xy, psi = worst_landing(LATTICE_TOLERANCE)
    assert xy < CELL and psi < BIN, (xy, psi)
    # ... which the old tolerance (a library shape "as it is") does not give
    xy, psi = worst_landing(JOINT_TOLERANCE)
    assert xy > CELL or psi > BIN


def test_the_lattice_covers_only_lattice_shapes_within_the_tolerance() -> None:
    assert LIB.lattice_covers((0.52, -0.48, 0.5)).shape == "zigzag"
    assert LIB.covers((0.25, -0.25, -0.05)).kind == "interpolated"
    assert not LIB.lattice_covers((0.25, -0.25, -0.05)).covered  # a blend is not a lattice
    assert not LIB.lattice_covers((0.1, 0.0, 0.0)).covered
    assert LIB.lattice_covers((0.1, 0.0, 0.0), tolerance=0.1).shape == "straight"


def test_a_full_set_is_learned_deterministically_within_the_librarys_bar() -> None:
    seen: list[tuple[int, int]] = []
    a = learn_shape((0.9, -0.3, 0.6), progress=lambda done, total: seen.append((done, total)))
    assert a.shape == "body-p090-m030-p060" and a.learner == "pi2-cma"
    assert seen[0] == (0, 22) and seen[-1] == (22, 22)
    assert len(a.entries) + len(a.failed) == 22 and len(a.entries) >= 20
    assert all(e.cost < LATTICE_STOP.threshold and e.shape == a.shape for e in a.entries)
    assert all(e.id.startswith("lat-body-p090-m030-p060-") for e in a.entries)
    grown = LIB.with_entries(a.entries)
    assert grown.lattice_covers((0.9, -0.3, 0.62)).shape == a.shape
    assert len(grown.with_entries(a.entries)) == len(grown)  # the same entries join once
    b = learn_shape((0.9, -0.3, 0.6))
    assert b.entries == a.entries and b.seed == a.seed


def test_cancel_and_the_budget_stop_learning_naming_the_shape() -> None:
    calls = []

    def cancelled() -> bool:
        calls.append(1)
        return len(calls) > 30  # some updates into the set

    with pytest.raises(LearningCancelled, match="body-m080-p040-m070"):
        learn_shape((-0.8, 0.4, -0.7), cancelled=cancelled)
    with pytest.raises(LearningOverBudget, match=r"body-m080-p040-m070: not learned within"):
        learn_shape((-0.8, 0.4, -0.7), budget=1e-6)
