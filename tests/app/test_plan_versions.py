"""A mission's plan versions write their PDDL problem when read, the same text as at once."""

from pathlib import Path

import pytest

from app.executor.runner import MissionRunner
from app.missions.spec import load_mission
from primitives.library import load_bundled

MISSION = Path(__file__).resolve().parents[2] / "examples" / "fig10-two-obstacles.json"


def run(kept: int) -> list:
    runner = MissionRunner(load_mission(MISSION), load_bundled(), unwritten_kept=kept)
    result = runner.run()
    assert result.status == "succeeded", result.reason
    return result.pddl


def test_problems_written_late_equal_those_written_at_once() -> None:
    late = run(kept=100)
    assert len(late) >= 3  # the first plan and replans after sensing the obstacles
    assert not any(v.written for v in late)  # nobody read them: none written yet
    at_once = run(kept=0)
    assert all(v.written for v in at_once)
    # Later replans do not change the graph an earlier version's problem lists.
    assert [v.to_dict() for v in late] == [v.to_dict() for v in at_once]
    assert all("(:goal" in v["problem"] for v in late)


def test_at_most_kept_versions_stay_unwritten() -> None:
    versions = run(kept=1)
    unwritten = [v.version for v in versions if not v.written]
    assert unwritten == [versions[-1].version]  # the newest alone keeps its search graph


def test_a_negative_bound_is_refused_naming_it() -> None:
    with pytest.raises(ValueError, match="unwritten_kept"):
        MissionRunner(load_mission(MISSION), load_bundled(), unwritten_kept=-1)
