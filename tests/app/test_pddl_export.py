"""The PDDL a mission stores: every plan version is valid on its own stored domain and problem."""

from app.executor.runner import run_mission
from app.missions.spec import MissionSpec
from domain.pyperplan_adapter import parse_and_ground, validate_plan
from primitives.library import load_bundled


def test_every_stored_plan_of_a_tour_validates_on_its_stored_problem() -> None:
    spec = MissionSpec.model_validate(
        {
            "order": "any",
            "goals": [{"x": -1.0, "y": -1.0}, {"x": 1.0, "y": -1.0}],
            "bounds": {"xmin": -2, "xmax": 2, "ymin": -2, "ymax": 2},
            "obstacles": [
                {"type": "circle", "x": 0.0, "y": -0.3, "radius": 0.2, "known": True},
                {"type": "circle", "x": -0.6, "y": -0.6, "radius": 0.15, "known": False},
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
        task = parse_and_ground(version["domain"], version["problem"])
        assert validate_plan(task, version["plan"]) == (True, "valid")
