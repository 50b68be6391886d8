"""Shapes the library lacks, learned in the mission (app/executor/learning.py): a deformation or
a start shape without a lattice shape within the tolerance is learned, then planned on; cancel and
the wall budget stop learning; the worker reports the ``learning`` status, progress and the
learned entries."""

from __future__ import annotations

import queue
import threading
import time
from typing import Any

import pytest

from app.executor.learning import LearningSettings
from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec
from app.missions.status import MissionStatus
from app.service.frames import LearnedEvent, StateFrame, parse_frame
from app.service.messages import Job, Learned, PlanMade, Publish, Transition, frames_of
from app.service.worker import run_mission
from primitives.library import load_bundled

LIB = load_bundled()
DEFORMED = [0.9, -0.3, 0.6]  # 0.4 rad from every library shape, no blend within 0.05 rad
LEARNED = "body-p090-m030-p060"


def mission(**fields: Any) -> MissionSpec:
    """A goal past a hidden post (the robot must sense it and go round)."""
    return MissionSpec.model_validate(
        {
            "name": "learn",
            "goals": [{"x": -2.5, "y": 1.0}],
            "bounds": {"xmin": -4, "xmax": 4, "ymin": -4, "ymax": 4},
            "obstacles": [{"type": "circle", "x": -1.3, "y": 0.5, "radius": 0.3, "known": False}],
            "seed": 1,
            **fields,
        }
    )


def kinds(events: list[dict[str, Any]]) -> list[str]:
    return [e["kind"] for e in events]


def test_a_deformed_body_learns_its_shape_reaches_the_goal_and_a_later_mission_learns_nothing() -> (
    None
):
    deform = [{"t": 20, "type": "deform", "joints": DEFORMED}]
    runner = MissionRunner(mission(events=deform), LIB)
    result = runner.run()
    assert result.status == "succeeded", result.reason
    assert any(e["kind"] == "obstacle_sensed" for e in result.events)
    learned = [e for e in result.events if e["kind"] == "learned"]
    assert len(learned) == 1 and learned[0]["shape"] == LEARNED and learned[0]["t"] == 20.0
    assert learned[0]["primitives"] + len(learned[0]["failed"]) == 22
    assert learned[0]["library"] == runner.ctx.library.version[:12] != LIB.version[:12]
    # deform, learned, then the replan on the new lattice; every move after it is learned
    after = kinds([e for e in result.events if e["t"] >= 20])
    assert after.index("deform") < after.index("learned") < after.index("replan")
    moved = [e for e in result.executed if e["from"] > 20 and e["primitives"]]
    assert moved and all(p.startswith(f"lat-{LEARNED}-") for e in moved for p in e["primitives"])
    # each learned entry lands within the library build's bar (3 mm + 1 m/rad)
    assert all(e.cost < 0.003 for e in runner.ctx.library.lattice(LEARNED))
    # a mission starting in that shape on the grown library learns nothing and succeeds
    again = MissionRunner(mission(shape={"joints": DEFORMED}), runner.ctx.library).run()
    assert again.status == "succeeded" and "learned" not in kinds(again.events)
    # the same mission where the shape was learned already (another worker, the store) ends
    # identically: learning takes no model time and gives the same entries
    known = MissionRunner(mission(events=deform), runner.ctx.library).run()
    assert "learned" not in kinds(known.events)
    assert known.trajectory == result.trajectory and known.model_time == result.model_time


def test_a_start_shape_without_a_lattice_is_learned_before_the_first_plan() -> None:
    runner = MissionRunner(mission(shape={"joints": [-0.8, 0.4, -0.7]}), LIB)
    assert runner.ctx.shape == "body-m080-p040-m070" and runner.ctx.plan_version == 0
    assert not runner.step()  # learned, then planned on it and moved one tick
    assert kinds(runner.ctx.events)[0] == "learned" and runner.ctx.events[0]["t"] == 0.0
    assert runner.ctx.plan_version == 1 and runner.ctx.t == 0.25
    result = runner.run()
    assert result.status == "succeeded", result.reason


def test_a_shape_within_the_tolerance_of_a_library_shape_learns_nothing() -> None:
    near = [0.52, -0.48, 0.53]  # zigzag within 0.05 rad
    runner = MissionRunner(mission(shape={"joints": near}), LIB)
    assert runner.ctx.shape == "zigzag" and runner.ctx.learn is None


def test_cancel_during_learning_ends_the_mission_cancelled_within_a_second() -> None:
    cancel = threading.Event()
    asked: list[float] = []

    def on_learning(ctx: Any) -> None:
        if ctx.learning["done"] >= 2 and not cancel.is_set():
            cancel.set()
            asked.append(time.perf_counter())

    runner = MissionRunner(
        mission(shape={"joints": DEFORMED}), LIB, cancel=cancel, on_learning=on_learning
    )
    assert runner.step()
    assert time.perf_counter() - asked[0] < 1.0
    assert runner.status == "cancelled" and runner.learned == []


def test_past_the_wall_budget_the_mission_fails_naming_the_shape() -> None:
    runner = MissionRunner(
        mission(shape={"joints": DEFORMED}), LIB, learning=LearningSettings(budget=0.001)
    )
    result = runner.run()
    assert result.status == "failed"
    assert result.reason.startswith(f"learning: shape {LEARNED}: not learned within the 0.001 s")


def test_learning_settings_reject_nonsense() -> None:
    with pytest.raises(ValueError, match="budget"):
        LearningSettings(budget=0)
    with pytest.raises(ValueError, match="tolerance"):
        LearningSettings(tolerance=2.0)


def test_the_worker_reports_learning_its_progress_and_the_learned_entries() -> None:
    spec = mission(shape={"joints": DEFORMED}).model_dump(mode="json")
    out: queue.Queue[Any] = queue.Queue()
    run_mission(Job("m-1", spec, 600.0), LIB, 1000.0, out, threading.Event())
    messages = []
    while not out.empty():
        messages.append(out.get())
    statuses = [m.status for m in messages if isinstance(m, Transition)]
    assert statuses[:3] == [MissionStatus.PLANNING, MissionStatus.LEARNING, MissionStatus.EXECUTING]
    progress = [
        m.frame["learning"]
        for m in messages
        if isinstance(m, Publish) and m.frame["type"] == "state" and m.frame["learning"]
    ]
    assert progress and all(p["shape"] == LEARNED for p in progress)
    learned = [m for m in messages if isinstance(m, Learned)]
    assert len(learned) == 1 and learned[0].shape == LEARNED and learned[0].shapes == (LEARNED,)
    first_plan = next(i for i, m in enumerate(messages) if isinstance(m, PlanMade))
    assert messages.index(learned[0]) < first_plan  # learned before it planned
    assert messages[-1].status == MissionStatus.SUCCEEDED
    # every frame is one of the protocol's (the AsyncAPI document is made from them)
    frames = [parse_frame(frame) for m in messages for frame in frames_of(m)]
    assert any(isinstance(f, LearnedEvent) and f.library for f in frames)
    assert any(isinstance(f, StateFrame) and f.learning is not None for f in frames)
