"""Open-loop simulation of one parameter set."""

from __future__ import annotations

import math

from fastapi import APIRouter
from starlette.concurrency import run_in_threadpool

from app.api.errors import responses
from app.api.schemas import SimulateIn, SimulateOut
from sim.controls import Control, FixedShape, PeriodicGait
from sim.rollout import RolloutConfig, rollout

router = APIRouter(tags=["simulate"])


def simulate_now(body: SimulateIn) -> SimulateOut:
    control: Control
    if body.phases is not None:
        control = PeriodicGait.of(body.theta, body.phases)
    else:
        control = FixedShape.of(body.theta, body.joints or [0.0, 0.0, 0.0])
    config = RolloutConfig(body.duration, body.dt, body.joint_mode)
    result = rollout(control, (body.start.x, body.start.y, body.start.psi), config)
    states = result.states[0]
    # every stride-th step plus the last: never more than max_points rows
    stride = max(1, math.ceil((len(states) - 1) / (body.max_points - 1)))
    idx = list(range(0, len(states), stride))
    if idx[-1] != len(states) - 1:
        idx.append(len(states) - 1)
    points = [
        [round(float(result.times[i]), 4), *(round(float(v), 6) for v in states[i])] for i in idx
    ]
    end = states[-1]
    return SimulateOut(
        points=points,
        stride=stride,
        steps=len(states) - 1,
        end={"x": float(end[0]), "y": float(end[1]), "psi": float(end[2])},
    )


@router.post("/simulate", response_model=SimulateOut, responses=responses(422))
async def simulate(body: SimulateIn) -> SimulateOut:
    """Parameters -> trajectory rows ``[t, x, y, psi, p1, p2, p3]``, thinned to at most
    ``max_points`` rows (every ``stride``-th step, the last always included)."""
    return await run_in_threadpool(simulate_now, body)
