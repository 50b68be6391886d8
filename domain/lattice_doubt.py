"""Whether a goal is out of reach before any search (a planner's ``doubt``), told exactly when
the search and the reachability test after it would end in ``unreachable``.

A clearance tier that found a goal unreachable at the last replan usually still does (a
corridor closed on a guess stays closed); asking the reachability test (domain/lattice_reach.py)
first spares the search that would fail before the same test. The test's relaxation holds
every motion that keeps the margin, but motions out of the start keep only the start's
allowance (the robot may touch something after a contact), and from a start that touches
something the test starts from a free configuration beside it, maybe in a pocket the first
motion leaves. So the answer is "apart" only when the test says so from the start (as it would
after the search) and from every state a free first motion leads to; a goal within one
motion's reach is left to the search.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from domain.goal_order import LegGoal
from domain.lattice import Key, LatticeGrid, MotionTable
from domain.lattice_reach import Reachability
from domain.lattice_repair import leg_reach


def within_one_motion(grid: LatticeGrid, table: MotionTable, start: Key, goal: LegGoal) -> bool:
    """Whether one motion of ``table``'s body from ``start`` might bring its head onto ``goal``
    (such a plan may end where only the start's allowance holds, which the test does not
    grant: the search is asked first)."""
    here = grid.centre(*start[:2])
    return math.dist(here, (goal.x, goal.y)) <= (
        table.reach + leg_reach(goal) + grid.settings.resolution
    )


def apart(
    answers: Reachability, start: Key, goal: LegGoal, first_moves: Callable[[], list[Key]]
) -> bool:
    """Whether the reachability test keeps ``goal`` apart from ``start`` and from every
    state a free motion out of it leads to (``first_moves``, asked only when needed): no
    plan from ``start`` can bring the head there, whose first motion keeps only the start's
    allowance."""
    at, reach = (goal.x, goal.y), leg_reach(goal)
    return not answers.reaches(start, at, reach) and not answers.reaches_after(
        first_moves(), at, reach
    )
