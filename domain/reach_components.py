"""Components of the lattice's free configuration space: labelled exactly, or carried over
from an earlier world's where a box of cells changed.

``domain.lattice_reach`` asks whether a start and a goal share a component. Labelling every
configuration afresh (``scipy.ndimage.label``) costs the whole grid; between replans a few cells
change, so ``carried_over`` labels the box of changed cells (and a ring round it) afresh and
joins it with the earlier components its frame touches. It can only join too much (a component
cut apart inside the box since stays joined), so "apart" from it is sound.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray
from scipy import ndimage
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


class Components(NamedTuple):
    """The free configurations ``[K, nx, ny]`` and their components: ``component[labels]``."""

    free: NDArray[np.bool_]
    labels: NDArray[np.int32]  # [K, nx, ny] a node number per configuration
    component: NDArray[np.int32]  # node number -> component
    exact: bool  # False: some components may be joined that no longer connect


# The 8 neighbouring cells at one orientation, and one orientation step in place.
NEIGHBOURS = np.zeros((3, 3, 3), dtype=bool)
NEIGHBOURS[1] = True
NEIGHBOURS[0, 1, 1] = NEIGHBOURS[2, 1, 1] = True


def exact_components(free: NDArray[np.bool_]) -> Components:
    """Every free configuration's component (``scipy.ndimage.label``; orientation wraps)."""
    labels, count = ndimage.label(free, structure=NEIGHBOURS)
    return Components(free, labels, _joined(count + 1, [_wrapped(free, labels)]), True)


RENUMBER_AFTER = 1 << 20  # nodes of carried-over components before they are numbered afresh


def carried_over(old: Components, free: NDArray[np.bool_], box: tuple[slice, slice]) -> Components:
    """Components for ``free``, which equals ``old.free`` outside ``box`` (``old`` is taken
    over: its labels are written): the box and a
    ring of one cell round it labelled afresh, each joined with the old components its
    ring (unchanged) configurations had; elsewhere the old components. Every path of free
    configurations stays within one component (a step leaving the box ends in the ring or
    beyond it, both old, where the old labels join it), so a start and a goal apart here
    are apart; old components cut apart since stay joined."""
    nx, ny = free.shape[1:]
    ring = (
        slice(max(0, box[0].start - 1), min(nx, box[0].stop + 1)),
        slice(max(0, box[1].start - 1), min(ny, box[1].stop + 1)),
    )
    if len(old.component) > RENUMBER_AFTER:  # each carry adds nodes: number them afresh
        renumbered = old.component[old.labels]
        identity = np.arange(int(old.component.max()) + 1, dtype=np.int32)
        old = Components(old.free, renumbered, identity, old.exact)
    inner = free[:, ring[0], ring[1]]
    fresh, count = ndimage.label(inner, structure=NEIGHBOURS)
    # Nodes: the old labels, then one per old component, then the fresh labels.
    labels, first = old.labels, len(old.component)
    nodes = first + int(old.component.max()) + 1
    # Joined only on the frame (ring less box), where old and new free configurations agree
    # and every path out of the ring passes: old labels inside the box are of the old world
    # (joining there kept a pen closed since joined, and made the joins as many as the box's
    # configurations: 5 s and 1.8 GB on a 40 m arena where the box spans it).
    frame = np.ones(inner.shape[1:], dtype=bool)
    frame[
        box[0].start - ring[0].start : box[0].stop - ring[0].start,
        box[1].start - ring[1].start : box[1].stop - ring[1].start,
    ] = False
    both = inner & frame
    a = labels[:, ring[0], ring[1]][both]
    fresh = fresh.astype(labels.dtype, copy=False)
    np.add(fresh, nodes, out=fresh, where=inner)  # (in place: a box may span the arena)
    labels[:, ring[0], ring[1]] = fresh  # (in place: ``old`` is taken over)
    ids = np.arange(first, dtype=labels.dtype)
    joins = [(ids, first + old.component), (a, fresh[both]), _wrapped(inner, fresh)]
    return Components(free, labels, _joined(nodes + count + 1, joins), False)


def _wrapped(
    free: NDArray[np.bool_], labels: NDArray[np.int32]
) -> tuple[NDArray[np.int32], NDArray[np.int32]]:
    """Orientation wraps round: the labels that meet across bins K-1 and 0."""
    both = free[0] & free[-1]
    return labels[0][both], labels[-1][both]


def _joined(
    nodes: int, joins: list[tuple[NDArray[np.int32], NDArray[np.int32]]]
) -> NDArray[np.int32]:
    """Node number -> component, for ``nodes`` nodes joined pairwise by ``joins``."""
    ids = np.arange(nodes)
    a = np.concatenate([ids, *(x for x, _ in joins)])
    b = np.concatenate([ids, *(y for _, y in joins)])
    graph = coo_matrix((np.ones(a.size), (a, b)), shape=(nodes, nodes))
    component: NDArray[np.int32] = connected_components(graph, directed=False)[1]
    return component.astype(np.int32)
