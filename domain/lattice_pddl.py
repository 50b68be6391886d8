"""The lattice navigation domain as portable PDDL (STRIPS + typing), naming the primitives.

``(move ?a ?b ?p)`` takes the robot from lattice state ``?a`` to ``?b`` by library primitive
``?p`` where ``(succ ?a ?b ?p)`` holds (the primitive's swept footprint is free from ``?a``);
``(visit ?s ?g)`` marks goal ``?g`` visited where ``(near ?s ?g)`` (the tracked point is on
it); ``(reshape ?a ?b)`` changes the body from shape ``?a`` to ``?b`` in place where
``(reshapes ?a ?b)`` (the sweep is free; a problem whose plan needs it asks for ``(body ?b)``). A problem lists the part of the lattice a search generated: every state it expanded with
all its successors, so any planner that solves it finds a plan that is valid on the lattice.
Type and predicate names are distinct (unified-planning rejects a name used as both).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cache
from typing import cast

from domain.lattice import Key
from domain.lattice_task import LatticeTask, primitive_name, state_name
from domain.pddl import Action, Domain, Problem


def lattice_domain() -> Domain:
    return Domain(
        "screwsnake-lattice",
        ["lstate", "primitive", "goalpoint", "bodyshape"],
        [
            "(at ?s - lstate)",
            "(body ?b - bodyshape)",
            "(reshapes ?a - bodyshape ?b - bodyshape)",
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
            ),
            Action(
                "visit",
                [("?s", "lstate"), ("?g", "goalpoint")],
                ["(at ?s)", "(near ?s ?g)"],
                ["(visited ?g)"],
            ),
            Action(
                "reshape",
                [("?a", "bodyshape"), ("?b", "bodyshape")],
                ["(body ?a)", "(reshapes ?a ?b)"],
                ["(body ?b)"],
                ["(body ?a)"],
            ),
        ],
        comment=(
            "screwsnake lattice navigation: states are (centroid cell, orientation, shape); each\n"
            "move applies one learned library primitive whose swept footprint is free."
        ),
    )


@cache
def lattice_domain_text() -> str:
    """The domain's PDDL text (the same for every plan: written once per process)."""
    return lattice_domain().text()


@dataclass
class LatticeGraph:
    """The part of the lattice a problem lists: a start, move edges, goal points and where the
    head is on each."""

    start: Key
    start_number: int
    edges: set[tuple[int, int, str]] = field(default_factory=set)  # (state, next, primitive)
    near: set[tuple[int, int]] = field(default_factory=set)  # (state, goal index)
    goals: list[tuple[int, float, float, float]] = field(default_factory=list)  # i, x, y, reach
    notes: list[str] = field(default_factory=list)

    @classmethod
    def of_legs(cls, tasks: Sequence[LatticeTask]) -> LatticeGraph:
        """What the searches of a tour's legs generated: every state they expanded with all
        its successors."""
        if not tasks:
            raise ValueError("lattice_problem needs at least one leg")
        first = tasks[0]
        graph = cls(first.start_key, first.start_number)
        for task in tasks:
            graph.edges.update([(a, b, p) for a, out in task.edges.items() for b, p in out])
            graph.near.update((s, task.goal_index) for s in task.near)
            graph.goals.append((task.goal_index, task.goal[0], task.goal[1], task.reach))
            graph.notes.append(
                f"goal g{task.goal_index} at ({task.goal[0]:g}, {task.goal[1]:g}) within "
                f"{task.reach:g} m; {len(task.edges)} states expanded for it"
            )
        if len(tasks) > 1:
            graph.notes.append("goals in the order planned; the PDDL goal does not state an order")
        return graph


def lattice_problem(
    legs: LatticeTask | Sequence[LatticeTask] | LatticeGraph,
    shape: str,
    reshaped_from: str | None = None,
) -> Problem:
    """The generated part of the lattice as a PDDL problem: one leg's task, every leg of a
    tour (their lattices merged, one goal point per leg, all to be visited), or a graph put
    together otherwise (a repaired plan's). ``shape`` is the lattice's body shape;
    ``reshaped_from`` the shape the body has before the plan's first action changes it (the
    problem then starts in that body and asks for ``shape``).

    A tour's goals are a conjunction, so the problem does not state an order: a peer planner
    may visit ordered goals in another order (the plan is still valid on the lattice).
    """
    # cast: LatticeTask derives from an untyped class, so isinstance cannot narrow it away
    graph = (
        cast(LatticeGraph, legs)
        if isinstance(legs, LatticeGraph)
        else LatticeGraph.of_legs(_tasks(legs))
    )
    edges = graph.edges
    states = {graph.start_number, *[a for a, _, _ in edges], *[b for _, b, _ in edges]}
    states.update([s for s, _ in graph.near])
    body = primitive_name(shape)
    before = primitive_name(reshaped_from) if reshaped_from else body
    init = [f"(at {state_name(graph.start_number)})", f"(body {before})"]
    if before != body:
        init.append(f"(reshapes {before} {body})")
    init += [f"(succ s{a} s{b} {p})" for a, b, p in sorted(edges)]  # state_name() inlined
    init += [f"(near {state_name(s)} g{g})" for s, g in sorted(graph.near)]
    goals = [f"g{index}" for index, *_ in graph.goals]
    i, j, k = graph.start
    lines = [
        f"shape {shape}; start state {state_name(graph.start_number)} = cell ({i}, {j}), "
        f"orientation {k}",
        *graph.notes,
    ]
    objects = {
        "lstate": [state_name(s) for s in sorted(states)],
        "primitive": sorted({p for _, _, p in edges}) or ["none"],
        "goalpoint": goals,
        "bodyshape": sorted({before, body}),
    }
    goal = [f"(visited {g})" for g in goals] + ([f"(body {body})"] if before != body else [])
    return Problem("lattice", "screwsnake-lattice", objects, init, goal, "\n".join(lines))


def _tasks(legs: LatticeTask | Sequence[LatticeTask]) -> list[LatticeTask]:
    return [legs] if isinstance(legs, LatticeTask) else list(legs)
