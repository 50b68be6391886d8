"""What a motion costs, as the search reads it: metres of travel, more where it sweeps space the
head has not looked at (head first is cheapest, then tail first, then sideways), more where it
sweeps contact evidence (never invalid: soft evidence is a cost), invalid where a known obstacle
is in the way; and the compiled evaluation gives what its Python form gives."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from domain.navigation import NavigationSettings, Planner
from domain.navigation.lattice.costs import (
    CostInputs,
    cell_centre,
    flat_cells,
    kernel_table,
    lethal_costs,
    lethal_part,
    motion_slack,
    risk_costs,
    risk_part,
    start_costs,
    state_costs,
)
from domain.world import RangeObservation, WorldModel
from sim.obstacles import Circle
from sim.world import Bounds
from tests.domain.lattice_scenes import LIB, SETTINGS, STRAIGHT, scene

BOUNDS = Bounds(-3.0, 3.0, -3.0, 3.0)
POSE = (0.0, 0.0, 0.0)  # the straight body lies along +x from the head at the origin
STRAIGHT_JOINTS = (0.0, 0.0, 0.0)
NAMES = {name: m for m, name in enumerate(STRAIGHT.names)}


def motions(goal: tuple[float, float]) -> list[int]:
    """The straight body's translations learned for ``goal`` (body frame: +x towards the
    tail)."""
    return [
        NAMES[name]
        for name, motion in zip(STRAIGHT.names, STRAIGHT.motions, strict=True)
        if LIB.get(motion.primitive).goal == goal
    ]


(HEAD_FIRST,) = motions((-0.25, 0.0))
(TAIL_FIRST,) = motions((0.25, 0.0))
SIDEWAYS = [*motions((0.0, 0.25)), *motions((0.0, -0.25))]
TURNS = [m for m, motion in enumerate(STRAIGHT.motions) if abs(float(motion.end[2])) > 0.05]


def costs(
    world: WorldModel, pose=POSE, margin: float | None = None
) -> tuple[int, np.ndarray, Planner]:
    """The valid motions (bitmask) and costs of the state at ``pose``, with the risk of the
    never-observed space as a replan reads it."""
    p = Planner(BOUNDS, SETTINGS)
    inputs = p.inputs(world, STRAIGHT)
    kt = kernel_table(STRAIGHT, SETTINGS.margin if margin is None else margin)
    bits, out = state_costs(p.grid.encode(p.key_of(STRAIGHT, pose)), inputs, kt)
    return bits, out, p


def valid(bits: int, m: int) -> bool:
    return bool((bits >> m) & 1)


def test_on_a_free_lattice_head_first_is_cheapest_then_tail_first_then_sideways() -> None:
    world = WorldModel(BOUNDS, (), SETTINGS.costmap)  # nothing observed yet
    bits, c, _ = costs(world)
    assert bits == (1 << len(STRAIGHT.motions)) - 1  # in open space every motion is valid
    assert np.all(c >= STRAIGHT.lengths - 1e-12)  # never less than the metres travelled
    # The head's rays look first where the head leads: that motion sweeps nothing blind.
    assert c[HEAD_FIRST] == pytest.approx(STRAIGHT.lengths[HEAD_FIRST], rel=1e-4)
    assert c[HEAD_FIRST] < c[TAIL_FIRST] < min(c[m] for m in SIDEWAYS)
    assert all(c[m] > STRAIGHT.lengths[m] for m in TURNS)  # a turn swings the tail round blind


def test_observed_space_costs_its_metres_only() -> None:
    """Once beams have crossed the space round the robot (reading nothing) and the body has lain
    there, no motion risks anything: each costs its length (open space: no closeness cost), and
    the length the tail leads costs ``reverse_penalty`` more."""
    world = WorldModel(BOUNDS, (), SETTINGS.costmap)
    _, blind, _ = costs(world)
    for x in np.arange(-1.5, 1.6, 0.25):
        for y in np.arange(-1.5, 1.6, 0.25):
            world.integrate(
                RangeObservation((float(x), float(y)), float(a), 0.0, 0.5, 0.5, False)
                for a in np.linspace(-math.pi, math.pi, 120, endpoint=False)
            )
    world.observe_body(POSE, STRAIGHT_JOINTS)
    _, seen, _ = costs(world)
    reverse = SETTINGS.costs.reverse_penalty  # a move the tail leads pays for it, seen or not
    np.testing.assert_allclose(seen, STRAIGHT.lengths * (1.0 + reverse * STRAIGHT.leads))
    assert seen[TAIL_FIRST] == pytest.approx(
        (1.0 + reverse) * STRAIGHT.lengths[TAIL_FIRST], rel=1e-4
    )
    assert np.all(blind >= seen) and np.sum(blind > seen + 0.1) > len(STRAIGHT.motions) // 2


def test_closeness_to_a_known_obstacle_costs_more_and_an_obstacle_in_the_way_is_invalid() -> None:
    open_world = WorldModel(BOUNDS, (), SETTINGS.costmap)
    _, free, _ = costs(open_world)
    # A post on the head's axis: the head-first move ends with its head 0.03 m beyond the
    # margin from it, the tail-first move, going away, keeps about the inflation radius.
    near_post = WorldModel(BOUNDS, [Circle(-0.455, 0.0, 0.05)], SETTINGS.costmap)
    bits, close, _ = costs(near_post)
    assert valid(bits, HEAD_FIRST) and close[HEAD_FIRST] > free[HEAD_FIRST]
    assert close[HEAD_FIRST] > 1.4 * free[HEAD_FIRST]
    assert close[TAIL_FIRST] - free[TAIL_FIRST] < 0.05 * (close[HEAD_FIRST] - free[HEAD_FIRST])
    blocked = WorldModel(BOUNDS, [Circle(-0.25, 0.0, 0.08)], SETTINGS.costmap)
    bits, c, _ = costs(blocked)
    assert not valid(bits, HEAD_FIRST) and math.isinf(c[HEAD_FIRST])
    assert valid(bits, TAIL_FIRST) and math.isfinite(c[TAIL_FIRST])


def test_contact_evidence_raises_the_cost_and_never_invalidates_a_motion() -> None:
    world = WorldModel(BOUNDS, (), SETTINGS.costmap)
    bits0, before, _ = costs(world)
    # A bumper on the tail unit's left side (towards -y) fired, again and again.
    for t in range(12):
        world.add_contact(POSE, STRAIGHT_JOINTS, 4, "left", float(t))
    assert world.evidence().max() > 0.5
    bits, after, _ = costs(world)
    assert bits == bits0  # the same motions valid: soft evidence is never lethal
    assert np.all(np.isfinite(after))
    assert np.all(after >= before - 1e-12)
    # The sideways move towards the touched side sweeps it blind: it costs far more now; the
    # head-first move the head sees its way for costs what it did.
    towards = [m for m in SIDEWAYS if float(STRAIGHT.motions[m].end[1]) < 0]
    assert towards and all(after[m] > before[m] + 1.0 for m in towards)
    assert after[HEAD_FIRST] == pytest.approx(before[HEAD_FIRST])
    assert world.version == 0  # nothing lethal changed


def test_the_start_may_rest_closer_than_the_margin_but_not_move_in_deeper() -> None:
    """A robot resting 0.01 m from a post (closer than the 0.02 m margin): at the margin no
    motion towards it is valid; the planner's start table lets it move away."""
    world = WorldModel(BOUNDS, [Circle(-0.055 - 0.01 - 0.1, 0.0, 0.1)], SETTINGS.costmap)
    p = Planner(BOUNDS, SETTINGS)
    inputs = p.inputs(world, STRAIGHT)
    start = p.key_of(STRAIGHT, POSE)
    at_margin, _ = state_costs(p.grid.encode(start), inputs, kernel_table(STRAIGHT, 0.02))
    kt_start, touching = p.start_table(STRAIGHT, start, inputs)
    out_of_start, c_start = start_costs(p.grid.encode(start), inputs, kt_start)
    assert touching
    assert not valid(at_margin, HEAD_FIRST) and not valid(out_of_start, HEAD_FIRST)
    assert valid(out_of_start, TAIL_FIRST) and math.isfinite(c_start[TAIL_FIRST])
    assert out_of_start & ~at_margin  # moves away the margin alone would forbid


def random_inputs(seed: int, settings: NavigationSettings = SETTINGS) -> tuple[CostInputs, Planner]:
    """A cluttered scene's costmap with sensed cells, contacts and never-observed space."""
    bounds, obstacles = scene("cluttered", 5.0, seed)
    rng = np.random.default_rng(seed)
    known = obstacles[: len(obstacles) // 2]
    world = WorldModel(bounds, known, settings.costmap)
    for _ in range(4):
        x, y = (float(v) for v in rng.uniform(-2.0, 2.0, 2))
        world.add_contact((x, y, float(rng.uniform(-3, 3))), STRAIGHT_JOINTS, 2, "right", 0.0)
    p = Planner(bounds, settings)
    inputs = p.inputs(world, STRAIGHT)
    return inputs, p


def with_layers(inputs: CostInputs, risk, blocked, flat) -> CostInputs:
    """``inputs`` with other risk and blocked layers and flat cells."""
    return dataclasses.replace(inputs, risk=risk, blocked=blocked, flat=flat)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_each_motion_reads_what_its_own_cells_hold(seed: int) -> None:
    """A state's evaluation reads each of its bin's distinct cells once for all its motions;
    it gives, bit for bit, what each motion gives read on its own: validity and slack from
    its own checks' cells (``motion_slack``; off the grid, invalid), risk summed over its own
    new cells in its order (off the grid, nothing), in the open, near obstacles, over the
    evidence and at the arena's edge."""
    inputs, p = random_inputs(seed)
    kt = kernel_table(STRAIGHT, SETTINGS.margin)
    radius, decay, penalty, contact, block, reverse = inputs.params
    nx, ny, plane = inputs.nx, inputs.ny, inputs.nx * inputs.ny
    rng = np.random.default_rng(200 + seed)
    numbers = rng.integers(0, p.grid.size, 300).tolist()
    numbers += [p.grid.encode((0, 0, 0)), p.grid.encode((nx - 1, 5, 17))]
    no_flat = np.zeros_like(inputs.flat)
    kinds = set()
    for number in numbers:
        k, cell = divmod(number, plane)
        i, j = divmod(cell, ny)
        cx, cy = cell_centre(inputs.geo, i, j)
        bits, base = lethal_costs(number, inputs, kt)
        extra = risk_costs(number, with_layers(inputs, inputs.risk, inputs.blocked, no_flat), kt)
        open_space = inputs.values[i, j] >= kt.open_need + radius
        for m in range(len(STRAIGHT.motions)):
            di, dj = kt.deltas[k, m, :2]
            on_grid = 0 <= i + di < nx and 0 <= j + dj < ny
            slack = math.inf if open_space else motion_slack(
                k, m, i, j, cx, cy, nx, ny, inputs.values, inputs.geo, kt.checks,
                kt.check_needs, kt.check_fails, kt.check_points, kt.grouped, kt.check_segments,
            )  # fmt: skip
            valid = on_grid and slack >= 0.0
            kinds.add(valid)
            assert bool((bits >> m) & 1) == valid
            if valid:
                close = math.exp(-slack / decay) if slack < radius else 0.0
                want = kt.lengths[m] * (1.0 + penalty * close) + reverse * kt.lead_lengths[m]
                assert base[m] == want
            else:
                assert base[m] == math.inf
            unseen = seen = 0.0
            for c in range(kt.cell_segments[k, m], kt.cell_segments[k, m + 1]):
                ci, cj, blind = (int(v) for v in kt.cells[k, c])
                if 0 <= i + ci < nx and 0 <= j + cj < ny:
                    if blind:
                        unseen += inputs.risk[i + ci, j + cj]
                    else:
                        seen += inputs.blocked[i + ci, j + cj]
            assert extra[m] == -contact * unseen - block * seen
    assert kinds == {True, False}


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_compiled_cost_evaluation_equals_its_python_form(seed: int) -> None:
    """``lethal_part`` and ``risk_part`` run as Python (numba's ``py_func``, as without numba)
    give the compiled values bit for bit, valid motions, lengths, closeness and risk, for
    states in the open, near obstacles, over the evidence and at the arena's edge."""
    if not hasattr(lethal_part, "py_func"):
        pytest.skip("numba kernels are off: only the Python form runs")
    inputs, p = random_inputs(seed)
    kt = kernel_table(STRAIGHT, SETTINGS.margin)
    rng = np.random.default_rng(100 + seed)
    n = len(STRAIGHT.motions)
    numbers = rng.integers(0, p.grid.size, 300).tolist()
    numbers += [p.grid.encode((0, 0, 0)), p.grid.encode((p.grid.nx - 1, 5, 17))]
    seen_bits = set()
    for number in numbers:
        outs = []
        for fn in (lethal_part, lethal_part.py_func):
            outs.append(lethal_costs(number, inputs, kt, fn))
        assert outs[0][0] == outs[1][0]
        np.testing.assert_array_equal(outs[0][1], outs[1][1])
        seen_bits.add(outs[0][0] == (1 << n) - 1)
        extras = []
        for fn in (risk_part, risk_part.py_func):
            extras.append(risk_costs(number, inputs, kt, fn))
        np.testing.assert_array_equal(extras[0], extras[1])
    assert seen_bits == {True, False}  # states with every motion valid, and with some not


def test_flat_cells_are_those_whose_reach_holds_one_risk_and_one_blocked_value() -> None:
    rng = np.random.default_rng(3)
    risk = np.where(rng.random((30, 20)) < 0.02, -0.1, 0.0)
    risk[:, 12:] += -0.3  # a prior over never-observed cells
    blocked = np.where(rng.random((30, 20)) < 0.01, -0.2, 0.0)
    reach = 3
    got = flat_cells(risk, blocked, reach)

    def alike(i: int, j: int, r: int) -> bool:
        box = np.s_[max(0, i - r) : i + r + 1, max(0, j - r) : j + r + 1]
        return bool((risk[box] == risk[i, j]).all() and (blocked[box] == blocked[i, j]).all())

    for i in range(30):
        for j in range(20):
            inside = reach <= i < 30 - reach and reach <= j < 20 - reach
            zero = risk[i, j] == 0 and blocked[i, j] == 0
            if got[i, j]:  # sound: every cell within reach has the cell's values
                assert alike(i, j, reach) and (inside or zero), (i, j)
            elif inside or zero:  # and it misses none whose box, one cell wider, is alike
                assert not alike(i, j, reach + 1), (i, j)
    assert got.any() and not got.all()
    assert (got & (risk != 0)).any()  # flat under the prior, not only where there is none


@pytest.mark.parametrize("seed", range(3))
def test_a_motions_risk_from_a_flat_cell_is_the_sum_over_its_cells(seed: int) -> None:
    """The shortcut (a flat cell's values times the motions' cell counts) and the sum over
    every new cell agree (to rounding) wherever the shortcut is taken."""
    inputs, p = random_inputs(seed)
    risk = np.full((inputs.nx, inputs.ny), -0.02)
    risk[: inputs.nx // 2] = 0.0
    blocked = np.zeros_like(risk)
    blocked[:, : inputs.ny // 3] = -0.05
    kt = kernel_table(STRAIGHT, SETTINGS.margin)
    flat = flat_cells(risk, blocked, STRAIGHT.cell_reach_new + 1)
    assert flat.any()
    rng = np.random.default_rng(seed)
    for number in rng.integers(0, p.grid.size, 400).tolist():
        i, j = divmod(number % (inputs.nx * inputs.ny), inputs.ny)
        if not flat[i, j]:
            continue
        got = risk_costs(number, with_layers(inputs, risk, blocked, flat), kt)
        full = risk_costs(number, with_layers(inputs, risk, blocked, np.zeros_like(flat)), kt)
        np.testing.assert_allclose(got, full, rtol=1e-12, atol=1e-12)
