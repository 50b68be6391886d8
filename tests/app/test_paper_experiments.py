"""The paper's experiments as the paper describes them (issue 11 item 4): one test each,
asserting the primitives the mission result says were executed, and the goals."""

import math

import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.paper import FIG8_GOAL, GOAL_MARGIN, fig8_run
from app.paper_missions import chain_targets, run_paper
from primitives.library import load_bundled

LIB = load_bundled()


def reached(run) -> bool:
    r = run.result
    return (
        r.status == "succeeded"
        and r.collisions == 0
        and all(g.reached and g.error is not None and g.error <= g.tolerance for g in r.goals)
    )


def test_fig9b_set1_then_p2s_while_blocked_then_set1_then_p6s_after_a_time_out() -> None:
    run = run_paper("fig9b-obstacles", LIB)
    assert reached(run), run.result.reason
    b = run.behaviours()
    set1 = {"P4s", "P5s", "P6s"}  # quadrant C's primitives, interpolated towards (-3, -1)
    assert (b[0]["action"], b[0]["method"], b[0]["sources"]) == (
        "(po1 straight)",
        "interpolated",
        set1,
    )
    assert (b[1]["action"], b[1]["labels"]) == ("(po2 straight)", ["P2s"])
    assert b[2]["action"] == "(po1 straight)" and set1 <= b[2]["sources"]  # back to Set 1
    assert (b[3]["action"], b[3]["labels"]) == ("(return po3 straight)", ["P6s"])
    assert all(e["action"].startswith("(po1 straight") for e in b[4:])  # then to the goal
    # P2s started because the range towards the goal read below the threshold
    blocked = [r for r in run.result.replans if r.trigger == "path_blocked"]
    assert blocked and blocked[0].new == ["(po2 straight)", "(po1 straight)"]
    assert abs(blocked[0].at - b[1]["from"]) <= 0.5


def test_fig10_p4s_and_p2z_around_two_obstacles() -> None:
    run = run_paper("fig10-two-obstacles", LIB)
    assert reached(run), run.result.reason
    b = run.behaviours()
    assert b[0]["labels"] == ["P4s"]
    avoid = [e for e in b if e["action"].startswith("(po2")]
    assert avoid and all(e["labels"] == ["P2z"] for e in avoid)
    # PO2 ran at each obstacle (within a metre of it) and PO1 in between, in the straight shape
    for ob in run.spec.obstacles:
        assert any(math.dist(e["start"], (ob.x, ob.y)) < 1.0 for e in avoid), ob
    assert all(e["shape"] == "straight" for e in b if e["action"].startswith("(po1"))
    plans = [p["plan"] for p in run.result.pddl]
    assert plans[0] == ["(po1 straight)"]
    assert plans.count(["(po2 straight)", "(po1 straight)"]) >= 2


def test_fig11_p1s_p4z_p9_with_shape_changes_through_g1_g2_g3() -> None:
    run = run_paper("fig11-multiple-goals", LIB)
    assert run.result.status == "succeeded" and run.result.collisions == 0
    assert run.chain() == ["P1s", "P4z", "P9"]
    assert [e["method"] for e in run.behaviours()] == ["library"] * 3
    changes = [e["shape"] for e in run.result.events if e["kind"] == "shape_change"]
    assert changes == ["zigzag", "semi-arc"]
    goals = chain_targets(run.spec, LIB)  # G1, G2, G3 as the library predicts them
    ends = run.step_ends()
    assert len(ends) == 3
    for want, got in zip(goals, ends, strict=True):
        assert math.dist(want, got) < GOAL_MARGIN["fig11-multiple-goals"], (want, got)


def test_fig12_im1_im2_im3_p5pe_p4pe_through_g1_g2_g3() -> None:
    run = run_paper("fig12-multiple-goals", LIB)
    assert run.result.status == "succeeded" and run.result.collisions == 0
    assert run.chain() == ["P1s+P2s+P8s", "P1a+P2a+P8a", "P4a+P5a+P6a", "P5pe", "P4pe"]
    assert [e["method"] for e in run.behaviours()] == ["interpolated"] * 3 + ["library"] * 2
    targets, ends = chain_targets(run.spec, LIB), run.step_ends()
    # G1 after IM3, G2 after P5pe, G3 after P4pe: the IMs' interpolation error adds up
    for want, got in zip(targets[2:], ends[2:], strict=True):
        assert math.dist(want, got) < GOAL_MARGIN["fig12-multiple-goals"], (want, got)
    # the library primitives themselves move as recorded, from wherever they start
    for i in (3, 4):
        moved = (ends[i][0] - ends[i - 1][0], ends[i][1] - ends[i - 1][1])
        want = (targets[i][0] - targets[i - 1][0], targets[i][1] - targets[i - 1][1])
        assert math.dist(moved, want) < 0.10


def test_fig13b_after_the_deformation_im4_from_p10_p11_p12_reaches_the_goal() -> None:
    run = run_paper("fig13b-deformation", LIB)
    assert reached(run), run.result.reason
    deform = [e for e in run.result.events if e["kind"] == "deform"]
    assert len(deform) == 1 and deform[0]["t"] == 15.0 and deform[0]["shape"] == "semi-zigzag"
    assert deform[0]["coverage"]["kind"] == "library"
    b = run.behaviours()
    assert b[0]["shape"] == "straight" and b[0]["to"] == 15.0
    im4 = b[1]
    assert (im4["action"], im4["method"], im4["from"]) == (
        "(po1 semi-zigzag)",
        "interpolated",
        15.0,
    )
    assert set(im4["labels"][:3]) == {"P10", "P11", "P12"}  # its sources at the deformation
    assert 0 < im4["towards_deg"] < 90  # quadrant B in the paper's labels (the paper: 30°)
    assert all(e["shape"] == "semi-zigzag" for e in b[1:])


def test_fig8_cross_shape_interpolation_within_5_cm_of_2_1() -> None:
    run = fig8_run(LIB)
    # the paper's interpolation of P1s, P12, P13: at the goal itself it lands off in our model
    # (the blend's motion is not linear in its weights); aimed where it lands, within 5 cm
    assert set(run.aimed.sources) == {"P1s", "P12", "P13"} and run.aimed.method == "bilinear+aim"
    assert run.aimed_error < 0.05, run.aimed_end
    assert run.error > run.aimed_error
    assert run.aimed_end == pytest.approx(FIG8_GOAL, abs=0.05)
    coverage = LIB.covers(tuple(float(v) for v in run.aimed.joints))  # the cross shape
    assert coverage.kind == "interpolated" and set(coverage.sources) == {"straight", "semi-zigzag"}


def test_cli_paper_prints_the_executed_chain(tmp_path) -> None:
    out = CliRunner().invoke(cli, ["paper", "fig13b-deformation", "--out", str(tmp_path)])
    assert out.exit_code == 0, out.output
    assert (
        "P10" in out.output
        and "IM4" in out.output
        and (tmp_path / "fig13b-deformation.png").exists()
    )
