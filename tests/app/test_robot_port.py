"""The executor talks to a robot only through the Robot port: it runs on a scripted fake robot."""

import math

import numpy as np
import pytest

import sim.simulator
from app.executor.robot import ContactReading, Observation, SimRobot, sim_robot
from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec
from domain.world import RangeObservation
from primitives.library import load_bundled
from sim.controls import Control
from sim.robot import DEFAULT_GEOMETRY, RobotGeometry
from sim.rollout import RolloutConfig, rollout

LIB = load_bundled()


class ScriptedRobot:
    """A robot without a simulator: it moves by the kinematic model, reads whatever the script
    says (an empty world, a wall ahead once), and bumps once when told to."""

    def __init__(self, pose, bump_at: float | None = None, echo_at: float | None = None) -> None:
        self.t = 0.0
        self.pose = np.array(pose, dtype=float)
        self.joints = np.zeros(3)
        self.bump_at, self.echo_at = bump_at, echo_at
        self.rows = [[0.0, *self.pose, *self.joints]]
        self.controls: list[Control] = []

    @property
    def geometry(self) -> RobotGeometry:
        return DEFAULT_GEOMETRY

    def _obs(self, contact: ContactReading | None = None) -> Observation:
        x, y, psi = (float(v) for v in self.pose)
        echo = self.echo_at is not None and abs(self.t - self.echo_at) < 0.2
        ir = RangeObservation(
            (x - 0.055 * math.cos(psi), y - 0.055 * math.sin(psi)),
            psi + math.pi,
            math.radians(10),
            0.8,
            0.5 if echo else 0.8,
            echo,
        )
        return Observation(self.t, (x, y, psi), (0.0, 0.0, 0.0), (("ir", ir),), contact)

    def observe(self) -> Observation:
        return self._obs()

    def act(self, control: Control, duration: float) -> Observation:
        self.controls.append(control)
        end = rollout(control, self.pose, RolloutConfig(duration, 0.05)).end[0]
        self.t = round(self.t + duration, 9)
        contact = None
        if self.bump_at is not None and self.t >= self.bump_at:
            contact, self.bump_at = ContactReading(3, "left"), None  # stopped: no motion
        else:
            self.pose = end[:3]
        self.rows.append([self.t, *self.pose, *self.joints])
        return self._obs(contact)

    def trajectory(self) -> list[list[float]]:
        return self.rows


def spec(**extra) -> MissionSpec:
    data = {
        "goals": [{"x": -2.0, "y": 0.5}],
        "bounds": {"xmin": -5, "xmax": 5, "ymin": -5, "ymax": 5},
        **extra,
    }
    return MissionSpec.model_validate(data)


@pytest.fixture
def no_simulator(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the executor built a Simulator")

    monkeypatch.setattr(sim.simulator.Simulator, "__init__", refuse)


def test_the_executor_runs_on_a_fake_robot_without_a_simulator(no_simulator) -> None:
    robot = ScriptedRobot((0.0, 0.0, 0.0), bump_at=10.0, echo_at=20.0)
    runner = MissionRunner(spec(), LIB, robot=robot)
    result = runner.run()
    assert result.status == "succeeded", result.reason
    assert result.goals[0].error is not None and result.goals[0].error <= 0.1
    # the scripted bump became contact evidence (soft), a back-off and a replan triggered by it
    assert result.collisions == 1
    collisions = [e for e in result.events if e["kind"] == "collision"]
    assert len(collisions) == 1 and (collisions[0]["part"], collisions[0]["side"]) == (3, "left")
    recoveries = [e for e in result.events if e["kind"] == "recovery"]
    assert recoveries and recoveries[0]["recovery"] == "back off"
    assert recoveries[0]["because"] == "part 3 touched something on its left side"
    # ... and the plan is made again from where the back-off left the body, saying why
    replan = next(r for r in result.replans if r.trigger != "initial")
    assert replan.trigger == "recovered" and replan.detail["recovery"] == "back off"
    assert "part 3" in replan.detail["because"] and replan.status == "solved"
    assert runner.ctx.world.evidence().any()
    assert robot.controls  # it drove the robot through the port only


def test_sim_robot_reports_no_simulator_truth() -> None:
    robot = sim_robot(spec(obstacles=[{"type": "circle", "x": -1, "y": 0, "radius": 0.2}]))
    assert isinstance(robot, SimRobot)
    obs = robot.observe()
    names = [n for n, _ in obs.ranges]
    assert names[0] == "ir" and len(names) == 9  # the IR cone and the ring of 8
    ir = obs.ranges[0][1]
    assert ir.hit and ir.distance == pytest.approx(1.0 - 0.2 - 0.055, abs=1e-6)
    assert not hasattr(obs, "hits")  # which obstacle a ray hit is truth: not passed on
