"""The navigation domain: move(from, to, heading, shape) over a roadmap, goals as visits.

``NavigationPlanner`` writes the PDDL (for export and for other planners) and, for speed,
grounds the same task directly from the roadmap instead of asking pyperplan to enumerate
every parameter combination (tests check that both groundings are identical). The grounded
operators are kept between replans; a replan only changes what changed: blocked edges, the
start node, the body shape and the remaining goals. pyperplan's searches then run on it,
with its heuristics or the roadmap heuristic below.
"""

from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray
from pyperplan.heuristics.heuristic_base import Heuristic
from pyperplan.task import Operator

from domain.actions import PlannedAction, describe_grounding, groundable_headings
from domain.knowledge import Goal, WorldKnowledge
from domain.navigation_domain import navigation_domain
from domain.pddl import Problem, heading_name
from domain.pyperplan_adapter import (
    IndexedTask,
    PlanResult,
    check_names,
    make_facts,
    search_task,
    validate_plan,
)
from domain.roadmap import Roadmap
from primitives.library import Library
from sim.obstacles import Obstacle

HEADINGS = [0.0, 45.0, 90.0, 135.0, 180.0, -135.0, -90.0, -45.0]
START = "s0"


class RoadmapHeuristic(Heuristic):  # type: ignore[misc]
    """Hop distances on the roadmap, precomputed from every goal by breadth-first search.

    Ordered goals: distance to the next goal plus the legs between the rest (exact on the
    roadmap). Any order: a nearest-neighbour tour for greedy search, or the distance to the
    farthest remaining goal when ``admissible`` (for A*). Plus one visit action per goal.
    """

    def __init__(self, planner: NavigationPlanner, admissible: bool) -> None:
        self.p = planner
        self.admissible = admissible

    def __call__(self, node: Any) -> float:
        p, state = self.p, node.state
        at = next((p.at_node[f] for f in state if f in p.at_node), None)
        if at is None:
            return math.inf
        if p.ordered:
            stage = next((p.stage_index[f] for f in state if f in p.stage_index), len(p.goal_nodes))
            left = list(range(stage, len(p.goal_nodes)))
            if not left:
                return 0.0
            total = p.hops[left[0]][at]
            for a, b in itertools.pairwise(left):
                total += p.hops[b][p.goal_nodes[a]]
            return float(total + len(left))
        left = [j for j, f in enumerate(p.visited_facts) if f not in state]
        if not left:
            return 0.0
        if self.admissible:
            return float(max(p.hops[j][at] for j in left) + len(left))
        total, here, todo = 0.0, at, set(left)
        while todo:
            j = min(todo, key=lambda k: (p.hops[k][here], k))
            total += p.hops[j][here]
            here = p.goal_nodes[j]
            todo.remove(j)
        return float(total + len(left))


@dataclass
class NavigationPlan:
    result: PlanResult
    actions: list[PlannedAction]
    domain_pddl: str = ""
    problem_pddl: str = ""
    timings: dict[str, float] = field(default_factory=dict)

    @property
    def pddl_plan(self) -> list[str]:
        return [a.pddl for a in self.actions]


class NavigationPlanner:
    """Plans tours of goals over a roadmap and replans incrementally as knowledge changes."""

    def __init__(
        self,
        knowledge: WorldKnowledge,
        library: Library,
        spacing: float = 0.5,
        inflation: float = 0.3,
        search: str = "gbf",
        heuristic: str = "roadmap",
        time_limit: float = 5.0,
        body_margin: float = 0.05,
    ) -> None:
        check_names(search, None if heuristic == "roadmap" else heuristic)
        self.library = library
        self.search, self.heuristic, self.time_limit = search, heuristic, time_limit
        self.bounds = knowledge.bounds
        self.roadmap = Roadmap.grid(knowledge.bounds, spacing, knowledge.known, inflation)
        self.applied: list[Obstacle] = list(knowledge.known)
        self.active = np.ones(self.roadmap.edge_count, dtype=bool)
        self.goal_node_of: dict[tuple[float, float], int] = {}
        self.knowledge = knowledge
        self.body_margin = body_margin
        self._body_key: tuple[float, ...] | None = None
        self._body_checked = 0
        self.body_ok = np.ones(self.roadmap.edge_count, dtype=bool)
        self._edge_ops: dict[str, list[Operator]] = {}
        self.task: IndexedTask | None = None
        self.last: NavigationPlan | None = None

    # -- naming ------------------------------------------------------------------------------
    def node_name(self, node: int) -> str:
        if node == self.start_node:
            return START
        if node >= self.roadmap.grid_size:
            return f"g{node - self.roadmap.grid_size}"
        return f"w{node}"

    # -- building the grounded task ------------------------------------------------------------
    def _goal_node(self, goal: Goal) -> int:
        key = (goal.x, goal.y)
        if key not in self.goal_node_of:
            before = self.roadmap.edge_count
            node = self.roadmap.add_node(goal.x, goal.y, self.applied, self.bounds)
            self.goal_node_of[key] = node
            self.active = np.concatenate(
                [self.active, np.ones(self.roadmap.edge_count - before, bool)]
            )
            self._edge_ops.clear()
        return self.goal_node_of[key]

    def _block(self, obstacles: tuple[Obstacle, ...]) -> None:
        for ob in obstacles:
            if not any(ob is seen for seen in self.applied):
                self.active[self.roadmap.edges_blocked_by(ob)] = False
                self.applied.append(ob)

    def _prepare(self, knowledge: WorldKnowledge) -> None:
        """Bring the roadmap, facts and operators up to date with ``knowledge``."""
        self.knowledge = knowledge
        self.goal_nodes = [self._goal_node(g) for g in knowledge.goals]  # may extend the roadmap
        self._block(knowledge.obstacles)
        self._body_mask(knowledge)
        self.start_node = len(self.roadmap.points)
        x, y, psi = knowledge.pose
        self.start_links = self.roadmap.links(x, y, self.applied, self.bounds, escape=True)
        self.ordered = knowledge.order == "given"
        self.psi_deg = math.degrees(psi)
        self.headings = groundable_headings(self.library, knowledge.shape, self.psi_deg, HEADINGS)

        n_nodes = self.start_node + 1
        names = [f"(at {self.node_name(v)})" for v in range(n_nodes)]
        if self.ordered:
            names += [f"(stage k{k})" for k in range(len(self.goal_nodes) + 1)]
        else:
            names += [f"(visited {self.node_name(n)})" for n in self.goal_nodes]
        if self.task is None or self.task.names != names:
            self.facts = make_facts(names)
            self._edge_ops.clear()
        facts = self.facts
        self.at_node = {facts[i]: i for i in range(n_nodes)}
        extra = facts[n_nodes:]
        self.stage_index = {f: k for k, f in enumerate(extra)} if self.ordered else {}
        self.visited_facts = [] if self.ordered else list(extra)
        usable = self.active & self.body_ok
        ops = [op for e, op in self._edge_operators(knowledge.shape) if usable[e]]
        ops += self._start_operators(knowledge.shape)
        ops += self._visit_operators()
        ops.sort(key=lambda op: op.name)
        if self.ordered:
            init, goals = [facts[self.start_node], extra[0]], [extra[-1]]
        else:
            init, goals = [facts[self.start_node]], list(self.visited_facts)
        if self.task is None or self.task.names != self.facts:
            self.task = IndexedTask("navigation", self.facts, init, goals, ops)
        else:
            self.task.initial_state, self.task.goals = frozenset(init), frozenset(goals)
            self.task.set_operators(ops)
        adjacency = self._adjacency()
        self.hops = [self.roadmap.hops_from(g, adjacency, n_nodes) for g in self.goal_nodes]

    def _body_mask(self, knowledge: WorldKnowledge) -> None:
        """Edges the whole body can travel at the current heading and joints (when known).

        Recomputed when the heading turns by more than 5°, the joints change or obstacles
        are added; otherwise kept.
        """
        if knowledge.joints is None:
            self.body_ok = np.ones(self.roadmap.edge_count, dtype=bool)
            return
        psi = knowledge.pose[2]
        key = (
            round(math.degrees(psi) / 5),
            *np.round(knowledge.joints, 2),
            self.roadmap.edge_count,
        )
        joints = np.asarray(knowledge.joints)
        if key != self._body_key:
            self.body_ok = self.roadmap.body_clear_edges(
                psi, joints, self.applied, self.bounds, self.body_margin
            )
            self._body_key, self._body_checked = key, len(self.applied)
        elif self._body_checked < len(
            self.applied
        ):  # same pose class: check only the new obstacles
            new = self.applied[self._body_checked :]
            self.body_ok &= self.roadmap.body_clear_edges(
                psi, joints, new, self.bounds, self.body_margin
            )
            self._body_checked = len(self.applied)

    def _move(self, a: int, b: int, heading: float, shape: str) -> Operator:
        name = f"(move {self.node_name(a)} {self.node_name(b)} {heading_name(heading)} {shape})"
        return Operator(name, [self.facts[a]], [self.facts[b]], [self.facts[a]])

    def _edge_operators(self, shape: str) -> list[tuple[int, Operator]]:
        """Move operators of every roadmap edge in ``shape``, built once per shape and heading set."""
        key = f"{shape}:{self.headings}"
        if key not in self._edge_ops:
            ok = set(self.headings)
            road = self.roadmap
            self._edge_ops = {
                key: [
                    (e, self._move(road.starts[e], road.ends[e], road.headings[e], shape))
                    for e in range(road.edge_count)
                    if road.headings[e] in ok
                ]
            }
        return self._edge_ops[key]

    def _start_operators(self, shape: str) -> list[Operator]:
        ok = set(self.headings)
        return [self._move(self.start_node, n, h, shape) for n, h in self.start_links if h in ok]

    def _visit_operators(self) -> list[Operator]:
        ops = []
        for j, node in enumerate(self.goal_nodes):
            g, at = self.node_name(node), self.facts[node]
            if self.ordered:
                k0, k1 = self.facts[self.start_node + 1 + j], self.facts[self.start_node + 2 + j]
                ops.append(Operator(f"(visit-next {g} k{j} k{j + 1})", [at, k0], [k1], [k0]))
            else:
                ops.append(Operator(f"(visit {g})", [at], [self.visited_facts[j]], []))
        return ops

    def _adjacency(self) -> dict[int, list[int]]:
        adjacency = self.roadmap.adjacency(self.active & self.body_ok & self._heading_mask())
        for n, h in self.start_links:  # both ways: hops are measured from the goals outwards
            if h in self.headings:
                adjacency.setdefault(self.start_node, []).append(n)
                adjacency.setdefault(n, []).append(self.start_node)
        return adjacency

    def _heading_mask(self) -> NDArray[np.bool_]:
        ok = set(self.headings)
        return np.array([h in ok for h in self.roadmap.headings], dtype=bool)

    # -- planning ------------------------------------------------------------------------------
    def plan(self, knowledge: WorldKnowledge, cancel: Any = None) -> NavigationPlan:
        t0 = time.perf_counter()
        self._prepare(knowledge)
        t1 = time.perf_counter()
        assert self.task is not None
        unreachable = [
            j for j, hops in enumerate(self.hops) if not np.isfinite(hops[self.start_node])
        ]
        if unreachable and self.ordered:
            unreachable = unreachable[:1]
        if unreachable:
            g = knowledge.goals[unreachable[0]]
            reason = (
                f"goal {unreachable[0]} at ({g.x:g}, {g.y:g}) cannot be reached: no free path on the "
                f"roadmap (spacing {self.roadmap.spacing:g} m, obstacles inflated by {self.roadmap.inflation:g} m)"
            )
            result = PlanResult("unsolvable", [], 0.0, 0, reason)
        else:
            if self.heuristic == "roadmap":
                admissible = self.search == "astar"
                result = search_task(
                    self.task,
                    self.search,
                    lambda t: RoadmapHeuristic(self, admissible),
                    self.time_limit,
                    cancel,
                )
            else:
                result = search_task(
                    self.task, self.search, self.heuristic, self.time_limit, cancel
                )
        t2 = time.perf_counter()
        actions = [self._describe(name) for name in result.plan]
        plan = NavigationPlan(
            result, actions, timings={"prepare_ms": (t1 - t0) * 1e3, "search_ms": (t2 - t1) * 1e3}
        )
        self.last = plan
        return plan

    def validate(self, plan: NavigationPlan) -> tuple[bool, str]:
        assert self.task is not None
        return validate_plan(self.task, plan.result.plan)

    def _describe(self, pddl: str) -> PlannedAction:
        name, *args = pddl.strip("()").split()
        if name == "move":
            target = self.roadmap.points[self._node_of(args[1])] if args[1] != START else None
            heading = float(next(h for h in HEADINGS if heading_name(h) == args[2]))
            shape = args[3]
            grounding = describe_grounding(self.library, shape, heading, self.psi_deg)
            xy = None if target is None else (float(target[0]), float(target[1]))
            return PlannedAction(name, tuple(args), heading, shape, xy, grounding)
        node = self._node_of(args[0])
        goal = self.goal_nodes.index(node)
        point = self.roadmap.points[node]
        return PlannedAction(
            name, tuple(args), target=(float(point[0]), float(point[1])), goal=goal
        )

    def _node_of(self, name: str) -> int:
        if name == START:
            return self.start_node
        if name.startswith("g"):
            return self.roadmap.grid_size + int(name[1:])
        return int(name[1:])

    # -- export --------------------------------------------------------------------------------
    def problem(self) -> Problem:
        """The current problem as PDDL (valid for other planners; blocked edges left out)."""
        road, k = self.roadmap, self.knowledge
        waypoints = [self.node_name(v) for v in range(self.start_node + 1)]
        init = [f"(at {START})", f"(body {k.shape})"]
        init += [f"(groundable {heading_name(h)} {k.shape})" for h in self.headings]
        for e in np.flatnonzero(self.active & self.body_ok):
            init.append(
                f"(edge {self.node_name(road.starts[e])} {self.node_name(road.ends[e])} {heading_name(road.headings[e])})"
            )
        init += [
            f"(edge {START} {self.node_name(n)} {heading_name(h)})" for n, h in self.start_links
        ]
        goal_names = [self.node_name(n) for n in self.goal_nodes]
        if self.ordered:
            stages = [f"k{i}" for i in range(len(goal_names) + 1)]
            init += ["(stage k0)"]
            init += [f"(goal-at k{i} {g})" for i, g in enumerate(goal_names)]
            init += [f"(next k{i} k{i + 1})" for i in range(len(goal_names))]
            goal = [f"(stage k{len(goal_names)})"]
        else:
            stages = []
            init += [f"(goal-point {g})" for g in goal_names]
            goal = [f"(visited {g})" for g in goal_names]
        x, y, psi = k.pose
        comment = (
            f"start s0 = ({x:.3f}, {y:.3f}), psi = {math.degrees(psi):.1f} deg; shape {k.shape}; "
            f"goals {[(g.x, g.y) for g in k.goals]} ({k.order} order)\n"
            f"{int((~self.active).sum())} roadmap edges blocked by sensed obstacles"
        )
        objects = {
            "waypoint": waypoints,
            "heading": [heading_name(h) for h in HEADINGS],
            "shape": sorted(set(self.library.shapes()) | {k.shape}),
            "stage": stages,
        }
        return Problem("navigation", "screwsnake-navigation", objects, init, goal, comment)

    def export(self) -> tuple[str, str]:
        return navigation_domain().text(), self.problem().text()
