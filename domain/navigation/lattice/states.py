"""Search states of the lattice that know their state number, one object per number.

pyperplan's searches keep states as frozensets of facts in dicts and heaps, so every state
handed out is hashed and compared. A lattice state is ``{(at s)}`` (or ``{(at s), (visited g)}``
once the goal is visited): ``LatticeState`` is that frozenset, equal to and hashing as the
plain one, with its number and whether the goal is visited attached, so a search never scans
a state for its ``at`` fact. ``StatePool`` hands out one object per state number, shared by
every task on a grid: a state met again (in the same search or a later one) is the same object,
its hash (which calls ``Fact.__hash__`` in Python) computed once.
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager
from itertools import islice

from domain.pyperplan_adapter import Fact

POOL_LIMIT = 100_000  # states kept per pool (~0.4 KB each); then the older half goes
FREEZE_AFTER = 100_000  # objects made during a pause past which the survivors are frozen
freezes = [0]  # how many pauses froze what they made (a worker collects after such a mission)


class LatticeState(frozenset[Fact]):
    """``{(at s)}`` or ``{(at s), (visited g)}`` with ``number`` (s) and ``visited``."""

    __slots__ = ("number", "visited")
    number: int
    visited: bool

    @classmethod
    def of(cls, facts: tuple[Fact, ...], number: int, visited: bool) -> LatticeState:
        state = cls(facts)
        state.number, state.visited = number, visited
        return state


def at_fact(number: int) -> Fact:
    """The fact ``(at s<number>)``."""
    return Fact(f"(at s{number})", number)


class StatePool:
    """One ``(at s)`` fact and one search state per lattice state number."""

    def __init__(self, limit: int = POOL_LIMIT) -> None:
        if limit < 1:
            raise ValueError("limit: at least 1 state")
        self.limit = limit
        self.states: dict[int, LatticeState] = {}

    def state(self, number: int) -> LatticeState:
        """The state ``{(at s<number>)}``."""
        state = self.states.get(number)
        if state is None:
            if len(self.states) >= self.limit:  # the older half goes: equal ones are made again
                for old in list(islice(self.states, max(1, len(self.states) // 2))):
                    del self.states[old]
            state = self.states[number] = LatticeState.of((at_fact(number),), number, False)
        return state

    def fact(self, number: int) -> Fact:
        """The fact ``(at s<number>)``."""
        return next(iter(self.state(number)))


@contextmanager
def no_cycle_collection(freeze_after: bool = False) -> Iterator[None]:
    """Python's cycle collector paused for a search (and resumed as it was). A search allocates
    hundreds of thousands of nodes, states and operators, none in a reference cycle (all are
    freed by reference counting), yet the allocations trigger full collections that walk every
    object of the process: a fifth of a long search's time in a mission worker.

    ``freeze_after``: what was made meanwhile and is still alive (a grounding of the whole
    lattice, kept for its search) goes to the collector's permanent generation if there is much
    of it (``gc.freeze``): the first collection after the pause would otherwise walk millions of
    objects, for up to a second, with a cancel waiting behind it. Reference counting still
    frees them; only a cycle among them would stay (none is made)."""
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if freeze_after and gc.get_count()[0] > FREEZE_AFTER:
            gc.freeze()
            freezes[0] += 1
        if enabled:
            gc.enable()
