# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Bodies added to or removed from a running scene: a new Scene and World, the state carried.

A World's model arrays, effects and compiled kernels belong to one set of bodies, so adding
or removing a body builds a new World (:func:`rigid_sim.core.scene.build_world` of the new
Scene) and then carries over what the running one holds (:func:`carry_over`): every kept
body's state and initial state, the time, the held wrenches and the step diagnostics.
Building (a mesh's inertia, compiling kernels for a new effect set) may take seconds and
reads only the Scene, so a caller may do it on another thread while the old World steps on;
carrying is cheap and reads the old World as it is at that moment.

New bodies come as scene entries, checked by the scene loader with its messages and the
running scene's limits (``limits:`` of its file), and :class:`SpawnRefused` says why one is
refused with a ``kind`` a caller can map to its own codes.
"""
from dataclasses import replace

import numpy as np
from scipy.spatial.transform import Rotation

from rigid_sim.core import body_state
from rigid_sim.core.scene import (
    load_scene, parse_body, SceneError, world_frame_clash)
from rigid_sim.core.robot_description import DescriptionRefused, model_body
from rigid_sim.core.scene_fields import describe, Mistake, token, vector
from rigid_sim.core.scene_file import FileRefused, MAX_SCENE_BYTES, parse_yaml
from rigid_sim.core.scene_limits import Budget

# What a refusal is about: the name, the text or file, a format not served, an asset it
# names, the pose, or that nothing was given.
KINDS = ('name_taken', 'name_invalid', 'parse', 'unsupported', 'missing_asset', 'pose',
         'no_resource')


class SpawnRefused(ValueError):
    """A spawn refused whole: ``kind`` (one of KINDS) and the one-line reason."""

    def __init__(self, kind, reason):
        super().__init__(reason)
        self.kind = kind


def _parse_refusal(error):
    """Return the SpawnRefused for a loader's SceneError (a missing mesh: missing asset)."""
    missing = error.key.endswith('shape.file') and 'not found' in str(error.reason)
    return SpawnRefused('missing_asset' if missing else 'parse', str(error))


def check_name(name, where='name'):
    """Return ``name`` if it is a valid body name, else SpawnRefused('name_invalid')."""
    try:
        return token(name, where)
    except Mistake as mistake:
        raise SpawnRefused('name_invalid', f'{mistake.key}: {mistake.reason}') from None


def body_from_text(text, scene, name=None, max_bytes=MAX_SCENE_BYTES, base_dir='.',
                   roots=None):
    """One :class:`BodySpec` from ``text``, a body entry of the scene format (YAML).

    ``name``, when given, replaces the entry's own. The entry is checked as an item of a
    scene's ``bodies:`` would be, within ``scene``'s limits, and ``text`` is at most
    ``max_bytes`` long; a mesh file is relative to ``base_dir`` and must be in one of
    ``roots`` (None: anywhere). Raises SpawnRefused.
    """
    entry = entry_from_text(text, max_bytes)
    if name is not None:
        entry = {**entry, 'name': name}
    return checked_body(entry, scene, base_dir, roots)


def entry_from_text(text, max_bytes=MAX_SCENE_BYTES, where='resource_string'):
    """Return the body entry (a mapping) the YAML ``text`` holds, unchecked; or SpawnRefused."""
    try:
        entry = parse_yaml(text, max_bytes)
    except FileRefused as refused:
        raise SpawnRefused('parse', f'{where}: {refused.where}: {refused.reason}') from None
    if not isinstance(entry, dict):
        raise SpawnRefused('parse', f'{where}: expected one body entry (a mapping with name, '
                                    f'shape, mass, ...), got {describe(entry)}')
    return entry


def entry_from_model(text, spawn_format, resolve, where='resource_string'):
    """Return the body entry and centre of mass of a one-link URDF or SDFormat model.

    See :func:`rigid_sim.core.robot_description.model_body`.
    """
    try:
        return model_body(text, spawn_format, resolve)
    except DescriptionRefused as refused:
        raise SpawnRefused(refused.kind, f'{where}: {refused}') from None


def checked_body(entry, scene, base_dir='.', roots=None, center_of_mass=None,
                 where='resource_string'):
    """Return the :class:`BodySpec` of ``entry``, checked as an item of ``bodies:`` would be.

    Within ``scene``'s limits; a mesh file is relative to ``base_dir`` and in one of
    ``roots`` (None: anywhere). ``center_of_mass`` ((3,) m, body frame), when given,
    replaces the shape's, as a model's ``<inertial>`` places it. Raises SpawnRefused.
    """
    try:
        budget = Budget({}, scene.work_limits, base_dir, roots)
        body = parse_body(entry, '', budget, scene.magnetic_field is not None)
    except Mistake as mistake:
        raise _parse_refusal(SceneError(where, mistake.key.lstrip('.') or '(entry)',
                                        mistake.reason)) from None
    if center_of_mass is None:
        return body
    try:   # held to the bound of every scene number, as the shape's would be
        center = vector(np.asarray(center_of_mass, dtype=float).tolist(),
                        'inertial origin (the centre of mass)')
    except Mistake as mistake:
        raise SpawnRefused('parse', f'{where}: {mistake.key}: {mistake.reason}') from None
    properties = replace(body.mass_properties, center_of_mass=center)
    return replace(body, mass_properties=properties)


def bodies_from_file(path, roots=None, **limits):
    """Return the bodies and springs of the scene file at ``path``, by the scene loader.

    ``roots`` and ``limits`` are the operator's, as :func:`rigid_sim.core.scene.load_scene`
    takes them. Returns (bodies, springs): springs index the file's own bodies. Raises
    SpawnRefused, also for a file with effects other than springs: the running scene's
    effects act on spawned bodies, and a file's gravity dropped in silence would be a
    different motion than the file describes.
    """
    try:
        loaded = load_scene(path, roots, **limits)
    except SceneError as error:
        raise _parse_refusal(error) from None
    dropped = sorted(set(loaded.effects) - {'springs'})
    if dropped:
        raise SpawnRefused('parse', f'uri: the file has effects {dropped}, which are not '
                                    "spawned (the running scene's effects act on every body): "
                                    'spawn a file whose effects are at most springs')
    return loaded.bodies, loaded.effects.get('springs', ())


def placed(spec, origin, orientation, compose=False):
    """``spec`` (a BodySpec) at a new pose: replaced, or with ``compose`` moved by it.

    Composing places the entry's own frame at (origin, orientation): its pose and twist are
    carried along, as when a scene file's world is put down somewhere else. Raises
    SpawnRefused('pose') for a non-finite position or a quaternion that is not a rotation.
    """
    try:
        origin = np.asarray(origin, dtype=float)
        if origin.shape != (3,) or not np.all(np.isfinite(origin)):
            raise ValueError(f'non-finite position {origin.tolist()}')
        orientation = body_state.unit_quaternion(orientation)
    except ValueError as error:
        raise SpawnRefused('pose', f'initial_pose: {error}') from None
    if not compose:
        return replace(spec, origin=origin, orientation=orientation)
    turn = Rotation.from_quat(orientation)
    return replace(spec, origin=origin + turn.apply(spec.origin),
                   orientation=(turn * Rotation.from_quat(spec.orientation)).as_quat(),
                   linear_velocity=turn.apply(spec.linear_velocity),
                   angular_velocity=turn.apply(spec.angular_velocity))


def with_bodies(scene, added, springs=()):
    """Return ``scene`` with the BodySpecs ``added`` after its own, and their ``springs``.

    ``springs`` index ``added``. Names must be new, no frame may be named like the scene's
    world_frame, and the count stays within ``limits.max_bodies``. Raises SpawnRefused.
    """
    limit = scene.work_limits['max_bodies']
    if len(scene.bodies) + len(added) > limit:
        raise SpawnRefused('parse', f'{len(scene.bodies)} bodies and {len(added)} more are '
                                    f'above the scene limit of {limit} (limits.max_bodies)')
    named = sum(len(body.points) for body in scene.bodies)
    adding = sum(len(body.points) for body in added)
    limit = scene.work_limits['max_points']
    if named + adding > limit:   # all points are frames of every swap's /tf_static
        raise SpawnRefused('parse', f'{named} named points and {adding} more are above the '
                                    f'scene limit of {limit} (limits.max_points)')
    taken = {body.name for body in scene.bodies}
    for body in added:
        if body.name in taken:
            raise SpawnRefused('name_taken', f'a body named {body.name!r} exists already')
        taken.add(body.name)
    clash = world_frame_clash(added, scene.world_frame)
    if clash is not None:
        raise SpawnRefused('name_invalid', clash[2])
    for body in added:
        for point in body.points:
            if point in taken:
                raise SpawnRefused('parse', f'point name {point!r} of {body.name!r} is '
                                            'already a frame name (a body)')
    offset = len(scene.bodies)
    moved = tuple(replace(spring, body=spring.body + offset,
                          other=None if spring.other is None else spring.other + offset)
                  for spring in springs)
    return _with(scene, scene.bodies + tuple(added),
                 scene.effects.get('springs', ()) + moved)


def without_body(scene, index):
    """Return ``scene`` without body ``index``, and how many springs went with it.

    A spring with an end on that body goes with it; the others keep their ends.
    """
    kept, dropped = [], 0
    for spring in scene.effects.get('springs', ()):
        if index in (spring.body, spring.other):
            dropped += 1
            continue
        kept.append(replace(spring, body=spring.body - (spring.body > index),
                            other=None if spring.other is None
                            else spring.other - (spring.other > index)))
    bodies = scene.bodies[:index] + scene.bodies[index + 1:]
    if not bodies:
        raise SpawnRefused('parse', 'a scene keeps at least one body')
    return _with(scene, bodies, tuple(kept)), dropped


def _with(scene, bodies, springs):
    effects = {kind: value for kind, value in scene.effects.items() if kind != 'springs'}
    if springs:
        effects['springs'] = springs
    return replace(scene, bodies=bodies, effects=effects)


def carry_over(old, new, kept):
    """Give World ``new`` what World ``old`` holds, for the bodies in ``kept``.

    ``kept`` pairs (old index, new index): each such body's state row and initial row, its
    held wrenches (with their hold ends) are carried; so are the time and the step
    diagnostics. Bodies of ``new`` not in ``kept`` keep the state ``new`` was built with,
    which is also their initial state.
    """
    pairs = np.array(kept, dtype=int).reshape(-1, 2)
    before, after = pairs[:, 0], pairs[:, 1]
    y = new.y.copy()
    y[after] = old.y[before]
    new.initial[after] = old.initial[before]
    new.y = y
    new.time = old.time
    new.control.diagnostics = old.control.diagnostics
    moved = dict(zip(before.tolist(), after.tolist()))
    com = old.bodies.com_in_body
    for (body, key), held in old.inputs.held.items():
        if body in moved:
            point = held.lever + com[body] if held.frame == 'world_point' else None
            new.inputs.hold(moved[body], key, held.frame, held.force, held.torque, point,
                            held.expires)
