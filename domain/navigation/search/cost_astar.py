"""Weighted A* on action costs, as a pyperplan search module, with an anytime best node.

pyperplan's ``astar_search`` counts every operator as one step (``make_child_node`` adds 1 to
g). This is the same loop, over pyperplan's task interface and search nodes, with g the sum of
the operators' ``cost`` (``domain.navigation.lattice.task.CostOperator``; 1 for an operator
without one) and open entries ordered by ``(g + weight * h, h, tiebreaker)`` as pyperplan
orders them, but without reopening: a state is expanded once (weighted A* with a closed list,
as ARA*'s iterations are: the plan's cost stays within ``weight`` times the best's for a
consistent heuristic, and an inconsistent one, such as the turn onto the way, cannot make the
search expand the same states over and over). It also stops after ``budget`` expansions
(``SearchStopped("timeout")``) and keeps the best node it expanded, by h then first met, among
states ``restable`` accepts (the search's anytime answer: the robot goes there, senses, and
plans again).

The compiled search (``domain.navigation.search.kernel``) runs the same loop on the lattice and
returns the same plans; a test holds them to each other.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable
from typing import Any

from pyperplan.search import searchspace

from domain.pyperplan_adapter import SearchStopped


class Best:
    """The best expanded node so far (lowest h, the first of equals)."""

    def __init__(self) -> None:
        self.h = math.inf
        self.node: Any = None

    def offer(self, h: float, node: Any) -> None:
        if h < self.h:
            self.h, self.node = h, node


def cost_astar_search(
    task: Any,
    heuristic: Callable[[Any], float],
    weight: float = 1.0,
    budget: int | None = None,
    best: Best | None = None,
    restable: Callable[[Any], bool] = lambda node: True,
    stall: tuple[int, float] | None = None,
) -> list[Any] | None:
    """A plan (operators) for ``task`` found by weighted A* on action costs, or ``None`` when
    the reachable states run out. ``budget``: expansions before ``SearchStopped("timeout")``;
    ``best``: filled with the best expanded node; ``restable(node)``: whether the robot could
    stop at a node (a best node must be one); ``stall`` (after, weight): once ``after``
    expansions are spent, every open entry is re-keyed at ``weight`` and the search goes on
    at it (``kernel.Stall``)."""
    open_list: list[tuple[float, float, int, Any]] = []
    state_cost = {task.initial_state: 0.0}
    closed: set[Any] = set()
    tiebreaker = 0
    root = searchspace.make_root_node(task.initial_state)
    root.g = 0.0
    h0 = heuristic(root)
    heapq.heappush(open_list, (root.g + weight * h0, h0, tiebreaker, root))
    expansions = 0
    while open_list:
        if stall is not None and expansions >= stall[0]:
            weight = stall[1]
            open_list = [(n.g + weight * eh, eh, tie, n) for _, eh, tie, n in open_list]
            heapq.heapify(open_list)
            stall = None
        _, h, _, node = heapq.heappop(open_list)
        if node.state in closed or state_cost[node.state] != node.g:
            continue  # expanded already, or a cheaper path to it was found since
        if task.goal_reached(node.state):
            return node.extract_solution()  # type: ignore[no-any-return]
        expansions += 1
        if budget is not None and expansions > budget:
            raise SearchStopped("timeout")
        closed.add(node.state)
        successors = task.get_successor_states(node.state)
        if best is not None and restable(node):
            best.offer(h, node)
        for op, succ_state in successors:
            child = searchspace.SearchNode(succ_state, node, op, node.g + getattr(op, "cost", 1.0))
            if succ_state in closed:
                continue  # no reopening
            if not child.g < state_cost.get(succ_state, math.inf):
                continue  # reached as cheaply already
            h_child = heuristic(child)
            if h_child == math.inf:
                continue  # no way to the goal from there
            tiebreaker += 1
            entry = (child.g + weight * h_child, h_child, tiebreaker, child)
            heapq.heappush(open_list, entry)
            state_cost[succ_state] = child.g
    return None
