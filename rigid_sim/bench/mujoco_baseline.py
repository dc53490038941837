# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""MuJoCo's integrators on the benchmark cases (optional: needs ``mujoco``).

The body is the same free body (mass 1 kg, diag(1, 2, 3) kg m^2), with gravity off and no
contact. A whole run is one ``mj_step(model, data, nstep)`` call, so the timing is MuJoCo's
compiled loop without a Python call per step: its best case. MuJoCo's quaternion
``qpos[3:7]`` is (w, x, y, z) and its angular velocity ``qvel[3:6]`` is in body axes.

Each case is built from MuJoCo's own elements, so no Python runs inside a step:

``spring``  three slide joints with joint stiffness k and damping c (the force
``-k x - c x'`` componentwise, the case's zero-rest-length spring-damper at the centre of
mass) and a ball joint for the rotation: together a free body;
``offset_force``  a free body and a site actuator whose force is given in the axes of a
world site (``refsite``): a force of fixed world direction at the body point, held by a
constant control.
"""
import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim import bench
from rigid_sim.bench.cases import (MASS, MOMENTS, PUSH_FORCE, PUSH_POINT, SPRING_DAMPING,
                                   SPRING_START, SPRING_STIFFNESS, score)

try:
    import mujoco
except ImportError:   # an optional extra: the caller reports it
    mujoco = None

INTEGRATORS = ('Euler', 'implicitfast', 'RK4')
DIVERGENCE_NAMES = ('mjWARN_BADQACC', 'mjWARN_BADQVEL', 'mjWARN_BADQPOS')
DIVERGENCE_WARNINGS = (() if mujoco is None
                       else tuple(getattr(mujoco.mjtWarning, n) for n in DIVERGENCE_NAMES))
MODEL = """<mujoco><option gravity="0 0 0"><flag contact="disable"/></option><worldbody>
<site name="world_axes"/>
<body>{joints}<inertial pos="0 0 0" mass="{mass}" diaginertia="{i1} {i2} {i3}"/>
<site name="point" pos="{point}"/></body>
</worldbody>{actuators}</mujoco>"""
FREE = '<freejoint/>'
SPRUNG = ''.join(f'<joint type="slide" axis="{axis}" stiffness="{SPRING_STIFFNESS}" '
                 f'damping="{SPRING_DAMPING}"/>' for axis in ('1 0 0', '0 1 0', '0 0 1')) \
    + '<joint type="ball"/>'
# Unit control, gear = the force in world axes (refsite "world_axes" is the world frame).
PUSH = ('<actuator><general site="point" refsite="world_axes" gear="{gear} 0 0 0" '
        'ctrlrange="-1 1"/></actuator>')


def model_xml(case):
    """Write the MJCF of ``case``: a free body, a sprung one or a pushed one."""
    joints, actuators = FREE, ''
    if case.key == 'spring':
        joints = SPRUNG
    elif case.key == 'offset_force':
        actuators = PUSH.format(gear=' '.join(map(str, PUSH_FORCE)))
    return MODEL.format(joints=joints, actuators=actuators, mass=MASS, i1=MOMENTS[0],
                        i2=MOMENTS[1], i3=MOMENTS[2], point=' '.join(map(str, PUSH_POINT)))


def require():
    """Raise MissingPackage with an install hint when ``mujoco`` is missing."""
    if mujoco is None:
        raise bench.MissingPackage(
            '--compare mujoco needs the optional package mujoco: pip install mujoco')
    return mujoco.__version__


def prepare(case, integrator, dt):
    """Return a zero-argument callable that runs ``case`` to its end with MuJoCo.

    The callable returns (orientation (4,) (x, y, z, w), world angular velocity (3,), the
    case's energy J, world angular momentum (3,), centre of mass (3,)). Model building is
    outside the call.
    """
    model = mujoco.MjModel.from_xml_string(model_xml(case))
    model.opt.timestep = dt
    model.opt.integrator = getattr(mujoco.mjtIntegrator, 'mjINT_' + integrator.upper())
    data = mujoco.MjData(model)
    data.qpos[3:7] = (1.0, 0.0, 0.0, 0.0)
    data.qvel[3:6] = case.omega0
    if case.key == 'spring':
        data.qpos[0:3], data.qvel[0:3] = SPRING_START
    if case.key == 'offset_force':
        data.ctrl[0] = 1.0
    steps = int(round(case.duration / dt))

    def run():
        mujoco.mj_step(model, data, nstep=steps)
        return final_state(case, data)
    # Divergence is read from data.warning; without a handler MuJoCo also appends every
    # warning to MUJOCO_LOG.TXT in the working directory.
    mujoco.set_mju_user_warning(_ignore_warning)
    return run


def _ignore_warning(message):
    """Drop a MuJoCo warning message (the counters still count it)."""


def final_state(case, data):
    """Orientation (x, y, z, w), omega world, the case's energy, L world, position.

    MuJoCo resets a simulation whose state blows up and only raises a warning counter; such
    a run, like one whose orientation is not finite, is reported as non-finite (diverged),
    not scored from the reset state.
    """
    if (any(data.warning[kind].number for kind in DIVERGENCE_WARNINGS)
            or not np.all(np.isfinite(data.qpos[3:7]))):
        nan = np.full(3, np.nan)
        return np.full(4, np.nan), nan, np.nan, nan, nan
    w, x, y, z = data.qpos[3:7]
    turn = Rotation.from_quat([x, y, z, w])
    matrix = turn.as_matrix()
    omega_body = np.array(data.qvel[3:6])
    position, velocity = np.array(data.qpos[0:3]), np.array(data.qvel[0:3])
    energy = case_energy(case, position, omega_body, velocity, matrix)
    return turn.as_quat(), matrix @ omega_body, energy, matrix @ (MOMENTS * omega_body), position


def initial_translation(case):
    """Centre-of-mass velocity (3,) m/s and ``R`` (3, 3) at t = 0 (the identity)."""
    velocity = SPRING_START[1] if case.key == 'spring' else np.zeros(3)
    return velocity, np.eye(3)


def case_energy(case, position, omega_body, velocity, matrix):
    """Compute the energy ``case`` tracks (see ``Case.energy``), J.

    Kinetic energy, plus the spring's potential, or minus the work potential
    ``F.(x + R r)`` of the held push.
    """
    energy = 0.5 * omega_body @ (MOMENTS * omega_body) + 0.5 * MASS * velocity @ velocity
    if case.key == 'spring':
        energy += 0.5 * SPRING_STIFFNESS * position @ position
    elif case.key == 'offset_force':
        energy -= PUSH_FORCE @ (position + matrix @ PUSH_POINT)
    return float(energy)


def measure(case, dt, repeats, budget, integrator):
    """Median CPU time of MuJoCo's ``integrator`` on ``case``, scored."""
    omega0 = np.asarray(case.omega0, dtype=float)
    start_position = SPRING_START[0] if case.key == 'spring' else np.zeros(3)
    start = (case_energy(case, start_position, omega0, *initial_translation(case)),
             np.linalg.norm(MOMENTS * omega0))
    cpu_time, final = bench.median_cpu_time(lambda: prepare(case, integrator, dt), repeats,
                                            budget)
    return score(case, 'mujoco ' + integrator, dt, False, final, start, np.nan, cpu_time)
