"""Open-loop simulation of one parameter set."""

from __future__ import annotations

import math

from fastapi import APIRouter, Response

from app.api.deps import Svc
from app.api.errors import responses
from app.api.schemas import SimulateIn, SimulateOut
from app.api.validated import ValidatedRoute
from sim.controls import Control, FixedShape, PeriodicGait
from sim.rollout import RolloutConfig, rollout

router = APIRouter(tags=["simulate"], route_class=ValidatedRoute)  # bodies off the loop


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


def simulate_json(body: SimulateIn) -> bytes:
    """In a validation process: the rollout and its answer as JSON bytes (100,000 rows are
    6 MB of JSON: built there, the server's event loop only sends them)."""
    return simulate_now(body).model_dump_json().encode()


@router.post("/simulate", response_model=SimulateOut, responses=responses(422, 503))
async def simulate(body: SimulateIn, svc: Svc) -> Response:
    """Parameters -> trajectory rows ``[t, x, y, psi, p1, p2, p3]``, thinned to at most
    ``max_points`` rows (every ``stride``-th step, the last always included). The rollout runs
    in a validation process, off the event loop (a long one took the server's GIL for 300 ms)."""
    answer = await svc.validation.run(simulate_json, body)
    return Response(answer, media_type="application/json")
