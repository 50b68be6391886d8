"""Whether any sequence of valid motions reaches the goal: the lattice's own connectivity.

When the cost search's budget runs out, the relaxed checks (``domain.navigation.feasibility``)
may still say "maybe": they let through gaps a little narrower than the body, such as a sensed
wall whose cells a wide cone left below the occupied threshold. This search answers on the
lattice itself: a greedy best-first walk (by the cost heuristic) over the states every valid
motion joins, validity alone (no costs, so no cost keeps it from a way), each state once. It
finds a way quickly when there is one, and when the reachable states run out without the head
on the goal, no plan on this lattice and this lethal layer exists: a proof the cost search's
budget could not give. It reads the same validity (``costs.lethal_part``) as the search, and
stops at the task's deadline, a cancel, or ``states`` states.

A second walk goes the other way, in turns with the first: from every state with the head on
the goal, over the motions that lead into them (each predecessor's motion checked as the
forward walk checks it, ``costs.motion_slack``). The states that can reach the goal running
out without the start among them is the same proof, from the side that is small when a goal
is enclosed (an open arena round a closed room), so the proof costs what the smaller side
has, not what the open one has.

A goal side's proof outlives its replan (``GoalProof``): the states it found able to reach the
goal are all there are, and while the lethal clearance is nowhere higher than it was, valid
motions are only fewer, so those states can only be fewer too. A later start none of whose
own motions leads into them is cut off as well, without a search: an enclosure sensed wall by
wall is proven once, not at every replan (the clearance rising anywhere, as when evidence is
cleared, ends the proof as it stood). A goal proven out of reach before is then walked from
its side first (``goal_side_proof``), bounded by a few times the states its proof had: the
proof again at the cost of the enclosure's states, before a search that would spend its whole
budget outside it; past the bound, or having met the start, the search answers.
"""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

import numpy as np
from numpy.typing import NDArray

from domain.kernels import jit
from domain.navigation.lattice.costs import cell_centre, lethal_part, motion_slack
from domain.navigation.lattice.task import LatticeTask
from domain.navigation.search.heuristic import CostHeuristic, state_heuristic
from domain.pyperplan_adapter import stop_if_due
from sim.robot import Array

CHUNK = 4096  # states between checks of the deadline and the cancel flag
REACHED, NONE, OVER, RUNNING = range(4)


class Reach(NamedTuple):
    """What the walk found: ``reaches`` (``None``: ``states`` states met first on both sides),
    from which side it answered, how many states the start's side met, and, when the goal's
    side proved the goal out of reach, that proof (``GoalProof``)."""

    reaches: bool | None
    side: Literal["start", "goal"]
    met: int
    proof: GoalProof | None = None


class GoalProof(NamedTuple):
    """The states from which some sequence of valid motions reaches a goal (every one: the
    goal's walk ran out of them), and the lethal clearance they were found on."""

    values: Array
    reaching: NDArray[np.bool_]

    @property
    def states(self) -> int:
        """How many states could reach the goal."""
        return int(np.count_nonzero(self.reaching))

    def holds(self, task: LatticeTask) -> bool:
        """Whether ``task``'s start (of the same body, margin, goal and grid as the proof's)
        is cut off from the goal too: the clearance nowhere higher than the proof's (so no
        motion valid now was invalid then), the start none of those states, and none of its
        own valid motions leading into them."""
        values = task.inputs.values
        if values.shape != self.values.shape or not bool(np.all(values <= self.values)):
            return False
        start = task.start_number
        if self.reaching[start]:
            return False
        grid = task.grid
        plane = grid.nx * grid.ny
        bits = task.start_costs()[0]
        k, cell = divmod(start, plane)
        targets = task.motion_targets[k] + cell
        valid = (bits >> np.arange(len(targets), dtype=np.int64)) & 1 == 1
        return not bool(np.any(self.reaching[targets[valid]]))


def goal_side_proof(task: LatticeTask, states: int) -> GoalProof | None:
    """The goal's walk alone, up to ``states`` states: a proof that the task's start cannot
    reach the goal (``GoalProof``), or ``None`` when it met the start or the bound first. The
    check to run first for a goal proven out of reach before, whose proof no longer holds as
    it stood: its side was small then and, unless the clearance rose, stays small. Raises
    ``SearchStopped`` for a cancel or the deadline."""
    back = _Back(task, states)
    if _run_out(back, task) != NONE:
        return None
    return back.proof()


def leaves_start(task: LatticeTask, heuristic: CostHeuristic, states: int) -> bool:
    """Whether the start's side holds more than ``states`` states (or the goal): the body
    gets out of where it rests, rather than only into the few states its own motions reach.
    Raises ``SearchStopped`` for a cancel or the deadline."""
    return _run_out(_Forward(task, heuristic, states), task) != NONE


def _run_out(walk: _Walk, task: LatticeTask) -> int:
    """Step ``walk`` until it ends (checking the task's cancel and deadline between chunks)."""
    while walk.step() == RUNNING:
        stop_if_due(task.cancel, task.deadline)
    return walk.status


def lattice_reaches(task: LatticeTask, heuristic: CostHeuristic, states: int) -> Reach:
    """Whether some sequence of valid motions from the task's start puts the head on its goal
    (``Reach``). Raises ``SearchStopped`` for a cancel or the deadline.

    The two walks take turns, a chunk each: whichever side runs out first is the proof, so an
    enclosed goal costs about twice its own few states, not the open side's."""
    forward = _Forward(task, heuristic, states)
    back: _Back | None = None
    while True:
        stop_if_due(task.cancel, task.deadline)
        if forward.step() in (REACHED, NONE):
            return Reach(forward.status == REACHED, "start", forward.met)
        back = back or _Back(task, states)  # (made once the start's side did not answer at once)
        stop_if_due(task.cancel, task.deadline)
        if back.step() in (REACHED, NONE):
            if back.status == REACHED:
                return Reach(True, "goal", forward.met)
            return Reach(False, "goal", forward.met, back.proof())
        if forward.status == back.status == OVER:
            return Reach(None, "goal", forward.met)


class _Walk:
    """One side's walk, resumable a chunk at a time: ``step`` runs the next chunk (once the
    walk has ended, it only says how), ``status`` what the last one ended with. A side sets
    ``fanout``, the most states one state adds to its heap, and its chunk (``_chunk``)."""

    fanout = 0

    def __init__(self, task: LatticeTask, states: int, capacity: int) -> None:
        grid = task.grid
        self.task, self.states = task, states
        self.dims = np.array([grid.nx, grid.ny, grid.settings.orientations], dtype=np.int64)
        self.start_bits = task.start_costs()[0]
        self.near = task.near_states()
        self.seen = np.zeros(grid.size, dtype=np.bool_)
        self.heap_h, self.heap_s = np.empty(capacity), np.empty(capacity, dtype=np.int64)
        self.count = np.zeros(3, dtype=np.int64)  # heap size, states met, started
        self.status = RUNNING

    @property
    def met(self) -> int:
        return int(self.count[1])

    def step(self) -> int:
        if self.status == RUNNING:
            self.status = self._chunk()
            if int(self.count[0]) + self.fanout + 1 > len(self.heap_h):  # twice the room
                self.heap_h = np.concatenate([self.heap_h, np.empty(len(self.heap_h))])
                self.heap_s = np.concatenate(
                    [self.heap_s, np.empty(len(self.heap_s), dtype=np.int64)]
                )
        return self.status

    def _chunk(self) -> int:
        raise NotImplementedError


class _Forward(_Walk):
    """The walk from the start's side, greedy by the cost heuristic."""

    def __init__(self, task: LatticeTask, heuristic: CostHeuristic, states: int) -> None:
        super().__init__(task, states, 1 << 14)
        self.heuristic = heuristic
        self.fanout = len(task.table.motions)

    def _chunk(self) -> int:
        task, kt, inputs, h = self.task, self.task.kt, self.task.inputs, self.heuristic
        status: int = _walk(
            CHUNK, self.states, task.start_number, self.start_bits, self.near, self.dims,
            inputs.values, inputs.geo, kt.open_need, inputs.params, kt.check_unique,
            kt.check_unique_counts, kt.check_cells, kt.check_needs, kt.check_fails,
            kt.check_points, kt.grouped, kt.check_segments, kt.deltas, kt.cell_reach,
            kt.lengths, kt.lead_lengths, task.motion_targets, h.dims, h.hf,
            h.values, h.risk, self.seen, self.heap_h, self.heap_s, self.count,
        )  # fmt: skip
        return status


class _Back(_Walk):
    """The walk from the goal's side (see the module's docstring), nearest the start first:
    ``REACHED`` when the start can reach the goal, ``NONE`` when the states that can run out
    without it, ``OVER`` past ``states``."""

    def __init__(self, task: LatticeTask, states: int) -> None:
        super().__init__(task, states, max(1 << 14, 2 * task.near_states().size))
        K = task.grid.settings.orientations
        self.preds = predecessors(np.asarray(task.kt.deltas, dtype=np.int64), K)
        self.fanout = int(self.preds[2].max())

    def proof(self) -> GoalProof:
        """The walk's states, once it ran out (``NONE``), as the goal's proof."""
        return GoalProof(self.task.inputs.values.copy(), self.seen)

    def _chunk(self) -> int:
        task, kt, inputs = self.task, self.task.kt, self.task.inputs
        bins, motions, counts = self.preds
        si, sj, _k = task.start_key
        status: int = _walk_back(
            CHUNK, self.states, task.start_number, self.start_bits, self.near, self.dims,
            inputs.values, inputs.geo, kt.checks, kt.check_needs, kt.check_fails,
            kt.check_points, kt.grouped, kt.check_segments, kt.deltas, bins, motions, counts,
            si, sj, self.seen, self.heap_h, self.heap_s, self.count,
        )  # fmt: skip
        return status


def predecessors(deltas: NDArray[np.int64], K: int) -> tuple[NDArray[np.int64], ...]:
    """Per bin ``b``, the (bin, motion) pairs whose motion ends at bin ``b``: ``bins[b, :n]``,
    ``motions[b, :n]`` with ``n = counts[b]``."""
    ends = (np.arange(K)[:, None] + deltas[..., 2]) % K  # [K, M]
    counts = np.bincount(ends.ravel(), minlength=K).astype(np.int64)
    bins = np.zeros((K, max(1, int(counts.max()))), dtype=np.int64)
    motions = np.zeros_like(bins)
    for b in range(K):
        k, m = np.nonzero(ends == b)
        bins[b, : k.size], motions[b, : m.size] = k, m
    return bins, motions, counts


@jit
def _walk_back(  # pragma: no cover - compiled
    chunk: int, limit: int, start: int, start_bits: int, near: NDArray[np.int64],
    dims: NDArray[np.int64], values: Array, geo: Array, checks: Array, check_needs: Array,
    check_fails: Array, check_points: Array, grouped: Array, check_segments: Array,
    deltas: Array, bins: NDArray[np.int64], motions: NDArray[np.int64],
    counts: NDArray[np.int64], si: int, sj: int, seen: NDArray[np.bool_], heap_h: Array,
    heap_s: NDArray[np.int64], count: NDArray[np.int64],
) -> int:  # fmt: skip
    """Up to ``chunk`` states of the walk from the goal's side, nearest the start first (the
    start's own motions read from ``start_bits``: its margin is its own)."""
    nx, ny = dims[0], dims[1]
    plane = nx * ny
    if count[2] == 0:
        count[2] = 1
        for q in range(near.shape[0]):
            n = near[q]
            bc = n % plane
            bi, bj = bc // ny, bc % ny
            if seen[n]:
                continue
            if n == start:
                return REACHED
            seen[n] = True
            _push(heap_h, heap_s, count, math.hypot(bi - si, bj - sj), n)
    done = 0
    while count[0] > 0:
        if done >= chunk or count[0] + counts.max() + 1 > heap_h.shape[0]:
            return RUNNING
        state = _take(heap_h, heap_s, count)
        done += 1
        if count[1] > limit:
            return OVER
        b, cell = state // plane, state % plane
        ti, tj = cell // ny, cell % ny
        for q in range(counts[b]):
            k, m = bins[b, q], motions[b, q]
            i, j = ti - deltas[k, m, 0], tj - deltas[k, m, 1]
            if not (0 <= i < nx and 0 <= j < ny):
                continue
            source = k * plane + i * ny + j
            if seen[source]:
                continue
            if source == start:
                if (start_bits >> m) & 1:
                    return REACHED
                continue
            cx, cy = cell_centre(geo, i, j)
            slack = motion_slack(
                k, m, i, j, cx, cy, nx, ny, values, geo, checks, check_needs, check_fails,
                check_points, grouped, check_segments,
            )  # fmt: skip
            if slack < 0.0:
                continue
            seen[source] = True
            _push(heap_h, heap_s, count, math.hypot(i - si, j - sj), source)
    return NONE


@jit
def _push(  # pragma: no cover - compiled
    h: Array, s: NDArray[np.int64], count: NDArray[np.int64], key: float, state: int
) -> None:
    """``state`` onto the heap at ``key`` (``count[0]``: the heap's size; room is checked by
    the walks before each state's successors)."""
    p = count[0]
    h[p], s[p] = key, state
    _sift_up(h, s, p)
    count[0] = p + 1


@jit
def _take(  # pragma: no cover - compiled
    h: Array, s: NDArray[np.int64], count: NDArray[np.int64]
) -> int:
    """The heap's least state, taken off it and counted as met (``count``: heap size, states
    met)."""
    state = _pop(h, s, count[0])
    count[0] -= 1
    count[1] += 1
    return int(state)


@jit
def _sift_up(h: Array, s: NDArray[np.int64], p: int) -> None:  # pragma: no cover - compiled
    while p > 0:
        parent = (p - 1) // 2
        if not h[p] < h[parent]:
            break
        h[p], h[parent] = h[parent], h[p]
        s[p], s[parent] = s[parent], s[p]
        p = parent


@jit
def _pop(h: Array, s: NDArray[np.int64], size: int) -> int:  # pragma: no cover - compiled
    top = s[0]
    last = size - 1
    h[0], s[0] = h[last], s[last]
    p = 0
    while True:
        a, b, least = 2 * p + 1, 2 * p + 2, p
        if a < last and h[a] < h[least]:
            least = a
        if b < last and h[b] < h[least]:
            least = b
        if least == p:
            break
        h[p], h[least] = h[least], h[p]
        s[p], s[least] = s[least], s[p]
        p = least
    return int(top)


@jit
def _walk(  # pragma: no cover - compiled
    chunk: int, limit: int, start: int, start_bits: int, near: NDArray[np.int64],
    dims: NDArray[np.int64], values: Array, geo: Array, open_need: float, params: Array,
    check_unique: Array, check_unique_counts: Array, check_cells: Array,
    check_needs: Array, check_fails: Array, check_points: Array,
    grouped: Array, check_segments: Array, deltas: Array, cell_reach: Array, lengths: Array,
    lead_lengths: Array, targets: Array, h_dims: NDArray[np.int64], h_f: Array, h_values: Array,
    h_risk: Array, seen: NDArray[np.bool_],
    heap_h: Array, heap_s: NDArray[np.int64], count: NDArray[np.int64],
) -> int:  # fmt: skip
    """Up to ``chunk`` states of the walk (see the module's docstring); what it ended with."""
    nx, ny = dims[0], dims[1]
    plane = nx * ny
    n_motions = check_segments.shape[1] - 1
    base = np.empty(n_motions)
    at_cells = np.empty(check_unique.shape[1])
    if count[2] == 0:
        count[2] = 1
        seen[start] = True
        heap_h[0], heap_s[0] = 0.0, start
        count[0] = 1
    done = 0
    while count[0] > 0:
        if done >= chunk or count[0] + n_motions + 1 > heap_h.shape[0]:
            return RUNNING
        state = _take(heap_h, heap_s, count)
        done += 1
        if count[1] > limit:
            return OVER
        at = np.searchsorted(near, state)
        if at < near.shape[0] and near[at] == state:
            return REACHED
        if state == start:
            bits = start_bits
        else:
            bits = lethal_part(
                state, nx, ny, values, geo, open_need, check_unique, check_unique_counts,
                check_cells, check_needs, check_fails, check_points, grouped, check_segments,
                deltas, cell_reach, lengths, lead_lengths, params, base, at_cells,
            )  # fmt: skip
        k, cell = state // plane, state % plane
        for m in range(n_motions):
            if not (bits >> m) & 1:
                continue
            b = targets[k, m] + cell
            if b == state or seen[b]:
                continue
            seen[b] = True
            h = state_heuristic(b, h_dims, h_f, h_values, h_risk)
            if h == math.inf:
                continue  # the 2-D map proves no way on from there
            _push(heap_h, heap_s, count, h, b)
    return NONE
