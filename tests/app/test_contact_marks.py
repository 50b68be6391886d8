"""Where a contact is marked in the world model: an end bumper's axis point for certain, the
rest of the end and the surface's likely continuation suspected, never on the body itself and
never deeper than 0.1 m into the touched side."""

from types import SimpleNamespace

import numpy as np

from app.executor.behaviours import SUSPECT_DEPTH, contact_points
from app.executor.robot import ContactReading
from sim.obstacles import point_segment_distance
from sim.robot import DEFAULT_GEOMETRY, joint_positions
from sim.world import footprint

POSE = (0.0, 0.0, 0.0)  # ψ = 0: the tail lies towards +x
JOINTS = (0.0, 0.0, 0.0)
CTX = SimpleNamespace(pose=POSE, sensed_joints=lambda: JOINTS)


def tail_end() -> np.ndarray:
    return joint_positions(np.array(POSE), np.array(JOINTS))[-1]


def off_body(points: list[tuple[float, float]]) -> bool:
    fp = footprint(np.array(POSE), np.array(JOINTS))
    pts = np.asarray(points)
    gap = np.min(point_segment_distance(pts[:, None, :], fp.starts, fp.ends) - fp.radii, -1)
    return bool(np.all(gap > 0))


def test_an_end_bumper_marks_its_axis_point_and_suspects_the_rest_of_its_end() -> None:
    touched, suspected = contact_points(CTX, ContactReading(4, "rear"))
    end = tail_end()
    assert len(touched) == 1
    ((x, y),) = touched
    assert abs(y) < 1e-9 and x > end[0] + DEFAULT_GEOMETRY.unit_radius  # on the axis, beyond it
    sus = np.asarray(suspected)
    r = DEFAULT_GEOMETRY.unit_radius
    across = sus[np.abs(sus[:, 0] - x) < 0.02]
    assert across[:, 1].min() <= -r + 0.03 and across[:, 1].max() >= r - 0.03  # the end's width
    assert np.all(sus[:, 0] - x <= SUSPECT_DEPTH + 1e-9)  # no deeper into the touched side
    assert np.all(sus[:, 0] - x >= -0.01)
    assert off_body(suspected)


def test_a_side_bumper_marks_its_whole_side() -> None:
    touched, suspected = contact_points(CTX, ContactReading(2, "left"))
    pts = joint_positions(np.array(POSE), np.array(JOINTS))
    front, rear = pts[1], pts[2]
    t = np.asarray(touched)
    assert t[:, 0].min() <= min(front[0], rear[0]) - 0.09
    assert t[:, 0].max() >= max(front[0], rear[0]) + 0.09
    # ψ = 0: the body's left (towards the head, -x) is -y
    assert np.all(t[:, 1] < -DEFAULT_GEOMETRY.unit_radius)
    assert off_body(suspected)
