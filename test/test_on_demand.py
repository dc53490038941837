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


class CountingNode:
    """Lists a graph whose topics are set by the test, counting the listings."""

    def __init__(self):
        self.topics, self.listings = [], 0

    def get_topic_names_and_types(self):
        self.listings += 1
        return [(name, ['geometry_msgs/msg/PoseStamped']) for name in self.topics]


def test_looks_within_a_listing_age_share_one_listing_of_the_graph(monkeypatch):
    clock = [100.0]
    monkeypatch.setattr(on_demand, 'monotonic', lambda: clock[0])
    node = CountingNode()
    listing = on_demand.TopicListing(node)
    awaited = {'/a': 0, '/b': 1}

    def look():   # the names one look makes
        made = set()
        assert on_demand.make_appeared(listing, awaited, made.add)
        return made

    node.topics = ['/a']
    assert look() == {'/a'}
    node.topics = ['/a', '/b']
    clock[0] += 0.5 * on_demand.LISTING_AGE   # a second consumer's look, soon after
    assert look() == {'/a'} and node.listings == 1
    clock[0] += 0.5 * on_demand.LISTING_AGE   # the listing is old now: listed again
    assert look() == {'/a', '/b'} and node.listings == 2
