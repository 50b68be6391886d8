"""What each motion out of a lattice state costs, and whether it is valid at all.

A motion is **valid** where every swept sample point keeps the clearance it needs plus the
margin from the lethal layer, and it ends on the grid. A valid motion **costs**, in metres,

    length x (1 + inflation_penalty x closeness + reverse_penalty x tail_lead)
      + contact_cost x E[contacts] + blocked_cost x E[blocks],

where ``closeness = exp(-slack / inflation_decay)`` at the body's closest point (slack: its
clearance beyond need and margin; nothing past ``inflation_radius``), Nav2's inflation and
cost penalty measured on the swept body itself; ``tail_lead`` 0 for a head-first move, 1/2
sideways, 1 tail first (Smac's reverse penalty: the head's rays look where the head goes);
``E[contacts]`` the obstacles expected in the
blind new cells, ``-log P(free)`` of each summed (``domain.world``'s risk; for a cell of
never-observed space its prior, for one beside a bumper's contact far more), and
``E[blocks]`` the same over the new cells the head sees first, with what may block them. The
count grows with every piece of evidence swept: a motion that rams what was touched twice
costs twice what one that brushes it once does, so repeated contacts drive plans away. So the tail's risk belongs to the motion that takes it there: a
turn in place, a sideways or a tail-first move through never-observed space or past contact
evidence costs what it risks; a head-first move, whose rays look first, only what it may find
in its way (a gap in a wall seen as a dashed line).

The evaluation is compiled and in two parts, what the lethal layer decides (validity, length
and closeness: it changes seldom) and what the soft layers risk (it changes every tick near the
robot), so a cache keeps each apart; the search kernel and pyperplan's searches (through
``LatticeTask``) call the same functions, so every path reads the same numbers.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage

from domain.kernels import jit
from domain.navigation.lattice.motions import MotionTable
from domain.navigation.settings import CostSettings
from sim.robot import Array


@dataclass(frozen=True)
class KernelTable:
    """A motion table as the kernels read it, per bin padded to the longest bin: the cells
    each motion's sample points fall in (``checks`` ``[K, C, 2]``) with the clearance at which
    a cell's centre passes all its points and below which one fails, with the margin
    (``check_needs``, ``check_fails``; ``motions.CellChecks``), the points by cell
    (``grouped`` ``[K, P, 3]``: x, y, need with the margin; ``check_points``: each cell's
    bounds), each motion's cells (``check_segments``), the motions' cell deltas, lengths and
    new cells (``cells`` ``[K, N, 3]``: di, dj, blind; ``cell_segments``; ``cell_counts``
    ``[K, M, 2]``: how many of a motion's new cells are blind and how many seen).

    A bin's motions share most of their cells (each sweeps the body from the same start), so
    the evaluation reads each distinct cell of a bin once: ``check_unique`` ``[K, U, 2]``
    (``check_unique_counts`` per bin) and ``check_cells`` (per check, its distinct cell); the
    new cells likewise (``new_unique``, ``new_unique_counts``), each motion's blind ones
    (``blind_cells`` by ``blind_segments``) apart from its seen ones (``seen_cells``,
    ``seen_segments``), each in the motion's order, so every sum adds what it added before."""

    checks: NDArray[np.int64]
    check_needs: Array
    check_fails: Array
    check_points: NDArray[np.int64]
    grouped: Array
    check_segments: NDArray[np.int64]
    deltas: NDArray[np.int64]
    cell_reach: NDArray[np.int64]
    lengths: Array
    lead_lengths: Array  # [M] length x how far the tail leads (``motions.tail_lead``)
    cells: NDArray[np.int64]
    cell_segments: NDArray[np.int64]
    cell_counts: NDArray[np.int64]
    open_need: float  # centroid clearance beyond which every point keeps its need + margin
    check_unique: NDArray[np.int64]
    check_unique_counts: NDArray[np.int64]
    check_cells: NDArray[np.int64]
    new_unique: NDArray[np.int64]
    new_unique_counts: NDArray[np.int64]
    blind_segments: NDArray[np.int64]
    blind_cells: NDArray[np.int64]
    seen_segments: NDArray[np.int64]
    seen_cells: NDArray[np.int64]

    def bin(self, k: int) -> KernelTable:
        """The table of bin ``k`` alone, as bin 0 (views: nothing copied). One state's motions
        read it at its cell's number (``start_costs``): a table with that state's own margins
        (``with_start_margins``) then copies one bin, not all of them."""
        one = slice(k, k + 1)
        return dataclasses.replace(
            self,
            checks=self.checks[one],
            check_needs=self.check_needs[one],
            check_fails=self.check_fails[one],
            check_points=self.check_points[one],
            grouped=self.grouped[one],
            check_segments=self.check_segments[one],
            deltas=self.deltas[one],
            cell_reach=self.cell_reach[one],
            cells=self.cells[one],
            cell_segments=self.cell_segments[one],
            cell_counts=self.cell_counts[one],
            check_unique=self.check_unique[one],
            check_unique_counts=self.check_unique_counts[one],
            check_cells=self.check_cells[one],
            new_unique=self.new_unique[one],
            new_unique_counts=self.new_unique_counts[one],
            blind_segments=self.blind_segments[one],
            blind_cells=self.blind_cells[one],
            seen_segments=self.seen_segments[one],
            seen_cells=self.seen_cells[one],
        )


_TABLES: dict[tuple[int, float], tuple[MotionTable, KernelTable]] = {}
TABLES_KEPT = 16


def kernel_table(table: MotionTable, margin: float) -> KernelTable:
    """The kernels' form of ``table`` for motions keeping ``margin`` (made once per table)."""
    key = (id(table), margin)
    got = _TABLES.get(key)
    if got is not None and got[0] is table:
        return got[1]
    K, M = table.deltas.shape[:2]
    n_checks = max(1, max(len(c) for c in table.checks))
    n_points = max(1, max(len(g) for g in table.grouped))
    n_cells = max(1, max(len(c) for c in table.cells))
    checks = np.zeros((K, n_checks, 2), dtype=np.int64)
    check_needs = np.zeros((K, n_checks))
    check_fails = np.zeros((K, n_checks))
    check_points = np.zeros((K, n_checks + 1), dtype=np.int64)
    grouped = np.zeros((K, n_points, 3))
    check_segments = np.zeros((K, M + 1), dtype=np.int64)
    cells = np.zeros((K, n_cells, 3), dtype=np.int64)
    cell_segments = np.zeros((K, M + 1), dtype=np.int64)
    cell_counts = np.zeros((K, M, 2), dtype=np.int64)
    for k in range(K):
        checks[k, : len(table.checks[k])] = table.checks[k]
        n = len(table.check_needs[k])
        check_needs[k, :n] = table.check_needs[k] + margin
        check_fails[k, :n] = table.check_fails[k] + margin
        check_points[k, : n + 1] = table.check_points[k]
        g = table.grouped[k]
        grouped[k, : len(g), :2] = g[:, :2]
        grouped[k, : len(g), 2] = g[:, 2] + margin
        check_segments[k] = table.check_segments[k]
        cells[k, : len(table.cells[k])] = table.cells[k]
        cell_segments[k] = table.cell_segments[k]
        for m in range(M):
            blind = table.cells[k][cell_segments[k, m] : cell_segments[k, m + 1], 2]
            n_blind = int(np.count_nonzero(blind))
            cell_counts[k, m] = n_blind, len(blind) - n_blind
    check_unique, check_unique_counts, check_cells = _distinct(
        [table.checks[k] for k in range(K)], n_checks
    )
    new_unique, new_unique_counts, new_cells = _distinct(
        [table.cells[k][:, :2] for k in range(K)], n_cells
    )
    blind_segments, blind_cells, seen_segments, seen_cells = _blind_and_seen(
        table, cell_segments, new_cells
    )
    out = KernelTable(
        checks,
        check_needs,
        check_fails,
        check_points,
        grouped,
        check_segments,
        np.ascontiguousarray(table.deltas, dtype=np.int64),
        np.asarray(table.cell_reach, dtype=np.int64),
        np.ascontiguousarray(table.lengths, dtype=np.float64),
        np.ascontiguousarray(table.lengths * table.leads, dtype=np.float64),
        cells,
        cell_segments,
        cell_counts,
        table.open_clearance + table.settings.resolution + margin,
        check_unique,
        check_unique_counts,
        check_cells,
        new_unique,
        new_unique_counts,
        blind_segments,
        blind_cells,
        seen_segments,
        seen_cells,
    )
    if len(_TABLES) >= TABLES_KEPT:
        _TABLES.clear()
    _TABLES[key] = (table, out)
    return out


def _distinct(
    per_bin: list[NDArray[np.int64]], width: int
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Each bin's distinct cell offsets ``[K, U, 2]`` (padded), how many, and for each of the
    bin's cells (``[K, width]``, padded) its distinct cell."""
    found = []
    for cells in per_bin:
        cells = cells.reshape(-1, 2)
        low = cells.min(axis=0, initial=0)
        span = int(cells[:, 1].max(initial=0) - low[1]) + 1
        codes = (cells[:, 0] - low[0]) * span + (cells[:, 1] - low[1])  # one int per offset
        unique, inverse = np.unique(codes, return_inverse=True)
        offsets = np.stack([unique // span + low[0], unique % span + low[1]], axis=-1)
        found.append((offsets, inverse))
    n_unique = max(1, max(len(u) for u, _ in found))
    unique_cells = np.zeros((len(per_bin), n_unique, 2), dtype=np.int64)
    counts = np.zeros(len(per_bin), dtype=np.int64)
    index = np.zeros((len(per_bin), width), dtype=np.int64)
    for k, (u, inverse) in enumerate(found):
        unique_cells[k, : len(u)], counts[k] = u, len(u)
        index[k, : inverse.size] = inverse.ravel()
    return unique_cells, counts, index


def _blind_and_seen(
    table: MotionTable, cell_segments: NDArray[np.int64], new_cells: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]:
    """Per bin and motion, its blind new cells' distinct cells and its seen ones', each in
    the motion's order (``KernelTable``): segments ``[K, M + 1]`` and cells ``[K, B]``."""
    K, M = cell_segments.shape[0], cell_segments.shape[1] - 1
    parts = []
    for k in range(K):
        blind = table.cells[k][:, 2] != 0
        motion = np.repeat(np.arange(M), np.diff(cell_segments[k]))  # each cell's motion
        row = []
        for which in (blind, ~blind):  # (a motion's cells are contiguous: order is kept)
            per_motion = np.bincount(motion[which], minlength=M)
            segments = np.concatenate([[0], np.cumsum(per_motion)])
            row.append((segments, new_cells[k, : blind.size][which]))
        parts.append(row)
    width = max(1, max(len(cells) for row in parts for _, cells in row))
    out = []
    for side in (0, 1):
        segments = np.zeros((K, M + 1), dtype=np.int64)
        cells = np.zeros((K, width), dtype=np.int64)
        for k, row in enumerate(parts):
            segments[k], found = row[side]
            cells[k, : len(found)] = found
        out += [segments, cells]
    return out[0], out[1], out[2], out[3]


def cost_parameters(costs: CostSettings) -> Array:
    """``[inflation radius, decay, penalty, contact cost, blocked cost, reverse penalty]`` for
    the kernels."""
    return np.array(
        [
            costs.inflation_radius,
            costs.inflation_decay,
            costs.inflation_penalty,
            costs.contact_cost,
            costs.blocked_cost,
            costs.reverse_penalty,
        ]
    )


@jit
def lethal_at(  # pragma: no cover - compiled
    values: Array, geo: Array, x: float, y: float
) -> float:
    """The lethal clearance at one point: bilinear between cell centres (``values`` ``[nx,
    ny]``), at most the distance to the walls (``geo``: ox, oy, resolution, xmin, xmax, ymin,
    ymax), as ``domain.world.interpolate.bilinear`` computes it."""
    nx, ny = values.shape
    ox, oy, res = geo[0], geo[1], geo[2]
    u = min(max((x - ox) / res - 0.5, 0.0), nx - 1.0)
    v = min(max((y - oy) / res - 0.5, 0.0), ny - 1.0)
    i0 = min(int(u), max(nx - 2, 0))
    j0 = min(int(v), max(ny - 2, 0))
    fu, fv = u - i0, v - j0
    i1 = i0 + 1 if nx > 1 else i0
    j1 = j0 + 1 if ny > 1 else j0
    low = values[i0, j0] * (1 - fv) + values[i0, j1] * fv
    high = values[i1, j0] * (1 - fv) + values[i1, j1] * fv
    wall = min(min(x - geo[3], geo[4] - x), min(y - geo[5], geo[6] - y))
    return float(min(low * (1 - fu) + high * fu, wall))


@jit
def cell_centre(geo: Array, i: int, j: int) -> tuple[float, float]:  # pragma: no cover - compiled
    """The centre of cell ``(i, j)`` (``geo``: ox, oy, resolution, ...)."""
    return geo[0] + (i + 0.5) * geo[2], geo[1] + (j + 0.5) * geo[2]


@jit
def points_slack(  # pragma: no cover - compiled
    k: int,
    c: int,
    cx: float,
    cy: float,
    values: Array,
    geo: Array,
    check_points: Array,
    grouped: Array,
) -> float:
    """The least slack the points of check ``c`` of bin ``k`` keep beyond their need, read
    exactly between the centres (``lethal_at``; ``geo``: the grid and its walls) from the
    state's cell centre ``(cx, cy)``: for a clearance at the check's cell that neither passes
    nor fails all its points (``KernelTable``)."""
    s = math.inf
    for q in range(check_points[k, c], check_points[k, c + 1]):
        x, y = cx + grouped[k, q, 0], cy + grouped[k, q, 1]
        t = lethal_at(values, geo, x, y) - grouped[k, q, 2]
        if t < s:
            s = t
    return s


@jit
def motion_slack(  # pragma: no cover - compiled
    k: int,
    m: int,
    i: int,
    j: int,
    cx: float,
    cy: float,
    nx: int,
    ny: int,
    values: Array,
    geo: Array,
    checks: Array,
    check_needs: Array,
    check_fails: Array,
    check_points: Array,
    grouped: Array,
    check_segments: Array,
) -> float:
    """The least slack motion ``m`` keeps out of cell ``(i, j)`` (its centre ``(cx, cy)``) at
    bin ``k`` beyond what its points need (a bound, >= 0), or -1 when it is invalid: each of
    its cells read at its centre (``values``: the lethal clearance there); a cell whose
    clearance neither passes nor fails all its points (``KernelTable``) reads its points
    (``points_slack``). A cell off the grid is invalid."""
    slack = math.inf
    for c in range(check_segments[k, m], check_segments[k, m + 1]):
        ci, cj = i + checks[k, c, 0], j + checks[k, c, 1]
        if ci < 0 or ci >= nx or cj < 0 or cj >= ny:
            return -1.0
        here = values[ci, cj]
        if here >= check_needs[k, c]:
            s = here - check_needs[k, c]  # (a bound: every point keeps at least this)
        elif here < check_fails[k, c]:
            return -1.0
        else:
            s = points_slack(k, c, cx, cy, values, geo, check_points, grouped)
            if not s >= 0.0:
                return -1.0
        if s < slack:
            slack = s
    return slack


@jit
def lethal_part(  # pragma: no cover - compiled
    number: int,
    nx: int,
    ny: int,
    values: Array,
    geo: Array,
    open_need: float,
    check_unique: Array,
    check_unique_counts: Array,
    check_cells: Array,
    check_needs: Array,
    check_fails: Array,
    check_points: Array,
    grouped: Array,
    check_segments: Array,
    deltas: Array,
    cell_reach: Array,
    lengths: Array,
    lead_lengths: Array,
    params: Array,
    base: Array,
    at_cells: Array,
) -> int:
    """The valid motions of state ``number`` as a bitmask (bit ``m``: motion ``m``), and into
    ``base`` each valid motion's length and closeness cost (``inf`` for the others): what the
    lethal layer alone decides (``motion_slack``, each of the bin's distinct cells read once
    into ``at_cells``, ``-inf`` off the grid: a motion over one is invalid). ``open_need``:
    the centroid clearance past which every point of every motion keeps its need and more
    than the inflation radius (open space: nothing is read); ``params``:
    ``cost_parameters``. A motion reaching off the grid is invalid."""
    plane = nx * ny
    k, cell = number // plane, number % plane
    i, j = cell // ny, cell % ny
    cx, cy = cell_centre(geo, i, j)
    n_motions = check_segments.shape[1] - 1
    radius, decay, penalty, reverse = params[0], params[1], params[2], params[5]
    open_space = values[i, j] >= open_need + radius
    reach = cell_reach[k]
    edge = not (reach <= i < nx - reach and reach <= j < ny - reach)
    if not open_space:
        for u in range(check_unique_counts[k]):
            ci, cj = i + check_unique[k, u, 0], j + check_unique[k, u, 1]
            inside = 0 <= ci < nx and 0 <= cj < ny
            at_cells[u] = values[ci, cj] if inside else -math.inf
    bits = 0
    for m in range(n_motions):
        base[m] = math.inf
        if edge:
            ni, nj = i + deltas[k, m, 0], j + deltas[k, m, 1]
            if not (0 <= ni < nx and 0 <= nj < ny):
                continue
        slack = math.inf
        if not open_space:  # (motion_slack's test, on the cells read once)
            for c in range(check_segments[k, m], check_segments[k, m + 1]):
                here = at_cells[check_cells[k, c]]
                if here >= check_needs[k, c]:
                    s = here - check_needs[k, c]
                elif here < check_fails[k, c]:
                    slack = -1.0
                    break
                else:  # (``points_slack``, inline: a compiled call costs more than its work)
                    s = math.inf
                    for q in range(check_points[k, c], check_points[k, c + 1]):
                        x, y = cx + grouped[k, q, 0], cy + grouped[k, q, 1]
                        t = lethal_at(values, geo, x, y) - grouped[k, q, 2]
                        if t < s:
                            s = t
                    if not s >= 0.0:
                        slack = -1.0
                        break
                if s < slack:
                    slack = s
            if slack < 0.0:
                continue
        bits |= 1 << m
        close = math.exp(-slack / decay) if slack < radius else 0.0
        base[m] = lengths[m] * (1.0 + penalty * close) + reverse * lead_lengths[m]
    return bits


@jit
def risk_part(  # pragma: no cover - compiled
    number: int,
    nx: int,
    ny: int,
    risk: Array,
    blocked: Array,
    flat: Array,
    new_unique: Array,
    new_unique_counts: Array,
    blind_segments: Array,
    blind_cells: Array,
    seen_segments: Array,
    seen_cells: Array,
    cell_counts: Array,
    params: Array,
    extra: Array,
    at_risk: Array,
    at_blocked: Array,
) -> None:
    """Into ``extra``, what each motion of state ``number`` risks, valid or not: ``contact
    cost`` times the contacts expected over its blind new cells (``risk``: log P(free) per
    cell; a cell's -log P(free) is the obstacles expected in it, as a Poisson count) and
    ``blocked cost`` times those expected over the cells the head sees first (``blocked``);
    each of the bin's distinct new cells read once into ``at_risk`` and ``at_blocked`` (0 off
    the grid: nothing is expected there). From a cell where ``flat`` holds (``flat_cells``:
    both alike over every motion's reach), the sums are the cell's own values times the
    motions' cell counts."""
    plane = nx * ny
    k, cell = number // plane, number % plane
    i, j = cell // ny, cell % ny
    n_motions = blind_segments.shape[1] - 1
    contact, block = params[3], params[4]
    if flat[i, j]:
        r, b = risk[i, j], blocked[i, j]
        for m in range(n_motions):
            extra[m] = -contact * (r * cell_counts[k, m, 0]) - block * (b * cell_counts[k, m, 1])
        return
    for u in range(new_unique_counts[k]):
        ci, cj = i + new_unique[k, u, 0], j + new_unique[k, u, 1]
        if 0 <= ci < nx and 0 <= cj < ny:
            at_risk[u], at_blocked[u] = risk[ci, cj], blocked[ci, cj]
        else:
            at_risk[u], at_blocked[u] = 0.0, 0.0
    for m in range(n_motions):
        unseen = 0.0  # log P(free) of the blind new cells
        for c in range(blind_segments[k, m], blind_segments[k, m + 1]):
            unseen += at_risk[blind_cells[k, c]]
        seen = 0.0  # ... and of those the head sees first
        for c in range(seen_segments[k, m], seen_segments[k, m + 1]):
            seen += at_blocked[seen_cells[k, c]]
        extra[m] = -contact * unseen - block * seen  # (metres per expected contact or block)


@jit
def add_costs(base: Array, extra: Array, costs: Array) -> None:  # pragma: no cover - compiled
    """A motion's cost: its base (inf when invalid) plus its risk."""
    for m in range(base.shape[0]):
        costs[m] = base[m] + extra[m]


@dataclass
class CostInputs:
    """What ``evaluate`` reads of one search's world: the grid's numbers, the lethal
    clearance and its geometry, the risk of blind and of seen cells (and where either is
    alike over a motion's reach), the cost parameters."""

    nx: int
    ny: int
    gf: Array
    values: Array
    geo: Array
    risk: Array
    blocked: Array
    flat: NDArray[np.bool_]
    params: Array


def lethal_costs(
    number: int, inputs: CostInputs, kt: KernelTable, part: Any = None
) -> tuple[int, NDArray[np.float64]]:
    """``lethal_part`` of one state from Python: its valid motions' bitmask and base costs
    (``part``: the function to run instead, such as its Python form ``lethal_part.py_func``)."""
    base = np.empty(kt.check_segments.shape[1] - 1)
    bits = (part or lethal_part)(
        number, inputs.nx, inputs.ny, inputs.values, inputs.geo, kt.open_need, kt.check_unique,
        kt.check_unique_counts, kt.check_cells, kt.check_needs, kt.check_fails,
        kt.check_points, kt.grouped, kt.check_segments, kt.deltas, kt.cell_reach, kt.lengths,
        kt.lead_lengths, inputs.params, base, np.empty(kt.check_unique.shape[1]),
    )  # fmt: skip
    return int(bits), base


def risk_costs(
    number: int, inputs: CostInputs, kt: KernelTable, part: Any = None
) -> NDArray[np.float64]:
    """``risk_part`` of one state from Python (``part``: as ``lethal_costs``)."""
    extra = np.empty(kt.cell_segments.shape[1] - 1)
    width = kt.new_unique.shape[1]
    (part or risk_part)(
        number, inputs.nx, inputs.ny, inputs.risk, inputs.blocked, inputs.flat, kt.new_unique,
        kt.new_unique_counts, kt.blind_segments, kt.blind_cells, kt.seen_segments,
        kt.seen_cells, kt.cell_counts, inputs.params, extra, np.empty(width), np.empty(width),
    )  # fmt: skip
    return extra


def state_costs(
    number: int, inputs: CostInputs, kt: KernelTable
) -> tuple[int, NDArray[np.float64]]:
    """A state's valid motions (bitmask) and their costs (``inf`` for the invalid ones)."""
    bits, base = lethal_costs(number, inputs, kt)
    return bits, base + risk_costs(number, inputs, kt)


def start_costs(
    number: int, inputs: CostInputs, kt_bin: KernelTable
) -> tuple[int, NDArray[np.float64]]:
    """``state_costs`` of state ``number`` by ``kt_bin``, a one-bin table of its own bin
    (``KernelTable.bin``)."""
    return state_costs(number % (inputs.nx * inputs.ny), inputs, kt_bin)


def flat_cells(risk: Array, blocked: Array, reach: int) -> NDArray[np.bool_]:
    """Per cell, whether every cell within ``reach`` cells (a box) has its risk and its
    blocked value, and the box lies inside the grid unless both are 0: a motion from there
    reads those values on each of its cells (a maximum filter of the cells beside a
    different one, separable). Risk is piecewise constant (the never-observed prior, near
    and beyond the horizon; none where observed), so most cells are flat."""
    edge = np.zeros(risk.shape, dtype=bool)
    for layer in (risk, blocked):
        across = layer[1:, :] != layer[:-1, :]
        edge[1:, :] |= across
        edge[:-1, :] |= across
        along = layer[:, 1:] != layer[:, :-1]
        edge[:, 1:] |= along
        edge[:, :-1] |= along
    out: NDArray[np.bool_] = ~ndimage.maximum_filter(
        edge, size=2 * reach + 1, mode="constant", cval=False
    )
    nx, ny = risk.shape
    inside = np.zeros(risk.shape, dtype=bool)
    inside[reach : nx - reach, reach : ny - reach] = True
    out &= inside | ((risk == 0.0) & (blocked == 0.0))
    return out


def with_start_margins(kt_bin: KernelTable, shift: Array, point_shift: Array) -> KernelTable:
    """A one-bin table (``KernelTable.bin``) with its margins moved by ``shift`` per cell and
    ``point_shift`` per grouped point (the start's own allowance: ``Planner.start_table``)."""
    passes = np.array(kt_bin.check_needs, copy=True)
    fails = np.array(kt_bin.check_fails, copy=True)
    grouped = np.array(kt_bin.grouped, copy=True)
    passes[0, : len(shift)] += shift
    fails[0, : len(shift)] += shift
    grouped[0, : len(point_shift), 2] += point_shift
    return dataclasses.replace(
        kt_bin, check_needs=passes, check_fails=fails, grouped=grouped, open_need=math.inf
    )
