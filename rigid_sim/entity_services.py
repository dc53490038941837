# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""simulation_interfaces' entity services: list bodies, read and set their states.

An entity is a body, named as in the scene. States are the body frame's, as the node
publishes them: its origin and orientation, the velocity of that origin and the angular
velocity, in ``world_frame`` (``header.frame_id`` empty or ``world_frame``) or, for
SetEntityState and a spawn's ``initial_pose``, relative to another entity's frame. A state
is set at once, between two ticks, so the answer means it is applied. Spawns and deletes are
in :mod:`rigid_sim.spawning`.

The name filter is a POSIX extended regular expression, as the standard says, matched by RE2:
its work is linear in the name's length whatever the pattern (no backtracking, so no pattern
can hold the executor), its memory is capped, and it speaks the POSIX classes
(``[[:alpha:]]``). GetEntities and GetEntitiesStates take one snapshot at the call (the
names, and every body frame in one vectorised pass), then match the names and build the
states' messages in slices of executor time and send a big answer from a thread, so a big
scene's answer never holds control up.
"""
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from time import perf_counter

from rclpy.clock import Clock, ClockType
try:
    import re2
except ImportError:   # a ROS install has no rosdep key for it: filters are refused, not run
    re2 = None

from rigid_sim import conversions, deferred
from rigid_sim.core import body_state
from rigid_sim.core.state import frame_rows
from rigid_sim.core.text import clipped, shown
from rigid_sim.tick_loop import SLICE

from simulation_interfaces import msg as si_msg, srv as si_srv

# Characters of an answer's error_message: its outside text is quoted cut already.
MESSAGE_LIMIT = 1000
# Characters of a name filter: a longer one is refused, never cut. A name pattern needs far
# fewer; this bounds the compile (RE2's is linear in the pattern) and the nesting.
FILTER_LIMIT = 1000
NO_RE2 = ('name filters need RE2 (linear-time POSIX regular expressions): pip install '
          'google-re2; an empty filter lists every entity')
# Bytes RE2 may use for one compiled filter (its default is 8 MiB): a bigger program is
# refused at compile, as RE2 refuses repetitions above 1000 in all (a{1000}{1000}).
FILTER_MEMORY = 1 << 20
# Answers too big for one slice that may be in the making or waiting to be sent at once; one
# more is refused before any work. Each holds a snapshot of every body (13 numbers each), and
# then its messages, until it is sent.
MAX_BUILDING = 4


def _filter_options():
    """RE2 options for POSIX extended syntax, leftmost-longest, ``^``/``$`` at the name's ends."""
    options = re2.Options()
    options.posix_syntax = True     # no Perl classes (\d, \b) or (?i): POSIX ERE
    options.longest_match = True
    options.one_line = True
    options.max_mem = FILTER_MEMORY
    options.log_errors = False      # the refusal says it; nothing on the node's stderr
    return options


def compiled_filter(text):
    """Return the compiled name filter ``text`` (a POSIX ERE), or ValueError saying why not."""
    if len(text) > FILTER_LIMIT:
        raise ValueError(f'filter of {len(text)} characters, above the limit of '
                         f'{FILTER_LIMIT}')
    try:
        return re2.compile(text, _filter_options())
    except re2.error as error:
        reason = error.args[0] if error.args else error
        if isinstance(reason, bytes):
            reason = reason.decode('utf-8', 'replace')
        raise ValueError(f'filter {shown(text)} is not a POSIX extended regular expression '
                         f'RE2 accepts: {clipped(str(reason), 200)}') from None


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


def entity_state(frame_id, stamp, origin, orientation, velocity, angular):
    """Return the EntityState of a body frame: pose and twist in ``frame_id`` at ``stamp``."""
    state = si_msg.EntityState()
    state.header.frame_id = frame_id
    state.header.stamp = stamp
    conversions.fill_pose(state.pose, origin, orientation)
    conversions.fill_twist(state.twist, velocity, angular)
    return state


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

        self._builds = SlicedBuilds(node)

    def close(self):
        """End the thread that sends big answers (the node is gone)."""
        self._builds.close()

    def _index(self, name):
        """Scene index of entity ``name``, or None."""
        names = self._node.world.bodies.names
        return names.index(name) if name in names else None

    def _pattern(self, filters):
        """Return the compiled name filter of ``filters`` (None: all), or a (code, reason)."""
        Result = si_msg.Result
        if filters.categories or filters.tags.tags or filters.bounds.type:
            return Result.RESULT_FEATURE_UNSUPPORTED, 'only the name filter is supported'
        if not filters.filter:
            return None
        if re2 is None:
            return Result.RESULT_FEATURE_UNSUPPORTED, NO_RE2
        try:
            return compiled_filter(filters.filter)
        except ValueError as error:
            return Result.RESULT_OPERATION_FAILED, str(error)

    def _answer(self, request, response, reply, with_states):
        """Start the answer of GetEntities (or GetEntitiesStates); the response or LATER."""
        pattern = self._pattern(request.filters)
        if isinstance(pattern, tuple):
            response.result = result(*pattern)     # no entity on a refusal
            return response
        if self._builds.full:
            response.result = result(si_msg.Result.RESULT_OPERATION_FAILED,
                                     self._builds.refusal())
            return response
        world = self._node.world
        # The snapshot: the names and, for states, every body frame at once, now.
        frames = frame_rows(world.bodies, world.y)[:, :13] if with_states else None
        limit = self._node.settings.max_answer_states if with_states else None
        answer = EntitiesAnswer(response, list(world.bodies.names), pattern, frames,
                                self._node.settings.world_frame, world.time, reply, limit)
        # Behind answers in the making it waits its turn, with no slice of its own now: a
        # burst of calls, each worked on for a slice as it came, held control for seconds.
        if self._builds.idle and answer.run(perf_counter() + SLICE):
            return response
        return self._builds.add(answer)

    def _on_entities(self, request, response, reply):
        return self._answer(request, response, reply, with_states=False)

    def _state_message(self, index):
        world = self._node.world
        origin, orientation, velocity, angular = body_state.body_frame_state(
            world.bodies, world.y, index)
        return entity_state(self._node.settings.world_frame, conversions.to_time(world.time),
                            origin, orientation, velocity, angular)

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
        return self._answer(request, response, reply, with_states=True)

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
        accel = state.acceleration
        if any(conversions.vector_array(part).any() for part in (accel.linear, accel.angular)):
            # An acceleration follows from the forces; a set one would be dropped silently.
            response.result = result(Result.RESULT_FEATURE_UNSUPPORTED,
                                     'acceleration: set by the forces, not settable; '
                                     'leave it zero')
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


class EntitiesAnswer:
    """One GetEntities or GetEntitiesStates answer, worked out from a snapshot, in slices.

    Parameters
    ----------
    response : GetEntities.Response or GetEntitiesStates.Response
        Filled (``entities``, ``states``, ``result``) and sent through ``reply`` when done.
    names : list of str
        Every entity's name, in scene order, at the call.
    pattern : compiled RE2 filter or None
        Names it finds a match in are kept; None keeps every name.
    frames : (N, 13) float or None
        Per body, its frame's origin (3), orientation (4, x, y, z, w), origin velocity (3)
        and angular velocity (3), world axes, at the call; None: no states asked.
    frame_id : str
        The world frame's name.
    time : float
        Simulated time of the snapshot, s.
    reply : deferred.Reply
        Sends the answer when it is built over several slices.
    limit : int or None
        Entities the answer may carry (None: any); more matches refuse it, saying how many.
    """

    # Names matched or messages built between two looks at the clock.
    CHUNK = 128

    def __init__(self, response, names, pattern, frames, frame_id, time, reply, limit=None):
        self._response, self._names, self._pattern, self._reply = response, names, pattern, reply
        self._limit = limit
        self._frames, self._frame_id, self._stamp = frames, frame_id, conversions.to_time(time)
        self._found = [] if pattern is not None else list(range(len(names)))
        self._looked = 0 if pattern is not None else len(names)
        self._states = []

    def run(self, until):
        """Work until ``perf_counter()`` passes ``until``; True when the answer is complete."""
        names, search = self._names, self._pattern and self._pattern.search
        while self._looked < len(names):
            end = self._looked + self.CHUNK
            self._found += [index for index in range(self._looked, min(end, len(names)))
                            if search(names[index])]
            self._looked = end
            if perf_counter() > until:
                return False
        if self._limit is not None and len(self._found) > self._limit:
            self._response.result = result(
                si_msg.Result.RESULT_OPERATION_FAILED,
                f'{len(self._found)} entities match, more than one answer may carry '
                f'(parameter max_answer_states = {self._limit}): narrow the filter')
            return True
        if self._frames is not None and not self._build_states(until):
            return False
        self._response.entities = [names[index] for index in self._found]
        self._response.result = result(si_msg.Result.RESULT_OK)
        return True

    def _build_states(self, until):
        """Build the states' messages until ``until``; True when all are built."""
        states, found = self._states, self._found
        while len(states) < len(found):
            for row in self._frames[found[len(states):len(states) + self.CHUNK]].tolist():
                states.append(entity_state(self._frame_id, self._stamp, row[0:3], row[3:7],
                                           row[7:10], row[10:13]))
            if len(states) < len(found) and perf_counter() > until:
                return False
        self._response.states = states
        return True

    def send(self, sender):
        """Have ``sender`` (a one-thread pool) send the answer; its future.

        rclpy converts a message to C holding the interpreter throughout (2000 states: 16 ms
        on the quiet machine, seconds for 20 000 under load). From a thread of its own the
        executor's thread takes its turns at least between two answers; that is why few
        may wait to be sent (MAX_BUILDING).
        """
        return sender.submit(self._reply, self._response)


class SlicedBuilds:
    """Runs answers too big for one slice, a ``SLICE`` of executor time per round, in order.

    Between two slices the executor answers everything else (control, parameters, signals),
    as between the tick loop's slices. Built answers are sent one after another by one
    thread: a thread each (300 answers of 2000 states at once) took the interpreter in turn
    with the executor's thread, and held a parameter call for 1.5 s.
    """

    def __init__(self, node):
        self._queue = deque()
        self._sending = []
        self._sender = ThreadPoolExecutor(max_workers=1, thread_name_prefix='entities answer')
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self._timer = node.create_timer(0.0, self._on_timer, clock=steady)
        self._timer.cancel()

    def close(self):
        """End the sending thread once the answers in hand are sent (the node is gone)."""
        self._sender.shutdown(wait=False, cancel_futures=True)

    @property
    def idle(self):
        """Return whether no answer is in the making."""
        return not self._queue

    def _held(self):
        """Return how many answers are in the making or not yet sent."""
        self._sending = [future for future in self._sending if not future.done()]
        return len(self._queue) + len(self._sending)

    @property
    def full(self):
        """Return whether MAX_BUILDING answers are in the making or unsent: one more is refused.

        A client that kept asking queued them without end: 300 answers of 2000 states at
        once grew the node by 290 MB.
        """
        return self._held() >= MAX_BUILDING

    def refusal(self):
        """Return why a call is refused while the queue is full."""
        return (f'{self._held()} answers are being built or sent, at most {MAX_BUILDING} at '
                'once: ask again when one is sent')

    def add(self, build):
        """Queue ``build`` (an :class:`EntitiesAnswer`); LATER, its callback's answer."""
        self._queue.append(build)
        self._timer.reset()
        return deferred.LATER

    def _on_timer(self):
        until = perf_counter() + SLICE
        while self._queue and perf_counter() < until:
            if not self._queue[0].run(until):
                return
            self._sending.append(self._queue.popleft().send(self._sender))
        if not self._queue:
            self._timer.cancel()
