"""The lattice navigation domain as portable PDDL (STRIPS + typing), naming the primitives.

``(move ?a ?b ?p)`` takes the robot from lattice state ``?a`` to ``?b`` by library primitive
``?p`` where ``(succ ?a ?b ?p)`` holds (the primitive's swept footprint is free from ``?a``);
``(visit ?s ?g)`` marks goal ``?g`` visited where ``(near ?s ?g)`` (the tracked point is on
it). A problem lists the part of the lattice a search generated: every state it expanded with
all its successors, so any planner that solves it finds a plan that is valid on the lattice.
Type and predicate names are distinct (unified-planning rejects a name used as both).
"""

from __future__ import annotations

from domain.lattice_task import LatticeTask, state_name
from domain.pddl import Action, Domain, Problem


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
            ),
            Action(
                "visit",
                [("?s", "lstate"), ("?g", "goalpoint")],
                ["(at ?s)", "(near ?s ?g)"],
                ["(visited ?g)"],
            ),
        ],
        comment=(
            "screwsnake lattice navigation: states are (centroid cell, orientation, shape); each\n"
            "move applies one learned library primitive whose swept footprint is free."
        ),
    )


def lattice_problem(task: LatticeTask, shape: str) -> Problem:
    """The generated part of ``task``'s lattice as a PDDL problem."""
    states: set[int] = {task.start_number}
    init = [f"(at {state_name(task.start_number)})"]
    primitives: set[str] = set()
    for a, edges in sorted(task.edges.items()):
        states.add(a)
        for b, p in edges:
            states.add(b)
            primitives.add(p)
            init.append(f"(succ {state_name(a)} {state_name(b)} {p})")
    goal = f"g{task.goal_index}"
    for s in sorted(task.near):
        states.add(s)
        init.append(f"(near {state_name(s)} {goal})")
    i, j, k = task.start_key
    comment = (
        f"shape {shape}; start state {state_name(task.start_number)} = cell ({i}, {j}), "
        f"orientation {k}; goal {goal} at ({task.goal[0]:g}, {task.goal[1]:g}) within "
        f"{task.reach:g} m\n{len(task.edges)} states expanded"
    )
    objects = {
        "lstate": [state_name(s) for s in sorted(states)],
        "primitive": sorted(primitives) or ["none"],
        "goalpoint": [goal],
    }
    return Problem("lattice", "screwsnake-lattice", objects, init, [f"(visited {goal})"], comment)
