"""The paper's reactive domain (Table 3) reproduces the paper's plans (§6.1.1)."""

from domain.pyperplan_adapter import parse_and_ground, validate_plan
from domain.reactive import ReactiveState, plan_reactive, reactive_domain, reactive_problem


def ops(state: ReactiveState) -> list[str]:
    _, steps = plan_reactive(state, "straight")
    return [s.operator for s in steps]


def test_free_start_plans_po1() -> None:
    assert ops(ReactiveState()) == ["PO1"]  # S_ini = {F, F, F, F}


def test_obstacle_towards_goal_plans_a_detour_then_po1() -> None:
    assert ops(ReactiveState(obstacle_togoal=True)) in (
        ["PO2", "PO1"],
        ["PO3", "PO1"],
    )  # {F, T, F, F}
    assert ops(ReactiveState(obstacle_togoal=True, obstacle_m90=True)) == ["PO2", "PO1"]  # Fig. 10
    assert ops(ReactiveState(obstacle_togoal=True, obstacle_p90=True)) == ["PO3", "PO1"]


def test_moves_carry_angle_and_shape() -> None:
    _, steps = plan_reactive(ReactiveState(obstacle_togoal=True, obstacle_m90=True), "zigzag")
    assert [(s.relative_angle, s.shape) for s in steps] == [(90.0, "zigzag"), (0.0, "zigzag")]


def test_boxed_in_is_unsolvable_and_on_goal_needs_nothing() -> None:
    result, steps = plan_reactive(ReactiveState(True, False, False, False), "straight")
    assert result.solved and steps == []
    result, _ = plan_reactive(ReactiveState(False, True, True, True), "straight")
    assert result.status == "unsolvable" and result.reason


def test_plans_validate_on_the_grounded_task() -> None:
    task = parse_and_ground(
        reactive_domain().text(),
        reactive_problem(ReactiveState(obstacle_togoal=True), "arc").text(),
    )
    assert validate_plan(task, ["(po2 arc)", "(po1 arc)"]) == (True, "valid")
    ok, why = validate_plan(task, ["(po1 arc)"])
    assert not ok and "not applicable" in why
