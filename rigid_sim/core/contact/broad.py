# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Broad phase: the pairs of bodies whose bounding boxes overlap, by sort and sweep.

The boxes are sorted by their lower bound along world x (a stable sort, so equal bounds
keep body order and the pairs come out in the same order every run); a sweep then compares
each box only with those that start before it ends, and checks y and z. The cost is the
sort plus the overlapping pairs along x: ``O(N log N)`` for bodies spread over the scene,
where checking every pair is ``O(N^2)``.
"""
import numpy as np

from rigid_sim.core.compiled import helper


@helper
def overlapping_pairs(low, high, active, pairs):
    """Write the pairs (i < j) whose boxes overlap into ``pairs`` (M, 2); return how many.

    Parameters
    ----------
    low, high : (N, 3) float
        Each body's axis-aligned bounding box, world, m.
    active : (N,) bool
        Bodies that have a collision shape; the others are in no pair.
    pairs : (M, 2) int
        Filled while there is room; a count above M says how much room was needed.
    """
    order = np.argsort(low[:, 0], kind='mergesort')
    count = 0
    for s in range(order.shape[0]):
        i = order[s]
        if not active[i]:
            continue
        for u in range(s + 1, order.shape[0]):
            j = order[u]
            if low[j, 0] > high[i, 0]:
                break
            if not active[j] or low[j, 1] > high[i, 1] or low[i, 1] > high[j, 1] \
                    or low[j, 2] > high[i, 2] or low[i, 2] > high[j, 2]:
                continue
            if count < pairs.shape[0]:
                pairs[count, 0] = min(i, j)
                pairs[count, 1] = max(i, j)
            count += 1
    return count
