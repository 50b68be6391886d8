"""Missions in the periodic gait: planned on its lattice primitives, driven as the gait."""

import math

import numpy as np
from pytest import approx

from app.executor.runner import run_mission
from app.missions.spec import MissionSpec
from primitives.grounding import TICK
from primitives.library import load_bundled
from primitives.shapes import SHAPES
from sim.controls import GAIT_AMPLITUDE, GAIT_OMEGA

LIB = load_bundled()
POST = (-1.3, 0.0, 0.25)  # hidden: on the way to the first goal


def test_a_periodic_mission_reaches_two_goals_past_a_hidden_obstacle() -> None:
    spec = MissionSpec.model_validate(
        {
            "shape": "periodic",
            "goals": [{"x": -2.5, "y": 0.0}, {"x": -2.5, "y": 2.0}],
            "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5},
            "obstacles": [
                {"type": "circle", "x": POST[0], "y": POST[1], "radius": POST[2], "known": False}
            ],
            "seed": 3,
        }
    )
    result = run_mission(spec, LIB)
    assert result.status == "succeeded", result.reason
    assert result.collisions == 0
    assert all(g.reached and g.error is not None and g.error <= 0.10 for g in result.goals)
    # the post was found on the way and planned round
    assert any(r.trigger == "path_blocked" for r in result.replans)
    rows = np.array(result.trajectory)
    assert min(math.hypot(x - POST[0], y - POST[1]) for x, y in rows[:, 1:3]) > POST[2]
    # every plan moves by the gait's lattice primitives
    gait = {e.id for e in LIB.lattice("periodic")}
    moves = [a for v in result.pddl for a in v.plan if a.startswith("(move")]
    assert moves and all(a.strip("()").split()[-1] in gait for a in moves)
    # the body's joints follow the gait: they bend through its whole amplitude, never faster
    # than the gait itself (no jump at a motion's boundary, nor where a replan cut one short)
    joints = rows[:, 4:7]
    assert np.max(np.abs(joints)) > 0.9 * GAIT_AMPLITUDE
    steps = np.max(np.abs(np.diff(joints, axis=0)), axis=1)
    dt = np.diff(rows[:, 0])
    assert np.all(dt >= TICK - 1e-9)
    assert np.all(steps <= GAIT_AMPLITUDE * GAIT_OMEGA * dt + 1e-9)
    assert joints[0] == approx(SHAPES["periodic"].joints)
