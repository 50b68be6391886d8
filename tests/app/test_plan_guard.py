"""The plan guard reports the first of the next moves whose swept footprint the lethal layer now
blocks, as checking the moves one by one would; soft evidence (a contact) never breaks a plan."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec
from domain.navigation import NavigationStrategy
from domain.navigation.guard import Lookahead
from domain.triggers import PathBlocked
from primitives.library import load_bundled
from tests.domain.lattice_scenes import sense_post

LIB = load_bundled()


def first_blocked_one_by_one(
    strategy: NavigationStrategy, world, first: int | None = None
) -> tuple[str, tuple] | None:
    """The reference: each move of the lookahead checked alone, in plan order (from the
    strategy's next step unless ``first`` is given)."""
    plan, table = strategy.plan, strategy.table
    assert plan is not None and table is not None
    if first is None:
        first = strategy.index + (1 if strategy.running is not None else 0)
    lookahead = strategy.settings.follow.lookahead
    for n, action in enumerate(plan.actions[first : first + lookahead], start=first):
        if action.name != "move" or action.source is None or action.motion is None or n == 0:
            continue
        i, j, k = action.source
        centre = strategy.planner.grid.centre(i, j)
        seg = table.segments[k]
        lo = int(seg[action.motion])
        hi = int(seg[action.motion + 1]) if action.motion + 1 < len(seg) else len(table.points[k])
        need = table.needs[k][lo:hi] + strategy.settings.margin
        if not np.all(world.clearance_at(centre + table.points[k][lo:hi]) >= need):
            return action.pddl, (round(float(centre[0]), 3), round(float(centre[1]), 3))
    return None


def planned_runner() -> MissionRunner:
    spec = MissionSpec.model_validate(
        {"goals": [{"x": 3, "y": 0}], "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5}}
    )
    runner = MissionRunner(spec, LIB)
    while not runner.ctx.have_plan:
        assert not runner.step()
    return runner


@pytest.mark.parametrize("pick", [1, 2, 4, 6])
def test_the_first_blocked_move_is_reported(pick: int) -> None:
    runner = planned_runner()
    ctx = runner.ctx
    strategy = ctx.strategy
    assert isinstance(strategy, NavigationStrategy) and strategy.plan is not None
    situation = ctx.situation()
    assert strategy.broken(situation) is None  # nothing in the way: the guard is quiet
    moves = [a for a in strategy.plan.actions[strategy.index + 1 :] if a.name == "move"]
    assert len(moves) > pick
    # Something sensed where the body's far end lies after a later move (not under the body
    # now: the cells it lies over are known free).
    x, y, psi = moves[pick].target
    ex, ey = x + 0.95 * math.cos(psi), y + 0.95 * math.sin(psi)
    sense_post(ctx.world, ex, ey, -math.pi / 2)  # echoes from the north until it is sensed
    want = first_blocked_one_by_one(strategy, ctx.world)
    got = strategy.broken(ctx.situation())
    assert want is not None and isinstance(got, PathBlocked)
    assert (got.action, got.at) == want
    assert strategy.broken(ctx.situation()) is None  # checked once per model version


def test_the_guard_answers_from_every_step_of_the_plan_as_one_by_one() -> None:
    runner = planned_runner()
    ctx = runner.ctx
    strategy = ctx.strategy
    assert isinstance(strategy, NavigationStrategy) and strategy.plan is not None
    plan, table = strategy.plan, strategy.table
    assert table is not None
    moves = [a for a in plan.actions if a.name == "move"]
    for move in (moves[3], moves[len(moves) // 2]):  # two posts the plan runs into
        x, y, psi = move.target
        sense_post(ctx.world, x + 0.95 * math.cos(psi), y + 0.95 * math.sin(psi), -math.pi / 2)
    guard = Lookahead(strategy.settings.follow.lookahead)
    steps = len(plan.actions)
    order = list(range(steps + 2)) + list(np.random.default_rng(0).permutation(steps))
    answers = set()
    # forwards past the end, then anywhere: one gathering serves all; then again with the
    # layer's version, so that a check skips what the last one at that version found clear
    for first, version in [(f, None) for f in order] + [(f, ctx.world.version) for f in order]:
        got = guard.first_blocked(
            plan,
            table,
            int(first),
            strategy.planner.grid,
            strategy.settings.margin,
            ctx.world.clearance_at,
            version,
        )
        answer = None
        if got is not None:
            action, (cx, cy) = got
            answer = (action.pddl, (round(cx, 3), round(cy, 3)))
        assert answer == first_blocked_one_by_one(strategy, ctx.world, int(first))
        answers.add(answer)
    assert None in answers and len(answers) >= 3  # both posts block some lookahead, and none


def test_contact_evidence_on_the_path_never_breaks_the_plan() -> None:
    runner = planned_runner()
    ctx = runner.ctx
    strategy = ctx.strategy
    assert isinstance(strategy, NavigationStrategy) and strategy.plan is not None
    moves = [a for a in strategy.plan.actions if a.name == "move"]
    version = ctx.world.version
    for _ in range(5):  # a body lying across the plan, touched on its side again and again
        x, y, _ = moves[3].target
        ctx.world.add_contact((x, y - 0.3, math.pi / 2), (0.0, 0.0, 0.0), 2, "left", ctx.t)
    assert ctx.world.evidence().any() and ctx.world.version == version
    assert strategy.broken(ctx.situation()) is None
    assert first_blocked_one_by_one(strategy, ctx.world) is None
