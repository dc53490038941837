# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Bodies stepped on several threads give the bits and the failure code of one call.

When no effect couples bodies, a large scene's step shares its bodies among threads
(:class:`~rigid_sim.core.dispatch.BodyThreads`). Each body's arithmetic is the same whoever
steps it, so the states must agree to the last bit with a one-thread step, and a step that
goes bad must report what one pass over the bodies in order reports: the earliest bad
substep. Small scenes, and one thread, keep the single call.
"""
import numpy as np
import pytest

from rigid_sim.core import dispatch
from rigid_sim.core.world import World
from test_fast_paths import _per_body_scene, COUNT

THREADS = 3   # ranges of 2 of the 6 bodies: (0, 2), (2, 4), (4, 6)


def _worlds(monkeypatch, name, damped, **options):
    """Two worlds of the same scene: stepped in one call, and on THREADS threads."""
    bodies, y, effects, wrenches = _per_body_scene(damped=damped)
    one = World(bodies, y, effects, name, auto_substep=False, inputs=wrenches, **options)
    monkeypatch.setattr(dispatch, 'THREADED_BODIES', COUNT)
    monkeypatch.setattr(dispatch, 'HEAVY_THREADED_BODIES', COUNT)
    monkeypatch.setattr(dispatch.config, 'NUMBA_NUM_THREADS', THREADS)
    shared = World(bodies, y, effects, name, auto_substep=False, inputs=wrenches, **options)
    assert isinstance(shared.integrator._kernel, dispatch.BodyThreads)
    assert not isinstance(one.integrator._kernel, dispatch.BodyThreads)
    return one, shared


@pytest.mark.parametrize('name, damped', [
    ('rk4', True), ('rk4_world', False), ('exact_split', True), ('dlm4', True)])
def test_bodies_on_threads_step_to_the_bits_of_one_call(monkeypatch, name, damped):
    """Three substeps of gravity, damping and held wrenches: every bit agrees.

    The error estimates too, and the largest of them is the largest over all ranges.
    """
    one, shared = _worlds(monkeypatch, name, damped)
    start = one.y.copy()
    for world in (one, shared):
        assert world.integrator.advance(world.y, 0.0, 0.05, 3, world.effect_parameters()) == 0
    np.testing.assert_array_equal(shared.y, one.y)
    assert not np.array_equal(shared.y, start)
    np.testing.assert_array_equal(shared.integrator.error, one.integrator.error)
    assert shared.integrator.largest_error == one.integrator.error.max() > 0.0


@pytest.mark.parametrize('name', ['rk4', 'rk4_world', 'dlm4'])
def test_bodies_on_threads_without_estimates_step_to_the_bits_of_one_call(monkeypatch, name):
    """The kernels that skip the estimate share bodies as the others: the same bits, NaN."""
    one, shared = _worlds(monkeypatch, name, True, error_control=False, estimates=False)
    for world in (one, shared):
        assert world.integrator.advance(world.y, 0.0, 0.05, 3, world.effect_parameters()) == 0
    np.testing.assert_array_equal(shared.y, one.y)
    assert np.isnan(shared.integrator.largest_error) and np.isnan(shared.integrator.error).all()


@pytest.mark.parametrize('name', ['rk4', 'exact_split'])
@pytest.mark.parametrize('bad, code', [
    ({3: (1.78e308, 8e307)}, 2), ({2: (0.0, np.inf)}, 1),
    ({2: (1.78e308, 8e307), 4: (0.0, np.inf)}, 1)])
def test_bodies_on_threads_report_the_earliest_bad_substep(monkeypatch, name, bad, code):
    """A body that goes bad fails the step with the code of one call over all bodies.

    Body 3 (2 kg) at x = 1.78e308 m moving at 4e307 m/s gains 1e306 m per substep of
    0.025 s: beyond the largest double after the second (code 2); body 2 (1.5 kg) at the
    same place at 5.3e307 m/s too. Infinite momentum is non-finite in the first (code 1).
    With body 2 (second range) bad in substep 2 and body 4 (third range) in substep 1, the
    third range's code wins, though the second range's comes first in body order.
    """
    one, shared = _worlds(monkeypatch, name, damped=False)
    state = one.y.copy()
    for body, (position, momentum) in bad.items():
        state[body, 0], state[body, 7] = position, momentum
    expected = state.copy()
    effects = one.effect_parameters()
    assert shared.integrator.advance(state, 0.0, 0.1, 4, effects) == code
    assert one.integrator.advance(expected, 0.0, 0.1, 4, effects) == code
    np.testing.assert_array_equal(state, expected)


def test_small_scenes_and_one_thread_keep_one_call(monkeypatch):
    """Below THREADED_BODIES bodies, or with NUMBA_NUM_THREADS = 1, the kernel is called as is."""
    call, threaded = object(), object()
    monkeypatch.setattr(dispatch.config, 'NUMBA_NUM_THREADS', 2)
    assert dispatch.across_threads(call, threaded, dispatch.THREADED_BODIES - 1) is call
    assert isinstance(dispatch.across_threads(call, threaded, dispatch.THREADED_BODIES),
                      dispatch.BodyThreads)
    monkeypatch.setattr(dispatch.config, 'NUMBA_NUM_THREADS', 1)
    assert dispatch.across_threads(call, threaded, 10 * dispatch.THREADED_BODIES) is call


def test_splittings_share_their_bodies_from_fewer_of_them(monkeypatch):
    """A splitting's body-step costs several Runge-Kutta ones: threads from 1000 bodies."""
    call, threaded = object(), object()
    monkeypatch.setattr(dispatch.config, 'NUMBA_NUM_THREADS', 2)
    heavy = dispatch.HEAVY_THREADED_BODIES
    assert heavy < dispatch.THREADED_BODIES
    assert dispatch.across_threads(call, threaded, heavy - 1, heavy=True) is call
    assert isinstance(dispatch.across_threads(call, threaded, heavy, heavy=True),
                      dispatch.BodyThreads)
    assert dispatch.across_threads(call, threaded, heavy) is call
