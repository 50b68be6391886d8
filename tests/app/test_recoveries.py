"""Recoveries in the behaviour tree: the printed tree and its snapshots show the recovery node
and every recovery by name; a mission that touches something backs off (a ``recovery`` event,
the node seen running) and still reaches its goal; a body that cannot reach its goal in its
shape changes shape and reaches it; the recovery composites retry, give up and take turns as
Nav2's RecoveryNode and RoundRobin do."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import py_trees
import pytest
from py_trees.behaviours import Failure as Fails
from py_trees.behaviours import Success as Succeeds
from py_trees.common import Status

from app.executor.recoveries import RecoveryNode, RoundRobin
from app.executor.runner import MissionRunner
from app.executor.tree import build_tree
from app.missions.spec import MissionSpec, load_mission
from app.service.frames import parse_frame
from bench.worlds import layout
from domain.navigation import RecoverySettings
from primitives.library import load_bundled

LIB = load_bundled()
EXAMPLES = Path(__file__).parents[2] / "examples"
HARD = Path(__file__).parents[2] / "examples" / "hard"
RECOVERIES = ("back off", "sense and retry", "spin to sense", "reshape", "clear stale evidence")


def nodes(tree: dict[str, Any]) -> list[dict[str, Any]]:
    """A snapshot's nodes, depth first."""
    return [tree, *(n for child in tree["children"] for n in nodes(child))]


def node(tree: dict[str, Any], name: str) -> dict[str, Any]:
    """The snapshot's node of that name (the first, depth first)."""
    return next(n for n in nodes(tree) if n["name"] == name)


def test_the_printed_tree_shows_the_recovery_node_and_every_recovery() -> None:
    spec = MissionSpec.model_validate(
        {"goals": [{"x": 1, "y": 0}], "bounds": {"xmin": -3, "xmax": 3, "ymin": -3, "ymax": 3}}
    )
    root = build_tree(spec, "/mission_printed", RecoverySettings(retries=3))
    text = py_trees.display.unicode_tree(root, show_status=True)
    lines = [line.strip() for line in text.splitlines()]
    assert any(line.endswith("navigate with recovery [-]") for line in lines)
    for name in ("follow plan", "recover", *RECOVERIES):
        assert any(name in line for line in lines), name
    # the recovery node runs the plan first and the recoveries second, in that order
    recovery = next(n for n in root.iterate() if isinstance(n, RecoveryNode))
    assert [c.name for c in recovery.children] == ["follow plan", "recover"]
    assert recovery.retries == 3
    order = [
        next(i for i, line in enumerate(lines) if line.startswith(f"{mark} {name} "))
        for mark, name in (("[-]", "follow plan"), ("[o]", "recover"), ("-->", "back off"))
    ]
    assert order == sorted(order)


def test_a_mission_that_touches_something_backs_off_and_still_reaches_its_goal() -> None:
    """A field of hidden posts (a tuning seed of the generated worlds) seen by noisy range
    sensors (σ 0.05 m): the body touches a post on the way."""
    mission = layout("posts", 1)
    mission["sensors"] = {**mission.get("sensors", {}), "noise": 0.05}
    spec = MissionSpec.model_validate(mission)
    snapshots: list[dict[str, Any]] = []
    runner = MissionRunner(spec, LIB, on_tick=lambda ctx, snap: snapshots.append(snap))
    result = runner.run()
    assert result.status == "succeeded", result.reason
    assert all(g.reached for g in result.goals)
    kinds = [e["kind"] for e in result.events]
    assert "collision" in kinds and "recovery" in kinds
    touched = kinds.index("collision")
    recovery = result.events[kinds.index("recovery")]
    assert kinds.index("recovery") > touched
    assert recovery["recovery"] == "back off" and recovery["moves"]
    assert "touched something" in recovery["because"]
    done = next(e for e in result.events if e["kind"] == "recovery_done")
    assert done["recovery"] == "back off" and done["outcome"] == "done"
    # While it backs off, the tree shows the recovery node and the back-off running.
    backing = [s for s in snapshots if node(s["tree"], "back off")["status"] == "RUNNING"]
    assert backing
    during = node(backing[0]["tree"], "navigate with recovery")
    assert during["type"] == "RecoveryNode" and during["status"] == "RUNNING"
    assert during["feedback"].startswith("recovering (1 of at most")
    assert backing[0]["action"].startswith("(back-off ")
    # the goal was reached after the back-off
    reached = next(e for e in result.events if e["kind"] == "goal_reached")
    assert reached["t"] > done["t"]
    # and every event is a frame of the websocket's protocol, recoveries included (a replan's
    # frame gets its old and new plans from the worker)
    frames = [
        parse_frame(
            {"type": "event", **e} | ({"old": [], "new": []} if e["kind"] == "replan" else {})
        )
        for e in result.events
    ]
    assert {"recovery", "recovery_done"} <= {getattr(f, "kind", None) for f in frames}


def test_a_back_off_a_contact_stopped_begins_with_another_move_from_there() -> None:
    """A tail touches a post it never saw, in a corridor, and the first back-off's first move
    presses into the post again (the world model does not hold it where it is): the next
    back-off from there begins with another move, and the mission goes on to its goal."""
    spec = load_mission(EXAMPLES / "untuned" / "corridor-20-028-noisy-clutter.json")
    result = MissionRunner(spec, LIB).run()
    assert result.status == "succeeded", result.reason
    events = result.events
    backs = [i for i, e in enumerate(events) if e["kind"] == "recovery"]
    stopped = [
        i
        for i in backs
        if any(
            e["kind"] == "recovery_done" and e["outcome"] == "stopped by a contact"
            for e in events[i + 1 : i + 3]
        )
    ]
    assert stopped, "the scene no longer has a back-off a contact stopped"
    for i in stopped:
        later = next(j for j in backs if j > i)
        assert events[later]["moves"][0] != events[i]["moves"][0]


def pocket_mission() -> tuple[MissionRunner, Any]:
    spec = load_mission(HARD / "reshape-into-pocket.json")
    assert spec.shape == "zigzag"
    runner = MissionRunner(spec, LIB)
    return runner, runner.run()


def test_a_body_that_cannot_enter_a_pocket_in_its_shape_reshapes_and_reaches_the_goal() -> None:
    runner, result = pocket_mission()
    assert result.status == "succeeded", result.reason
    assert all(g.error is not None and g.error <= g.tolerance for g in result.goals)
    kinds = [e["kind"] for e in result.events]
    recovery = result.events[kinds.index("recovery")]
    assert recovery["recovery"] == "reshape" and recovery["moves"] == ["into straight"]
    assert recovery["because"].startswith("unreachable")
    assert result.events[kinds.index("shape_change")]["shape"] == "straight"
    assert runner.ctx.shape == "straight"
    # the first plan (zigzag) found it out of reach; the one after the change reaches it
    assert [(r.trigger, r.status) for r in result.replans][:1] == [("recovered", "solved")]


def test_a_commanded_shape_change_is_not_reported_as_a_deformation() -> None:
    runner, result = pocket_mission()
    assert result.status == "succeeded"
    assert not [e for e in result.events if e["kind"] == "deform"]
    change = next(e for e in result.events if e["kind"] == "shape_change")
    assert (change["previous"], change["shape"]) == ("zigzag", "straight")
    assert not runner.ctx.deformed


# -- the composites -----------------------------------------------------------------------------


HERE = (0.0, 0.0)


def still() -> tuple[float, float]:
    return HERE


def tick(root: py_trees.behaviour.Behaviour, times: int = 1) -> Status:
    for _ in range(times):
        root.tick_once()
    return root.status


def test_the_recovery_node_recovers_then_follows_again() -> None:
    """The plan fails; a recovery succeeds; the plan runs again on the next tick."""
    pipeline = py_trees.behaviours.StatusQueue(
        "follow", [Status.FAILURE, Status.RUNNING, Status.RUNNING], eventually=Status.SUCCESS
    )
    root = RecoveryNode("with recovery", pipeline, Succeeds("recover"), 2, 0.3, still)
    assert tick(root) == Status.RUNNING and "recovered" in root.feedback_message
    assert tick(root) == Status.RUNNING and root.feedback_message.startswith("following")
    assert tick(root, 2) == Status.SUCCESS


def test_the_recovery_node_gives_up_after_its_retries() -> None:
    root = RecoveryNode("with recovery", Fails("follow"), Succeeds("recover"), 3, 0.3, still)
    statuses = [tick(root) for _ in range(4)]
    assert statuses == [Status.RUNNING] * 3 + [Status.FAILURE]
    assert root.feedback_message == "gave up after 3 recoveries in a row"


def test_recoveries_count_afresh_once_the_robot_got_somewhere() -> None:
    """Following the plan between recoveries, the robot gets ``settle_distance`` from where the
    last recovery left it each time: progress, so it never gives up; the same plan failing
    where it stands (backing off and driving into the same contact again) gives up."""
    pattern = [Status.FAILURE, Status.RUNNING, Status.RUNNING] * 6
    at = [0.0]

    def moving() -> tuple[float, float]:
        at[0] += 0.2  # every look: a little farther along
        return (at[0], 0.0)

    pipeline = py_trees.behaviours.StatusQueue("follow", pattern, eventually=Status.RUNNING)
    root = RecoveryNode("with recovery", pipeline, Succeeds("recover"), 2, 0.3, moving)
    assert all(tick(root) == Status.RUNNING for _ in range(len(pattern)))
    pipeline = py_trees.behaviours.StatusQueue("follow", pattern, eventually=Status.RUNNING)
    root = RecoveryNode("with recovery", pipeline, Succeeds("recover"), 2, 0.3, still)
    seen = [(tick(root), root.feedback_message) for _ in range(len(pattern))]
    assert seen[6] == (Status.FAILURE, "gave up after 2 recoveries in a row")  # the third failure


def test_the_recovery_node_fails_when_no_recovery_applies() -> None:
    root = RecoveryNode("with recovery", Fails("follow"), Fails("recover"), 3, 0.3, still)
    assert tick(root) == Status.FAILURE and root.feedback_message == "no recovery applies"


@pytest.mark.parametrize("ran", [0, 1])
def test_round_robin_starts_after_the_child_that_ran_last(ran: int) -> None:
    children = [Succeeds("spin"), Succeeds("reshape"), Succeeds("clear")]
    robin = RoundRobin("sense and retry", children)
    for _ in range(ran + 1):
        tick(robin)
    assert robin.status == Status.SUCCESS
    assert robin.feedback_message == f"{children[ran].name} done"
    assert robin.next == (ran + 1) % 3


def test_round_robin_hands_on_past_failing_children_and_fails_when_all_did() -> None:
    robin = RoundRobin("sense and retry", [Fails("spin"), Succeeds("reshape"), Fails("clear")])
    assert tick(robin) == Status.SUCCESS and robin.feedback_message == "reshape done"
    nothing = RoundRobin("sense and retry", [Fails("spin"), Fails("reshape"), Fails("clear")])
    assert tick(nothing) == Status.FAILURE and nothing.feedback_message == "none applies"


def snapshots_of(spec: MissionSpec) -> tuple[list[dict[str, Any]], Any]:
    snapshots: list[dict[str, Any]] = []
    runner = MissionRunner(spec, LIB, on_tick=lambda ctx, snap: snapshots.append(snap["tree"]))
    return snapshots, runner.run()


@pytest.mark.parametrize("which", ["posts-with-contact", "pocket", "chain"])
def test_the_light_composites_tick_as_py_trees_own(which: str, monkeypatch) -> None:
    """The tree's Sequence and Selector (py_trees' own, without debug messages, yielding only
    their own node) give, tick for tick, the statuses, feedback and outcome py_trees'
    composites give: through a contact and its back-off, a reshape, and a chain of
    primitives."""
    if which == "posts-with-contact":
        mission = layout("posts", 1)
        mission["sensors"] = {**mission.get("sensors", {}), "noise": 0.05}
        spec = MissionSpec.model_validate(mission)
    elif which == "pocket":
        spec = load_mission(HARD / "reshape-into-pocket.json")
    else:
        spec = load_mission(HARD.parent / "fig9b-chain.json")
    light, light_result = snapshots_of(spec)
    import app.executor.recoveries as recoveries
    import app.executor.tree as tree

    monkeypatch.setattr(tree, "Sequence", py_trees.composites.Sequence)
    monkeypatch.setattr(tree, "Selector", py_trees.composites.Selector)
    monkeypatch.setattr(recoveries, "Selector", py_trees.composites.Selector)
    own, own_result = snapshots_of(spec)
    assert len(light) == len(own) > 10
    assert light == own
    assert (light_result.status, light_result.reason) == (own_result.status, own_result.reason)
    assert light_result.model_time == own_result.model_time
    kinds = [e["kind"] for e in light_result.events]
    if which == "posts-with-contact":
        assert "recovery" in kinds
