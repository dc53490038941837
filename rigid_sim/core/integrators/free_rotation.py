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

Precision: the result is exact up to ~1e-15 relative per call times the phase
``|lambda| dt``. Near the separatrix the complementary parameter ``mc = 1 - k^2`` is computed
from ``L^2 - 2 E I2`` without cancellation and used for ``K``, ``u0`` and ``dn``, but
``scipy.special.ellipj`` takes ``k^2`` itself, so the phase error grows like
``eps * (half-periods travelled) / mc``; the state itself fixes ``mc`` only to relative
``eps / mc``, so this is the conditioning of the problem, not a loss of the method.
No NaN is produced for ``mc -> 0`` (on the separatrix ``K = inf`` and no period is reduced).
"""
import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core import rotation
from rigid_sim.core.integrators.elliptic_flow import (elliptic_working, separatrix_gap,
                                                      shape_constants)

# Moments closer than this (relative) are treated as equal: a few ulps, where the closed form
# errs by ~1e-14 of the angle turned; the elliptic form stays ~1e-12 accurate down to 1e-14 gaps.
SYMMETRY_RTOL = 1e-14
# Proper rotation (x, y, z) -> (z, y, -x): makes the minor axis the working axis 3.
SWAP_MAJOR_MINOR = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0]])
# Half-turn about axis 3: makes m1 >= 0 so u0 = F(am0) needs no period (K may be infinite).
HALF_TURN_Z = np.diag([-1.0, -1.0, 1.0])
AXES = np.eye(3)
# Entries of a signed permutation matrix, each in {-1, 0, 1}, read as a base-3 number (a key).
_KEY_DIGITS = 3 ** np.arange(9)


def _signed_permutation_quaternions():
    """Table: key of each proper signed permutation matrix -> its quaternion (x, y, z, w).

    The working frames are these 24 matrices only, so one lookup replaces a general (and,
    per call, ~100x dearer) matrix-to-quaternion conversion.
    """
    permutations = np.array([np.eye(3)[list(p)] for p in np.ndindex(3, 3, 3)
                             if len(set(p)) == 3])
    signs = np.array(np.meshgrid(*[[-1.0, 1.0]] * 3)).reshape(3, -1).T
    frames = (permutations[:, None] * signs[None, :, :, None]).reshape(-1, 3, 3)
    frames = frames[np.linalg.det(frames) > 0.0]
    table = np.full((3 ** 9, 4), np.nan)
    table[_frame_keys(frames)] = Rotation.from_matrix(frames).as_quat()
    return table


def _frame_keys(frames):
    """Keys (N,) int of (N, 3, 3) signed permutation matrices."""
    return (np.rint(frames.reshape(-1, 9)) + 1.0).astype(int) @ _KEY_DIGITS


_FRAME_QUATERNIONS = _signed_permutation_quaternions()


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
    moments = np.asarray(moments, dtype=float)
    m = np.asarray(angular_momentum_body, dtype=float)
    q = np.asarray(orientation, dtype=float)
    if moments.ndim != 2 or moments.shape[1] != 3 or m.shape != moments.shape:
        raise ValueError('moments and angular_momentum_body must both be (N, 3)')
    if q.shape != (len(m), 4):
        raise ValueError('orientation must be (N, 4) quaternions (x, y, z, w)')
    if np.any(moments <= 0.0):
        raise ValueError('principal moments must be positive')
    return TorqueFreeFlow(moments)(m, q, dt)


class TorqueFreeFlow:
    """:func:`torque_free_flow` for bodies of fixed moments (N, 3), positive.

    What depends on the moments alone (their order, symmetry, the working frames and their
    quaternions, the elliptic shape constants) is computed once here, not in every step.
    """

    def __init__(self, moments):
        # Scale-free: flow(m, I, dt) == flow(m/a, I/b, dt a/b) scaled back; no over/underflow.
        self._i_scale = np.max(moments, axis=1)
        self._moments = moments / self._i_scale[:, None]
        self._order = np.argsort(self._moments, axis=1)
        s = np.take_along_axis(self._moments, self._order, axis=1)
        self._sorted = s
        self._equal_12 = s[:, 1] - s[:, 0] <= SYMMETRY_RTOL * s[:, 2]
        self._equal_23 = s[:, 2] - s[:, 1] <= SYMMETRY_RTOL * s[:, 2]
        self._symmetric = self._equal_12 | self._equal_23
        self._working_frames(s)

    def _working_frames(self, s):
        """Tables over the four working frames of each body.

        Major or minor axis 3, m1 flipped or not (index ``2 minor + flip``): frames, moments,
        quaternions, constants.
        """
        major = AXES[self._order]
        major[np.linalg.det(major) < 0.0, 0] *= -1.0
        minor = SWAP_MAJOR_MINOR @ major
        self._frames = np.stack((major, HALF_TURN_Z @ major, minor, HALF_TURN_Z @ minor))
        self._quaternions = _FRAME_QUATERNIONS[_frame_keys(self._frames)].reshape(4, -1, 4)
        self._working_moments = np.stack((s, s[:, ::-1]))
        # Symmetric bodies divide 0 by 0 here; they take the closed form and never read it.
        with np.errstate(invalid='ignore', divide='ignore'):
            self._shape = np.array([shape_constants(i) for i in self._working_moments])

    def __call__(self, m, q, dt):
        """Return body-axes ``m`` (N, 3) and unit ``q`` (N, 4) ``dt`` after ``m``, ``q``."""
        m_scale = np.max(np.abs(m), axis=1)
        time = dt * m_scale / self._i_scale
        moving = m_scale > 0.0
        if moving.all():
            symmetric = self._symmetric | self._saddle(m)
            if not symmetric.any():   # every body elliptic: no masks, no gathers
                m_next, step = self._asymmetric(slice(None), m / m_scale[:, None], time)
                return m_next * m_scale[:, None], rotation.normalize(rotation.multiply(q, step))
        return self._masked(m, q, m_scale, time, moving)

    def _masked(self, m, q, m_scale, time, moving):
        """Return the flow when some bodies are still, symmetric or spinning about axis 2."""
        m_new, q_new = m.copy(), q.copy()
        if np.any(moving):
            safe = np.where(moving, m_scale, 1.0)[:, None]
            m_unit = m / safe
            step = np.zeros_like(q)
            m_next = np.zeros_like(m)
            symmetric, axis, i_axis, i_perp = self._classify(m_unit)
            sym = moving & symmetric
            ell = moving & ~symmetric
            if np.any(sym):   # an empty branch would still cost its ~50 numpy calls
                m_next[sym], step[sym] = _axisymmetric(
                    axis[sym], i_axis[sym], i_perp[sym], m_unit[sym], time[sym])
            if np.any(ell):
                m_next[ell], step[ell] = self._asymmetric(ell, m_unit[ell], time[ell])
            m_new[moving] = m_next[moving] * safe[moving]
            q_new[moving] = rotation.multiply(q[moving], step[moving])
        return m_new, rotation.normalize(q_new)

    def _saddle(self, m):
        """(N,) bool: m along the intermediate axis, an (unstable) equilibrium, a pure spin."""
        m_sorted = np.take_along_axis(m, self._order, axis=1)
        return (m_sorted[:, 0] ** 2 == 0.0) & (m_sorted[:, 2] ** 2 == 0.0)

    def _classify(self, m):
        """Which bodies take the closed form, and its symmetry axis, I_axis and I_perp.

        Returns symmetric (N,) bool, axis (N, 3) unit body vector, i_axis (N,), i_perp (N,).
        """
        order, s, equal_12, equal_23 = self._order, self._sorted, self._equal_12, self._equal_23
        saddle = self._saddle(m)
        index = np.where(equal_23 & ~equal_12, order[:, 0], order[:, 2])
        index = np.where(saddle & ~equal_12 & ~equal_23, order[:, 1], index)
        i_axis = np.take_along_axis(self._moments, index[:, None], axis=1)[:, 0]
        i_perp = np.where(equal_23, 0.5 * (s[:, 1] + s[:, 2]), 0.5 * (s[:, 0] + s[:, 1]))
        i_perp = np.where(saddle & ~equal_12 & ~equal_23, s[:, 0], i_perp)
        i_axis = np.where(equal_12 & equal_23, i_perp, i_axis)
        return self._symmetric | saddle, AXES[index], i_axis, i_perp

    def _asymmetric(self, bodies, m, time):
        """Elliptic free motion of the asymmetric ``bodies`` (a slice or mask).

        New m (K, 3) and body-frame rotation step (K, 4), from m (K, 3) in working units and time
        (K,).
        """
        frames = self._frames[:, bodies]
        each = np.arange(len(m))
        # L^2 - 2 E I2 < 0: m circles the minor axis.
        m_major = np.einsum('nij,nj->ni', frames[0], m)
        minor = (separatrix_gap(self._working_moments[0, bodies], m_major) < 0.0).astype(int)
        m_w = np.einsum('nij,nj->ni', frames[2 * minor, each], m)
        variant = 2 * minor + (m_w[:, 0] < 0.0)
        frame = frames[variant, each]
        m_w = np.einsum('nij,nj->ni', frame, m)
        ratio, nu = self._shape[:, :, bodies][minor, :, each].T
        m_w_new, core = elliptic_working(self._working_moments[:, bodies][minor, each], m_w,
                                         time, ratio, nu)
        m_new = np.einsum('nji,nj->ni', frame, m_w_new)
        p = self._quaternions[:, bodies][variant, each]
        step = rotation.multiply(rotation.multiply(rotation.conjugate(p), core), p)
        return m_new, step


def _axisymmetric(axis, i_axis, i_perp, m, time):
    """Closed-form free motion of symmetric tops: body rotation and new m (working units).

    ``omega = m / I_perp + Omega e`` with ``Omega = (m.e)(1/I_axis - 1/I_perp)`` constant; the
    first part turns about the fixed world L, the second about the body axis, so
    ``R(t) = R0 exp(m0 t / I_perp) exp(e Omega t)`` and ``m(t) = Rot(e, -Omega t) m0``.
    """
    spin = np.sum(m * axis, axis=1) * (1.0 / i_axis - 1.0 / i_perp)
    angle = -(spin * time)[:, None]
    m_new = (m * np.cos(angle) + np.cross(axis, m) * np.sin(angle)
             + axis * np.sum(axis * m, axis=1, keepdims=True) * (1.0 - np.cos(angle)))
    step = rotation.multiply(rotation.exp_map(m * (time / i_perp)[:, None]),
                             rotation.exp_map(axis * (spin * time)[:, None]))
    return m_new, step
