"""Sound failure only from hard facts: a goal walled in by known obstacles, or behind a gap the
body cannot pass, is proved unreachable (a ``Failure`` with its proof), a goal behind a gap
wider than the body is planned to, soft evidence never proves anything; and the compiled flood
of the body's free configurations answers as the labelling of all of them does."""

from __future__ import annotations

import math

import numpy as np
import pytest

from domain.navigation import Failure, Feasibility, LatticeGrid, Plan, Planner, PlanRequest
from domain.navigation.flood import AVAILABLE
from domain.world import RangeObservation, WorldModel
from sim.obstacles import rectangle
from sim.world import Bounds
from tests.domain.disc_scenes import clearance, ring
from tests.domain.lattice_scenes import SETTINGS, STRAIGHT, legs, move_slack, plan, solved

BOX = [rectangle(2.0, 2.0 + d, 1.6, 0.2) for d in (-0.7, 0.7)] + [
    rectangle(2.0 + d, 2.0, 0.2, 1.6) for d in (-0.7, 0.7)
]


def barrier(gap: float, thickness: float = 0.3) -> list:
    """A wall across a 6 m arena at x = 0 with a ``gap`` wide opening round y = 0."""
    half = (6 - gap) / 4
    return [
        rectangle(0.0, 3 - half, thickness, 2 * half),
        rectangle(0.0, -3 + half, thickness, 2 * half),
    ]


def test_a_goal_inside_a_closed_known_box_is_proved_unreachable() -> None:
    _, _, out = plan(Bounds(-4, 4, -4, 4), BOX, (-2.0, -2.0, 0.0), [(2.0, 2.0)])
    assert isinstance(out, Failure)
    assert (out.kind, out.proof, out.goal) == ("unreachable", "known", 0)
    assert out.status == "unreachable"
    assert out.reason == "unreachable: goal 0 at (2, 2) enclosed by known obstacles"


def test_a_box_with_a_door_wider_than_the_body_is_entered() -> None:
    """The same box with a 0.4 m door in its west wall: the goal inside is planned to (by a
    robot that has looked round: in space never observed the plan may come in parts)."""
    west = [rectangle(1.3, 2.0 + d, 0.2, 0.6) for d in (-0.5, 0.5)]
    walls = [*BOX[:3], *west]
    bounds = Bounds(-4, 4, -4, 4)
    p, _, out = plan(bounds, walls, (-2.0, 2.0, 0.0), [(2.0, 2.0)], observed=True)
    result = solved(out)
    assert not result.partial and result.actions[-1].name == "visit"
    assert min(move_slack(p, STRAIGHT, result, bounds, walls)[1:]) >= SETTINGS.margin - 1e-3


@pytest.mark.parametrize("gap", [0.12, 0.15])
def test_a_gap_narrower_than_the_body_and_its_margin_is_proved_unreachable(gap: float) -> None:
    """The straight body is 0.15 m wide and keeps 0.02 m either side: 0.19 m."""
    _, _, out = plan(Bounds(-3, 3, -3, 3), barrier(gap), (1.5, 0.0, 0.0), [(-1.5, 0.0)])
    assert isinstance(out, Failure), out
    assert out.kind == "unreachable" and out.proof == "known" and out.goal == 0
    assert out.reason.startswith("unreachable")


@pytest.mark.parametrize("gap", [0.26, 0.30])
def test_a_goal_behind_a_gap_wider_than_the_body_is_not(gap: float) -> None:
    bounds = Bounds(-3, 3, -3, 3)
    walls = barrier(gap)
    p, _, out = plan(bounds, walls, (1.5, 0.0, 0.0), [(-1.5, 0.0)])
    result = solved(out)
    assert not result.partial
    assert math.dist(result.actions[-1].target[:2], (-1.5, 0.0)) <= 0.06
    assert min(move_slack(p, STRAIGHT, result, bounds, walls)[1:]) >= SETTINGS.margin - 1e-3


def test_a_goal_walled_in_by_sensed_obstacles_is_unreachable_with_that_proof() -> None:
    """A ring of cells the head sensed round the goal: unreachable, and the proof says it
    rests on what was sensed (sensing again may clear it), not on the known map."""
    bounds = Bounds(-3, 3, -3, 3)
    world = WorldModel(bounds, (), SETTINGS.costmap)
    gx, gy = 1.5, 1.5
    angles = np.linspace(-math.pi, math.pi, 180, endpoint=False)
    for _ in range(3):  # single rays from the goal outwards, each echoing at 0.4 m
        world.integrate(RangeObservation((gx, gy), float(a), 0.0, 1.0, 0.4, True) for a in angles)
    assert world.sensed_occupied().sum() > 40 and world.version > 0
    out = Planner(bounds, SETTINGS).plan(
        PlanRequest((-1.5, -1.5, 0.0), STRAIGHT, legs([(gx, gy)]), True, world)
    )
    assert isinstance(out, Failure)
    assert (out.kind, out.proof, out.goal) == ("unreachable", "sensed", 0)
    assert "sensed obstacles" in out.reason


def heads_closer(result: Plan, start: tuple[float, float], goal: tuple[float, float]) -> bool:
    """Whether the plan (whole, or partial: its best node) ends nearer the goal than it starts."""
    return math.dist(result.actions[-1].target[:2], goal) < math.dist(start, goal) - 0.5


def test_soft_evidence_never_proves_a_goal_unreachable() -> None:
    """Contact evidence all round the goal (touched again and again, from every side) raises
    what going there costs; the planner still plans towards the goal (a partial plan when the
    detours spend its budget: the robot goes there, senses and plans again), never a failure."""
    bounds = Bounds(-3, 3, -3, 3)
    world = WorldModel(bounds, (), SETTINGS.costmap)
    gx, gy = 1.5, 1.5
    for n, a in enumerate(np.linspace(-math.pi, math.pi, 16, endpoint=False)):
        # a body whose tail unit lies tangent to a circle of 0.35 m round the goal
        x, y = gx + 0.35 * math.cos(a), gy + 0.35 * math.sin(a)
        psi = a + math.pi / 2
        head = (x - 0.79 * math.cos(psi), y - 0.79 * math.sin(psi), psi)
        for t in range(3):
            world.add_contact(head, (0.0, 0.0, 0.0), 4, "right", float(3 * n + t))
    assert world.evidence().max() > 0.3 and world.version == 0
    out = Planner(bounds, SETTINGS).plan(
        PlanRequest((-1.5, -1.5, 0.0), STRAIGHT, legs([(gx, gy)]), True, world)
    )
    assert isinstance(out, Plan), out
    assert heads_closer(out, (-1.5, -1.5), (gx, gy))


@pytest.mark.parametrize("gap", [0.26, 0.30])
def test_contact_evidence_across_a_gap_wider_than_the_body_does_not_close_it(gap: float) -> None:
    """A side contact's evidence lies along the whole touched unit: here right across a real
    gap. It is a cost, never a wall: the plan still leads to the gap; the same line sensed
    (lethal) proves the goal out of reach."""
    bounds = Bounds(-3, 3, -3, 3)
    world = WorldModel(bounds, barrier(gap), SETTINGS.costmap)
    for t in range(3):  # a body lying along +y in the gap, unit 2's right side touching
        points = world.add_contact((0.1, -0.35, math.pi / 2), (0.0, 0.0, 0.0), 2, "right", t)
    assert np.all(np.abs(points[:, 0]) < 0.01) and np.ptp(points[:, 1]) > gap
    request = PlanRequest((1.5, 0.0, 0.0), STRAIGHT, legs([(-1.5, 0.0)]), True, world)
    out = Planner(bounds, SETTINGS).plan(request)
    assert isinstance(out, Plan), out
    assert heads_closer(out, (1.5, 0.0), (-1.5, 0.0)) or not out.partial
    sensed = WorldModel(bounds, barrier(gap), SETTINGS.costmap)
    for _ in range(3):  # the same line as sensed cells: rays from the east echoing on it
        sensed.integrate(
            RangeObservation((0.5, float(y)), math.pi, 0.0, 1.0, 0.5 - 0.005, True)
            for y in np.arange(-0.2, 0.21, 0.025)
        )
    failed = Planner(bounds, SETTINGS).plan(
        PlanRequest((1.5, 0.0, 0.0), STRAIGHT, legs([(-1.5, 0.0)]), True, sensed)
    )
    assert isinstance(failed, Failure) and failed.kind == "unreachable"
    assert failed.proof == "sensed"


# -- the flood against the labelling ----------------------------------------------------------


@pytest.mark.skipif(not AVAILABLE, reason="numba kernels are off")
@pytest.mark.parametrize("seed", range(4))
def test_the_flood_answers_as_the_labelling(seed: int) -> None:
    rng = np.random.default_rng(seed)
    grid = LatticeGrid(Bounds(-1.5, 1.5, -1.5, 1.5), SETTINGS)
    discs = [(*rng.uniform(-1.4, 1.4, 2), rng.uniform(0.05, 0.3)) for _ in range(4 + seed)]
    discs += ring(0.9, 0.9, 0.45)  # a pen: goals inside it cannot be reached from outside
    check = Feasibility(grid, STRAIGHT, clearance(grid, discs), margin=0.03)
    check.flood_budget = 10**9  # the flood answers every question itself
    answers = []
    for _ in range(10):
        start = (int(rng.integers(grid.nx)), int(rng.integers(grid.ny)), int(rng.integers(64)))
        for goal in [(0.9, 0.9), tuple(rng.uniform(-1.4, 1.4, 2)), (-1.2, -1.2)]:
            flood = check.reaches(start, goal, 0.08, compiled=True)
            labels = check.reaches(start, goal, 0.08, compiled=False)
            assert flood == labels, (seed, start, goal)
            answers.append(flood)
    assert True in answers and False in answers  # both answers were put to the test


def test_a_start_that_touches_everything_may_reach() -> None:
    grid = LatticeGrid(Bounds(-1.0, 1.0, -1.0, 1.0), SETTINGS)
    blocked = np.full((grid.nx, grid.ny), -1.0)  # nowhere may the body lie
    check = Feasibility(grid, STRAIGHT, blocked, margin=0.03)
    assert check.reaches((20, 20, 0), (0.5, 0.5), 0.08, compiled=True)
    assert check.reaches((20, 20, 0), (0.5, 0.5), 0.08, compiled=False)


@pytest.mark.skipif(not AVAILABLE, reason="numba kernels are off")
def test_a_flood_over_budget_leaves_the_answer_to_the_labelling() -> None:
    grid = LatticeGrid(Bounds(-1.5, 1.5, -1.5, 1.5), SETTINGS)
    check = Feasibility(grid, STRAIGHT, clearance(grid, ring(0.9, 0.9, 0.45)), margin=0.03)
    start, outside, inside = (10, 10, 0), (-1.0, 1.0), (0.9, 0.9)
    check.flood_budget = 10**9
    assert check.reaches(start, outside, 0.08) and not check.reaches(start, inside, 0.08)
    check.flood_budget = 50  # too few to decide either: the labelling answers, the same
    assert check.reaches(start, outside, 0.08) and not check.reaches(start, inside, 0.08)


@pytest.mark.skipif(not AVAILABLE, reason="numba kernels are off")
def test_the_flood_within_a_small_budget_decides_or_says_it_cannot() -> None:
    """What the planner asks before a search: the flood alone, within a few configurations.
    A goal in a small pen is decided at once (the pen's side runs out); a goal across the
    open arena is left undecided (``None``: the search answers), never answered wrongly."""
    grid = LatticeGrid(Bounds(-1.5, 1.5, -1.5, 1.5), SETTINGS)
    check = Feasibility(grid, STRAIGHT, clearance(grid, ring(0.9, 0.9, 0.45)), margin=0.03)
    start, outside, inside = (10, 10, 0), (-1.0, 1.0), (0.9, 0.9)
    assert check.flood_decides(start, inside, 0.08, budget=2_000) is False
    assert check.flood_decides(start, outside, 0.08, budget=50) is None
    assert check.flood_decides(start, outside, 0.08, budget=10**9) is True
