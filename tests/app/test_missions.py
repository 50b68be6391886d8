"""Missions run on the simulator: every example succeeds, replanning, reproducibility, tree."""

import json
import math
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.executor.runner import MissionRunner, run_mission
from app.missions.spec import MissionFileError, MissionSpec, load_mission, parse_mission
from primitives.library import load_bundled

LIB = load_bundled()
EXAMPLES = sorted(Path(__file__).parents[2].joinpath("examples").glob("*.json"))


def run(spec: MissionSpec):
    return run_mission(spec, LIB)


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_every_example_mission_succeeds(path: Path) -> None:
    result = run(load_mission(path))
    assert result.status == "succeeded", result.reason
    assert result.collisions == 0
    for goal in result.goals:
        assert goal.reached and goal.error is not None and goal.error <= 0.10


def test_at_least_three_harder_examples_and_all_paper_missions() -> None:
    names = {p.stem for p in EXAMPLES}
    assert {"cluttered-field", "five-unordered-goals", "deform-while-avoiding"} <= names
    for fig in ("fig9a", "fig9b", "fig10", "fig11", "fig12", "fig13a", "fig13b", "fig13c"):
        assert any(n.startswith(fig) for n in names), fig


def test_hidden_obstacle_on_the_straight_path_forces_a_replan() -> None:
    spec = MissionSpec.model_validate(
        {
            "goals": [{"x": -3, "y": 0}],
            "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5},
            "obstacles": [{"type": "circle", "x": -1.5, "y": 0, "radius": 0.3, "known": False}],
        }
    )
    result = run(spec)
    assert result.status == "succeeded" and result.collisions == 0
    # the sensed obstacle broke the plan's precondition (its swept footprint), so it replanned
    assert any(r.trigger == "path_blocked" for r in result.replans)
    # the path really went round: it never came within the obstacle
    assert min(math.hypot(p[1] + 1.5, p[2]) for p in result.trajectory) > 0.3


def test_reactive_domain_replans_with_po2_or_po3_then_po1() -> None:
    result = run(load_mission(Path("examples/fig9b-obstacles.json")))
    plans = [p["plan"] for p in result.pddl]
    assert plans[0] == ["(po1 straight)"]
    assert any(
        p in (["(po2 straight)", "(po1 straight)"], ["(po3 straight)", "(po1 straight)"])
        for p in plans[1:]
    )


def test_same_mission_and_seed_give_the_same_trajectory() -> None:
    spec = load_mission(Path("examples/five-unordered-goals.json"))
    a, b = run(spec), run(spec)
    assert a.trajectory == b.trajectory and [r.new for r in a.replans] == [r.new for r in b.replans]


def test_deformation_switches_to_the_new_shapes_primitives() -> None:
    spec = load_mission(Path("examples/fig13b-deformation.json"))
    grounded = []
    runner = MissionRunner(
        spec,
        LIB,
        on_tick=lambda ctx, snap: grounded.append((ctx.t, ctx.shape, snap["grounding"])),
    )
    result = runner.run()
    assert result.status == "succeeded"
    assert any(e["kind"] == "deform" and e.get("shape") == "semi-zigzag" for e in result.events)
    after = [g for t, shape, g in grounded if t > 20 and g.get("primitives")]
    # every move after the deformation runs the new shape's lattice primitives
    assert after and all(
        all(p.startswith("lat-semi-zigzag-") for p in g["primitives"]) for g in after
    )
    assert all(g["method"] in ("library", "interpolated") for _, _, g in grounded if g)


def test_tree_snapshots_are_json_with_names_and_statuses() -> None:
    snaps = []
    spec = load_mission(Path("examples/fig9a-single-goal.json"))
    MissionRunner(spec, LIB, on_tick=lambda ctx, snap: snaps.append(snap)).run()
    first = snaps[0]
    json.dumps(first)
    tree = first["tree"]
    assert tree["name"] == spec.name and tree["status"] in (
        "RUNNING",
        "SUCCESS",
        "FAILURE",
        "INVALID",
    )
    names = json.dumps(tree)
    for part in ("sense", "guard: body shape", "guard: plan holds", '"plan"', "execute plan"):
        assert part in names
    for part in ("navigate with recovery", "RecoveryNode", "back off", "spin to sense"):
        assert part in names
    assert first["action"].startswith("(move") and first["pose"]["x"] <= 0.1


def test_chain_switches_on_a_sensor_threshold_with_timeout() -> None:
    spec = MissionSpec.model_validate(
        {
            "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5},
            "obstacles": [
                {"type": "rectangle", "x": -2.2, "y": 0, "width": 0.3, "height": 2, "known": False}
            ],
            "chain": [
                {"primitive": "P4s", "until": {"sensor": "ir", "below": 0.4, "timeout": 200}},
                {"primitive": "P8s", "until": {"duration": 30}},
            ],
        }
    )
    result = run(spec)
    assert result.status == "succeeded" and result.collisions == 0
    xs = [p[1] for p in result.trajectory]
    assert min(xs) > -2.05  # stopped before the wall by the sensor, then backed off
    assert xs[-1] > min(xs) + 0.2


def test_unreachable_goal_fails_with_a_reason_not_a_hang() -> None:
    walls = [
        {"type": "rectangle", "x": 3, "y": 3 + d, "width": 2.4, "height": 0.3} for d in (-1, 1)
    ]
    walls += [
        {"type": "rectangle", "x": 3 + d, "y": 3, "width": 0.3, "height": 2.4} for d in (-1, 1)
    ]
    spec = MissionSpec.model_validate({"goals": [{"x": 3, "y": 3}], "obstacles": walls})
    result = run(spec)
    assert result.status == "failed"
    assert result.reason == "unreachable: goal 0 at (3, 3) enclosed by known obstacles"


@pytest.mark.parametrize(
    ("patch", "field"),
    [
        ({"goals": []}, "goals"),
        ({"goals": [{"x": float("nan"), "y": 0}]}, "goals.0.x"),
        ({"goals": [{"x": 50, "y": 0}]}, "goals.0: outside the bounds"),
        (
            {
                "goals": [{"x": 0.5, "y": 0.5}],
                "obstacles": [{"type": "circle", "x": 0.5, "y": 0.5, "radius": 0.3}],
            },
            "inside obstacles.0",
        ),
        ({"shape": "blob"}, "shape"),
        ({"extra": 1}, "extra"),
        ({"obstacles": [{"type": "star", "x": 1, "y": 1}]}, "obstacles.0"),
        ({"events": [{"t": 1, "type": "deform", "joints": [0, 0, 3]}]}, "events.0.joints"),
        (  # the head is clear, the body (units 2-3 at x = 0.3..0.7) is not
            {"obstacles": [{"type": "circle", "x": 0.5, "y": 0.15, "radius": 0.2}]},
            "start: the robot's body (head and four units) overlaps obstacles.0",
        ),
        ({"start": {"x": 9.5, "y": 0, "psi": 0}}, "start: the robot's body"),  # tail in the wall
        (
            {
                "goals": [{"x": 1, "y": 1.02, "tolerance": 0.05}],
                "obstacles": [{"type": "rectangle", "x": 1, "y": 2, "width": 1, "height": 1.9}],
            },
            "goals.0: closer to obstacles.0 than the robot can reach",
        ),
        ({"goals": [{"x": 9.97, "y": 0}]}, "goals.0: closer to a wall than the robot can reach"),
    ],
)
def test_bad_missions_name_the_field(patch, field) -> None:
    data = {"goals": [{"x": 1, "y": 1}], **patch}
    with pytest.raises(MissionFileError, match=re.escape(field)):
        parse_mission(json.dumps(data))


def test_a_goal_015_m_from_a_wall_is_accepted() -> None:
    spec = MissionSpec.model_validate({"goals": [{"x": 9.85, "y": 0, "tolerance": 0.1}]})
    assert spec.goals[0].x == 9.85


def test_cli_mission_prints_a_summary_and_writes_a_plot(tmp_path: Path) -> None:
    out = tmp_path / "m.png"
    result = CliRunner().invoke(
        cli, ["mission", "examples/fig9b-obstacles.json", "--out", str(out)]
    )
    assert result.exit_code == 0, result.output
    for text in ("succeeded", "goals", "replans", "collisions: 0", "model time"):
        assert text in result.output
    assert out.read_bytes()[:4] == b"\x89PNG"
    bad = tmp_path / "bad.json"
    bad.write_text('{"goals": [{"x": 1}]}')
    result = CliRunner().invoke(cli, ["mission", str(bad)])
    assert result.exit_code == 2 and "goals.0.y" in result.output


def test_paper_command_lists_and_runs(tmp_path: Path) -> None:
    listed = CliRunner().invoke(cli, ["paper", "list"])
    assert (
        listed.exit_code == 0 and "fig13b-deformation" in listed.output and "exp4" in listed.output
    )
    ran = CliRunner().invoke(cli, ["paper", "fig8", "--out", str(tmp_path)])
    assert ran.exit_code == 0 and "the paper" in ran.output and (tmp_path / "fig8.png").exists()


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('{"goals": [{"x": 1, "y": 1}], "obst', "not valid JSON"),
        ("", "not valid JSON"),
        ('{"version": 7, "goals": [{"x": 1, "y": 1}]}', "version: Extra inputs are not permitted"),
        ("[1, 2, 3]", "mission"),
    ],
)
def test_corrupt_truncated_or_future_mission_files(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "m.json"
    path.write_text(text)
    with pytest.raises(MissionFileError, match=message):
        load_mission(path)
    with pytest.raises(MissionFileError, match="cannot read"):
        load_mission(tmp_path / "missing.json")


def test_a_manual_chain_stops_on_contact_with_the_part_and_side() -> None:
    spec = MissionSpec.model_validate(
        {
            "chain": [{"primitive": "P4s", "until": {"duration": 300}}],  # head first, towards -x
            "obstacles": [{"type": "rectangle", "x": -2, "y": 0, "width": 0.2, "height": 3}],
        }
    )
    result = run(spec)
    assert result.status == "failed" and result.collisions == 1
    assert result.reason == "chain step 0 stopped: part 0 touched something on its front side"
    assert result.model_time < 120  # stopped at the wall (~1.9 m at 2 cm/s), not after 300 s
