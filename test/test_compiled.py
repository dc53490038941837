# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The compiled kernels: warming them up changes nothing, and inputs are not effects."""
import numpy as np
import pytest

import physics_cases as cases
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.inputs import AppliedWrenches
from rigid_sim.core.integrators import REGISTRY, registry
from rigid_sim.core.integrators.base import Integrator
from rigid_sim.core.safeguards import UNBOUNDED
from rigid_sim.core.warm_up import warm_up


def test_warm_up_leaves_the_world_as_it_was():
    """Warming up compiles or loads every kernel a world uses without moving the world.

    warm_up reports the seconds it took; state, time, counters and diagnostics stay as they
    were, and the next step is the step an unwarmed twin takes.
    """
    def build():
        bodies = cases.make_bodies(1.5, np.diag([0.3, 0.5, 0.7]))
        inputs = AppliedWrenches(bodies)
        inputs.hold(0, 'push', 'body', (1.0, 0.0, 0.0), (0.0, 0.1, 0.0))
        return cases.make_world(bodies, (0.0, 0.0, 1.0), (0.0, 0.0, 0.0, 1.0),
                                (0.2, 0.0, 0.0), (1.0, -2.0, 3.0),
                                [Gravity(bodies, (0.0, 0.0, -9.81))], 'exact_split',
                                inputs=inputs)
    world, twin = build(), build()
    before = world.y.copy()
    seconds = warm_up(world)
    assert seconds > 0.0
    np.testing.assert_array_equal(world.y, before)
    assert world.time == 0.0 and world.integrator.evaluations == 0
    assert world.diagnostics == twin.diagnostics
    world.step(0.01)
    twin.step(0.01)
    np.testing.assert_array_equal(world.y, twin.y)


def test_every_integrator_carries_its_own_step_bound():
    """Each registered method declares the bound the guard splits its steps by.

    The bounds are positive (inf: unbounded), and the exact-flow splittings leave
    torque-free bodies out.
    """
    for name, cls in REGISTRY.items():
        bound = cls.bound
        assert bound.oscillation > 0.0 and bound.rotation > 0.0, name
        assert bound.kind in ('accuracy', 'stability', 'none'), name
    assert not REGISTRY['exact_split'].bound.rotation_all
    assert REGISTRY['dlm'].bound.rotation_all and REGISTRY['rk4'].bound.rotation_all


def test_an_integrator_without_its_own_step_bound_is_refused_at_registration():
    """A method that forgets its bound or its estimate's order is not registered.

    It would step unguarded, or error control could not predict its substeps.
    """
    forgetful = type('Forgetful', (Integrator,), {'name': 'forgetful', 'order': 2,
                                                  'estimate_order': 2})
    with pytest.raises(TypeError, match='Forgetful declares no step bound'):
        registry(forgetful)
    unordered = type('Unordered', (Integrator,), {'name': 'unordered', 'bound': UNBOUNDED})
    with pytest.raises(TypeError, match='Unordered declares no estimate_order'):
        registry(unordered)
    declared = type('Declared', (Integrator,), {'name': 'declared', 'bound': UNBOUNDED,
                                                'estimate_order': 2})
    assert registry(declared) == {'declared': declared}


def test_carlson_integrals_match_scipy():
    """R_F and R_J by Carlson's duplication agree with scipy's and keep their closed forms.

    Agreement is to round-off over the arguments the free flow passes (x, y in [0, 1], y down
    to 1e-30, z = 1, p > 1); the closed forms are R_F(x, x, x) = x^-1/2 and
    R_F(0, 1, 1) = pi / 2.
    """
    from scipy import special as reference
    from rigid_sim.core.special import elliprf, elliprj
    rng = np.random.default_rng(3)
    for _ in range(2000):
        x, y, p = rng.uniform(0.0, 1.0), 10.0 ** rng.uniform(-30.0, 0.0), rng.uniform(1.0, 30.0)
        x = 0.0 if rng.uniform() < 0.2 else x
        assert abs(elliprf(x, y, 1.0) / reference.elliprf(x, y, 1.0) - 1.0) < 1e-14
        assert abs(elliprj(x, y, 1.0, p) / reference.elliprj(x, y, 1.0, p) - 1.0) < 1e-14
    assert abs(elliprf(4.0, 4.0, 4.0) - 0.5) < 1e-16
    assert abs(elliprf(0.0, 1.0, 1.0) - np.pi / 2.0) < 4e-16


def test_jacobi_sn_cn_from_the_complementary_parameter():
    """Jacobi sn and cn of u in [-K, K], m = 1 - mc, mc from 1e-6 to 1, against mpmath.

    Both to an absolute 2e-15 (30 digits, m formed from mc exactly on mpmath's side); scipy's
    ellipj, which takes m itself, errs by up to 1.2e-14 there. (Below mc = 1e-6 the flow
    takes cn near a quarter period from sd instead: elliptic_flow.NEAR_SEPARATRIX.)
    """
    import mpmath
    from scipy.special import ellipkm1
    from rigid_sim.core.special import sn_cn
    rng = np.random.default_rng(5)
    with mpmath.workdps(30):
        for _ in range(300):
            mc = 10.0 ** rng.uniform(-6.0, 0.0)
            u = rng.uniform(-1.0, 1.0) * ellipkm1(mc)
            m = 1 - mpmath.mpf(mc)
            sn, cn = sn_cn(u, mc)
            assert abs(sn - float(mpmath.ellipfun('sn', u, m=m))) < 2e-15
            assert abs(cn - float(mpmath.ellipfun('cn', u, m=m))) < 2e-15


def test_carlson_third_kind_on_both_branches_and_far_below():
    """R_J where (p - x)(p - y)(p - z) is negative too, against scipy and 40-digit mpmath.

    The sign of that product chooses between the arctangent and the inverse hyperbolic
    tangent in each duplication's R_C term; the free flow only reaches the first (p > 1 >= x,
    y, z), so p below x, y or z is drawn here. Far below them (p from 1e-9 to 1e-300) the
    term's 1 + e_m would cancel if summed as written; there scipy's own R_J errs by up to
    3e-13, so mpmath is the reference. R_J(x, x, x, x) = x^-3/2 is DLMF 19.20.15.
    """
    import mpmath
    from scipy import special as reference
    from rigid_sim.core.special import elliprj
    rng = np.random.default_rng(4)
    negative = 0
    for _ in range(2000):
        x, y, z = rng.uniform(0.0, 4.0), 10.0 ** rng.uniform(-20.0, 1.0), rng.uniform(0.5, 3.0)
        p = 10.0 ** rng.uniform(-3.0, 1.0)
        negative += (p - x) * (p - y) * (p - z) < 0.0
        assert abs(elliprj(x, y, z, p) / reference.elliprj(x, y, z, p) - 1.0) < 1e-14
    assert negative > 200
    for x, y, z in ((1.0, 2.0, 3.0), (3.3158, 7.7985, 1.4402)):
        for p in (3e-9, 1e-12, 1e-20, 1e-300):
            # mpmath's own duplication cancels ~log10(1 / p) digits: 400 leave 100 to spare.
            with mpmath.workdps(400):
                exact = mpmath.elliprj(x, y, z, p)
                assert abs(float((elliprj(x, y, z, p) - exact) / exact)) < 1e-15
    for x in (1e-3, 0.7, 9.0):
        assert abs(elliprj(x, x, x, x) * x ** 1.5 - 1.0) < 4e-16
