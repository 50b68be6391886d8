"""The plan guard reports the first of the next moves whose swept footprint the world model now
blocks, as checking the moves one by one would."""

from __future__ import annotations

import numpy as np
import pytest

from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec
from domain.navigation_strategy import LOOKAHEAD
from domain.triggers import PathBlocked
from primitives.library import load_bundled

LIB = load_bundled()


def first_blocked_one_by_one(strategy, table) -> tuple[str, tuple[float, float]] | None:
    """The reference: each move of the lookahead checked alone, in plan order."""
    plan = strategy.plan
    first = strategy.index + (1 if strategy.running is not None else 0)
    for n, action in enumerate(plan.actions[first : first + LOOKAHEAD], start=first):
        if action.name != "move" or action.source is None or action.motion is None or n == 0:
            continue
        i, j, k = action.source
        centre = strategy.planner.grid.centre(i, j)
        seg = table.segments[k]
        lo = int(seg[action.motion])
        hi = int(seg[action.motion + 1]) if action.motion + 1 < len(seg) else len(table.points[k])
        need = table.needs[k][lo:hi] + strategy.settings.margin
        if not np.all(strategy.clearance(centre + table.points[k][lo:hi]) >= need):
            return action.pddl, (round(float(centre[0]), 3), round(float(centre[1]), 3))
    return None


@pytest.mark.parametrize("pick", [1, 2, 4, 6])
def test_the_first_blocked_move_is_reported(pick: int) -> None:
    spec = MissionSpec.model_validate(
        {"goals": [{"x": 3, "y": 0}], "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5}}
    )
    runner = MissionRunner(spec, LIB)
    while not runner.ctx.have_plan:
        assert not runner.step()
    ctx = runner.ctx
    strategy = ctx.strategy
    plan, table = strategy.plan, strategy.table
    situation = ctx.situation()
    assert strategy.broken(situation) is None  # nothing in the way: the guard is quiet
    moves = [a for a in plan.actions[strategy.index + 1 :] if a.name == "move"]
    assert len(moves) > pick
    x, y, _ = moves[pick].target  # a contact where a later move ends
    ctx.world.add_contact((x, y))
    want = first_blocked_one_by_one(strategy, table)
    got = strategy.broken(situation)
    assert want is not None and isinstance(got, PathBlocked)
    assert (got.action, got.at) == want
    assert strategy.broken(situation) is None  # checked once per model version
