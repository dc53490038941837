# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Topics made on demand: one look makes a slice's worth, the rest wait for the next look."""
from rigid_sim import on_demand
from rigid_sim.tick_loop import SLICE


def test_a_look_makes_what_a_slice_allows_and_leaves_the_rest(monkeypatch):
    clock = [0.0]
    monkeypatch.setattr(on_demand, 'perf_counter', lambda: clock[0])
    made = []

    def make(name):   # a topic that takes 0.4 of a slice to make
        made.append(name)
        clock[0] += 0.4 * SLICE

    assert not on_demand.make_for_a_slice(['a', 'b', 'c', 'd', 'e'], make)
    assert made == ['a', 'b', 'c']   # past the slice after the third
    made.clear()
    assert on_demand.make_for_a_slice(['d', 'e'], make) and made == ['d', 'e']
