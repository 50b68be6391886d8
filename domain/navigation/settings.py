"""Every behavioural parameter of navigation, with its unit and reason, in one typed object.

``NavigationSettings`` groups them by concept: the lattice (resolution, headings, margins), what
a motion costs, the search, the recoveries and the plan follower; ``costmap`` holds the world
model's. Sizes of buffers and caches stay constants where they live: they change speed, never a
plan.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

from domain.world.settings import CostmapSettings


def _check_finite(obj: object, what: str) -> None:
    for f in fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, f.name)
        if isinstance(value, float) and not math.isfinite(value):
            raise ValueError(f"{what}: {f.name} must be finite")


@dataclass(frozen=True)
class CostSettings:
    """What a motion costs, in metres: its length, more where it passes close to lethal
    obstacles, plus metres per contact it risks by sweeping space blind (Nav2's inflation and
    cost penalty, with the risk measured on the body's own swept cells)."""

    inflation_radius: float = 0.25
    """metres of slack (clearance beyond the body's need and the margin) past which closeness
    costs nothing"""
    inflation_decay: float = 0.05
    """metres in which the closeness cost falls by e (Nav2's 1 / cost_scaling_factor)"""
    inflation_penalty: float = 1.0
    """a motion whose body passes at zero slack costs (1 + this) times its length"""
    contact_cost: float = 10.0
    """metres a plan would go round to avoid one expected contact"""
    reverse_penalty: float = 1.0
    """a move the tail leads costs (1 + this) times its length, a sideways one (1 + this / 2):
    the head's rays look where the head goes (Smac's reverse penalty)"""
    narrow_weight: float = 10.0
    """how many times a metre costs the heuristic where the body's centroid cannot keep the
    margin (a passage only a turned or a rounded body might pass): the search tries the roomy
    way first"""
    cramped_weight: float = 5.0
    """how many times a metre costs the heuristic where the body keeps the margin but has no
    room to change its heading (the resting body's farthest point would sweep the margin in
    one heading step): a straight narrow passage is still taken, a bent one only when
    nothing roomier leads there"""
    blocked_cost: float = 3.0
    """metres a plan would go round to avoid a move that would find its way blocked: the
    approach that sensing then stops, the way back out and a replan (a few body lengths)"""
    sensing_horizon: float = 1.5
    """metres from the robot within which never-observed space behind the head's tip carries
    its whole prior risk (the head's ring reaches 1.5 m: what lies within it, beside or behind
    the body, may be swept before anything looks at it) ..."""
    beyond_horizon: float = 0.2
    """... and the share of that risk it carries farther out or ahead of the head: a way
    there, mostly head first, will have looked at most of it by the time the body arrives
    (pricing it whole makes every distant turn dear and the search wide, and a turn ahead
    as dear as one where the robot stands; 1 prices it whole)"""

    def __post_init__(self) -> None:
        _check_finite(self, "cost settings")
        if not (self.inflation_radius >= 0 and self.inflation_decay > 0):
            raise ValueError("cost settings: inflation_radius >= 0 and inflation_decay > 0")
        if (
            min(self.inflation_penalty, self.contact_cost, self.blocked_cost, self.reverse_penalty)
            < 0
            or min(self.narrow_weight, self.cramped_weight) < 1
        ):
            raise ValueError("cost settings: penalties must be >= 0")
        if not (self.sensing_horizon >= 0 and 0 <= self.beyond_horizon <= 1):
            raise ValueError("cost settings: sensing_horizon >= 0, beyond_horizon in [0, 1]")


@dataclass(frozen=True)
class SearchSettings:
    """The one search: weighted A* over the lattice with one expansion budget."""

    weight: float = 2.0
    """f = g + weight * h: above 1 trades optimality for fewer expansions"""
    stalled_weight: float = 5.0
    """the weight a search goes on at once ``stall_after`` expansions found no plan (every
    open entry re-keyed: ``search.kernel.Stall``); ``weight`` to keep one weight"""
    stall_after: int = 5_000
    """expansions at the first weight before a search goes on at ``stalled_weight``"""
    expansions: int = 50_000
    """expansions per leg before the search returns its best node (a budget, not seconds: the
    same mission and seed plan the same on any machine)"""
    progress: float = 0.25
    """metres closer (by the heuristic) than the start the best node must be to be a partial
    plan worth running"""
    start_free: float = 0.15
    """metres round the start centroid the heuristic's map always lets through (the body may
    rest closer to something than its margin: it must still be able to leave)"""
    flood_first: int = 20_000
    """configurations the relaxed body's flood (``navigation.feasibility``) may meet before a
    leg's search: a goal it proves out of reach needs no search; one it leaves undecided (two
    large sides, as in a maze) is searched, and the whole check follows a spent budget"""
    reach_states: int = 1_000_000
    """states the lattice's own connectivity check (``search.reach``) may walk from each side
    (the start's and the goal's, in turns) when the budget ran out, before "no plan within the
    budget" is all that can be said"""
    exported_states: int = 1000
    """states of each leg's search its PDDL problem lists: the first expanded (A*'s order:
    round the start and along the way) and every state of the plan; bounds what each plan
    version keeps and writes however long the search ran"""

    def __post_init__(self) -> None:
        _check_finite(self, "search settings")
        if not 1 <= self.weight <= self.stalled_weight:
            raise ValueError("search settings: 1 <= weight <= stalled_weight")
        if self.stall_after < 1:
            raise ValueError("search settings: stall_after must be >= 1")
        if self.expansions < 1 or self.progress < 0:
            raise ValueError("search settings: expansions >= 1 and progress >= 0")
        if min(self.exported_states, self.reach_states, self.flood_first) < 1:
            raise ValueError(
                "search settings: exported_states, reach_states and flood_first must be >= 1"
            )


@dataclass(frozen=True)
class RecoverySettings:
    """The behaviour tree's recoveries (back off, spin to sense, reshape, clear evidence)."""

    retries: int = 6
    """recoveries in a row, with no progress between them, before the goal is given up"""
    settle_distance: float = 0.3
    """metres the robot, following a plan, must get from where the last recovery left it for
    the recoveries in a row to count from zero again (progress: three back-offs' worth, so
    backing off a contact and driving into it again is none)"""
    back_off_steps: int = 2
    """short library translations away from a contact, or out of a blocked start"""
    clear_radius: float = 1.0
    """metres round the robot where stale evidence is cleared (sensing refills what is real)"""
    wait_ticks: int = 4
    """control ticks the robot holds still after clearing, so the sensors read again"""
    reshape_rate: float = 0.5
    """rad per model second the joints are given to turn in a commanded shape change"""

    def __post_init__(self) -> None:
        _check_finite(self, "recovery settings")
        if min(self.retries, self.back_off_steps, self.wait_ticks) < 0:
            raise ValueError("recovery settings: counts must be >= 0")
        if not (self.clear_radius > 0 and self.settle_distance > 0):
            raise ValueError("recovery settings: clear_radius and settle_distance must be positive")


@dataclass(frozen=True)
class FollowSettings:
    """How the executor follows a plan and watches the body."""

    off_plan: float = 0.3
    """metres from a planned state past which a finished move is no progress (replan)"""
    off_plan_turn: float = math.radians(35)
    """... or radians of heading"""
    arrive_tries: int = 4
    """final approaches to one goal before the plan is given up"""
    lookahead: int = 16
    """plan steps the guard re-checks against the lethal layer when it changes"""
    shape_tolerance: float = 0.1
    """radians between sensed and commanded joints beyond which the body was deformed"""
    no_progress_time: float = 120.0
    """model seconds in which the body must move ``progress_radius`` (or turn
    ``progress_turn``) or the mission gives up (Nav2's progress checker)"""
    progress_radius: float = 0.1
    """metres the tracked point must move for progress"""
    progress_turn: float = math.radians(20)
    """... or radians the heading must turn"""

    def __post_init__(self) -> None:
        _check_finite(self, "follow settings")
        if (
            min(
                self.off_plan,
                self.off_plan_turn,
                self.shape_tolerance,
                self.progress_radius,
                self.progress_turn,
            )
            <= 0
        ):
            raise ValueError("follow settings: distances and tolerances must be positive")
        if self.arrive_tries < 1 or self.lookahead < 1 or not self.no_progress_time > 0:
            raise ValueError("follow settings: arrive_tries, lookahead >= 1, no_progress_time > 0")


@dataclass(frozen=True)
class NavigationSettings:
    """The lattice, what its motions cost, how it is searched, recovered and followed."""

    resolution: float = 0.05
    """metres per centroid cell (the costmap's cells)"""
    orientations: int = 64
    """headings per turn (5.625° apart)"""
    margin: float = 0.02
    """metres the swept footprint keeps from anything lethal"""
    start_margin: float = 0.0
    """margin of motions out of the start (the robot may rest closer: it just stopped)"""
    touch_radius: float = 0.15
    """metres round a resting body point closer than ``start_margin`` to something within
    which motions out of the start may keep as close as that point already is ..."""
    touch_deeper: float = 0.005
    """... less this (m): the body moves off what it touches, never in deeper"""
    costs: CostSettings = field(default_factory=CostSettings)
    search: SearchSettings = field(default_factory=SearchSettings)
    recovery: RecoverySettings = field(default_factory=RecoverySettings)
    follow: FollowSettings = field(default_factory=FollowSettings)
    costmap: CostmapSettings = field(default_factory=CostmapSettings)

    def __post_init__(self) -> None:
        _check_finite(self, "navigation settings")
        if not (0.01 <= self.resolution <= 0.5):
            raise ValueError("resolution: must lie within [0.01, 0.5] m")
        if self.orientations < 16 or self.orientations % 4:
            raise ValueError("orientations: need at least 16, a multiple of 4")
        if not (0 <= self.margin <= 0.2 and 0 <= self.start_margin <= self.margin):
            raise ValueError("margin: must lie within [0, 0.2] m and start_margin <= margin")
        if abs(self.costmap.resolution - self.resolution) > 1e-12:
            raise ValueError("resolution: the lattice and the costmap share their cells")

    @property
    def step(self) -> float:
        """Radians between neighbouring headings."""
        return 2 * math.pi / self.orientations
