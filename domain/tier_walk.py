"""Which clearance tier's plan the robot runs: the tiers tried in turn, strictest first.

Suspected surfaces (where a touched one probably goes on) are kept clear of while a way round
them exists; only if none does are they passed closely near the goals, then planned through;
contacts are kept far from while that finds a plan, then only just (``clearance_tiers``).

A tier whose short search finds nothing closer has not shown that no way round exists, only
that none is near. Before its long search (up to ``SEARCH_AGAIN`` expansions), the looser
tiers' short searches are asked for a whole plan: behind a suspected surface that closes a
corridor on a guess, the long search of the strict tier used to spend 40,000 expansions
(0.3-0.5 s) failing, and the robot then spun in place to sense up to three times before the
looser tier was tried at all. The strategy asks for long searches only after a turn to
sense (``NavigationStrategy._plan``).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from domain.clearance_tiers import Tier, tier_clearance, tiers
from domain.grid_clearance import GridClearance
from domain.lattice import MotionTable
from domain.lattice_plan import LatticeAction, LatticePlan
from domain.lattice_planner import LatticePlanner
from domain.lattice_repair import leg_reach
from domain.pyperplan_adapter import CancelFlag
from domain.strategy import Situation

# Configurations the reachability flood may meet when pruning a shape before it hands the
# question to the labelling: each shape is asked once (no later question reuses its labels),
# and an enclosed goal's pen of some 60,000 configurations is flooded in about 17 ms where
# labelling a 10 m arena's 2.56 million takes about 44 ms.
PRUNING_FLOOD = 100_000


class TierWalk:
    """Plans through the clearance tiers in turn; remembers which ones found the goal
    unreachable, so that the next replan doubts them (``LatticePlanner.plan(doubt=...)``)."""

    def __init__(self, planner: LatticePlanner) -> None:
        self.planner = planner
        # (shape, tier) whose plan was unreachable at the last replan that tried it: the next
        # asks the reachability test before searching (a corridor closed on a guess stays so)
        self._closed: set[tuple[str, Tier]] = set()

    def plan(
        self,
        table: MotionTable,
        s: Situation,
        pose: Any,
        cancel: CancelFlag | None,
        remaining: Sequence[LatticeAction] = (),
        long: bool = True,
        probed: bool = False,
    ) -> tuple[LatticePlan, GridClearance]:
        """A lattice plan from ``pose`` (a repair of ``remaining``, the rest of the last plan,
        where one will do) and the clearance of the tier it keeps (what the plan guard checks
        it against). A timeout is returned when no tier found a plan and some tier ran out of
        search: the robot turns to sense around instead of passing closer still. ``long``:
        a tier whose short search finds nothing near (nor a looser tier a whole plan) searches
        again, longer; without it that tier's timeout is the answer (the strategy turns to
        sense first: a long search on what one look showed mostly searches in vain). ``probed``:
        a walk without ``long`` from this same pose and world found nothing; each tier searches
        long at once (its long search begins with the same short search, and the looser tiers'
        short searches found no whole plan then either)."""
        world = s.world
        plan = LatticePlan("unsolvable")
        goals = tuple((g.x, g.y) for g in s.goals)
        reachable = False  # in the first tier: so in every later one, which keeps less
        order = tiers(world.any_suspected())
        for n, tier in enumerate(order):
            clearance = tier_clearance(world, tier, goals)
            looser = order[n + 1 :]
            # (not the last tier: its plan is the answer, and only a search tells an
            # exhausted lattice, ``unsolvable``, from ``unreachable``)
            closed = (table.shape, tier)
            doubt = closed in self._closed and bool(looser)
            searches = (True, False) if long else (True,)  # quick, then long
            if probed:
                searches = (False,)
            for quick in searches if looser else searches[-1:]:
                plan = self._ask(
                    table, s, pose, cancel, tier, clearance, quick, remaining, reachable, doubt
                )
                if not quick or plan.status != "timeout":
                    break
                found = self._whole_looser(table, s, pose, cancel, looser)
                if found is not None:
                    self._closed.discard(closed)  # (it timed out: not found unreachable)
                    return found
            if plan.status == "unreachable":
                self._closed.add(closed)
            else:
                self._closed.discard(closed)
            reachable = reachable or (n == 0 and plan.reachable)
            if plan.status not in ("unreachable", "unsolvable"):
                break  # a timeout turns to sense around instead (``NavigationStrategy._plan``)
        return plan, clearance

    def _whole_looser(
        self,
        table: MotionTable,
        s: Situation,
        pose: Any,
        cancel: CancelFlag | None,
        looser: Sequence[Tier],
    ) -> tuple[LatticePlan, GridClearance] | None:
        """The first looser tier whose short search finds a whole plan (a partial one would
        give up the stricter tier on a guess), with its clearance; ``None`` if none does."""
        goals = tuple((g.x, g.y) for g in s.goals)
        for tier in looser:
            if cancel is not None and cancel.is_set():
                return None
            clearance = tier_clearance(s.world, tier, goals)
            plan = self._ask(table, s, pose, cancel, tier, clearance, True)
            if plan.solved and not plan.partial:
                self._closed.discard((table.shape, tier))
                return plan, clearance
        return None

    def _ask(
        self,
        table: MotionTable,
        s: Situation,
        pose: Any,
        cancel: CancelFlag | None,
        tier: Tier,
        clearance: GridClearance,
        quick: bool,
        remaining: Sequence[LatticeAction] = (),
        reachable: bool = False,
        doubt: bool = False,
    ) -> LatticePlan:
        """One tier's plan (``LatticePlanner.plan``)."""
        world = s.world
        return self.planner.plan(
            table,
            clearance,
            (world.version, tier, tuple((g.x, g.y) for g in s.goals)),
            tuple(float(v) for v in pose),
            s.goals,
            s.ordered,
            cancel,
            static=(world.static_clearance_at, world.static_version),
            previous=remaining,
            reachable=reachable,
            family=tier,
            doubt=doubt,
            quick=quick,
        )

    def may_reach(
        self, table: MotionTable, s: Situation, pose: Any, cancel: CancelFlag | None = None
    ) -> bool:
        """``False`` when no plan of any tier can take this shape's body to every goal: the
        loosest tier's clearance is at least every other's everywhere, and its free resting
        configurations do not connect the start with some goal (``lattice_reach``)."""
        goals = tuple((g.x, g.y) for g in s.goals)
        loosest = tiers(s.world.any_suspected())[-1]
        clearance = tier_clearance(s.world, loosest, goals)
        version = (s.world.version, loosest, goals)
        if self.planner.cut_off(table, clearance, version, pose, s.goals, cancel):
            return False  # the centroid's distance map already says so (no 3-D labelling)
        reach = self.planner.reachability(table, clearance, version, loosest)
        start = self.planner.key_of(table, pose)
        return all(
            not (cancel is not None and cancel.is_set())  # cancelled: no shape is tried
            and reach.reaches(start, (g.x, g.y), leg_reach(g), flood_budget=PRUNING_FLOOD)
            for g in s.goals
        )
