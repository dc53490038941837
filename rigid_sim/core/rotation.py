# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The angle between orientations, for the errors of runs that may have failed.

Quaternions are scalar-last ``(x, y, z, w)``. Everything else that turns vectors or
composes rotations uses ``scipy.spatial.transform.Rotation`` (Python) or
:mod:`rigid_sim.core.kinematics` (compiled). This measure is written out because it must
take what ``Rotation`` refuses or changes: a NaN row (a flight or a run that diverged,
scored as such) and a quaternion that is not unit (one that overflowed to zeros must not
be normalised into a rotation).
"""
import numpy as np


def angle_between(p, q):
    """Rotation angle in radians from ``p`` to ``q``, (N, 4) each -> (N,); NaN rows stay NaN.

    ``atan2`` of the relative rotation ``p^-1 q`` keeps full precision for tiny angles,
    where ``arccos`` of a dot product bottoms out near 1e-8 rad.
    """
    p, q = np.asarray(p, dtype=float), np.asarray(q, dtype=float)
    # The Hamilton product conj(p) q: its vector part and its scalar part.
    vector = p[:, 3:] * q[:, :3] - q[:, 3:] * p[:, :3] - np.cross(p[:, :3], q[:, :3])
    scalar = p[:, 3] * q[:, 3] + np.einsum('ni,ni->n', p[:, :3], q[:, :3])
    return 2.0 * np.arctan2(np.linalg.norm(vector, axis=1), np.abs(scalar))
