# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The executable's loop keeps the garbage collector's full passes off the tick.

A full pass over a started node's long-lived objects stalls the process for tens of
milliseconds at an unpredictable tick; ``rigid_sim_node`` freezes them before it spins
(:func:`rigid_sim.executor.freeze_long_lived_objects`). The loop runs here with a stand-in
node and executor, so no ROS graph is needed.
"""
import gc
from types import SimpleNamespace
import signal
import sys
import weakref

from rigid_sim import main as entry
from rigid_sim import spin
from rigid_sim.executor import freeze_long_lived_objects


class _RecordingExecutor:
    """Records what the collector would walk at the first spin, then asks the loop to stop."""

    def __init__(self, stopper, started):
        self.stopper, self.started = stopper, started
        self.seen = None

    def add_node(self, node):
        self.node = node

    def spin_once(self, timeout_sec):
        generation_2 = gc.get_objects(generation=2)
        self.seen = (gc.get_freeze_count(), any(o is self.started for o in generation_2))
        self.stopper.requested = True

    def shutdown(self, timeout_sec):
        pass


class _StandInNode:
    def __init__(self, start):
        self.owner = SimpleNamespace(keeps_heap_frozen=False)
        start.exists(self)
        start.compiled()

    def destroy_node(self):
        pass

    def get_logger(self):
        return SimpleNamespace(info=lambda message: None)


def test_objects_alive_before_the_first_spin_are_frozen(monkeypatch):
    """A container made before the loop starts is out of every generation once it spins."""
    started = [object()]   # long-lived, as the node's messages and kernels are
    gc.collect()           # in the oldest generation now: what a full pass walks
    assert any(o is started for o in gc.get_objects(generation=2))
    stopper = entry._Stopper()
    executor = _RecordingExecutor(stopper, started)
    monkeypatch.setattr(spin, 'RigidSimNode', _StandInNode)
    monkeypatch.setattr(spin, 'make_executor', lambda: executor)
    handlers = {number: signal.getsignal(number) for number in entry.STOP_SIGNALS}
    interval = sys.getswitchinterval()
    try:
        assert spin.run(stopper) == 0
        switched = sys.getswitchinterval()
    finally:
        for number, handler in handlers.items():   # run ignores them on its way out
            signal.signal(number, handler)
        gc.unfreeze()
        sys.setswitchinterval(interval)
    frozen, walked = executor.seen
    assert frozen > 0 and not walked
    assert executor.node.owner.keeps_heap_frozen   # and what its scene edits build
    assert switched == spin.SWITCH_INTERVAL   # and its threads take turns often


def test_freezing_collects_the_garbage_first():
    """A reference cycle dropped before the freeze is collected, not frozen with the rest."""
    class Cycle:
        pass
    cycle = Cycle()
    cycle.self = cycle
    alive = weakref.ref(cycle)
    gc.collect()
    del cycle
    try:
        freeze_long_lived_objects()
        assert alive() is None
    finally:
        gc.unfreeze()
