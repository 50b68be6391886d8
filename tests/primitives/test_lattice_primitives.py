"""Lattice primitives: the bundled entries land where they say, near their targets, fast."""

import json
import math
import re

import numpy as np
import pytest

from primitives.build import build_library
from primitives.catalogue import default_specs, lattice_specs
from primitives.lattice import (
    SPEED_TARGET,
    SWEEP_STEP,
    SWEEP_TURN,
    TICK,
    body_points,
    centroid_motion,
    compose,
    idle_direction,
    retime,
    trim_idle,
    world_swept,
)
from primitives.library import FORMAT_VERSION, Library, bundled_library_path, load_bundled
from primitives.params import ParameterSpace
from primitives.pose_task import PoseTask
from primitives.shapes import FIXED_SHAPES
from sim.robot import body_twist, centroid, centroid_offset, unit_centres
from sim.rollout import RolloutConfig, rollout
from sim.world import footprint
from tests.primitives.test_library import assert_close

LIB = load_bundled()
LATTICE = [e for shape in FIXED_SHAPES for e in LIB.lattice(shape)]
POSITION_TOL = 0.003  # m
TURN_TOL = math.radians(0.2)
PDDL_NAME = re.compile(r"^[a-z][a-z0-9_-]*$")


def test_centroid_is_the_mean_of_the_unit_centres() -> None:
    assert centroid_offset(np.zeros(3)) == pytest.approx([0.442, 0.0], abs=1e-12)
    phi = np.array([0.5, -0.5, -0.1])
    pose = np.array([1.0, -2.0, 0.7])
    assert centroid(pose, phi) == pytest.approx(unit_centres(pose, phi).mean(axis=0), abs=1e-12)
    batch = centroid_offset(np.array([[0.0, 0.0, 0.0], [0.3, 0.3, 0.3]]))
    assert batch.shape == (2, 2) and batch[1] == pytest.approx(centroid_offset(np.full(3, 0.3)))


def test_bundled_library_has_22_lattice_primitives_per_shape_in_catalogue_order() -> None:
    assert len(LATTICE) == 110
    for shape in (*FIXED_SHAPES, "periodic"):
        assert [e.id for e in LIB.lattice(shape)] == [s.id for s in lattice_specs((shape,))]
    assert all(e.family == "paper" for e in LIB.of_shape("straight"))  # what older callers see
    assert len(LIB.paper()) == 49 and len(LIB) == 49 + 110 + 22


def test_ids_are_unique_and_pddl_safe() -> None:
    ids = [e.id for e in LIB]
    assert len(set(ids)) == len(ids)
    assert all(PDDL_NAME.match(e.id) for e in LATTICE)
    assert "lat-straight-t025-a180" in LIB and "lat-zigzag-rm22p5" in LIB
    assert all(e.label is None for e in LATTICE)


@pytest.mark.parametrize("entry", LATTICE, ids=lambda e: e.id)
def test_lattice_primitive_lands_where_it_says_near_its_target(entry) -> None:
    assert entry.family == "lattice" and entry.reference == "centroid" and entry.space == "U1"
    states = rollout(entry.control(), config=entry.rollout.config()).states[0]
    end = states[-1, :3]
    assert end == pytest.approx(entry.end_pose, abs=1e-9)
    assert end[:2] == pytest.approx(entry.end, abs=1e-9)
    # the centroid moved by goal and the body turned by turn, within the build threshold
    moved = centroid_motion(entry)
    assert math.dist(moved[:2], entry.goal) <= POSITION_TOL
    assert abs(moved[2] - entry.turn) <= TURN_TOL
    task = PoseTask(
        (*entry.goal, entry.turn), entry.parameter_space(), config=entry.rollout.config()
    )
    assert float(task.costs(np.array(entry.theta)[None, :])[0]) == pytest.approx(entry.cost)
    # executor-friendly: whole control ticks, screws at most at the lattice speed
    duration = entry.rollout.duration
    assert duration / TICK == pytest.approx(round(duration / TICK), abs=1e-12) and duration > 0
    assert entry.rollout.dt == 0.05
    assert max(abs(v) for v in entry.theta) <= SPEED_TARGET + 1e-9
    # swept poses: from the start to end_pose, finely spaced along the simulated motion
    swept = np.array(entry.swept)
    assert swept[0] == pytest.approx([0.0, 0.0, 0.0], abs=0.0)
    assert swept[-1] == pytest.approx(entry.end_pose, abs=0.0)
    points = body_points(swept, entry.joints)
    assert np.max(np.linalg.norm(np.diff(points, axis=0), axis=-1)) <= SWEEP_STEP + 1e-12
    assert np.max(np.abs(np.diff(swept[:, 2]))) <= SWEEP_TURN + 1e-12
    on_path = np.array([np.min(np.abs(states[:, :3] - p).sum(axis=1)) for p in swept])
    assert np.all(on_path < 1e-12)


def test_turns_keep_the_centroid_and_translations_keep_the_heading() -> None:
    for entry in LATTICE:
        moved = centroid_motion(entry)
        if entry.turn:
            assert math.hypot(*moved[:2]) <= POSITION_TOL and abs(moved[2]) > 0.09
        else:
            assert abs(moved[2]) <= TURN_TOL and math.hypot(*moved[:2]) > 0.045


def test_world_helpers_place_the_swept_footprint() -> None:
    entry = LIB.get("lat-straight-t025-a180")
    pose = (1.0, 2.0, math.pi / 2)
    world = world_swept(entry, pose)
    assert world[0] == pytest.approx(pose)
    assert world[-1] == pytest.approx(compose(pose, entry.end_pose), abs=1e-12)
    start = rollout(entry.control(), start=pose, config=entry.rollout.config()).end[0, :3]
    assert world[-1] == pytest.approx(start, abs=1e-9)
    fp = footprint(world, np.array(entry.joints))
    assert fp.starts.shape == (len(world), 5, 2)


def test_retime_keeps_speed_times_duration_and_rounds_up_to_ticks() -> None:
    theta, duration = retime([0.2, -0.1, 0.05, 0.0], 10.0)
    assert duration == 2.5 and max(abs(theta)) <= SPEED_TARGET
    assert theta * duration == pytest.approx(np.array([0.2, -0.1, 0.05, 0.0]) * 10.0)


def test_trimming_the_idle_screw_component_keeps_the_twist() -> None:
    joints = (0.5, -0.5, 0.5)
    theta = np.array([0.3, 0.7, -0.2, 0.6])
    trimmed = trim_idle(theta, joints)
    phi = np.array(joints)[None, :]
    assert body_twist(trimmed[None, :], phi) == pytest.approx(body_twist(theta[None, :], phi))
    assert max(abs(trimmed)) < max(abs(theta))
    assert idle_direction((0.0, 0.0, 0.0)) * np.sign(idle_direction((0.0, 0.0, 0.0))[0]) == (
        pytest.approx([0.5, -0.5, -0.5, 0.5])
    )


def test_pose_task_costs_centroid_error_plus_weighted_turn_error() -> None:
    space = ParameterSpace.for_shape("straight")
    task = PoseTask((0.0, 0.0, 0.1), space, config=RolloutConfig(1.0, 0.05))
    assert task.costs(np.zeros((1, 4)))[0] == pytest.approx(0.1)  # standing still: 0.1 rad off
    spin = np.array([[-1.0, -1 / 3, 1 / 3, 1.0]])  # docs/robot-model.md: spin about the middle
    motion = task.motions(spin)[0]
    assert math.hypot(*motion[:2]) < 1e-3 and abs(motion[2]) > 0.1
    with pytest.raises(ValueError, match="reference"):
        PoseTask((0.0, 0.0, 0.0), space, reference="tail")  # type: ignore[arg-type]


def test_lattice_rebuild_matches_the_bundled_entries() -> None:
    specs = default_specs() + lattice_specs()
    seeds = {s.id: i for i, s in enumerate(specs)}
    for name in ("lat-straight-t025-a180", "lat-semi-zigzag-rp45p0", "lat-arc-t005-a315"):
        spec = next(s for s in specs if s.id == name)
        rebuilt = next(iter(build_library([spec], seed=seeds[name]))).model_dump()
        bundled = LIB.get(name).model_dump()
        assert_close(rebuilt, bundled, name)


@pytest.mark.parametrize("learner", ["pi2", "cmaes"])
def test_other_learners_learn_lattice_primitives_too(learner) -> None:
    specs = [
        s
        for s in lattice_specs(("zigzag",))
        if s.id in {"lat-zigzag-t025-a045", "lat-zigzag-rm45p0"}
    ]
    library = build_library(specs, learner=learner)
    for entry in library:
        assert entry.learner == learner and entry.cost < 0.003
        assert max(abs(v) for v in entry.theta) <= SPEED_TARGET + 1e-9


def test_version_1_files_still_load(tmp_path) -> None:
    data = json.loads(bundled_library_path().read_text())
    assert data["version"] == FORMAT_VERSION == 3
    new_fields = ("family", "reference", "turn", "end_pose", "swept", "cycles", "swept_joints")
    entries = [
        {k: v for k, v in e.items() if k not in new_fields}
        for e in data["entries"]
        if e["family"] == "paper"
    ]
    path = tmp_path / "v1.json"
    path.write_text(json.dumps(data | {"version": 1, "entries": entries}))
    old = Library.load(path)
    assert len(old) == 49 and all(e.family == "paper" and e.reference == "head" for e in old)
    assert old.lattice("straight") == [] and old.get("P1s").end_pose is None
