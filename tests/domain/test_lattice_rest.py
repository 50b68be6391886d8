"""The resting-body check of a plan's last state (``domain/lattice_rest.py``): it agrees with
what every motion checks at its start, and a partial plan never ends where the body cannot
rest."""

from __future__ import annotations

import numpy as np
import pytest
from pyperplan.task import Operator

from domain.leg_search import resting_end
from tests.domain.test_lattice_entry import scene, task_of


@pytest.mark.parametrize("seed", range(4))
def test_a_state_the_body_cannot_rest_at_starts_no_motion(seed: int) -> None:
    world, goal = scene(seed)
    task = task_of(world, goal, 0)
    grid = task.grid
    rng = np.random.default_rng(seed)
    numbers = rng.integers(0, grid.size, 3000)
    numbers = numbers[numbers != task.start_number]
    rests = task.resting(numbers)
    assert rests.any() and not rests.all()  # the scene has both kinds near its obstacles
    for number, rest in zip(numbers.tolist(), rests.tolist(), strict=True):
        free = task.free_mask(grid.decode(number))
        if not rest:  # every motion sweeps the resting body first
            assert not free.any(), number


def test_a_partial_plan_loses_a_last_move_onto_a_pose_it_cannot_rest_at() -> None:
    world, goal = scene(0)
    task = task_of(world, goal, 0)
    numbers = np.arange(task.grid.size, dtype=np.int64)
    rests = task.resting(numbers)
    ok, blocked = int(numbers[rests][0]), int(numbers[~rests][0])
    start = task.fact(task.start_number)
    plan = [
        Operator(f"(move s{task.start_number} s{ok} p1)", [start], [task.fact(ok)], [start]),
        Operator(f"(move s{ok} s{blocked} p2)", [task.fact(ok)], [task.fact(blocked)], []),
    ]
    assert resting_end(plan, task) == plan[:1]
    assert resting_end(plan[:1], task) == plan[:1]
    assert resting_end([], task) == []
