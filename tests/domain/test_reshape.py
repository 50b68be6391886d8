"""Shape changes are plan actions: a body that cannot reach a goal in its shape switches, where
the sweep is clear, to a library shape that can (the head stays put)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from app.executor.runner import MissionRunner
from app.missions.spec import load_mission
from domain.reshape import reshape_clear, reshape_duration
from primitives.library import load_bundled
from primitives.shapes import SHAPES
from sim.robot import Array
from sim.world import footprint

POCKET = Path(__file__).parents[2] / "examples" / "hard" / "reshape-into-pocket.json"


def open_space(points: Array) -> Array:
    return np.full(len(points), 5.0)


def test_reshape_sweep_is_checked_against_the_world() -> None:
    zigzag, straight = SHAPES["zigzag"].joints, SHAPES["straight"].joints
    assert reshape_clear((0.0, 0.0, 0.0), zigzag, straight, open_space, 0.02)

    # A post where the straight body's tail would be, clear of the zigzag body's.
    straight_tail = footprint(np.zeros(3), np.asarray(straight)).ends[-1]

    def post(points: Array) -> Array:
        out: Array = np.linalg.norm(points - straight_tail, axis=-1) - 0.02
        return out

    fp = footprint(np.zeros(3), np.asarray(zigzag))
    assert float(np.min(post(fp.ends) - fp.radii)) > 0.02  # the zigzag body keeps the margin
    assert not reshape_clear((0.0, 0.0, 0.0), zigzag, straight, post, 0.02)
    # Joints turn at a bounded rate: 0.5 rad takes a second, in whole ticks.
    assert reshape_duration(zigzag, straight, 0.25) == 1.0


def test_a_zigzag_body_changes_to_straight_to_enter_a_narrow_pocket() -> None:
    spec = load_mission(POCKET)
    assert spec.shape == "zigzag"
    runner = MissionRunner(spec, load_bundled())
    result = runner.run()
    assert result.status == "succeeded", result.reason
    assert all(g.error is not None and g.error <= g.tolerance for g in result.goals)
    first = result.pddl[0]["plan"]  # the first plan
    assert first[0] == "(reshape zigzag straight)", first[:2]
    assert all("lat-straight-" in step for step in first[1:] if step.startswith("(move"))
    assert runner.ctx.shape == "straight"
