"""The paper's reactive domain (Table 3): ongoal, obstacle(direction), operators PO1-PO3.

STRIPS without negation: obstacle(d) = F is written (free d), ongoal = F is (offgoal).
PO1 moves towards the goal, PO2 at +90° to it and PO3 at −90°, each in the current shape.
"""

from __future__ import annotations

from dataclasses import dataclass

from domain.pddl import Action, Domain, Problem
from domain.pyperplan_adapter import PlanResult, plan_pddl, validate_plan

DIRECTIONS = {"togoal": 0.0, "togoal_p90": 90.0, "togoal_m90": -90.0}
OPERATORS = {"po1": "togoal", "po2": "togoal_p90", "po3": "togoal_m90"}


def reactive_domain() -> Domain:
    def avoid(name: str, side: str) -> Action:
        return Action(
            name,
            [("?s", "shape")],
            [f"(free {side})", "(blocked togoal)", "(body ?s)"],
            ["(free togoal)"],
            ["(blocked togoal)"],
        )

    return Domain(
        "screwsnake-reactive",
        ["direction", "shape"],
        [
            "(ongoal)",
            "(offgoal)",
            "(free ?d - direction)",
            "(blocked ?d - direction)",
            "(body ?s - shape)",
        ],
        [
            Action(
                "po1",
                [("?s", "shape")],
                ["(free togoal)", "(offgoal)", "(body ?s)"],
                ["(ongoal)"],
                ["(offgoal)"],
            ),
            avoid("po2", "togoal_p90"),
            avoid("po3", "togoal_m90"),
        ],
        comment="Paper Table 3: move(angletoGoal + {0, +90, -90} deg, shape).",
        constants={"direction": list(DIRECTIONS)},
    )


@dataclass(frozen=True)
class ReactiveState:
    """The paper's state vector {ongoal, obstacle(togoal), obstacle(+90°), obstacle(−90°)}."""

    ongoal: bool = False
    obstacle_togoal: bool = False
    obstacle_p90: bool = False
    obstacle_m90: bool = False


def reactive_problem(state: ReactiveState, shape: str, shapes: tuple[str, ...] = ()) -> Problem:
    flags = {
        "togoal": state.obstacle_togoal,
        "togoal_p90": state.obstacle_p90,
        "togoal_m90": state.obstacle_m90,
    }
    init = ["(ongoal)" if state.ongoal else "(offgoal)", f"(body {shape})"]
    init += [f"({'blocked' if blocked else 'free'} {d})" for d, blocked in flags.items()]
    return Problem(
        "reactive",
        "screwsnake-reactive",
        {"shape": sorted({shape, *shapes})},
        init,
        ["(ongoal)"],
        comment=f"S_ini = {{{', '.join('T' if v else 'F' for v in (state.ongoal, *flags.values()))}}}",
    )


@dataclass(frozen=True)
class ReactiveStep:
    """One planned move(angle, shape): the operator, its angle relative to the goal direction."""

    operator: str
    relative_angle: float
    shape: str


def plan_reactive(
    state: ReactiveState,
    shape: str,
    search: str = "gbf",
    heuristic: str = "hff",
    time_limit: float = 2.0,
) -> tuple[PlanResult, list[ReactiveStep]]:
    domain, problem = reactive_domain().text(), reactive_problem(state, shape).text()
    task, result = plan_pddl(domain, problem, search, heuristic, time_limit)
    if result.solved:
        ok, why = validate_plan(task, result.plan)
        assert ok, why
    steps = []
    for name in result.plan:
        op, arg = name.strip("()").split()
        steps.append(ReactiveStep(op.upper(), DIRECTIONS[OPERATORS[op]], arg))
    return result, steps
