"""Peer-checked PDDL: every exported domain and problem parses in unified-planning, Fast
Downward solves it, and our plans and Fast Downward's validate on the same problem. The lattice
is exported with ``:action-costs``: an optimal Fast Downward finds no plan cheaper than ours is
allowed to be, and none of Fast Downward's plans is cheaper than the optimum; the plain STRIPS
text of the same problem grounds in pyperplan, where Fast Downward's plans are valid too.

The lattice checks run on a coarser lattice (0.1 m cells, 32 orientations) in a 2 m x 2 m arena,
with short legs: unified-planning 1.3 lists every grounding of every predicate and function
when it writes or inspects a problem (aiplan4eu/unified-planning#689), |states|² x |primitives|
for ``succ`` and ``move-cost``, which makes the exports of long searches cost it minutes. The
exporter is the same at every resolution.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from typing import Any

import pytest

pytest.importorskip("unified_planning")
pytest.importorskip("up_fast_downward")

from unified_planning.engines import PlanGenerationResultStatus, ValidationResultStatus
from unified_planning.io import PDDLReader
from unified_planning.model.metrics import MinimizeActionCosts, MinimizeSequentialPlanLength
from unified_planning.shortcuts import OneshotPlanner, PlanValidator, get_environment

from domain.navigation import NavigationSettings, Plan, lattice_domain_text, motion_table
from domain.pyperplan_adapter import parse_and_ground, validate_plan
from domain.reactive import ReactiveState, plan_reactive, reactive_domain, reactive_problem
from domain.world import CostmapSettings
from sim.obstacles import Circle
from sim.world import Bounds
from tests.domain.lattice_scenes import LIB, plan, solved
from tests.domain.test_lattice_pddl import move_costs

get_environment().credits_stream = None  # no engine banners in the test output
# unified-planning cannot tell whether Fast Downward takes a problem with action costs; it does.
pytestmark = pytest.mark.filterwarnings("ignore:We cannot establish whether Fast Downward")


@pytest.fixture(autouse=True)
def own_directory(tmp_path: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    """Fast Downward writes its translation (output.sas) to the working directory: each test
    its own, so tests on parallel workers never read each other's."""
    monkeypatch.chdir(tmp_path)


COARSE = NavigationSettings(
    resolution=0.1, orientations=32, costmap=CostmapSettings(resolution=0.1)
)
ARENA = Bounds(-1.0, 1.0, -1.0, 1.0)
OBSTACLE = Circle(0.0, -0.1, 0.15)
START = (-0.5, 0.6, 0.0)  # the body lies along +x from here, clear of the post
FD_TIME_LIMIT = 120.0
SOLVED = (
    PlanGenerationResultStatus.SOLVED_SATISFICING,
    PlanGenerationResultStatus.SOLVED_OPTIMALLY,
)
UNSOLVABLE = (
    PlanGenerationResultStatus.UNSOLVABLE_PROVEN,
    PlanGenerationResultStatus.UNSOLVABLE_INCOMPLETELY,
)


def read(domain: str, problem: str) -> Any:
    return PDDLReader().parse_problem_string(domain, problem)


def fast_downward(problem: Any, optimal: bool = False) -> Any:
    """lama-first, or A* with LM-cut (``optimal``: minimising the problem's metric, the plan
    length when it has none)."""
    if optimal and not problem.quality_metrics:
        problem = problem.clone()
        problem.add_quality_metric(MinimizeSequentialPlanLength())
    name = "fast-downward-opt" if optimal else "fast-downward"
    with OneshotPlanner(name=name) as planner:
        return planner.solve(problem, timeout=FD_TIME_LIMIT)


def names(up_plan: Any) -> list[str]:
    """A unified-planning plan as our operator names, e.g. ``(move s1 s2 lat-x)``."""
    return [
        f"({' '.join([a.action.name, *(str(p) for p in a.actual_parameters)])})"
        for a in up_plan.actions
    ]


def up_valid(problem: Any, plan: Sequence[str]) -> bool:
    """Our plan (operator names) validated by unified-planning's sequential plan validator."""
    parsed = PDDLReader().parse_plan_string(problem, "\n".join(plan))
    with PlanValidator(name="sequential_plan_validator") as validator:
        result = validator.validate(problem, parsed)
    return bool(result.status == ValidationResultStatus.VALID)


# -- the reactive domain (paper Table 3) --------------------------------------------------------


@pytest.mark.parametrize(
    "flags",
    list(itertools.product((False, True), repeat=4)),
    ids=lambda f: "".join("FT"[v] for v in f),
)
def test_every_reactive_state_is_solved_alike_by_fast_downward(flags: tuple[bool, ...]) -> None:
    state = ReactiveState(*flags)
    domain, problem_text = reactive_domain().text(), reactive_problem(state, "straight").text()
    problem = read(domain, problem_text)
    assert {a.name for a in problem.actions} == {"po1", "po2", "po3"}
    ours, _ = plan_reactive(state, "straight")
    lama = fast_downward(problem)
    if not ours.solved:  # boxed in: the peer agrees there is no plan
        assert ours.status == "unsolvable"
        assert lama.status in UNSOLVABLE, lama.status
        return
    assert lama.status in SOLVED, lama.status
    theirs = names(lama.plan)
    assert up_valid(problem, ours.plan)
    assert up_valid(problem, theirs)
    # Fast Downward's plan is valid on pyperplan's grounding of the same text too.
    assert validate_plan(parse_and_ground(domain, problem_text), theirs) == (True, "valid")
    # Ours is optimal here (an optimal peer finds no shorter plan); lama-first's is no shorter.
    optimal = fast_downward(problem, optimal=True)
    assert optimal.status == PlanGenerationResultStatus.SOLVED_OPTIMALLY
    assert len(ours.plan) == len(optimal.plan.actions)
    assert len(theirs) >= len(ours.plan)


def test_reactive_problems_with_every_library_shape_parse() -> None:
    shapes = tuple(LIB.shapes())
    text = reactive_problem(ReactiveState(obstacle_togoal=True), shapes[0], shapes).text()
    problem = read(reactive_domain().text(), text)
    assert {o.name for o in problem.all_objects} >= set(shapes)
    assert up_valid(problem, [f"(po2 {shapes[0]})", f"(po1 {shapes[0]})"])
    assert not up_valid(problem, [f"(po1 {shapes[0]})"])  # the validator does reject


# -- the navigation lattice -----------------------------------------------------------------------


def lattice_plan(goals: Sequence[tuple[float, float]], shape: str = "straight") -> Plan:
    table = motion_table(LIB, shape, (0.0, 0.0, 0.0), COARSE)
    assert table is not None
    _, _, out = plan(
        ARENA, [OBSTACLE], START, goals, False, table=table, settings=COARSE, time_limit=60.0
    )
    result = solved(out)
    assert not result.partial and len(result.legs) == len(goals)
    return result


def costed(result: Plan) -> tuple[str, str]:
    """The plan's problem with action costs, and the same as plain STRIPS."""
    problem = result.problem()
    assert problem is not None
    return problem.text(), problem.text(costs=False)


def cost_of(problem_text: str, steps: Sequence[str]) -> int:
    """A plan's total cost on the problem (its moves' costs, in millimetres; visits are free)."""
    costs = move_costs(problem_text)
    return sum(costs[s] for s in steps if s.startswith("(move "))


@pytest.mark.slow
@pytest.mark.parametrize(
    ("goals", "shape"),
    [
        ([(-0.8, 0.3)], "straight"),
        ([(-0.8, 0.35)], "semi-zigzag"),
        ([(-0.8, 0.3), (-0.75, 0.4)], "straight"),  # several unordered goals: one tour
    ],
    ids=["one-goal", "one-goal-semi-zigzag", "two-goals"],
)
def test_lattice_exports_parse_and_fast_downward_agrees(
    goals: list[tuple[float, float]], shape: str
) -> None:
    result = lattice_plan(goals, shape)
    problem_text, plain_text = costed(result)
    problem = read(lattice_domain_text(), problem_text)
    assert problem.quality_metrics and isinstance(problem.quality_metrics[0], MinimizeActionCosts)
    assert len(problem.goals) == 1 and problem.goals[0].is_and() == (len(goals) > 1)
    assert up_valid(problem, result.pddl_plan)  # the whole tour, on the exported problem
    ours = cost_of(problem_text, result.pddl_plan)
    assert ours == sum(max(1, round(a.cost * 1000)) for a in result.actions if a.name == "move")
    optimal = fast_downward(problem, optimal=True)
    assert optimal.status == PlanGenerationResultStatus.SOLVED_OPTIMALLY
    best = names(optimal.plan)
    assert up_valid(problem, best)
    lama = fast_downward(problem)
    assert lama.status in SOLVED, lama.status
    theirs = names(lama.plan)
    assert up_valid(problem, theirs)
    # Fast Downward's plans are valid on pyperplan's grounding of the plain text too.
    grounded = parse_and_ground(lattice_domain_text(costs=False), plain_text)
    for steps in (theirs, best, result.pddl_plan):
        assert validate_plan(grounded, steps) == (True, "valid")
    visited = {n.split()[2].rstrip(")") for n in theirs if n.startswith("(visit ")}
    assert visited == {f"g{i}" for i in range(len(goals))}
    # The optimum is no dearer than any plan, ours (weighted A*, leg by leg) included.
    assert cost_of(problem_text, best) <= min(ours, cost_of(problem_text, theirs))


def test_a_broken_plan_is_rejected_by_the_peer_validator() -> None:
    result = lattice_plan([(-0.8, 0.3)])
    problem_text, _ = costed(result)
    problem = read(lattice_domain_text(), problem_text)
    moves = result.pddl_plan
    assert len(moves) >= 3
    assert not up_valid(problem, moves[:-1])  # stops short of the visit
    assert not up_valid(problem, [moves[1], moves[0], *moves[2:]])  # out of order
