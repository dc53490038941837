# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Scene files: YAML -> a validated :class:`Scene` -> a :class:`~rigid_sim.core.world.World`.

The format is the "Scene file" section of the package's interface page, written down once
as field tables (name -> (checker, default)): below, and each effect's in its own module,
which :data:`rigid_sim.core.effects.REGISTRY` names by its scene key. Every mistake is
refused at load with a :class:`SceneError` naming the file, the key and the reason, so a
scene either builds exactly what it says or nothing at all. Only the effects a scene lists
are built, from the registry: an unlisted effect costs nothing while stepping.
"""
import dataclasses
import os
from dataclasses import dataclass, field

import numpy as np

from rigid_sim.core.contact import Contact
from rigid_sim.core.contact.shapes import collision_shape, default_collision, exact_refusal
from rigid_sim.core.inputs import (
    DEFAULT_MAX_FORCE, DEFAULT_MAX_TORQUE, AppliedWrenches)
from rigid_sim.core.effects import REGISTRY as EFFECTS
from rigid_sim.core.goals import MAX_SPEED, MAX_SPIN, UNKNOWNS, WRENCH_AXES
from rigid_sim.core.imu_spec import parse_imus
from rigid_sim.core.inertia import MassProperties, check_inertia, shape_mass_properties
from rigid_sim.core.integrators import DEFAULT_INTEGRATOR
from rigid_sim.core.state import RigidBodies, initial_state
from rigid_sim.core.world import World
from rigid_sim.core.scene_fields import (
    ABSENT, choice, count, describe, fields, list_of, matrix, Mistake, of_type,
    points, positive, quaternion, raw, REQUIRED, scale, size, table, token, vector)
from rigid_sim.core.scene_file import confined, FileRefused, load_yaml
from rigid_sim.core.scene_limits import Budget, operator_limits, raise_note, WORK_LIMITS
from rigid_sim.core.text import clipped, shown

INERTIA_METHODS = ('exact', 'bounding_box', 'sampling', 'given')
GOAL_DEFAULT = {'unknowns': 'twist', 'axes': 'world', 'max_speed': MAX_SPEED,
                'max_spin': MAX_SPIN}


class SceneError(ValueError):
    """A scene mistake; ``str()`` is ``"<file>: <key path>: <reason>"``."""

    def __init__(self, path, key, reason):
        super().__init__(f'{clipped(path)}: {clipped(key)}: {clipped(reason, 2000)}')
        self.path, self.key, self.reason = path, key, reason


@dataclass(frozen=True)
class BodySpec:
    """One body as the scene gives it; vectors in SI units, world axes unless stated."""

    name: str
    shape: dict                       # validated shape; a mesh ``file`` is an absolute path
    mass_properties: MassProperties   # mass, centre of mass (body frame), inertia about it
    origin: np.ndarray                # (3,) m, body-frame origin
    orientation: np.ndarray           # (4,) unit quaternion (x, y, z, w), body to world
    linear_velocity: np.ndarray       # (3,) m/s, of the body-frame origin
    angular_velocity: np.ndarray      # (3,) rad/s
    points: dict                      # name -> (3,) m, body-frame coordinates
    wrench_input: bool                # False: the body takes no applied wrenches
    imus: tuple = ()                  # of rigid_sim.core.imu_spec.ImuSpec, in file order
    # What a goal for this body solves for: unknowns in goals.UNKNOWNS, axes of a wrench,
    # and the speed limits of a solved twist (goals.Goal).
    goal: dict = dataclasses.field(default_factory=lambda: dict(GOAL_DEFAULT))
    # Collision shape, body frame (rigid_sim.core.contact.shapes): given, else the shape's
    # own where it is a sphere or box; None: neither (refused where the scene lists contact).
    collision: dict = None


@dataclass(frozen=True)
class Scene:
    """A validated scene: the bodies and only the effects the file lists.

    ``effects`` holds the listed ones only, scene key -> settings as the effect's class
    (in :data:`rigid_sim.core.effects.REGISTRY`) resolved them: ``'gravity'``:
    {acceleration (3,) m/s^2}, ``'damping'``: {linear, angular} rates in 1/s,
    ``'springs'``: tuple of SpringSpec.
    """

    path: str
    world_frame: str
    max_force: float    # N, applied forces above are refused
    max_torque: float   # N m
    bodies: tuple       # of BodySpec, in file order
    effects: dict
    magnetic_field: np.ndarray = None   # (3,) T, world axes; None: not given
    # Work limits in force (the operator's, lowered by the file's limits:): bodies spawned
    # later are held to them too.
    work_limits: dict = field(default_factory=lambda: dict(WORK_LIMITS))
    # The contact: entry of effects: as rigid_sim.core.contact.SETTINGS checks it; None:
    # not listed, and the world has no contact stage.
    contact: dict = None


SHAPES = {
    'box': {'size': (size, REQUIRED)},
    'sphere': {'radius': (positive, REQUIRED)},
    'cylinder': {'radius': (positive, REQUIRED), 'length': (positive, REQUIRED)},
    'mesh': {'file': (of_type(str, 'a file name'), REQUIRED), 'scale': (scale, 1.0)},
}
GIVEN = {'diagonal': (vector, ABSENT), 'matrix': (matrix, ABSENT)}
INERTIA = {'method': (choice(*INERTIA_METHODS), ABSENT),
           'samples': (count, ABSENT),
           'given': (table(GIVEN), ABSENT), **GIVEN}
ZERO = [0.0, 0.0, 0.0]
# Shape and inertia arrive raw: their valid keys depend on their type, checked in parse_body.
BODY = {'name': (token, REQUIRED), 'shape': (raw, REQUIRED),
        'mass': (positive, ABSENT), 'density': (positive, ABSENT), 'inertia': (raw, {}),
        'pose': (table({'position': (vector, ZERO),
                        'orientation': (quaternion, [0.0, 0.0, 0.0, 1.0])}), {}),
        'twist': (table({'linear': (vector, ZERO), 'angular': (vector, ZERO)}), {}),
        'points': (points, {}), 'wrench_input': (of_type(bool, 'true or false'), True),
        'imu': (raw, ABSENT), 'collision': (collision_shape, ABSENT),
        'goal': (table({'unknowns': (choice(*UNKNOWNS), GOAL_DEFAULT['unknowns']),
                        'axes': (choice(*WRENCH_AXES), GOAL_DEFAULT['axes']),
                        'max_speed': (positive, MAX_SPEED),
                        'max_spin': (positive, MAX_SPIN)}), {})}
SCENE = {'world_frame': (token, 'world'),
         'limits': (table({'max_force': (positive, DEFAULT_MAX_FORCE),
                           'max_torque': (positive, DEFAULT_MAX_TORQUE),
                           **{name: (count, ABSENT) for name in WORK_LIMITS}}), {}),
         # Each effect's own fields (rigid_sim.core.effects.REGISTRY), in its order.
         # Contact is listed among them but is a stage after each step, not a force.
         'effects': (table({**{name: (effect.scene_fields, ABSENT)
                               for name, effect in EFFECTS.items()},
                            Contact.name: (Contact.scene_fields, ABSENT)}), {}),
         'magnetic_field': (vector, ABSENT),   # read by magnetometers only, T
         # Raw here; parse_body checks each, as it needs the scene's directory.
         'bodies': (list_of(raw, 'bodies'), REQUIRED)}


def _shape(value, key, base_dir, roots=None):
    """Validate a shape dict; a mesh file is resolved against the scene's directory.

    The file must be in one of ``roots`` (:func:`rigid_sim.core.scene_file.confined`).
    """
    kind = value.get('type') if isinstance(value, dict) else None
    if not isinstance(kind, str) or kind not in SHAPES:
        where = f'{key}.type' if isinstance(value, dict) else key
        raise Mistake(where, f'expected a shape type in {tuple(SHAPES)}, got '
                             f'{describe(kind if where != key else value)}')
    shape = fields(value, key, {'type': (raw, REQUIRED), **SHAPES[kind]})
    if kind == 'mesh':
        try:
            shape['file'] = confined(os.path.join(base_dir, shape['file']), roots, 'mesh')
        except FileRefused as refused:
            raise Mistake(f'{key}.file', f'{refused.reason} (a relative path starts at the '
                                         "scene file's directory)") from None
        except ValueError as error:  # an embedded NUL
            raise Mistake(f'{key}.file', str(error)) from None
    return shape


def _inertia(value, key):
    """Validate an inertia method; a diagonal or matrix without a method means 'given'.

    ``given: {diagonal: [..]}`` (or ``matrix``), as the README writes it, is the same as
    ``{method: given, diagonal: [..]}``.
    """
    inertia = fields(value, key, INERTIA)
    tensor_key = key
    if 'given' in inertia:
        nested = inertia.pop('given')
        if not nested:
            raise Mistake(f'{key}.given', 'expected a diagonal or a matrix, got neither')
        if set(nested) & set(inertia) or inertia.get('method', 'given') != 'given':
            raise Mistake(f'{key}.given', 'given holds the diagonal or matrix itself; '
                                          'give no method, diagonal or matrix beside it')
        inertia.update(nested, method='given')
        tensor_key = f'{key}.given'
    given = [name for name in ('diagonal', 'matrix') if name in inertia]
    method = inertia.setdefault('method', 'given' if given else 'exact')
    if (method == 'given') != (len(given) == 1):
        raise Mistake(key, "method 'given' takes exactly one of diagonal or matrix; "
                           "other methods take neither")
    if (method == 'sampling') != ('samples' in inertia):
        raise Mistake(f'{key}.samples', "method 'sampling' needs samples, others take none")
    for name in given:
        try:
            check_inertia(np.diag(inertia[name]) if name == 'diagonal' else inertia[name])
        except ValueError as error:
            raise Mistake(f'{tensor_key}.{name}', str(error)) from None
    return inertia


def parse_body(value, key, budget, has_field):
    """One :class:`BodySpec` from its scene entry, within the scene's work ``budget``.

    ``has_field``: whether the scene gives a magnetic field (for magnetometers). Raises
    Mistake naming the entry's ``key`` path and the reason.
    """
    body = fields(value, key, BODY)
    budget.draw('max_points', len(body['points']), f'{key}.points', ('points', 'named'))
    amount = {name: body[name] for name in ('mass', 'density') if name in body}
    if len(amount) != 1:
        raise Mistake(f'{key}.mass', 'give exactly one of mass (kg) or density (kg/m^3)')
    shape = _shape(body['shape'], f'{key}.shape', budget.base_dir, budget.roots)
    inertia = _inertia(body['inertia'], f'{key}.inertia')
    if body['goal']['unknowns'] == 'wrench' and not body['wrench_input']:
        raise Mistake(f'{key}.goal.unknowns', 'a wrench needs wrench_input: true')
    mesh = budget.mesh(shape, f'{key}.shape') if shape['type'] == 'mesh' else None
    if inertia['method'] == 'sampling':
        budget.draw('max_samples', inertia['samples'], f'{key}.inertia.samples',
                    ('samples', 'drawn'))
    try:
        properties = shape_mass_properties(shape, inertia, mesh=mesh, **amount)
    except Exception as error:  # trimesh and scipy on a user's mesh: any error refuses it
        # Given tensors are checked already: what fails here is the mesh, or too few samples.
        blamed = 'inertia.samples' if inertia['method'] == 'sampling' else 'shape'
        raise Mistake(f'{key}.{blamed}', str(error)) from None
    return BodySpec(
        name=body['name'], shape=shape, mass_properties=properties,
        origin=body['pose']['position'], orientation=body['pose']['orientation'],
        linear_velocity=body['twist']['linear'], angular_velocity=body['twist']['angular'],
        points=body['points'], wrench_input=body['wrench_input'], goal=body['goal'],
        collision=body.get('collision', default_collision(shape)),
        imus=parse_imus(body['imu'], f'{key}.imu', body['points'], has_field)
        if 'imu' in body else ())


def _bodies(entries, world_frame, budget, has_field):
    """All bodies, with unique names and point names that do not shadow a frame."""
    if not entries:
        raise Mistake('bodies', 'expected a non-empty list of bodies, got an empty one')
    if len(entries) > budget.limits['max_bodies']:
        raise Mistake('bodies', f'{len(entries)} bodies, {budget.above("max_bodies")}')
    bodies = tuple(parse_body(entry, f'bodies[{i}]', budget, has_field)
                   for i, entry in enumerate(entries))
    clash = world_frame_clash(bodies, world_frame)
    if clash is not None:
        index, point, reason = clash
        raise Mistake(f'bodies[{index}].name' if point is None
                      else f'bodies[{index}].points.{point}', reason)
    names = [body.name for body in bodies]
    first = {}
    for i, name in enumerate(names):
        if name in first:
            raise Mistake(f'bodies[{i}].name', f'duplicate body name {name!r} '
                                               f'(also bodies[{first[name]}])')
        first[name] = i
    for i, body in enumerate(bodies):
        for point in body.points:
            if point in first:
                raise Mistake(f'bodies[{i}].points.{point}', f'point name {point!r} is '
                              'already a frame name (a body)')
    return bodies


def world_frame_clash(bodies, world_frame):
    """Find the first name of ``bodies`` that ``world_frame`` would also be.

    A wrench's frame_id names world axes, a body's axes or one of its points, so the
    world_frame may be neither a body name nor a point frame ``<body>/<point>``; nor a bare
    point name, so that a name means one thing wherever it appears. The scene loader and the
    node's world_frame parameter both refuse by this one rule.

    Parameters
    ----------
    bodies : sequence of BodySpec
        The scene's bodies, with their named points.
    world_frame : str
        The name proposed for the fixed frame.

    Returns
    -------
    tuple of (int, str or None, str) or None
        Index of the body, the point's name (None for the body's own name) and the reason;
        None when ``world_frame`` names none of them.
    """
    for index, body in enumerate(bodies):
        if world_frame == body.name:
            return index, None, f'body name {body.name!r} is the world_frame'
        for point in body.points:
            if world_frame in (point, f'{body.name}/{point}'):
                return index, point, (f'point {point!r} of body {body.name!r} is named like '
                                      'the world_frame')
    return None


def _contact(listed, bodies):
    """Take the contact settings out of ``listed``; None if not listed.

    Every body then needs a collision shape: refused at the first that has none.
    """
    settings = listed.pop(Contact.name, None)
    if settings is not None:
        for i, body in enumerate(bodies):
            if body.collision is None:
                raise Mistake(f'bodies[{i}].collision', f'a {body.shape["type"]} body needs '
                              'a collision shape (sphere, box, capsule, cylinder or none) '
                              'when the scene lists contact: meshes do not collide yet')
            refusal = exact_refusal(body.collision, settings.get('mode'))
            if refusal is not None:
                raise Mistake(f'bodies[{i}].collision', refusal)
    return settings


def _effects(listed, bodies):
    """Return each listed effect's settings resolved against ``bodies``; empty ones left out.

    ``listed`` maps a scene key of :data:`rigid_sim.core.effects.REGISTRY` to its checked
    entry; ``bodies`` are the scene's BodySpecs.
    """
    resolved = {name: EFFECTS[name].resolve(settings, f'effects.{name}', bodies)
                for name, settings in listed.items()}
    return {name: settings for name, settings in resolved.items() if settings is not None}


def parse_scene(data, path='<memory>', base_dir='.', roots=None, **limits):
    """Validate an already-loaded scene mapping; mesh files are relative to ``base_dir``.

    A mesh file must be in one of the directories ``roots`` (real paths; None: anywhere).
    The roots are the caller's: nothing in a scene widens them.

    A non-unit orientation quaternion is normalised; a zero one is refused. Raises
    :class:`SceneError` naming ``path``, the key and the reason for any mistake. ``limits``
    are the operator's work limits (``max_bodies=``, ``max_samples=``, ...; the defaults
    of :data:`rigid_sim.core.scene_limits.RESOURCE_LIMITS` otherwise); the scene's own
    ``limits:`` may lower them, and is refused where it asks for more.
    """
    allowed = operator_limits(limits)
    try:
        scene = fields(data, '', SCENE)
        asked = scene['limits']
        budget = Budget({name: asked.pop(name) for name in WORK_LIMITS if name in asked},
                        allowed, base_dir, roots)
        field = scene.get('magnetic_field')
        bodies = _bodies(scene['bodies'], scene['world_frame'], budget, field is not None)
        contact = _contact(scene['effects'], bodies)
        effects = _effects(scene['effects'], bodies)
    except Mistake as mistake:
        raise SceneError(path, mistake.key, mistake.reason) from None
    return Scene(path=str(path), world_frame=scene['world_frame'], bodies=bodies,
                 effects=effects, magnetic_field=field, work_limits=budget.limits,
                 contact=contact, **scene['limits'])


def load_scene(path, roots=None, **limits):
    """Read and validate the scene file at ``path``; see :func:`parse_scene`.

    ``path`` and its mesh files must be in one of the directories ``roots`` (real paths;
    None: anywhere); any other file is refused unopened, as one that does not exist.

    Loads with PyYAML's safe loader (no arbitrary objects, YAML 1.2 floats), made to refuse
    duplicate keys, after the checks of :mod:`rigid_sim.core.scene_file`: a regular file of
    at most ``max_scene_bytes`` of UTF-8, nested at most MAX_DEPTH deep, at most MAX_NODES
    nodes. ``limits`` are the operator's resource limits, by name (``max_scene_bytes=``,
    ``max_bodies=``, ``max_samples=``, ``max_mesh_bytes=``, ``max_mesh_faces=``,
    ``max_points=``); the defaults of :data:`rigid_sim.core.scene_limits.RESOURCE_LIMITS`
    otherwise.
    """
    allowed = operator_limits(limits)
    try:
        real = confined(path, roots, 'scene file')
        data = load_yaml(real, allowed['max_scene_bytes'], raise_note('max_scene_bytes'))
    except FileRefused as refused:
        raise SceneError(path, refused.where, refused.reason) from None
    return parse_scene(data, path, os.path.dirname(real), roots,
                       **{name: allowed[name] for name in WORK_LIMITS})


def build_world(scene, integrator=DEFAULT_INTEGRATOR, tolerance=1e-6, error_control=True):
    """Return the :class:`World` of ``scene``, with only the effects the scene lists.

    ``integrator`` is a name from ``rigid_sim.core.integrators.REGISTRY``; ``tolerance``
    and ``error_control`` as :class:`World` takes them. The world's inputs accept wrenches
    on the bodies that take wrench input, within the scene's limits.
    """
    def stacked(get):
        return np.array([get(body) for body in scene.bodies], dtype=float)

    bodies = RigidBodies(
        names=tuple(body.name for body in scene.bodies),
        mass=stacked(lambda body: body.mass_properties.mass),
        inertia_body=stacked(lambda body: body.mass_properties.inertia),
        com_in_body=stacked(lambda body: body.mass_properties.center_of_mass))
    initial = initial_state(
        bodies, stacked(lambda body: body.origin), stacked(lambda body: body.orientation),
        stacked(lambda body: body.linear_velocity), stacked(lambda body: body.angular_velocity))
    effects = [EFFECTS[name].from_settings(bodies, settings)
               for name, settings in scene.effects.items()]
    accepts = [body.wrench_input for body in scene.bodies]
    inputs = AppliedWrenches(bodies, scene.max_force, scene.max_torque, accepts)
    return World(bodies, initial, effects, integrator, tolerance, inputs=inputs,
                 error_control=error_control, contact=_contact_stage(scene, bodies))


def _contact_stage(scene, bodies):
    """Return the :class:`Contact` of ``scene`` on ``bodies``; None when it lists no contact.

    Raises ValueError for a body without a collision shape (one spawned into the scene).
    """
    if scene.contact is None:
        return None
    for body in scene.bodies:
        if body.collision is None:
            raise ValueError(f'body {body.name!r}: a {body.shape["type"]} body needs a '
                             'collision shape (sphere, box, capsule, cylinder or none) in a '
                             'scene with contact')
        refusal = exact_refusal(body.collision, scene.contact.get('mode'))
        if refusal is not None:
            raise ValueError(f'body {body.name!r}: {refusal}')
    return Contact(bodies, [body.collision for body in scene.bodies], **scene.contact)


def check_world_frame(scene, world_frame):
    """Raise ValueError if ``world_frame`` is also a body or point name of ``scene``.

    The rule is :func:`world_frame_clash`'s, the one the scene loader applies, so a
    ``world_frame`` set at runtime is refused exactly where a scene naming it would be.
    """
    clash = world_frame_clash(scene.bodies, world_frame)
    if clash is not None:
        index, _, reason = clash
        raise ValueError(f'world_frame {shown(world_frame)} is a frame of body '
                         f'{scene.bodies[index].name!r} in {scene.path} ({reason}): a wrench '
                         'frame_id would mean both')


def wrench_target(body, frame_id, world_frame):
    """Where a WrenchStamped with ``frame_id`` acts on ``body`` (a BodySpec): (frame, point).

    ``world_frame`` -> ('world', None); ``""`` or ``<body>`` -> ('body', None);
    ``<body>/<point>`` -> ('point', (3,) body-frame coordinates, m). Raises ValueError naming
    an unknown frame and listing the valid frame ids.
    """
    if frame_id == world_frame:
        return 'world', None
    if frame_id in ('', body.name):
        return 'body', None
    prefix, _, point = frame_id.partition('/')
    if prefix == body.name and point in body.points:
        return 'point', body.points[point].copy()
    valid = [world_frame, '', body.name] + [f'{body.name}/{p}' for p in body.points]
    raise ValueError(f'unknown frame_id {shown(frame_id)} for body {body.name!r}; valid: '
                     f'{clipped(valid, 400)}')
