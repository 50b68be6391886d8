"""The lattice navigation domain as portable PDDL with ``:action-costs``, naming the primitives.

``(move ?a ?b ?p)`` takes the robot from lattice state ``?a`` to ``?b`` by library primitive
``?p`` where ``(succ ?a ?b ?p)`` holds (the motion is valid from ``?a``), and adds ``(move-cost
?a ?b ?p)`` to the total cost: the motion's cost in millimetres (PDDL costs are whole numbers;
``domain.navigation.lattice.costs``). ``(visit ?s ?g)`` marks goal ``?g`` visited where ``(near
?s ?g)`` (the tracked point is on it), at no cost. A problem lists the part of the lattice a
search generated: every state it expanded with all its successors and their costs, so any
planner that solves it finds a plan valid on the lattice, and an optimal one the cheapest there.
Without costs (``text(costs=False)``) the same domain is plain STRIPS, as pyperplan reads it.
Type and predicate names are distinct (unified-planning rejects a name used as both).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cache

from domain.navigation.lattice.grid import Key
from domain.navigation.lattice.motions import primitive_name
from domain.navigation.lattice.task import LatticeTask, state_name
from domain.pddl import Action, Domain, Problem


def millimetres(cost: float) -> int:
    """A motion's cost as the whole millimetres PDDL action costs take (at least 1)."""
    return max(1, round(cost * 1000.0))


def lattice_domain() -> Domain:
    return Domain(
        "screwsnake-lattice",
        ["lstate", "primitive", "goalpoint"],
        [
            "(at ?s - lstate)",
            "(succ ?a - lstate ?b - lstate ?p - primitive)",
            "(near ?s - lstate ?g - goalpoint)",
            "(visited ?g - goalpoint)",
        ],
        [
            Action(
                "move",
                [("?a", "lstate"), ("?b", "lstate"), ("?p", "primitive")],
                ["(at ?a)", "(succ ?a ?b ?p)"],
                ["(at ?b)"],
                ["(at ?a)"],
                cost="(move-cost ?a ?b ?p)",
            ),
            Action(
                "visit",
                [("?s", "lstate"), ("?g", "goalpoint")],
                ["(at ?s)", "(near ?s ?g)"],
                ["(visited ?g)"],
            ),
        ],
        comment=(
            "screwsnake lattice navigation: states are (centroid cell, orientation) of one body\n"
            "shape; each move applies one learned library primitive valid from its state, at\n"
            "its cost in millimetres (its length, more near obstacles and where it sweeps blind)."
        ),
        functions=["(move-cost ?a - lstate ?b - lstate ?p - primitive) - number"],
    )


@cache
def lattice_domain_text(costs: bool = True) -> str:
    """The domain's PDDL text (the same for every plan: written once per process)."""
    return lattice_domain().text(costs)


@dataclass
class LatticeGraph:
    """The part of the lattice a problem lists: a start, move edges with their costs, goal
    points and where the head is on each."""

    start: Key
    start_number: int
    edges: dict[tuple[int, int, str], int] = field(default_factory=dict)  # -> cost (mm)
    near: set[tuple[int, int]] = field(default_factory=set)  # (state, goal index)
    goals: list[tuple[int, float, float, float]] = field(default_factory=list)  # i, x, y, reach
    notes: list[str] = field(default_factory=list)

    def add(self, a: int, b: int, primitive: str, cost: float) -> None:
        self.edges.setdefault((a, b, primitive), millimetres(cost))

    @classmethod
    def of_legs(cls, tasks: Sequence[LatticeTask]) -> LatticeGraph:
        """What the searches of a tour's legs generated: every state they expanded with all
        its successors."""
        if not tasks:
            raise ValueError("lattice_problem needs at least one leg")
        first = tasks[0]
        graph = cls(first.start_key, first.start_number)
        for task in tasks:
            for a, out in task.edges.items():
                for b, p, cost in out:
                    graph.add(a, b, p, cost)
            graph.near.update((s, task.goal_index) for s in task.near)
            graph.goals.append((task.goal_index, task.goal[0], task.goal[1], task.reach))
            graph.notes.append(
                f"goal g{task.goal_index} at ({task.goal[0]:g}, {task.goal[1]:g}) within "
                f"{task.reach:g} m; {len(task.edges)} states expanded for it"
            )
        if len(tasks) > 1:
            graph.notes.append("goals in the order planned; the PDDL goal does not state an order")
        return graph


def lattice_problem(legs: LatticeTask | Sequence[LatticeTask], shape: str) -> Problem:
    """The generated part of the lattice as a PDDL problem: one leg's task, or every leg of a
    tour (their lattices merged, one goal point per leg, all to be visited). ``shape`` is the
    lattice's body shape.

    A tour's goals are a conjunction, so the problem does not state an order: a peer planner
    may visit ordered goals in another order (the plan is still valid on the lattice).
    """
    if isinstance(legs, LatticeTask):
        graph = LatticeGraph.of_legs([legs])
    else:
        graph = LatticeGraph.of_legs(list(legs))
    moves = graph.edges
    states = {graph.start_number, *[a for a, _, _ in moves], *[b for _, b, _ in moves]}
    states.update([s for s, _ in graph.near])
    init = [f"(at {state_name(graph.start_number)})"]
    ordered = sorted(moves)
    init += [f"(succ s{a} s{b} {p})" for a, b, p in ordered]  # state_name() inlined
    init += [f"(near {state_name(s)} g{g})" for s, g in sorted(graph.near)]
    costs = [f"(= (move-cost s{a} s{b} {p}) {moves[(a, b, p)]})" for a, b, p in ordered]
    goals = [f"g{index}" for index, *_ in graph.goals]
    i, j, k = graph.start
    lines = [
        f"shape {primitive_name(shape)}; start state {state_name(graph.start_number)} = cell "
        f"({i}, {j}), orientation {k}",
        *graph.notes,
    ]
    objects = {
        "lstate": [state_name(s) for s in sorted(states)],
        "primitive": sorted({p for _, _, p in moves}) or ["none"],
        "goalpoint": goals,
    }
    goal = [f"(visited {g})" for g in goals]
    return Problem("lattice", "screwsnake-lattice", objects, init, goal, "\n".join(lines), costs)
