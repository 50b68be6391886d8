"""Bad input raises a ValueError that names the argument."""

import math

import pytest

from sim.controls import FixedShape, PeriodicGait
from sim.events import Deformation
from sim.obstacles import Circle, Polygon, obstacle_from_dict, rectangle
from sim.rollout import RolloutConfig, rollout
from sim.world import Bounds


@pytest.mark.parametrize(
    ("call", "name"),
    [
        (lambda: FixedShape.of([0, 0, 0], [0, 0, 0]), "theta"),
        (lambda: FixedShape.of([0, 0, 0, math.nan], [0, 0, 0]), "theta"),
        (lambda: FixedShape.of([0, 0, 0, 2.0], [0, 0, 0]), "theta"),
        (lambda: FixedShape.of([0, 0, 0, 0], [0, 0, 2.0]), "joints"),
        (lambda: FixedShape.of([0, 0, 0, 0], [[0, 0, 0]] * 2), "joints"),
        (lambda: FixedShape.of("abc", [0, 0, 0]), "theta"),
        (lambda: PeriodicGait.of([0, 0, 0, 0], [0, math.inf, 0]), "phases"),
        (lambda: RolloutConfig(duration=-1), "duration"),
        (lambda: RolloutConfig(dt=math.nan), "dt"),
        (lambda: RolloutConfig(joint_mode="fast"), "joint_mode"),  # type: ignore[arg-type]
        (lambda: rollout(FixedShape.of([0, 0, 0, 0], [0, 0, 0]), start=(0, 0)), "start"),
        (lambda: Circle(0, 0, -1), "radius"),
        (lambda: Polygon(((0, 0), (1, 1), (2, 2))), "area"),
        (lambda: rectangle(0, 0, 0, 1), "width"),
        (lambda: Bounds(1, 0, 0, 1), "bounds"),
        (lambda: Deformation(1, (0, 0, 3)), "joints"),
        (lambda: obstacle_from_dict({"type": "star"}), "type"),
        (lambda: obstacle_from_dict({"type": "circle", "x": 1}), "y"),
    ],
)
def test_bad_input_names_the_argument(call, name) -> None:
    with pytest.raises(ValueError, match=name):
        call()
