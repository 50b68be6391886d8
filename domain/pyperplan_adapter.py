"""pyperplan in process: PDDL from strings, deterministic search, time limits, clear outcomes.

pyperplan 2.1 (GPL-3.0-or-later) is used as a library: its parser, grounding, searches and
heuristics. Three things are added around it:
- facts become ``Fact`` strings whose hash is their index (names sorted), and operators are
  sorted by name, so set order, and therefore the plan, no longer depends on PYTHONHASHSEED;
- successor generation goes through an index of operators by precondition fact, and checks a
  deadline and a cancel event, which gives every search a time limit and cancellation;
- pyperplan's root-logger chatter is filtered out.
"""

from __future__ import annotations

import logging
import time
from collections import defaultdict
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Literal, Protocol

from pyperplan import grounding
from pyperplan.heuristics.blind import BlindHeuristic
from pyperplan.heuristics.landmarks import LandmarkHeuristic
from pyperplan.heuristics.lm_cut import LmCutHeuristic
from pyperplan.heuristics.relaxation import hAddHeuristic, hFFHeuristic, hMaxHeuristic, hSAHeuristic
from pyperplan.pddl.parser import Parser
from pyperplan.search import (
    astar_search,
    breadth_first_search,
    enforced_hillclimbing_search,
    greedy_best_first_search,
    weighted_astar_search,
)
from pyperplan.task import Operator, Task


class _DropPyperplanLogs(logging.Filter):
    def filter(self, record: logging.LogRecord) -> bool:
        return "pyperplan" not in record.pathname


logging.getLogger().addFilter(_DropPyperplanLogs())

SEARCHES: dict[str, Callable[..., Any]] = {
    "gbf": greedy_best_first_search,
    "astar": astar_search,
    "wastar": weighted_astar_search,
    "ehs": enforced_hillclimbing_search,
    "bfs": breadth_first_search,
}
HEURISTICS: dict[str, Callable[[Task], Any]] = {
    "hff": hFFHeuristic,
    "hadd": hAddHeuristic,
    "hmax": hMaxHeuristic,
    "hsa": hSAHeuristic,
    "lmcut": LmCutHeuristic,
    "landmark": LandmarkHeuristic,
    "blind": BlindHeuristic,
}
Status = Literal["solved", "unsolvable", "timeout", "cancelled"]


class PlanningError(ValueError):
    """Malformed PDDL or an unknown search/heuristic."""


class SearchStopped(Exception):
    def __init__(self, status: Status) -> None:
        super().__init__(status)
        self.status = status


class Fact(str):
    """A fact's text with a deterministic hash (its index in the task), unlike ``str``'s."""

    number: int

    def __new__(cls, text: str, number: int) -> Fact:
        obj = super().__new__(cls, text)
        obj.number = number
        return obj

    def __hash__(self) -> int:
        return self.number

    def __eq__(self, other: object) -> bool:
        return str.__eq__(self, other)


class CancelFlag(Protocol):
    """A threading or multiprocessing event: searches only read ``is_set``."""

    def is_set(self) -> bool: ...


def make_facts(names: Sequence[str]) -> list[Fact]:
    return [Fact(n, i) for i, n in enumerate(names)]


def stop_if_due(cancel: CancelFlag | None, deadline: float, over_budget: bool = False) -> None:
    """Raise ``SearchStopped`` when the search is cancelled, past its deadline or its budget."""
    if cancel is not None and cancel.is_set():
        raise SearchStopped("cancelled")
    if over_budget or time.monotonic() > deadline:
        raise SearchStopped("timeout")


class IndexedTask(Task):  # type: ignore[misc]
    """A STRIPS task over ``Fact``s with operators indexed by a precondition fact.

    Every operator must have at least one precondition (true of all tasks built here);
    successors are the operators indexed under a fact of the state whose preconditions hold,
    in operator order.
    """

    def __init__(
        self,
        name: str,
        facts: Sequence[Fact],
        initial_state: Iterable[Fact],
        goals: Iterable[Fact],
        operators: Sequence[Operator],
    ) -> None:
        super().__init__(
            name, set(facts), frozenset(initial_state), frozenset(goals), list(operators)
        )
        self.names = list(facts)
        self.deadline = float("inf")
        self.cancel: CancelFlag | None = None
        self.expansions = 0
        self._reindex()

    def _reindex(self) -> None:
        index: dict[Fact, list[tuple[int, Operator]]] = defaultdict(list)
        for order, op in enumerate(self.operators):
            index[min(op.preconditions, key=hash)].append((order, op))
        self._index = dict(index)

    def set_operators(self, operators: Sequence[Operator]) -> None:
        self.operators = list(operators)
        self._reindex()

    def get_successor_states(
        self, state: frozenset[Fact]
    ) -> list[tuple[Operator, frozenset[Fact]]]:
        self.expansions += 1
        # Checked on every expansion: one expansion under hFF can cost tens of milliseconds.
        stop_if_due(self.cancel, self.deadline)
        candidates = [c for fact in state for c in self._index.get(fact, ())]
        candidates.sort(key=lambda c: c[0])
        return [(op, op.apply(state)) for _, op in candidates if op.preconditions <= state]

    def fact(self, text: str) -> Fact:
        return next(f for f in self.names if f == text)


def intern(task: Task, name: str | None = None) -> IndexedTask:
    """pyperplan's string-fact task as an ``IndexedTask`` (facts sorted, operators sorted)."""
    facts = make_facts(sorted(task.facts))
    ids = {str(f): f for f in facts}

    def conv(names: Iterable[str]) -> list[Fact]:
        return sorted((ids[n] for n in names), key=hash)

    ops = [
        Operator(o.name, conv(o.preconditions), conv(o.add_effects), conv(o.del_effects))
        for o in sorted(task.operators, key=lambda o: o.name)
    ]
    if any(not op.preconditions for op in ops):
        raise PlanningError("operators without preconditions are not supported")
    return IndexedTask(name or task.name, facts, conv(task.initial_state), conv(task.goals), ops)


def parse(domain_pddl: str, problem_pddl: str) -> Any:
    """Parse PDDL text in process (no temporary files) with pyperplan's parser: its problem."""
    parser = Parser(None)
    parser.domInput = domain_pddl
    parser.probInput = problem_pddl
    try:
        domain = parser.parse_domain(read_from_file=False)
        return parser.parse_problem(domain, read_from_file=False)
    except Exception as exc:  # pyperplan raises bare exceptions and SystemExit-free errors
        raise PlanningError(f"PDDL does not parse: {exc}") from exc


def parse_and_ground(
    domain_pddl: str, problem_pddl: str, remove_irrelevant: bool = True
) -> IndexedTask:
    """Parse PDDL text and ground it with pyperplan (``remove_irrelevant=False`` keeps effects
    that cannot lead to the goal, as a direct grounding does)."""
    problem = parse(domain_pddl, problem_pddl)
    return intern(grounding.ground(problem, remove_irrelevant_operators=remove_irrelevant))


def validate_plan_text(
    domain_pddl: str, problem_pddl: str, plan: Sequence[str]
) -> tuple[bool, str]:
    """Check a plan (``(move s1 s2 p)`` steps) on parsed PDDL as a plan validator does: each
    step's action schema instantiated with its arguments, its preconditions true in the state,
    its effects applied; the goal true at the end. Unlike ``validate_plan`` nothing is grounded
    beyond the plan's own steps, so it stays fast on problems too large for pyperplan's
    grounding (which enumerates every assignment of objects to a schema's parameters)."""
    problem = parse(domain_pddl, problem_pddl)
    actions = problem.domain.actions

    def atom(predicate: Any, binding: dict[str, str]) -> tuple[str, ...]:
        return (predicate.name, *(binding.get(name, name) for name, _ in predicate.signature))

    state = {atom(p, {}) for p in problem.initial_state}
    for step, text in enumerate(plan):
        name, *args = text.strip("() ").lower().split()
        action = actions.get(name)
        if action is None or len(args) != len(action.signature):
            return False, f"step {step}: {text} is not an action of the domain with its arity"
        binding = {param: arg for (param, _), arg in zip(action.signature, args, strict=True)}
        missing = [p for p in action.precondition if atom(p, binding) not in state]
        if missing:
            return (
                False,
                f"step {step}: {text} is not applicable ({' '.join(atom(missing[0], binding))} is false)",
            )
        state -= {atom(p, binding) for p in action.effect.dellist}
        state |= {atom(p, binding) for p in action.effect.addlist}
    if any(atom(p, {}) not in state for p in problem.goal):
        return False, "the plan ends without reaching the goal"
    return True, "valid"


@dataclass
class PlanResult:
    """The outcome of one search, never ``None``: solved with a plan, or why not."""

    status: Status
    plan: list[str] = field(default_factory=list)
    search_ms: float = 0.0
    expansions: int = 0
    reason: str = ""

    @property
    def solved(self) -> bool:
        return self.status == "solved"


def check_names(search: str, heuristic: str | None) -> None:
    if search not in SEARCHES:
        raise PlanningError(f"search: one of {', '.join(SEARCHES)}, got {search!r}")
    if search != "bfs" and heuristic is not None and heuristic not in HEURISTICS:
        raise PlanningError(f"heuristic: one of {', '.join(HEURISTICS)}, got {heuristic!r}")


def search_task(
    task: IndexedTask,
    search: str = "gbf",
    heuristic: str | Callable[[Task], Any] = "hff",
    time_limit: float = 5.0,
    cancel: CancelFlag | None = None,
) -> PlanResult:
    """Run a pyperplan search on ``task``: solved, unsolvable, timeout or cancelled."""
    check_names(search, heuristic if isinstance(heuristic, str) else None)
    started = time.monotonic()
    task.deadline, task.cancel, task.expansions = started + time_limit, cancel, 0
    try:
        if search == "bfs":
            plan = breadth_first_search(task)
        else:
            h = HEURISTICS[heuristic](task) if isinstance(heuristic, str) else heuristic(task)
            plan = SEARCHES[search](task, h)
    except SearchStopped as stop:
        return stopped(stop, started, task.expansions)
    return finished(plan, started, task.expansions)


def stopped(stop: SearchStopped, started: float, expansions: int) -> PlanResult:
    """The result of a search stopped by its deadline, budget or a cancel."""
    ms = (time.monotonic() - started) * 1e3
    return PlanResult(stop.status, [], ms, expansions, f"search {stop.status} after {ms:.0f} ms")


def finished(plan: Sequence[Operator] | None, started: float, expansions: int) -> PlanResult:
    """The result of a search that ran to its end (``plan``: its operators, or ``None``)."""
    ms = (time.monotonic() - started) * 1e3
    if plan is None:
        return PlanResult("unsolvable", [], ms, expansions, "no plan reaches the goal")
    return PlanResult("solved", [op.name for op in plan], ms, expansions)


def plan_pddl(
    domain_pddl: str,
    problem_pddl: str,
    search: str = "gbf",
    heuristic: str = "hff",
    time_limit: float = 5.0,
) -> tuple[IndexedTask, PlanResult]:
    """The naive path: parse, ground and search from PDDL strings."""
    check_names(search, heuristic)
    task = parse_and_ground(domain_pddl, problem_pddl)
    return task, search_task(task, search, heuristic, time_limit)


def validate_plan(task: Task, plan: Sequence[str]) -> tuple[bool, str]:
    """Simulate ``plan`` (operator names) on the grounded task from its initial state."""
    by_name = {op.name: op for op in task.operators}
    state = task.initial_state
    for step, name in enumerate(plan):
        op = by_name.get(name)
        if op is None:
            return False, f"step {step}: {name} is not an operator of the task"
        if not op.applicable(state):
            return False, f"step {step}: {name} is not applicable"
        state = op.apply(state)
    if not task.goal_reached(state):
        return False, "the plan ends without reaching the goal"
    return True, "valid"
