# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Per-body topics made on first use, a slice of executor time at a time.

In a scene above ``per_body_topics_limit`` bodies a body's topic is made once its other end
appears in the graph. Anyone may make those ends: a client that subscribed to 5000 pose
topics at once had the node make 5000 publishers in one callback, holding control for up to
4.8 s. Each look now makes what a slice allows; the rest waits for the next look.
"""
from time import perf_counter

from rigid_sim.tick_loop import SLICE


def appeared(node, awaited):
    """Return the names among ``awaited`` (a dict keyed by topic name) now in the graph."""
    present = {name for name, _ in node.get_topic_names_and_types()}
    return present & awaited.keys()


def make_for_a_slice(names, make):
    """Call ``make(name)`` for ``names`` until a SLICE has passed; whether all were made."""
    until = perf_counter() + SLICE
    for name in names:
        make(name)
        if perf_counter() > until:
            return False
    return True
