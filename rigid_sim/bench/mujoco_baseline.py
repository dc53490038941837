# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""MuJoCo's integrators on the torque-free benchmark cases (optional: needs ``mujoco``).

The body is the same free body (mass 1 kg, diag(1, 2, 3) kg m^2), with gravity off and no
contact. A whole run is one ``mj_step(model, data, nstep)`` call, so the timing is MuJoCo's
compiled loop without a Python call per step: its best case. MuJoCo's free-joint quaternion
``qpos[3:7]`` is (w, x, y, z) and its angular velocity ``qvel[3:6]`` is in body axes.
"""
import numpy as np

from rigid_sim.core import rotation
from rigid_sim import bench
from rigid_sim.bench.cases import MASS, MOMENTS, score

try:
    import mujoco
except ImportError:   # an optional extra: the caller reports it
    mujoco = None

INTEGRATORS = ('Euler', 'implicitfast', 'RK4')
DIVERGENCE_NAMES = ('mjWARN_BADQACC', 'mjWARN_BADQVEL', 'mjWARN_BADQPOS')
DIVERGENCE_WARNINGS = (() if mujoco is None
                       else tuple(getattr(mujoco.mjtWarning, n) for n in DIVERGENCE_NAMES))
MODEL = """<mujoco><option gravity="0 0 0"><flag contact="disable"/></option><worldbody>
<body><freejoint/><inertial pos="0 0 0" mass="{mass}" diaginertia="{i1} {i2} {i3}"/></body>
</worldbody></mujoco>"""


def require():
    """Raise MissingPackage with an install hint when ``mujoco`` is missing."""
    if mujoco is None:
        raise bench.MissingPackage(
            '--compare mujoco needs the optional package mujoco: pip install mujoco')
    return mujoco.__version__


def prepare(case, integrator, dt):
    """Return a zero-argument callable that runs ``case`` to its end with MuJoCo.

    The callable returns (orientation (4,) (x, y, z, w), world angular velocity (3,), kinetic
    energy J, world angular momentum (3,), centre of mass (3,)). Model building is outside the
    call.
    """
    model = mujoco.MjModel.from_xml_string(
        MODEL.format(mass=MASS, i1=MOMENTS[0], i2=MOMENTS[1], i3=MOMENTS[2]))
    model.opt.timestep = dt
    model.opt.integrator = getattr(mujoco.mjtIntegrator, 'mjINT_' + integrator.upper())
    data = mujoco.MjData(model)
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    data.qvel[3:6] = case.omega0
    steps = int(round(case.duration / dt))

    def run():
        mujoco.mj_step(model, data, nstep=steps)
        return final_state(data)
    # Divergence is read from data.warning; without a handler MuJoCo also appends every
    # warning to MUJOCO_LOG.TXT in the working directory.
    mujoco.set_mju_user_warning(_ignore_warning)
    return run


def _ignore_warning(message):
    """Drop a MuJoCo warning message (the counters still count it)."""


def final_state(data):
    """Orientation (x, y, z, w), omega world, kinetic energy, L world, position.

    MuJoCo resets a simulation whose state blows up and only raises a warning counter; such
    a run is reported as non-finite (diverged), not scored from the reset state.
    """
    if any(data.warning[kind].number for kind in DIVERGENCE_WARNINGS):
        nan = np.full(3, np.nan)
        return np.full(4, np.nan), nan, np.nan, nan, nan
    w, x, y, z = data.qpos[3:7]
    q = rotation.normalize(np.array([[x, y, z, w]]))
    matrix = rotation.to_matrix(q)[0]
    omega_body = np.array(data.qvel[3:6])
    velocity = np.array(data.qvel[0:3])
    energy = 0.5 * omega_body @ (MOMENTS * omega_body) + 0.5 * MASS * velocity @ velocity
    return (q[0], matrix @ omega_body, float(energy), matrix @ (MOMENTS * omega_body),
            np.array(data.qpos[0:3]))


def measure(case, dt, repeats, budget, integrator):
    """Median CPU time of MuJoCo's ``integrator`` on a torque-free ``case``, scored."""
    omega0 = np.asarray(case.omega0, dtype=float)
    start = (0.5 * omega0 @ (MOMENTS * omega0), np.linalg.norm(MOMENTS * omega0))
    cpu_time, final = bench.median_cpu_time(lambda: prepare(case, integrator, dt), repeats,
                                            budget)
    return score(case, 'mujoco ' + integrator, dt, False, final, start, np.nan, cpu_time)
