"""The PDDL a mission stores: every plan version is valid on its own stored domain and problem.

The stored lattice PDDL carries ``:action-costs``; pyperplan reads plain STRIPS, so the check
here reads the stored text without its costs (and checks that this is the plain domain the
exporter writes); the costed text is checked by peer planners in tests/domain."""

import re

from app.executor.runner import run_mission
from app.missions.spec import MissionSpec
from domain.navigation import lattice_domain_text
from domain.pyperplan_adapter import validate_plan_text
from primitives.library import load_bundled


def without_costs(text: str) -> str:
    """Stored PDDL less its action costs: requirement, functions, cost effects, cost facts and
    the metric."""
    text = text.replace(" :action-costs", "")
    text = re.sub(r"\n  \(:functions [^\n]*\)", "", text)
    text = text.replace(" (increase (total-cost) (move-cost ?a ?b ?p))", "")
    text = re.sub(r"\n    \(= \([^()]*\) \d+\)", "", text)
    return text.replace("\n  (:metric minimize (total-cost))", "")


def test_every_stored_plan_of_a_tour_validates_on_its_stored_problem() -> None:
    spec = MissionSpec.model_validate(
        {
            "order": "any",
            "goals": [{"x": -1.0, "y": -1.0}, {"x": 1.0, "y": -1.0}],
            "bounds": {"xmin": -2, "xmax": 2, "ymin": -2, "ymax": 2},
            "obstacles": [
                {"type": "circle", "x": 0.0, "y": -0.3, "radius": 0.2, "known": True},
                # hidden, on the way between the goals: sensed, and planned round
                {"type": "circle", "x": -0.5, "y": -1.1, "radius": 0.15, "known": False},
            ],
        }
    )
    result = run_mission(spec, load_bundled())
    assert result.status == "succeeded", result.reason
    versions = [p for p in result.pddl if p["problem"]]
    assert len(versions) >= 2  # the first plan and at least one replan
    # The first plan is a tour of both goals, and its problem asks for both.
    first = versions[0]
    assert first["problem"].count("(visited g") == 2
    assert sum(step.startswith("(visit ") for step in first["plan"]) == 2
    for version in versions:
        assert version["domain"] == lattice_domain_text()  # with action costs
        assert "(:metric minimize (total-cost))" in version["problem"]
        domain = without_costs(version["domain"])
        assert domain == lattice_domain_text(costs=False)
        problem = without_costs(version["problem"])
        assert validate_plan_text(domain, problem, version["plan"]) == (True, "valid")
    # and the check can fail: a plan cut short, or a step from a state the robot is not in
    plan, problem = versions[0]["plan"], without_costs(versions[0]["problem"])
    ok, why = validate_plan_text(domain, problem, plan[:-1])
    assert not ok and why == "the plan ends without reaching the goal"
    ok, why = validate_plan_text(domain, problem, plan[1:])
    assert not ok and why.startswith("step 0:") and "not applicable" in why
