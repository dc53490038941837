# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Exact torque-free motion of N rigid bodies (Jacobi elliptic functions, Carlson forms).

Quaternions are scalar-last ``(x, y, z, w)`` and map principal body axes to world axes.

Method (Celledoni, Fasso, Safstrom, Zanna, SIAM J. Sci. Comput. 2008; van Zon and
Schofield, J. Comput. Phys. 2007). Each body is turned into a *working* frame by a signed
permutation of its principal axes (a proper rotation, so Euler's equations keep their form):
axis 3 is the one ``m`` circles (the major axis when ``L^2 > 2 E I2``, else the minor one) and
``m1 >= 0``. There ``m = (a1 cn u, a2 sn u, +-a3 dn u)`` with ``u = u0 + lambda t``.
World ``L`` is fixed, so ``R(t) = Q Rz(psi(t)) B(m(t))`` with ``Q`` constant and
``B = Ry(-theta) Rz(-alpha)`` the Euler-angle rotation taking ``m`` to ``|L| e_z``; hence
``R(t1) = R(t0) B0^T Rz(dpsi) B1`` with
``dpsi = L dt/I3 + L (I3-I1)/(I1 I3 lambda) [Pi(-nu; am u)]_{u0}^{u1}``,
``nu = I3 (I2-I1)/(I1 (I3-I2))``: a third-kind integral, evaluated with ``elliprf``/``elliprj``.
Every amplitude enters only through ratios that stay finite for a pure spin (``a1 = a2 = 0``).

Axisymmetric and spherical bodies (and a spin about the intermediate axis, an equilibrium)
take the closed form ``R1 = R0 exp(m dt/I_perp) exp(e Omega dt)``; zero ``L`` is left alone.
Each body is one compiled scalar computation (:func:`free_flow`), so the splitting kernels
call it per body and one body's branch never costs another anything.

Precision: the result is exact up to ~1e-15 relative per call times the phase
``|lambda| dt``. Near the separatrix the complementary parameter ``mc = 1 - k^2`` is computed
from ``L^2 - 2 E I2`` without cancellation and used for ``K``, ``u0``, ``sn``, ``cn`` and
``dn`` (never ``k^2``, which rounds a small ``mc`` away). The state itself fixes ``mc`` only
to relative ``eps / mc``, so over many half periods the phase error grows like
``eps * (half-periods travelled) / mc``: the conditioning of the problem, not a loss of the
method.
No NaN is produced for ``mc -> 0`` (on the separatrix ``K = inf`` and no period is reduced).
"""
import math

import numpy as np

from rigid_sim.core import kinematics as kin
from rigid_sim.core.compiled import helper, kernel
from rigid_sim.core.integrators.elliptic_flow import (elliptic_working, separatrix_gap,
                                                      shape_constants)

# Moments closer than this (relative) are treated as equal: a few ulps, where the closed form
# errs by ~1e-14 of the angle turned; the elliptic form stays ~1e-12 accurate down to 1e-14 gaps.
SYMMETRY_RTOL = 1e-14


def torque_free_flow(moments, angular_momentum_body, orientation, dt):
    """Advance N torque-free rigid bodies exactly by dt.

    Parameters
    ----------
    moments : (N, 3) float
        Principal moments of inertia, any order, positive; symmetric or spherical allowed.
    angular_momentum_body : (N, 3) float
        Angular momentum in the principal body axes (same axes as ``moments``).
    orientation : (N, 4) float
        Unit quaternions ``(x, y, z, w)`` mapping principal body axes to world axes.
    dt : float
        Time step, s (may be negative).

    Returns
    -------
    angular_momentum_body_new : (N, 3) float
    orientation_new : (N, 4) float
        Unit quaternions, continuous in ``dt`` from ``orientation``.
    """
    moments = np.ascontiguousarray(moments, dtype=float)
    m = np.array(angular_momentum_body, dtype=float, order='C')
    q = np.array(orientation, dtype=float, order='C')
    if moments.ndim != 2 or moments.shape[1] != 3 or m.shape != moments.shape:
        raise ValueError('moments and angular_momentum_body must both be (N, 3)')
    if q.shape != (len(m), 4):
        raise ValueError('orientation must be (N, 4) quaternions (x, y, z, w)')
    if np.any(moments <= 0.0):
        raise ValueError('principal moments must be positive')
    _flow_all(moments, m, q, float(dt))
    return m, q


@kernel
def _flow_all(moments, m, q, dt):
    """:func:`free_flow` of every row of ``m`` (N, 3) and ``q`` (N, 4), in place."""
    for i in range(m.shape[0]):
        m_new, q_new = free_flow(kin.vector(moments, i, 0), kin.vector(m, i, 0),
                                 kin.orientation_row(q, i), dt)
        kin.store(m, i, 0, m_new)
        kin.store(q, i, 0, q_new)


@helper
def _sorted_axes(i):
    """Return the indices (3-tuple) that sort the moments ``i`` ascending, ties kept in order."""
    a, b, c = 0, 1, 2
    if i[b] < i[a]:
        a, b = b, a
    if i[c] < i[b]:
        b, c = c, b
        if i[b] < i[a]:
            a, b = b, a
    return a, b, c


@helper
def free_flow(moments, m, q, dt):
    """Body-axes ``m`` (3-tuple) and unit ``q`` (4-tuple) after ``dt`` of torque-free motion.

    ``moments`` (3-tuple) are principal moments, any order, positive. Scale-free:
    flow(m, I, dt) == flow(m/a, I/b, dt a/b) scaled back, so nothing over- or underflows.
    """
    i_scale = max(moments[0], max(moments[1], moments[2]))
    mom = (moments[0] / i_scale, moments[1] / i_scale, moments[2] / i_scale)
    m_scale = max(abs(m[0]), max(abs(m[1]), abs(m[2])))
    if m_scale == 0.0:
        return m, kin.normalize(q)
    time = dt * m_scale / i_scale
    unit = (m[0] / m_scale, m[1] / m_scale, m[2] / m_scale)
    order = _sorted_axes(mom)
    s = (mom[order[0]], mom[order[1]], mom[order[2]])
    equal_12 = s[1] - s[0] <= SYMMETRY_RTOL * s[2]
    equal_23 = s[2] - s[1] <= SYMMETRY_RTOL * s[2]
    # m along the intermediate axis: an (unstable) equilibrium, a pure spin.
    saddle = unit[order[0]] ** 2 == 0.0 and unit[order[2]] ** 2 == 0.0
    if equal_12 or equal_23 or saddle:
        m_next, step = _symmetric(mom, order, s, equal_12, equal_23, saddle, unit, time)
    else:
        m_next, step = _asymmetric(order, s, unit, time)
    m_new = (m_next[0] * m_scale, m_next[1] * m_scale, m_next[2] * m_scale)
    return m_new, kin.normalize(kin.multiply(q, step))


@helper
def _symmetric(mom, order, s, equal_12, equal_23, saddle, m, time):
    """Step a symmetric top, or a spin about the intermediate axis, by its closed form."""
    index = order[0] if equal_23 and not equal_12 else order[2]
    i_perp = 0.5 * (s[1] + s[2]) if equal_23 else 0.5 * (s[0] + s[1])
    if saddle and not equal_12 and not equal_23:
        index, i_perp = order[1], s[0]
    i_axis = i_perp if equal_12 and equal_23 else mom[index]
    return _axisymmetric(_unit_axis(index), i_axis, i_perp, m, time)


@helper
def _unit_axis(index):
    """Return the unit vector e_index as a 3-tuple."""
    return (1.0 if index == 0 else 0.0, 1.0 if index == 1 else 0.0, 1.0 if index == 2 else 0.0)


@helper
def _axisymmetric(axis, i_axis, i_perp, m, time):
    """Closed-form free motion of symmetric tops: new m and body rotation (working units).

    ``omega = m / I_perp + Omega e`` with ``Omega = (m.e)(1/I_axis - 1/I_perp)`` constant; the
    first part turns about the fixed world L, the second about the body axis, so
    ``R(t) = R0 exp(m0 t / I_perp) exp(e Omega t)`` and ``m(t) = Rot(e, -Omega t) m0``.
    """
    along = kin.dot(m, axis)
    spin = along * (1.0 / i_axis - 1.0 / i_perp)
    angle = -spin * time
    cos, sin = math.cos(angle), math.sin(angle)
    turned = kin.cross(axis, m)
    m_new = (m[0] * cos + turned[0] * sin + axis[0] * along * (1.0 - cos),
             m[1] * cos + turned[1] * sin + axis[1] * along * (1.0 - cos),
             m[2] * cos + turned[2] * sin + axis[2] * along * (1.0 - cos))
    scale = time / i_perp
    step = kin.multiply(kin.exp_map((m[0] * scale, m[1] * scale, m[2] * scale)),
                        kin.exp_map((axis[0] * spin * time, axis[1] * spin * time,
                                     axis[2] * spin * time)))
    return m_new, step


@helper
def _working_frame(order, s, m):
    """Return the working frame (9-tuple, body to working) of ``m`` and its moments (3-tuple).

    Axis 3 is the one m circles (major, or minor below the separatrix); the frame is a
    proper signed permutation with ``m1 >= 0``.
    """
    x, y, z = _unit_axis(order[0]), _unit_axis(order[1]), _unit_axis(order[2])
    if kin.dot(x, kin.cross(y, z)) < 0.0:
        x = (-x[0], -x[1], -x[2])
    moments = s
    if separatrix_gap(s, (kin.dot(x, m), kin.dot(y, m), kin.dot(z, m))) < 0.0:
        # (x, y, z) -> (z, y, -x): a proper rotation making the minor axis the working axis 3.
        x, z = z, (-x[0], -x[1], -x[2])
        moments = (s[2], s[1], s[0])
    if kin.dot(x, m) < 0.0:   # a half-turn about axis 3: then u0 = F(am0) needs no period
        x, y = (-x[0], -x[1], -x[2]), (-y[0], -y[1], -y[2])
    return (x[0], x[1], x[2], y[0], y[1], y[2], z[0], z[1], z[2]), moments


@helper
def _matrix_quaternion(r):
    """Quaternion (x, y, z, w) of a rotation matrix 9-tuple (Shepperd's method)."""
    trace = r[0] + r[4] + r[8]
    if trace >= max(r[0], max(r[4], r[8])):
        w = 0.5 * math.sqrt(1.0 + trace)
        return ((r[7] - r[5]) / (4.0 * w), (r[2] - r[6]) / (4.0 * w),
                (r[3] - r[1]) / (4.0 * w), w)
    if r[0] >= r[4] and r[0] >= r[8]:
        x = 0.5 * math.sqrt(1.0 + r[0] - r[4] - r[8])
        return (x, (r[1] + r[3]) / (4.0 * x), (r[2] + r[6]) / (4.0 * x),
                (r[7] - r[5]) / (4.0 * x))
    if r[4] >= r[8]:
        y = 0.5 * math.sqrt(1.0 + r[4] - r[0] - r[8])
        return ((r[1] + r[3]) / (4.0 * y), y, (r[5] + r[7]) / (4.0 * y),
                (r[2] - r[6]) / (4.0 * y))
    z = 0.5 * math.sqrt(1.0 + r[8] - r[0] - r[4])
    return ((r[2] + r[6]) / (4.0 * z), (r[5] + r[7]) / (4.0 * z), z, (r[3] - r[1]) / (4.0 * z))


@helper
def _asymmetric(order, s, m, time):
    """Elliptic free motion of an asymmetric body.

    From ``m`` (3-tuple, working units) and the scaled time: the new m and the body-frame
    rotation step (4-tuple).
    """
    frame, moments = _working_frame(order, s, m)
    ratio, nu = shape_constants(moments)
    m_working, core = elliptic_working(moments, kin.rotate(frame, m), time, ratio, nu)
    p = _matrix_quaternion(frame)
    return (kin.rotate_inverse(frame, m_working),
            kin.multiply(kin.multiply(kin.conjugate(p), core), p))
