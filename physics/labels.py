"""Which marker is which: a trajectory's node labels against the T6 layout (rods and cables).

Rod i joins nodes 2i and 2i+1 (physics.geometry.ROD_NODES); a rod is rigid, so the distance
between its ends is the same on every sample and for every rod (one ``rod_length``). Every cable
is shorter than a rod (SUPERball: cables about 1.0-1.1 m, rods 1.74 m). Labels that break
either are a swapped or mislabelled marker, which no parameter can explain.

Distances are summarized over time per node pair from nodes (T x 12 x 3) [m]::

    d_ab(t) = |x_a(t) - x_b(t)|,   D_ab = median_t d_ab(t),   S_ab = p95_t d_ab(t) - p5_t d_ab(t)

(NaN samples skipped).
"""
from __future__ import annotations

import warnings
from collections.abc import Iterator

import numpy as np

from physics.geometry import CABLE_NAMES, CABLE_NODES, N_NODES, N_RODS, ROD_NODES

__all__ = ["pair_distances", "rod_lengths", "find_rod_pairs", "flip_rod_ends", "relabel_order"]

#: A cable longer than this fraction of the rod length is a mislabelled node.
CABLE_TO_ROD = 0.8
#: At most this many evenly spaced samples enter the pair distances (memory T x 144 x 3).
MAX_SAMPLES = 2000


def pair_distances(nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(D, S): the median distance and its 5-95 % spread over time between every two nodes,
    each (12 x 12) [m], from nodes (T x 12 x 3) [m] (at most MAX_SAMPLES evenly spaced samples); NaN
    where a pair is never seen."""
    sampled = nodes[:: max(1, len(nodes) // MAX_SAMPLES)]
    d = np.linalg.norm(sampled[:, :, None, :] - sampled[:, None, :, :], axis=-1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)     # a pair never seen gives NaN, said in the docstring
        median = np.nanmedian(d, axis=0)
        low, high = np.nanpercentile(d, [5, 95], axis=0)
    return median, high - low


def rod_lengths(distance: np.ndarray) -> np.ndarray:
    """The six rod lengths D[2i, 2i+1] (6,) [m] from the pair distances (12 x 12)."""
    return distance[ROD_NODES[:, 0], ROD_NODES[:, 1]]


def _matchings(nodes: list[int]) -> Iterator[list[tuple[int, int]]]:
    """Every way of splitting an even-sized list of nodes into pairs ((n-1)!! of them)."""
    if not nodes:
        yield []
        return
    first, rest = nodes[0], nodes[1:]
    for k, partner in enumerate(rest):
        for tail in _matchings(rest[:k] + rest[k + 1:]):
            yield [(first, partner), *tail]


def find_rod_pairs(distance: np.ndarray, spread: np.ndarray, rods: list[int], length: float
                   ) -> tuple[list[tuple[int, int]], float]:
    """The pairing of the ends of ``rods`` that looks most like rigid rods of ``length`` [m].

    Over every pairing of the nodes {2i, 2i+1 : i in rods}, minimizes the cost
    max over pairs (a, b) of |D_ab - length| + S_ab [m]; returns (pairs, cost)."""
    nodes = sorted(int(n) for i in rods for n in ROD_NODES[i])
    best: tuple[list[tuple[int, int]], float] = ([], np.inf)
    for pairs in _matchings(nodes):
        cost = max(abs(distance[a, b] - length) + spread[a, b] for a, b in pairs)
        if np.isfinite(cost) and cost < best[1]:
            best = (pairs, float(cost))
    return best


def relabel_order(rods: list[int], pairs: list[tuple[int, int]]) -> list[int]:
    """Node order for ``ds.isel(node=order)`` that puts ``pairs`` into the slots of ``rods``."""
    order = list(range(N_NODES))
    for rod, (a, b) in zip(sorted(rods), pairs, strict=True):
        order[2 * rod], order[2 * rod + 1] = a, b
    return order


def _long_cables(distance: np.ndarray, order: np.ndarray, limit: float) -> int:
    lengths = distance[order[CABLE_NODES[:, 0]], order[CABLE_NODES[:, 1]]]
    return int(np.sum(lengths > limit))


def flip_rod_ends(distance: np.ndarray, rod_length: float) -> tuple[list[str], list[int]]:
    """(too-long cables, rods whose ends to swap): cables longer than CABLE_TO_ROD x rod_length,
    and the rods whose two end labels, swapped (greedily, best first), make the most cables short.
    distance (12 x 12) [m]."""
    limit = CABLE_TO_ROD * rod_length
    lengths = distance[CABLE_NODES[:, 0], CABLE_NODES[:, 1]]
    long = [f"{CABLE_NAMES[j]} {lengths[j]:.2f} m" for j in np.flatnonzero(lengths > limit)]
    order, flipped = np.arange(N_NODES), list[int]()
    while long:
        now = _long_cables(distance, order, limit)
        trials = []
        for rod in range(N_RODS):
            trial = order.copy()
            trial[[2 * rod, 2 * rod + 1]] = trial[[2 * rod + 1, 2 * rod]]
            trials.append((_long_cables(distance, trial, limit), rod, trial))
        count, rod, trial = min(trials, key=lambda item: item[0])
        if count >= now:
            break
        order, flipped = trial, [*flipped, rod]
    return long, sorted(flipped)
