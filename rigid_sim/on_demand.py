# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Per-body topics made on first use, a slice of executor time at a time.

In a scene above ``per_body_topics_limit`` bodies a body's topic is made once its other end
appears in the graph. Anyone may make those ends: a client that subscribed to 5000 pose
topics at once had the node make 5000 publishers in one callback, holding control for up to
4.8 s. Each look now makes what a slice allows; the rest waits for the next look.
"""
from time import monotonic, perf_counter

from rigid_sim.tick_loop import SLICE

# s of wall time one listing of the graph's topics is used for. The outputs, the inputs and
# the goals each look for their topics every 0.5 s; with 5000 pose topics subscribed in a
# 10 000-body scene, their three listings took a third of the node's time.
LISTING_AGE = 0.25


class TopicListing:
    """The graph's topic names as ``node`` last listed them, listed again once LISTING_AGE old."""

    def __init__(self, node):
        self._node = node
        self._names = frozenset()
        self._listed = -LISTING_AGE

    def names(self):
        """Return the set of topic names in the graph, at most LISTING_AGE s old."""
        now = monotonic()
        if now - self._listed >= LISTING_AGE:
            self._names = frozenset(name for name, _ in self._node.get_topic_names_and_types())
            self._listed = now
        return self._names


def make_appeared(listing, awaited, make):
    """Call ``make(name)`` for ``awaited``'s names in ``listing``: :func:`make_for_a_slice`.

    ``awaited`` is a dict keyed by topic name. Returns whether all were made.
    """
    return make_for_a_slice(listing.names() & awaited.keys(), make)


def make_for_a_slice(names, make):
    """Call ``make(name)`` for ``names`` until a SLICE has passed; whether all were made."""
    until = perf_counter() + SLICE
    for name in names:
        make(name)
        if perf_counter() > until:
            return False
    return True
