"""The paper's published parameter sets land where docs/robot-model.md says they do."""

import numpy as np
import pytest

from sim.paper_cases import PAPER_CASES
from sim.rollout import PAPER_ROLLOUT, RolloutConfig, rollout


def end_error(name: str, config: RolloutConfig = PAPER_ROLLOUT) -> float:
    case = PAPER_CASES[name]
    end = rollout(case.control(), config=config).end[0]
    return float(np.hypot(end[0] - case.goal[0], end[1] - case.goal[1]))


@pytest.mark.parametrize(
    ("name", "tolerance"),
    [("exp2", 0.15), ("exp4", 0.15), ("fig13-set1", 0.15), ("exp1", 0.45), ("fig9-set1", 0.8)],
)
def test_published_sets_reach_their_goals(name: str, tolerance: float) -> None:
    assert end_error(name) < tolerance


def test_exp3_is_pinned_where_it_lands() -> None:
    # Exp3's published inputs are within 0.14 of Fig. 13 Set 1's, whose goal (-1, 2) lies 5 m from
    # Exp3's (-1, -3): no convention reproduces both (docs/robot-model.md), so Exp3's goal or inputs
    # are probably misprinted. We pin where the published inputs actually take the robot.
    end = rollout(PAPER_CASES["exp3"].control()).end[0]
    assert end[:2] == pytest.approx((-0.746, 1.878), abs=0.01)
    assert end_error("exp3") > 4.5


def test_step_size_barely_matters() -> None:
    for name in ("exp1", "exp2", "fig13-set1"):
        coarse = end_error(name)
        fine = end_error(name, RolloutConfig(dt=0.01))
        assert abs(coarse - fine) < 0.03


def test_complete_joint_mode_changes_only_the_moving_joints() -> None:
    complete = RolloutConfig(dt=0.01, joint_mode="complete")
    assert end_error("exp1", complete) == pytest.approx(end_error("exp1", RolloutConfig(dt=0.01)))
    # docs/robot-model.md ("Joint motion"): Exp4 moves from 0.07 m to 0.36 m off when joint rates are included.
    assert end_error("exp4", complete) == pytest.approx(0.36, abs=0.02)
