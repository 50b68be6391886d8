"""One leg's search on the lattice: pyperplan's (or the compiled equivalent), with a partial
plan towards the most promising state seen when the budget runs out."""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

from pyperplan.task import Operator

from domain import lattice_search
from domain.lattice_heuristic import LatticeHeuristic
from domain.lattice_states import no_cycle_collection
from domain.lattice_task import LatticeTask
from domain.pyperplan_adapter import (
    HEURISTICS,
    SEARCHES,
    PlanResult,
    SearchStopped,
    finished,
    stopped,
)
from sim.robot import Array


@dataclass(frozen=True)
class _Root:
    """A stand-in search node for evaluating the heuristic at a state."""

    state: frozenset[Any]


def search_leg(task: LatticeTask, distances: Array, search: str, heuristic: str) -> PlanResult:
    """pyperplan's ``search`` (a name of ``SEARCHES``) on the leg, guided by ``heuristic``
    (``"lattice"``: the footprint-aware distance map ``distances``; else a name of
    ``HEURISTICS``). When the budget or time runs out, the path to the most promising state
    seen (by the lattice heuristic) is returned as a ``partial`` plan if it got closer: the
    robot goes there, senses more, and plans again."""
    t0 = time.monotonic()
    lattice_h = LatticeHeuristic(task, distances, task.table.longest_step)
    try:
        if heuristic == "lattice":
            h: Any = lattice_h
        else:
            with no_cycle_collection(freeze_after=True):  # millions of objects, no cycles
                task.ground_all()  # pyperplan's own heuristics need every operator
                h = HEURISTICS[heuristic](task)
        run = SEARCHES[search]
        if search == "gbf" and lattice_search.applies(task, h):
            plan = lattice_search.search(task, h)  # the same plan, compiled
        else:
            with no_cycle_collection(), task.search_reached(run):
                plan = run(task, h) if search != "bfs" else run(task)
    except SearchStopped as stop:
        best = lattice_h.best
        start_h = lattice_h(_Root(task.initial_state))
        if stop.status == "timeout" and best is not None and best[0] < start_h - 1.0:
            moves = resting_end(best[1].extract_solution(), task)
            if moves and lattice_h(_Root(moves[-1].add_effects)) < start_h - 1.0:
                ms = (time.monotonic() - t0) * 1e3
                names = [op.name for op in moves]
                return PlanResult("solved", names, ms, task.expansions, "partial")
        return stopped(stop, t0, task.expansions)
    return finished(plan, t0, task.expansions)


def resting_end(moves: list[Operator], task: LatticeTask) -> list[Operator]:
    """A partial plan's moves, less the last if the body cannot rest where it lands (its add
    effect): no motion out of a plan's last state checked it (``domain/lattice_rest.py``);
    the state before it started the last motion, so it can."""
    if moves and not task.resting([_landing(moves[-1], task)])[0]:
        return moves[:-1]
    return moves


def _landing(move: Operator, task: LatticeTask) -> int:
    """The state a move lands on."""
    number = task.at(move.add_effects)
    assert number is not None, move.name
    return number
