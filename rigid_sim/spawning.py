# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Scene edits at runtime: bodies spawned and deleted, a scene put back, never a stalled tick.

An edit builds a new Scene and World (:mod:`rigid_sim.core.scene_edit`): reading a mesh,
computing inertias and compiling the kernels of a new effect set may take seconds, so that
part runs in a worker thread while the running world ticks on. Then, between two ticks, the
stored input messages are applied to the running world, its state, time and held wrenches
are carried into the new one and the node runs the new scene: a spawned body has every
per-body topic from that tick on, a deleted one has none. An edit is a job of the node's
:class:`~rigid_sim.world_owner.WorldOwner`: edits, parameter changes that need preparing and
the resets that put the scene back run one at a time, in the order they were asked for, each
from what the one before left; each edit is answered when it has been swapped in, or refused
with the reason.
"""
from dataclasses import replace
import itertools
import os
from pathlib import Path
from urllib.parse import unquote, urlparse

import numpy as np

from rigid_sim import conversions, deferred
from rigid_sim.core import body_state
from rigid_sim.core.imu import scene_imus
from rigid_sim.core.scene import build_world
from rigid_sim.core.robot_description import (
    DescriptionRefused, find_resource, spawn_format)
from rigid_sim.core.scene_edit import (
    bodies_from_file, check_name, checked_body, entry_from_model, entry_from_text, placed,
    SpawnRefused, with_bodies, without_body)
from rigid_sim.core.scene_file import FileRefused, read_text
from rigid_sim.core.text import shown
from rigid_sim.entity_services import reference_frame, result
from rigid_sim.resources import allowed_roots, find_scene, package_share
from rigid_sim.world_owner import Job

from simulation_interfaces import msg as si_msg, srv as si_srv

# SpawnEntity's codes for the kinds of SpawnRefused.
SPAWN_CODES = {'name_taken': 'NAME_NOT_UNIQUE', 'name_invalid': 'NAME_INVALID',
               'parse': 'RESOURCE_PARSE_ERROR', 'unsupported': 'UNSUPPORTED_FORMAT',
               'missing_asset': 'MISSING_ASSETS', 'pose': 'INVALID_POSE',
               'no_resource': 'NO_RESOURCE'}
# Edits a client may have waiting at once: each holds its request, and a new scene while it
# is prepared; past this a spawn or delete is refused at once, not queued.
MAX_PENDING_EDITS = 64
GENERATED_NAME = 'body'   # what an unnamed spawn with allow_renaming is called, then _1, ...


def outcome(preparation):
    """Return what an edit's worker made, or the SpawnRefused any failure of it becomes."""
    error = preparation.error
    if error is None or isinstance(error, SpawnRefused):
        return error or preparation.result
    return SpawnRefused('parse', f'{type(error).__name__}: {error}')


class SceneEditor:
    """Scene edits for ``node`` (a RigidSimNode), as jobs of its WorldOwner.

    Also remembers which bodies were spawned and the scene as loaded, for the resets of
    ResetSimulation.
    """

    def __init__(self, node):
        self._node = node
        self._edited = None      # the last scene an edit made
        self.loaded = None       # the scene before the first edit (a reload forgets edits)
        self.spawned = []        # names of the bodies spawned into the running scene

    @property
    def edited(self):
        """Whether the running scene is one an edit made (not reloaded since)."""
        return self._edited is not None and self._edited is self._node.scene

    def submit(self, build, done):
        """Queue an edit: ``build(scene)`` off the executor, then ``done(outcome)`` on it.

        ``build`` returns (new scene, kept, note): ``kept`` pairs old and new body indices,
        ``note`` words the answer. ``done`` gets ``(scene, world, note)`` or the SpawnRefused.
        """
        self.submit_planned(lambda scene: build, done)

    def submit_planned(self, plan, done):
        """Queue an edit decided when its turn comes: ``plan(scene)`` is its build or None.

        With None nothing is prepared or swapped and ``done(None)`` is called then.
        """
        node = self._node

        def begin(scene, world, settings):
            build = plan(scene)
            if build is None:
                return None
            logger = node.get_logger()

            def work():   # any failure refuses the edit (outcome), never raises
                new_scene, kept, note = build(scene)
                new_world = build_world(new_scene, settings.integrator, settings.tolerance,
                                        settings.error_control)
                from rigid_sim.node import warm_up   # the node imports this module
                warm_up(new_world, settings.integrator, logger,
                        imus=scene_imus(new_scene, new_world))
                wiring = node.plan_wiring(new_scene, settings)
                return scene, new_scene, new_world, kept, note, wiring
            return work

        def conclude(preparation):
            done(None if preparation is None else self._swap(outcome(preparation)))
        node.owner.submit(Job(begin, conclude))

    def _swap(self, result):
        """Run the edit's scene from the next tick on; the (scene, world, note) or a refusal."""
        if isinstance(result, SpawnRefused):
            return result
        base, scene, world, kept, note, wiring = result
        if not self.edited:
            self.loaded, self.spawned = base, []
        self._edited = scene
        self._node.owner.swap(scene=scene, world=world, kept=kept, wiring=wiring)
        names = {body.name for body in scene.bodies}
        self.spawned = [name for name in self.spawned if name in names]
        return scene, world, note

    def wait(self, timeout=None):
        """Block until every queued edit is swapped in or refused (tests that tick themselves)."""
        return self._node.owner.wait(timeout)


def scene_path(uri, resource_paths):
    """Return the file a SpawnEntity ``uri`` names: a path, a URI or a packaged scene.

    The URI is ``file://``, ``package://`` or ``model://``.

    Only files in the allowed directories (:func:`rigid_sim.resources.allowed_roots` of
    ``resource_paths``) are found; any other is refused unopened, as a missing one is. A
    ``model://`` URI naming a model's folder means its ``model.sdf``.
    """
    parsed = urlparse(uri)
    if parsed.scheme in ('package', 'model'):
        roots = allowed_roots(resource_paths)
        try:
            path = find_resource(uri, '.', roots, 'uri file', package_share)
            if os.path.isdir(path):
                path = find_resource('model.sdf', path, roots, 'uri file')
        except DescriptionRefused as refused:
            raise SpawnRefused(refused.kind, f'uri {shown(uri)}: {refused}') from None
        return Path(path)
    if parsed.scheme == 'file':
        uri = unquote(parsed.path)
    elif parsed.scheme and len(parsed.scheme) > 1:   # not a Windows drive letter
        raise SpawnRefused('unsupported', f'uri {shown(uri)}: a path or a file://, package:// '
                                          'or model:// URI')
    try:
        return find_scene(uri, resource_paths)
    except FileNotFoundError as error:
        raise SpawnRefused('missing_asset', str(error)) from None


def entity_name(own, name, renaming, taken):
    """Return the spawned body's name: ``name`` (the request's), else ``own``.

    ``own`` is the resource's. Neither given: GENERATED_NAME with ``renaming``, else
    NAME_INVALID, as SpawnEntity.srv says. With ``renaming`` a name in ``taken`` becomes
    ``<name>_1``, ``<name>_2``, ...
    """
    chosen = name or own
    if not chosen:
        if not renaming:
            raise SpawnRefused('name_invalid', 'no name: give name (or one in the resource), '
                                               'or allow_renaming for a generated one')
        chosen = GENERATED_NAME
    chosen = check_name(chosen)
    # A free name is one more name: <name>_1 of a 100-character name is over the limit.
    return check_name(free_name(chosen, taken)) if renaming else chosen


def free_name(name, taken):
    """``name``, or ``name_1``, ``name_2``, ... the first not in ``taken``."""
    candidates = itertools.chain([name], (f'{name}_{n}' for n in itertools.count(1)))
    return next(candidate for candidate in candidates if candidate not in taken)


class SpawnServices:
    """SpawnEntity and DeleteEntity of ``node``, and the resets that undo edits.

    ``changed()`` is called after a spawn or a delete.
    """

    def __init__(self, node, editor, changed):
        self._node, self._editor, self._changed = node, editor, changed
        deferred.create_service(node, si_srv.SpawnEntity, '~/spawn_entity', self._on_spawn)
        deferred.create_service(node, si_srv.DeleteEntity, '~/delete_entity', self._on_delete)

    def _placement(self, request):
        """(origin, orientation, is_default) of ``initial_pose`` in world, or SpawnRefused."""
        stamped = request.initial_pose
        origin, orientation = conversions.pose_arrays(stamped.pose)
        default = not origin.any() and np.array_equal(orientation, [0.0, 0.0, 0.0, 1.0])
        try:
            frame = reference_frame(self._node, stamped.header.frame_id)
            if not np.all(np.isfinite(origin)):
                raise ValueError(f'non-finite position {origin.tolist()}')
            orientation = body_state.unit_quaternion(orientation)
        except KeyError as error:
            raise SpawnRefused('pose', f'initial_pose: {error.args[0]}') from None
        except ValueError as error:
            raise SpawnRefused('pose', f'initial_pose: {error}') from None
        if frame is not None:
            zero = np.zeros(3)
            origin, orientation, _, _ = body_state.seen_in_world(
                frame, (origin, orientation, zero, zero))
            default = False
        return origin, orientation, default

    def _spawn_builder(self, request):
        """Return the edit's build for ``request``, checking its name and pose now."""
        name = check_name(request.name) if request.name else None
        origin, orientation, default = self._placement(request)
        uri, text, renaming = request.uri, request.resource_string, request.allow_renaming
        settings = self._node.settings
        limits = settings.resource_limits   # the operator's, as for the scene
        if len(text) > limits['max_scene_bytes']:   # refused before any parser reads it
            raise SpawnRefused('parse', f'resource_string: {len(text)} characters, above '
                                        f'the limit of {limits["max_scene_bytes"]} bytes of '
                                        'a scene (parameter max_scene_bytes)')
        paths, roots = settings.resource_paths, allowed_roots(settings.resource_paths)

        def resolver(base_dir):
            return lambda mesh: find_resource(mesh, base_dir, roots, 'mesh', package_share)

        def body(entry, scene, base_dir, center_of_mass, where):
            taken = {body.name for body in scene.bodies}
            entry = {**entry, 'name': entity_name(entry.get('name'), name, renaming, taken)}
            return checked_body(entry, scene, base_dir, roots, center_of_mass, where)

        def from_uri(scene):
            path = scene_path(uri, paths)
            try:
                model = read_text(path, limits['max_scene_bytes'], 'uri file')
                kind = spawn_format(model, path.name)
            except FileRefused as refused:
                raise SpawnRefused('parse', f'uri: {refused.where}: {refused.reason}') from None
            except DescriptionRefused as refused:
                raise SpawnRefused(refused.kind, f'uri: {refused}') from None
            if kind != 'rigid_sim_yaml':
                entry, center = entry_from_model(model, kind, resolver(str(path.parent)), 'uri')
                return [body(entry, scene, str(path.parent), center, 'uri')], ()
            bodies, springs = bodies_from_file(path, roots, **limits)
            if len(bodies) != 1:
                raise SpawnRefused('parse', f'uri: the file has {len(bodies)} bodies; '
                                            'SpawnEntity spawns one entity (set the scene '
                                            'parameter to load a scene of several)')
            taken = {other.name for other in scene.bodies}
            return [replace(bodies[0], name=entity_name(bodies[0].name, name, renaming,
                                                        taken))], springs

        def from_text(scene):
            try:
                kind = spawn_format(text)
            except DescriptionRefused as refused:
                raise SpawnRefused(refused.kind, f'resource_string: {refused}') from None
            if kind == 'rigid_sim_yaml':
                made = body(entry_from_text(text, limits['max_scene_bytes']), scene, '.',
                            None, 'resource_string')
                return made if default else placed(made, origin, orientation)
            entry, center = entry_from_model(text, kind, resolver('.'))
            made = body(entry, scene, '.', center, 'resource_string')
            return placed(made, origin, orientation, compose=True)

        def build(scene):
            if uri:
                bodies, springs = from_uri(scene)
                bodies = [placed(made, origin, orientation, compose=True) for made in bodies]
            elif text:
                bodies, springs = [from_text(scene)], ()
            else:
                raise SpawnRefused('no_resource', 'give a uri or a resource_string')
            new = with_bodies(scene, bodies, springs)
            count = len(scene.bodies)
            return new, [(i, i) for i in range(count)], [made.name for made in bodies]
        return build

    def _on_spawn(self, request, response, reply):
        codes = si_srv.SpawnEntity.Response
        if request.entity_namespace:
            response.result = result(si_msg.Result.RESULT_FEATURE_UNSUPPORTED,
                                     'entity_namespace: a body\'s topics are ~/<name>/...; '
                                     'leave it empty')
            return response
        if self._too_many_pending(response):
            return response
        try:
            build = self._spawn_builder(request)
        except SpawnRefused as refused:
            response.result = result(getattr(codes, SPAWN_CODES[refused.kind]), str(refused))
            return response

        def done(outcome):
            if isinstance(outcome, SpawnRefused):
                response.result = result(getattr(codes, SPAWN_CODES[outcome.kind]),
                                         str(outcome))
            else:
                names = outcome[2]
                self._editor.spawned.extend(names)
                self._changed()
                response.entity_name = ','.join(names)
                response.result = result(si_msg.Result.RESULT_OK)
            reply(response)
        self._editor.submit(build, done)
        return deferred.LATER

    def _too_many_pending(self, response):
        """Refuse into ``response`` (and say so) when MAX_PENDING_EDITS edits wait already."""
        if self._node.owner.pending < MAX_PENDING_EDITS:
            return False
        reason = (f'{MAX_PENDING_EDITS} scene edits are pending, the most the node queues: '
                  'ask again once some are answered')
        response.result = result(si_msg.Result.RESULT_OPERATION_FAILED, reason)
        self._node.get_logger().warning(f'refused a scene edit: {reason}',
                                        throttle_duration_sec=2.0)
        return True

    def _on_delete(self, request, response, reply):
        Result = si_msg.Result
        entity, missing = request.entity, f'no entity {shown(request.entity)}'
        if self._too_many_pending(response):
            return response
        # With edits pending, the body may come or go before this one's turn: decided then.
        if entity not in self._node.world.bodies.names and not self._node.owner.busy:
            response.result = result(Result.RESULT_NOT_FOUND, missing)
            return response

        def build(scene):
            names = [body.name for body in scene.bodies]
            if entity not in names:
                raise SpawnRefused('not_found', missing)
            index = names.index(entity)
            new, dropped = without_body(scene, index)
            kept = [(i, i - (i > index)) for i in range(len(scene.bodies)) if i != index]
            return new, kept, f'{dropped} springs went with it' if dropped else ''

        def done(outcome):
            failed = isinstance(outcome, SpawnRefused)
            code = (Result.RESULT_NOT_FOUND if failed and outcome.kind == 'not_found'
                    else Result.RESULT_OPERATION_FAILED)
            response.result = (result(code, str(outcome)) if failed
                               else result(Result.RESULT_OK, outcome[2]))
            if not failed:
                self._changed()
            reply(response)
        self._editor.submit(build, done)
        return deferred.LATER

    def reset_scene(self, restore, remove_spawned, done):
        """Queue the scene part of a reset behind every edit asked before it; ``done(outcome)``.

        When its turn comes: with ``restore``, the scene as loaded before the first edit is
        put back if an edit made the running one; else with ``remove_spawned`` every
        spawned body still there is removed. ``done`` gets None when nothing was to change.
        """
        editor = self._editor

        def plan(scene):
            if restore and editor.edited:
                loaded = editor.loaded
                return lambda scene: (loaded, [], '')
            if remove_spawned and editor.edited and editor.spawned:   # not before a reload
                return _without(set(editor.spawned))
            return None
        editor.submit_planned(plan, done)


def _without(names):
    """Return an edit's build that removes the bodies named ``names``."""
    def build(scene):
        keep = [i for i, body in enumerate(scene.bodies) if body.name not in names]
        new, kept = scene, set(keep)
        for index in reversed(range(len(scene.bodies))):
            if index not in kept:
                new, _ = without_body(new, index)
        return new, list(zip(keep, range(len(keep)))), ''
    return build
