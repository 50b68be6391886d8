"""Compiled (numba) kernels of the sensed layer's marking half: hit evidence shared, applied, thresholded.

The second half of ``SensedLayer._integrate_compiled`` (the first, the readings' layout and the
clearing, is ``domain.occupancy_kernel``'s). The same numbers as the numpy path, value for value:
a hit's evidence is normalised by numpy's pairwise summation (``_pairwise_sum``), every other
float by the same operations in the same order as numpy's.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from domain.kernels import jit
from domain.world.sensed.clearing import Ints, _pairwise_sum
from sim.robot import Array


@jit
def share_and_mark(  # pragma: no cover - compiled
    log_odds: Array,
    occupied: NDArray[np.bool_],
    arc: Ints,
    lik: Array,
    bounds: Ints,
    p: Array,  # per arc cell: 1 where known geometry explains it, else the occupancy probability
    explained: NDArray[np.bool_],
    narrow: NDArray[np.bool_],  # per hit: the cone's arc at the hit is at most a cell wide
    cleared: Ints,
    log_odds_hit: float,
    dominant_share: float,
    log_odds_max: float,
    ambiguous_ceiling: float,
    threshold: float,
    sure_acc: Array,  # scratch, one per cell, all 0 between calls
    vague_acc: Array,  # scratch, one per cell, all 0 between calls
    mark: Ints,  # scratch, one per cell, all -1 between calls
) -> tuple[Ints, Ints]:
    """The marking half: share each hit's evidence across its arc cells, apply sure shares (up
    to ``log_odds_max``) then vague ones (up to ``ambiguous_ceiling``), threshold the cells
    touched. Returns the cells that became occupied and those that ceased to be (sorted)."""
    n = arc.size
    weighted = np.empty(n, dtype=np.float64)
    for m in range(n):
        weighted[m] = lik[m] * p[m]
    sure_cells = np.empty(n, dtype=np.int64)
    vague_cells = np.empty(n, dtype=np.int64)
    n_sure = 0
    n_vague = 0
    for h in range(bounds.size - 1):
        lo, hi = bounds[h], bounds[h + 1]
        total = _pairwise_sum(weighted, lo, hi - lo)
        for m in range(lo, hi):
            if explained[m]:
                continue
            share = weighted[m] / total
            c = arc[m]
            if share > dominant_share and narrow[h]:
                if mark[c] != 1 and mark[c] != 3:
                    sure_cells[n_sure] = c
                    n_sure += 1
                    mark[c] = 1 if mark[c] < 0 else 3
                    sure_acc[c] = 0.0 + log_odds_hit * share
                else:
                    sure_acc[c] += log_odds_hit * share
            else:
                if mark[c] != 2 and mark[c] != 3:
                    vague_cells[n_vague] = c
                    n_vague += 1
                    mark[c] = 2 if mark[c] < 0 else 3
                    vague_acc[c] = 0.0 + log_odds_hit * share
                else:
                    vague_acc[c] += log_odds_hit * share
    for m in range(n_sure):
        c = sure_cells[m]
        log_odds[c] = min(log_odds[c] + sure_acc[c], log_odds_max)
        sure_acc[c] = 0.0
    for m in range(n_vague):
        c = vague_cells[m]
        now = log_odds[c]
        log_odds[c] = max(now, min(now + vague_acc[c], ambiguous_ceiling))
        vague_acc[c] = 0.0
    # Threshold every cell touched (cleared, sure or vague) once: each is marked (3) when its
    # turn comes; only the few that changed are sorted, as np.unique would have ordered them.
    for m in range(n_sure):
        mark[sure_cells[m]] = -1
    for m in range(n_vague):
        mark[vague_cells[m]] = -1
    total = cleared.size + n_sure + n_vague
    became = np.empty(total, dtype=np.int64)
    ceased = np.empty(total, dtype=np.int64)
    n_became = 0
    n_ceased = 0
    for m in range(total):
        if m < cleared.size:
            c = cleared[m]
        elif m < cleared.size + n_sure:
            c = sure_cells[m - cleared.size]
        else:
            c = vague_cells[m - cleared.size - n_sure]
        if mark[c] == 3:
            continue
        mark[c] = 3
        before = occupied[c]
        after = log_odds[c] > threshold
        occupied[c] = after
        if after and not before:
            became[n_became] = c
            n_became += 1
        elif before and not after:
            ceased[n_ceased] = c
            n_ceased += 1
    for m in range(cleared.size):  # forget the marks
        mark[cleared[m]] = -1
    for m in range(n_sure):
        mark[sure_cells[m]] = -1
    for m in range(n_vague):
        mark[vague_cells[m]] = -1
    return np.sort(became[:n_became]), np.sort(ceased[:n_ceased])


@jit
def explain_share_and_mark(  # pragma: no cover - compiled
    log_odds: Array,
    occupied: NDArray[np.bool_],
    known_clearance: Array,  # per cell: the static layer's clearance
    arc: Ints,
    lik: Array,
    bounds: Ints,
    tolerance: Array,  # per hit: known geometry within this explains an arc cell
    odds: Array,  # per arc cell: np.exp(-log_odds) after clearing (numpy's exp)
    narrow: NDArray[np.bool_],
    cleared: Ints,
    log_odds_hit: float,
    dominant_share: float,
    log_odds_max: float,
    ambiguous_ceiling: float,
    threshold: float,
    sure_acc: Array,
    vague_acc: Array,
    mark: Ints,
) -> tuple[Ints, Ints]:
    """``share_and_mark`` after finding which arc cells known geometry explains and the
    others' occupancy probability ``1 / (1 + odds)``, as the numpy path computes them."""
    n = arc.size
    p = np.empty(n)
    explained = np.empty(n, dtype=np.bool_)
    for h in range(bounds.size - 1):
        for m in range(bounds[h], bounds[h + 1]):
            explained[m] = known_clearance[arc[m]] <= tolerance[h]
            p[m] = 1.0 if explained[m] else 1.0 / (1.0 + odds[m])
    out: tuple[Ints, Ints] = share_and_mark(
        log_odds,
        occupied,
        arc,
        lik,
        bounds,
        p,
        explained,
        narrow,
        cleared,
        log_odds_hit,
        dominant_share,
        log_odds_max,
        ambiguous_ceiling,
        threshold,
        sure_acc,
        vague_acc,
        mark,
    )
    return out
