"""The periodic gait's lattice primitives: whole gait cycles from the lattice phases, landing
within the library's bar, and composing without a jump in the joints."""

import math

import numpy as np
import pytest

from primitives.build import build_library
from primitives.catalogue import default_specs, lattice_specs
from primitives.grounding import TICK, correction_basis, ground
from primitives.lattice import (
    GAIT_CYCLE,
    LATTICE_THRESHOLD,
    SWEEP_STEP,
    body_points,
    centroid_motion,
)
from primitives.library import load_bundled
from primitives.shapes import SHAPES
from sim.controls import GAIT_AMPLITUDE, GAIT_OMEGA, PeriodicGait
from sim.rollout import rollout
from sim.simulator import Simulator
from tests.primitives.test_library import assert_close

LIB = load_bundled()
GAIT = LIB.lattice("periodic")
POSITION_TOL = 0.003  # m: the library's lattice bar (LATTICE_THRESHOLD, 1 m/rad for turns)
TURN_TOL = math.radians(0.2)


def test_the_gaits_start_shape_is_its_lattice_phases_at_time_zero() -> None:
    shape = SHAPES["periodic"]
    assert shape.phases is not None
    assert shape.joints == pytest.approx([GAIT_AMPLITUDE * math.sin(p) for p in shape.phases])
    assert len(GAIT) == 22 and math.isclose(GAIT_CYCLE, 2 * math.pi / 0.6)


@pytest.mark.parametrize("entry", GAIT, ids=lambda e: e.id)
def test_gait_primitive_runs_whole_cycles_and_lands_within_the_bar(entry) -> None:
    assert entry.space == "U3" and entry.phases == SHAPES["periodic"].phases
    assert entry.cycles >= 1 and entry.gait_time == pytest.approx(entry.cycles * GAIT_CYCLE)
    # whole control ticks covering the cycles, the last one partly held
    duration = entry.rollout.duration
    assert duration / TICK == pytest.approx(round(duration / TICK), abs=1e-12)
    assert entry.gait_time <= duration < entry.gait_time + TICK
    states = rollout(entry.control(), config=entry.rollout.config()).states[0]
    assert states[-1, :3] == pytest.approx(entry.end_pose, abs=1e-9)
    # it starts and ends in the gait's start shape: the next motion starts without a jump
    rest = np.asarray(entry.rest_joints)
    assert states[0, 3:] == pytest.approx(rest, abs=1e-12)
    assert states[-1, 3:] == pytest.approx(rest, abs=1e-12)
    assert np.ptp(states[:, 3:], axis=0) == pytest.approx([0.4] * 3, abs=0.01)  # it bends
    moved = centroid_motion(entry)
    assert math.dist(moved[:2], entry.goal) <= POSITION_TOL
    assert abs(moved[2] - entry.turn) <= TURN_TOL
    assert entry.cost < LATTICE_THRESHOLD
    # swept poses and their joints lie on the rollout, finely spaced for the bending body
    swept, bent = np.array(entry.swept), np.array(entry.swept_joints)
    assert len(bent) == len(swept) and swept[-1] == pytest.approx(entry.end_pose, abs=0.0)
    rows = np.concatenate([swept, bent], axis=1)
    assert all(np.min(np.abs(states - r).sum(axis=1)) < 1e-12 for r in rows)
    points = body_points(swept, bent)
    assert np.max(np.linalg.norm(np.diff(points, axis=0), axis=-1)) <= SWEEP_STEP + 1e-12


def test_a_gait_primitive_rebuilds_as_bundled() -> None:
    specs = default_specs() + lattice_specs()
    seeds = {s.id: i for i, s in enumerate(specs)}
    name = "lat-periodic-rp22p5"
    spec = next(s for s in specs if s.id == name)
    rebuilt = next(iter(build_library([spec], seed=seeds[name]))).model_dump()
    assert_close(rebuilt, LIB.get(name).model_dump(), name)


def drive(sim: Simulator, entries: list, offset=None) -> list[list[float]]:
    """Run library entries one after the other as the executor does (each its gait clocked
    from its first tick, whole ticks), returning the simulator's trajectory rows."""
    basis = correction_basis(GAIT)
    for entry in entries:
        grounded = ground(entry.end_pose if offset is None else offset, basis, entry)
        control = grounded.control(sim.t)
        for _ in range(round(grounded.duration / TICK)):
            sim.step(control)
    return sim.trajectory


def test_consecutive_gait_motions_keep_the_joints_continuous() -> None:
    sim = Simulator(dt=TICK)
    sim.reset((0.0, 0.0, 0.0), SHAPES["periodic"].joints, check=False)
    names = ["lat-periodic-t025-a180", "lat-periodic-rp45p0", "lat-periodic-t005-a090"]
    rows = np.array(drive(sim, [LIB.get(n) for n in names]))
    joints = rows[:, 4:]
    # no step changes a joint by more than the gait's own rate over a tick
    assert np.max(np.abs(np.diff(joints, axis=0))) <= GAIT_AMPLITUDE * GAIT_OMEGA * TICK + 1e-9
    # at each boundary the body is back in its start shape, mid-motion it bends
    bounds = np.cumsum([LIB.get(n).rollout.duration / TICK for n in names]).astype(int)
    for b in bounds:
        assert joints[b] == pytest.approx(SHAPES["periodic"].joints, abs=1e-9)
    assert np.max(np.abs(joints)) > 0.19
    # the body goes where the entries say (the simulator's coarser tick: a few mm)
    first = LIB.get(names[0])
    assert rows[bounds[0], 1:4] == pytest.approx(first.end_pose, abs=0.01)


def test_a_blend_too_fast_for_the_screws_takes_more_whole_cycles() -> None:
    entry = LIB.get("lat-periodic-t025-a180")
    far = np.asarray(entry.end_pose) * 4  # a metre: four times the speed in one cycle
    grounded = ground(far, correction_basis(GAIT), entry)
    assert grounded.cycles > entry.cycles and grounded.phases is not None
    assert grounded.duration >= grounded.cycles * GAIT_CYCLE
    assert max(abs(v) for v in grounded.theta) <= 0.95 + 1e-9
    control = grounded.control(3.0)
    assert isinstance(control, PeriodicGait)
    assert control.t_end == pytest.approx(3.0 + grounded.cycles * GAIT_CYCLE)
