"""The one search over the lattice, and pyperplan's own searches on the same task as a check.

``run`` searches one leg: ``"cost"`` is weighted A* on the motions' costs with one expansion
budget and an anytime best node (``cost_astar``, compiled in ``kernel``); the names of
pyperplan's searches (``gbf``, ``astar``, ``wastar``, ``ehs``, ``bfs``) run pyperplan's unit-cost
search on the same ``LatticeTask``, with the obstacle heuristic or one of pyperplan's own.
"""

from __future__ import annotations

import time
from typing import Any

from domain.kernels import AVAILABLE
from domain.navigation.lattice.states import no_cycle_collection
from domain.navigation.lattice.task import LatticeTask
from domain.navigation.search import kernel
from domain.navigation.search.cost_astar import Best, cost_astar_search
from domain.navigation.search.heuristic import CostHeuristic
from domain.navigation.search.kernel import Found, Stall
from domain.pyperplan_adapter import HEURISTICS, SEARCHES, SearchStopped

COST_SEARCH = "cost"
SEARCH_NAMES = (COST_SEARCH, *SEARCHES)
COMPLETE = {COST_SEARCH, "gbf", "astar", "wastar", "bfs"}  # no plan found: none exists

__all__ = ["COST_SEARCH", "SEARCH_NAMES", "CostHeuristic", "Found", "Stall", "run"]


def run(
    task: LatticeTask,
    heuristic: CostHeuristic,
    search: str,
    weight: float,
    budget: int,
    pyperplan_heuristic: str | None = None,
    compiled: bool | None = None,
    stall: Stall | None = None,
) -> Found:
    """One leg's search. Raises ``SearchStopped`` for a cancel or the deadline. ``compiled``:
    force the kernel (True) or the Python cost search (False) for ``"cost"``; by default the
    kernel when it can run. ``stall``: where the cost search's weight goes up (``Stall``;
    pyperplan's searches keep theirs)."""
    if search == COST_SEARCH:
        use_kernel = compiled if compiled is not None else AVAILABLE
        if use_kernel and kernel.applies(task, heuristic):
            return kernel.search(task, heuristic, weight, budget, stall)
        return _python_cost_search(task, heuristic, weight, budget, stall)
    return _pyperplan_search(task, heuristic, search, budget, pyperplan_heuristic)


def _python_cost_search(
    task: LatticeTask,
    heuristic: CostHeuristic,
    weight: float,
    budget: int,
    stall: Stall | None = None,
) -> Found:
    best = Best()

    def restable(node: Any) -> bool:
        number = task.at(node.state)
        return number is not None and task.valid(number)[0] != 0

    status, plan = "solved", None
    with no_cycle_collection():
        try:
            at = None if stall is None else (stall.after, stall.weight)
            plan = cost_astar_search(task, heuristic, weight, budget, best, restable, at)
            if plan is None:
                status = "exhausted"
        except SearchStopped as stop:
            if stop.status != "timeout" or _timed_out(task):
                raise  # a cancel, or the deadline: no answer
            status = "budget"
    path = best.node.extract_solution() if best.node is not None else []
    expansions = task.expansions
    return Found(status, plan, best.h, path, expansions)


def _timed_out(task: LatticeTask) -> bool:
    """Whether the task's own deadline (not the search's budget) stopped it."""
    return time.monotonic() > task.deadline


def _pyperplan_search(
    task: LatticeTask,
    heuristic: CostHeuristic,
    search: str,
    budget: int,
    pyperplan_heuristic: str | None,
) -> Found:
    """pyperplan's unit-cost ``search`` on the task: no best node (a budget is a timeout)."""
    task.budget = budget
    if pyperplan_heuristic is not None:
        with no_cycle_collection(freeze_after=True):  # millions of objects, no cycles
            task.ground_all()  # pyperplan's own heuristics need every operator
            task.expansions = 0
        h: Any = HEURISTICS[pyperplan_heuristic](task)
    else:
        h = heuristic
    run_search = SEARCHES[search]
    try:
        with no_cycle_collection():
            plan = run_search(task) if search == "bfs" else run_search(task, h)
    except SearchStopped as stop:
        if stop.status != "timeout" or _timed_out(task):
            raise
        return Found("budget", None, float("inf"), [], task.expansions)
    # Enforced hill climbing gives up in a dead end a complete search would leave: its
    # failure proves nothing, and the planner's own checks decide (as when a budget ran out).
    status = "solved" if plan is not None else "exhausted" if search in COMPLETE else "budget"
    return Found(status, plan, float("inf"), [], task.expansions)
