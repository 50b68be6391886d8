"""Moving away from a touch: the allowance holds where the body touches, nowhere else."""

from __future__ import annotations

import numpy as np

from domain.lattice import LatticeSettings, capsule_samples, motion_table
from domain.lattice_planner import LatticePlanner
from domain.lattice_task import Clearance, LatticeTask
from domain.reshape import reshape_clear
from domain.touching import TOUCH_RADIUS, touch_allowance
from primitives.library import load_bundled
from primitives.shapes import SHAPES
from sim.world import Bounds, footprint

SETTINGS = LatticeSettings()
STRAIGHT = motion_table(load_bundled(), "straight", (0.0, 0.0, 0.0), SETTINGS)


def test_the_allowance_is_local_to_the_too_close_points() -> None:
    points = np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]])
    allowance = touch_allowance(points, np.array([-0.03, 0.2, 0.2]), 0.02)
    assert allowance.relaxed < -0.03 and len(allowance.sites) == 1
    at = allowance.at(np.array([[0.05, 0.0], [TOUCH_RADIUS + 0.01, 0.0], [1.0, 0.0]]))
    assert at.tolist() == [allowance.relaxed, 0.02, 0.02]
    untouched = touch_allowance(points, np.full(3, 0.1), 0.02)
    assert untouched.relaxed == 0.02 and untouched.at(points).tolist() == [0.02] * 3


def test_a_body_touching_at_its_tail_may_not_bring_its_head_as_close_to_something_else() -> None:
    assert STRAIGHT is not None
    grid = LatticePlanner(Bounds(-2, 2, -2, 2), SETTINGS).grid
    start = (40, 40, 0)
    centre = grid.centre(40, 40)
    body = centre + STRAIGHT.body_points[0]
    need = STRAIGHT.body_needs[0]
    head = centre + np.asarray(STRAIGHT.heads[0])
    axis = (head - centre) / np.linalg.norm(head - centre)
    side = np.array([-axis[1], axis[0]])
    tail = int(np.argmin(body @ axis))
    # A touched at the tail's end (0.02 m inside the margin-free distance); B beside the head,
    # 0.04 m clear of it: one 0.05 m step sideways towards B would leave the head 0.01 m deep.
    a = body[tail] - axis * (need[tail] - 0.02)
    near_head = int(np.argmax(body @ side - np.abs((body - head) @ axis)))
    b = body[near_head] + side * (need[near_head] + 0.04)

    def clearance(points: np.ndarray) -> np.ndarray:
        pts = np.asarray(points)
        return np.minimum(np.linalg.norm(pts - a, axis=-1), np.linalg.norm(pts - b, axis=-1))

    task = LatticeTask(grid, STRAIGHT, clearance, start, (1.9, 1.9), 0.1, 0.02, 0.0)
    assert task.start_margin.relaxed <= -0.02 - 0.005 + 1e-9
    steps = {
        m: STRAIGHT.deltas[0][m]
        for m, name in enumerate(STRAIGHT.names)
        if "t005" in name and STRAIGHT.deltas[0][m][2] == 0
    }
    toward = [m for m, d in steps.items() if np.allclose(d[:2] @ axis, 0) and d[:2] @ side > 0]
    away = [m for m, d in steps.items() if np.allclose(d[:2] @ axis, 0) and d[:2] @ side < 0]
    assert toward and away
    free = {m for _, m in task.valid_motions(start)}
    assert not free & set(toward)  # the head would come 0.01 m deep, far from the touch
    assert set(away) <= free  # stepping away from B, the tail no deeper into A


def test_a_shape_change_touching_at_one_end_keeps_the_margin_elsewhere() -> None:
    straight = np.asarray(SHAPES["straight"].joints, dtype=float)
    arc = np.asarray(SHAPES["arc"].joints, dtype=float)
    pose = np.zeros(3)

    def samples(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        fp = footprint(pose, joints)
        return capsule_samples(fp.starts, fp.ends, fp.radii)

    def nearest(obstacles: list[np.ndarray]) -> Clearance:
        spots = np.array(obstacles)
        return lambda p: np.min(np.linalg.norm(np.asarray(p)[:, None] - spots[None], axis=-1), 1)

    # The head's tip touches something: 0.03 m inside the 0.02 m margin (the tracked point stays
    # put during a change, so it stays touching).
    start, needs = samples(straight)
    tip = int(np.argmax(np.linalg.norm(start - start.mean(axis=0), axis=1) - start[:, 0]))
    out = (start[tip] - start.mean(axis=0)) / np.linalg.norm(start[tip] - start.mean(axis=0))
    touched = start[tip] + out * (needs[tip] - 0.01)
    assert reshape_clear(pose, straight, arc, nearest([touched]), 0.02)
    # Something else that the swinging body passes 0.01 m deep (shallower than the touch):
    # no longer a valid change, though a single allowance for the whole body would take it.
    end, end_needs = samples(arc)
    far = int(np.argmax(np.linalg.norm(end - start[tip], axis=1)))
    beyond = (end[far] - start[tip]) / np.linalg.norm(end[far] - start[tip])
    other = end[far] + beyond * (end_needs[far] - 0.01)
    assert not reshape_clear(pose, straight, arc, nearest([touched, other]), 0.02)
    assert reshape_clear(pose, straight, arc, nearest([touched, other + beyond * 0.05]), 0.02)
