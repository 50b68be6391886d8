"""A worker's warm-up: a real short mission (sensing, a replan, a deformation), and never a
reason for a worker to stop."""

import logging

import pytest

from app.executor import warm
from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec
from primitives.library import load_bundled


def test_the_warm_up_mission_senses_replans_and_arrives() -> None:
    result = MissionRunner(MissionSpec.model_validate(warm.WARM_UP), load_bundled()).run()
    assert result.status == "succeeded", result.reason
    assert any(r.trigger != "initial" for r in result.replans)  # the hidden post was sensed
    assert any(e["kind"] == "deform" for e in result.events)


def test_a_failing_warm_up_is_logged_not_raised(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setitem(warm.WARM_UP, "goals", [{"x": 99.0, "y": 0.0}])  # outside the arena
    with caplog.at_level(logging.ERROR, logger=warm.__name__):
        seconds = warm.warm_up(load_bundled())
    assert seconds >= 0.0
    assert "warm-up mission failed" in caplog.text
