"""Replanning on typed triggers, recording trigger, old and new plan and latency."""

from __future__ import annotations

import time
from typing import Any

from domain.knowledge import WorldKnowledge
from domain.navigation import NavigationPlan, NavigationPlanner
from domain.pyperplan_adapter import PlanResult, plan_pddl
from domain.triggers import Initial, ReplanRecord, Trigger


class Replanner:
    """Keeps one ``NavigationPlanner`` (and its grounded task) for a mission's lifetime."""

    def __init__(self, planner: NavigationPlanner) -> None:
        self.planner = planner
        self.history: list[ReplanRecord] = []
        self.current: NavigationPlan | None = None

    def plan(
        self,
        knowledge: WorldKnowledge,
        trigger: Trigger | None = None,
        at: float = 0.0,
        cancel: Any = None,
    ) -> tuple[NavigationPlan, ReplanRecord]:
        trigger = trigger or Initial()
        old = self.current.pddl_plan if self.current else []
        t0 = time.perf_counter()
        plan = self.planner.plan(knowledge, cancel)
        latency = (time.perf_counter() - t0) * 1e3
        record = ReplanRecord(
            trigger.kind, trigger.detail(), at, latency, old, plan.pddl_plan, plan.result.status
        )
        self.history.append(record)
        self.current = plan
        return plan, record


def naive_replan(
    planner: NavigationPlanner,
    search: str = "gbf",
    heuristic: str = "hff",
    time_limit: float = 30.0,
) -> tuple[PlanResult, dict[str, float]]:
    """The naive path for comparison: export PDDL, re-parse and re-ground with pyperplan, search."""
    t0 = time.perf_counter()
    domain, problem = planner.export()
    t1 = time.perf_counter()
    _, result = plan_pddl(domain, problem, search, heuristic, time_limit)
    t2 = time.perf_counter()
    ground_ms = (t2 - t1) * 1e3 - result.search_ms
    return result, {
        "export_ms": (t1 - t0) * 1e3,
        "parse_ground_ms": ground_ms,
        "search_ms": result.search_ms,
    }
