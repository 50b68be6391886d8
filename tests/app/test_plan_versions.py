"""A mission's plan versions write their PDDL problem when read, the same text as at once, and
superseded versions keep only what writing it needs."""

from pathlib import Path
from typing import Any

import pytest

from app.executor.context import MissionContext
from app.executor.plan_versions import PlanVersion
from app.executor.runner import MissionRunner
from app.missions.spec import load_mission
from primitives.library import load_bundled

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
MISSION = EXAMPLES / "hard" / "dropout-ir-hidden-wall.json"  # lattice plans, a dozen replans


def run(kept: int, at_once: bool = False) -> list[PlanVersion]:
    def read_each(ctx: MissionContext, _: dict[str, Any]) -> None:
        for version in ctx.pddl:  # as the service does: every version read as it is made
            assert "(:goal" in version.problem

    hook = read_each if at_once else None
    runner = MissionRunner(load_mission(MISSION), load_bundled(), on_tick=hook, searches_kept=kept)
    result = runner.run()
    assert result.status == "succeeded", result.reason
    return result.pddl


def test_problems_written_late_equal_those_written_at_once() -> None:
    late = run(kept=1)
    assert len(late) >= 5  # the first plan and replans after sensing the hidden wall
    assert not any(v.written for v in late)  # nobody read them: none written yet
    assert all(v.released for v in late[:-1]) and not late[-1].released
    at_once = run(kept=1, at_once=True)
    assert all(v.written for v in at_once)
    # Neither later replans nor releasing the searches change what a version's problem lists.
    assert [v.to_dict() for v in late] == [v.to_dict() for v in at_once]
    assert all("(succ " in v["problem"] for v in late)


def test_all_but_the_newest_kept_versions_release_their_searches() -> None:
    versions = run(kept=3)
    assert [v.released for v in versions] == [True] * (len(versions) - 3) + [False] * 3


def test_a_bound_below_one_is_refused_naming_it() -> None:
    with pytest.raises(ValueError, match="searches_kept"):
        MissionRunner(load_mission(MISSION), load_bundled(), searches_kept=0)
