# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""simulation_interfaces' entity services: list bodies, read and set their states.

An entity is a body, named as in the scene. States are the body frame's, as the node
publishes them: its origin and orientation, the velocity of that origin and the angular
velocity, in ``world_frame`` (``header.frame_id`` empty or ``world_frame``) or, for
SetEntityState and a spawn's ``initial_pose``, relative to another entity's frame. A state
is set at once, between two ticks, so the answer means it is applied. Spawns and deletes are
in :mod:`rigid_sim.spawning`.
"""
import re

from rigid_sim import conversions, deferred
from rigid_sim.core import body_state
from rigid_sim.core.text import clipped, shown

from simulation_interfaces import msg as si_msg, srv as si_srv

# Characters of an answer's error_message: its outside text is quoted cut already.
MESSAGE_LIMIT = 1000


def result(code, message=''):
    """Return a simulation_interfaces/Result with ``code`` and ``message``."""
    return si_msg.Result(result=code, error_message=clipped(message, MESSAGE_LIMIT))


def reference_frame(node, frame_id):
    """Pose and twist of the frame ``frame_id`` names (None: the world), or KeyError.

    ``""`` and ``world_frame`` name the world; an entity's name, its body frame.
    """
    if frame_id in ('', node.settings.world_frame):
        return None
    names = node.world.bodies.names
    if frame_id not in names:
        raise KeyError(f'unknown frame {shown(frame_id)}: give {node.settings.world_frame!r}'
                       ', "" or an entity name')
    return body_state.body_frame_state(node.world.bodies, node.world.y,
                                       names.index(frame_id))


class EntityServices:
    """GetEntities, GetEntityState, GetEntitiesStates and SetEntityState of ``node``.

    ``changed()`` is called after a state is set.
    """

    def __init__(self, node, changed):
        self._node, self._changed = node, changed
        srv = si_srv
        for kind, name, callback in (
                (srv.GetEntities, 'get_entities', self._on_entities),
                (srv.GetEntityState, 'get_entity_state', self._on_state),
                (srv.GetEntitiesStates, 'get_entities_states', self._on_states),
                (srv.SetEntityState, 'set_entity_state', self._on_set_state)):
            deferred.create_service(node, kind, f'~/{name}', callback)

    def _index(self, name):
        """Scene index of entity ``name``, or None."""
        names = self._node.world.bodies.names
        return names.index(name) if name in names else None

    def _matching(self, filters):
        """Names passing ``filters`` (a name regex), or a (code, reason) refusal."""
        Result = si_msg.Result
        if filters.categories or filters.tags.tags or filters.bounds.type:
            return Result.RESULT_FEATURE_UNSUPPORTED, 'only the name filter is supported'
        try:
            pattern = re.compile(filters.filter)
        except re.error as error:
            return Result.RESULT_OPERATION_FAILED, f'filter {shown(filters.filter)}: {error}'
        return [name for name in self._node.world.bodies.names if pattern.search(name)]

    def _on_entities(self, request, response, reply):
        found = self._matching(request.filters)
        if isinstance(found, tuple):
            response.result = result(*found)
            return response
        response.entities = found
        response.result = result(si_msg.Result.RESULT_OK)
        return response

    def _state_message(self, index):
        world = self._node.world
        origin, orientation, velocity, angular = body_state.body_frame_state(
            world.bodies, world.y, index)
        state = si_msg.EntityState()
        state.header.frame_id = self._node.settings.world_frame
        state.header.stamp = conversions.to_time(world.time)
        conversions.fill_pose(state.pose, origin, orientation)
        conversions.fill_twist(state.twist, velocity, angular)
        return state

    def _on_state(self, request, response, reply):
        index = self._index(request.entity)
        if index is None:
            response.result = result(si_msg.Result.RESULT_NOT_FOUND,
                                     f'no entity {shown(request.entity)}')
            return response
        response.state = self._state_message(index)
        response.result = result(si_msg.Result.RESULT_OK)
        return response

    def _on_states(self, request, response, reply):
        response = self._on_entities(request, response, reply)   # no entity on a refusal
        response.states = [self._state_message(self._index(name)) for name in response.entities]
        return response

    def _on_set_state(self, request, response, reply):
        Result, node = si_msg.Result, self._node
        index = self._index(request.entity)
        state = request.state
        try:
            if index is None:
                raise KeyError(f'no entity {shown(request.entity)}')
            frame = reference_frame(node, state.header.frame_id)
        except KeyError as error:
            response.result = result(Result.RESULT_NOT_FOUND, error.args[0])
            return response
        origin, orientation = conversions.pose_arrays(state.pose)
        twist = (conversions.vector_array(state.twist.linear),
                 conversions.vector_array(state.twist.angular))
        world = node.world
        try:
            orientation = body_state.unit_quaternion(orientation)
            wanted = (origin, orientation) + twist
            if frame is not None:
                wanted = body_state.seen_in_world(frame, wanted)
            y = body_state.with_pose(world.bodies, world.y, index, *wanted[:2])
        except ValueError as error:
            response.result = result(response.INVALID_POSE, str(error))
            return response
        try:
            world.y = body_state.with_twist(world.bodies, y, index, *wanted[2:])
        except ValueError as error:
            response.result = result(Result.RESULT_OPERATION_FAILED, f'twist: {error}')
            return response
        self._changed()
        response.result = result(Result.RESULT_OK)
        return response
