# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The node's parameters: names, descriptors, defaults and the checks that refuse bad values.

Every parameter is declared with ``dynamic_typing`` so that a numeric one accepts an integer
literal (``-p rate:=100``, ``ros2 param set ... rate 100``): rclpy 7 refuses an integer for a
parameter declared as double. The type and range are then checked here, for start-up and
runtime values alike (at runtime rclpy checks the range of a double first, in its own words).
"""
import math
import os
import re
from dataclasses import dataclass, replace

from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

from rigid_sim.core.integrators import DEFAULT_INTEGRATOR, REGISTRY
from rigid_sim.core.scene_limits import RESOURCE_LIMITS
from rigid_sim.core.text import shown
from rigid_sim.resources import DEFAULT_RESOURCE_PATHS, DEFAULT_SCENE

MAX_RATE = 1000.0  # Hz; a 1 kHz timer alone already jitters by 5 % (docs/ros_notes.md)
# Hz; one tick at least every 1000 s keeps the timer period and the diagnostics meaningful.
# Rate 0 is apart: it means no wall clock at all.
MIN_RATE = 1e-3
# s; a ROS stamp counts nanoseconds, so a shorter step would not advance /clock at all.
MIN_TIME_STEP = 1e-9
# World steps per tick (the `substeps` parameter): a tick's work grows with them, and above
# this one tick of one body takes longer than the fastest tick period (the step guard's own
# splitting of each World step is bounded apart, by safeguards.MAX_SUBSTEPS).
MAX_STEPS_PER_TICK = 1000
# Below float64 round-off an adaptive integrator can only shrink its steps forever.
MIN_TOLERANCE = 1e-12
# Each subscription and publisher slows every executor round (docs/performance.md): a
# scene larger than this makes its per-body topics only when someone uses them.
PER_BODY_TOPICS_LIMIT = 100
# States of one GetEntitiesStates answer: rclpy converts 2000 in ~20 ms (docs/ros_notes.md).
MAX_ANSWER_STATES = 2000
MAX_PATH = 4096  # characters of a scene path, the Linux PATH_MAX
MAX_RESOURCE_PATHS = 64  # directories in resource_paths; each is searched for a relative name
# A frame id: name tokens joined by '/', as tf2 and RViz take them, and not too long to quote.
FRAME_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*\Z')
# A frame prefix: the same name tokens, each followed by '/' (the last '/' may be left out:
# 'sim' makes 'simbox'), so that every prefixed frame is a frame name as well.
FRAME_PREFIX = r'([A-Za-z_][A-Za-z0-9_]*/)*([A-Za-z_][A-Za-z0-9_]*)?'
MAX_FRAME_NAME = 100
# The operator's resource limits have no ceiling of their own (the operator raises them,
# knowing the machine); this one is only what an int64 parameter and a float carry exactly.
MAX_RESOURCE_LIMIT = 1 << 53
MAX_STEP_TICKS = 10000  # one ~/step call blocks the executor for this many ticks at most
# With rate 0 (no wall clock), time_step and publish_rate default to those of this rate.
UNTIMED_DEFAULT_RATE = 100.0
# Parameters rclpy declares on every node; an override of these is not a misspelling.
NODE_BUILTINS = ('use_sim_time', 'start_type_description_service', 'qos_overrides')


class ParameterError(ValueError):
    """A parameter value the node refuses; the message names the parameter and the reason."""


@dataclass(frozen=True)
class Settings:
    """Validated parameter values, as the node uses them."""

    scene: str             # a path; a bare name: working dir, then config/, config/scenes/
    # Directories files may be read from besides the packaged config/ (read at start only).
    resource_paths: tuple
    rate: float            # Hz of wall time, ticks per second
    time_step: float       # s of simulated time advanced per tick
    substeps: int          # integrator steps per tick
    publish_rate: float    # Hz of wall time at which outputs go out
    integrator: str        # a name in rigid_sim.core.integrators.REGISTRY
    tolerance: float       # largest local error estimate a step keeps; dopri5's target
    error_control: bool    # split steps whose error estimate exceeds tolerance
    wrench_timeout: float  # s of simulated time a wrench is held; 0 holds until replaced
    world_frame: str       # frame_id of the fixed frame
    publish_clock: bool    # publish /clock
    start_paused: bool     # integration paused at start
    step_ticks: int        # ticks one ~/step call advances
    frame_prefix: str      # prefixed to every body and point frame
    per_body_topics_limit: int  # up to this many bodies, every per-body topic exists at start
    # The operator's resource limits of a scene load (rigid_sim.core.scene_limits).
    max_scene_bytes: int   # bytes of the scene file
    max_bodies: int        # bodies of a scene
    max_samples: int       # inertia samples of all bodies together
    max_mesh_bytes: int    # bytes of all distinct mesh files together
    max_mesh_faces: int    # faces of one mesh
    max_points: int        # named points of all bodies together
    goal_horizon: float    # s of simulated time to a ~/<body>/goal stamped zero or in the past
    max_answer_states: int  # states one GetEntitiesStates answer may carry

    @property
    def resource_limits(self):
        """Return the operator's limits, as :func:`rigid_sim.core.scene.load_scene` takes them."""
        return {name: getattr(self, name) for name in RESOURCE_LIMITS}

    @property
    def publish_every(self):
        """Ticks between two publications, at least 1.

        ``round(rate / publish_rate)``; with ``rate`` 0 there is no wall clock and
        ``publish_rate`` counts in simulated time: ``round(1 / (publish_rate time_step))``.
        """
        per_second = self.rate if self.rate > 0.0 else 1.0 / self.time_step
        return max(1, round(per_second / self.publish_rate))

    @property
    def real_time_factor(self):
        """Return the simulated seconds per wall second the loop aims at; None at rate 0."""
        return self.rate * self.time_step if self.rate > 0.0 else None


@dataclass(frozen=True)
class Spec:
    """How one parameter is declared and checked."""

    kind: type         # float, int, str, bool or tuple (of str: a string array)
    description: str
    low: float = None  # inclusive bounds of a numeric parameter
    high: float = None
    # A text parameter must match this regular expression in full (None: any non-empty
    # text); pattern_meaning says in words what it matches.
    pattern: str = None
    pattern_meaning: str = ''


SPECS = {
    'scene': Spec(str, 'scene YAML file; a bare name is looked up in the working directory, '
                       'then in share/rigid_sim/config and its scenes/'),
    'resource_paths': Spec(tuple, 'directories whose files (scenes, SpawnEntity uris, meshes) '
                                  'may be read, besides the packaged config/ (default: the '
                                  'working directory and the directory of the scene given at '
                                  'start); any other file is refused unopened; read at start '
                                  'only'),
    'rate': Spec(float, 'ticks per second of wall time, Hz; 0: no wall clock, tick as fast '
                        'as the CPU allows', 0.0, MAX_RATE),
    'time_step': Spec(float, 'simulated seconds per tick (default 1/rate at start, '
                             f'1/{UNTIMED_DEFAULT_RATE:g} with rate 0; a later change of rate '
                             'keeps it); time_step x rate is the real-time factor',
                      MIN_TIME_STEP, 10.0),
    'substeps': Spec(int, 'integrator steps per tick', 1, MAX_STEPS_PER_TICK),
    'publish_rate': Spec(float, 'Hz of wall time at which pose, twist, odometry, PoseArray '
                                'and markers go out (default rate at start): every '
                                'round(rate / publish_rate)-th tick, at most once per tick; '
                                'with rate 0, Hz of simulated time',
                         MIN_RATE, MAX_RATE),
    'integrator': Spec(str, f'integration method, one of {sorted(REGISTRY)}'),
    'tolerance': Spec(float, 'largest local error estimate a step may keep, relative to each '
                             "body's size and momenta (README: error estimates); dopri5's "
                             'target', MIN_TOLERANCE, 1.0),
    'error_control': Spec(bool, 'split steps whose error estimate exceeds tolerance, and give '
                                'the substeps back when it allows; false: fixed steps, as '
                                'studies of the methods need'),
    'wrench_timeout': Spec(float, 'seconds of simulated time a wrench is held after its '
                                  'message; 0 holds it until replaced', 0.0, 1.0e9),
    'world_frame': Spec(str, 'frame_id of the fixed frame of all published poses: name '
                             'tokens (letters, digits, _) joined by /'),
    'publish_clock': Spec(bool, 'publish /clock so other nodes can run on simulated time'),
    'start_paused': Spec(bool, 'start with integration paused (read at start only)'),
    'step_ticks': Spec(int, 'ticks that one ~/step call advances', 1, MAX_STEP_TICKS),
    'frame_prefix': Spec(str, 'prefixed to every body and point frame in messages and tf '
                              '(e.g. sim1/), for several simulators on one graph',
                         pattern=FRAME_PREFIX,
                         pattern_meaning='name tokens (letters, digits and _, not starting '
                                         'with a digit) each followed by /'),
    'per_body_topics_limit': Spec(int, 'a scene of at most this many bodies has every '
                                       "body's pose, twist, odom and wrench topic from the "
                                       'start; in a larger one each is made once a '
                                       'subscriber (wrench: a publisher) appears on it; read '
                                       'when a scene is loaded', 0, 1_000_000),
    **{name: Spec(int, f'{what}; a scene file may lower it in its limits:, never raise it; '
                       'read when a scene is loaded', 1, MAX_RESOURCE_LIMIT)
       for name, what in (
           ('max_scene_bytes', 'bytes a scene file may have at most'),
           ('max_bodies', 'bodies a scene may have at most'),
           ('max_samples', 'inertia samples all bodies of a scene may draw together'),
           ('max_mesh_bytes', 'bytes of all distinct mesh files of a scene together'),
           ('max_mesh_faces', 'faces of one mesh at most'),
           ('max_points', 'named points of all bodies of a scene together'))},
    'goal_horizon': Spec(float, 'seconds of simulated time from now to a ~/<body>/goal whose '
                                'stamp is zero or not in the future', 1e-6, 1.0e4),
    'max_answer_states': Spec(int, 'states one GetEntitiesStates answer may carry; a filter '
                                   'matching more is refused, naming the count (rclpy turns '
                                   'an answer into its C message in one call that holds the '
                                   'interpreter, ~10 us a state, during which the node '
                                   'answers nothing else)', 1, MAX_RESOURCE_LIMIT),
}


# The operator's resource limits. Anyone on the graph may set parameters, so at runtime they
# may be lowered, and raised again up to their value at start, never above it: a client
# that raised max_samples could make one spawned body sample for minutes and take gigabytes.
OPERATOR_LIMITS = ('per_body_topics_limit', *RESOURCE_LIMITS, 'max_answer_states')


def descriptor(name):
    """Return the ParameterDescriptor of parameter ``name``: description, type note and range."""
    spec = SPECS[name]
    numeric = ' (integer literals accepted)' if spec.kind is float else ''
    kind = 'string array' if spec.kind is tuple else spec.kind.__name__
    result = ParameterDescriptor(
        name=name, description=spec.description, dynamic_typing=True,
        read_only=spec.kind is tuple,
        additional_constraints=f'type {kind}{numeric}')
    if spec.kind is float:
        result.floating_point_range = [FloatingPointRange(from_value=float(spec.low),
                                                          to_value=float(spec.high))]
    elif spec.kind is int:
        result.integer_range = [IntegerRange(from_value=spec.low, to_value=spec.high, step=1)]
    return result


def coerce(name, value):
    """``value`` as parameter ``name`` takes it, or ParameterError saying why not."""
    spec = SPECS[name]
    # bool is an int in Python; a flag given for a number is a mistake, not 1 or 0.
    if spec.kind in (int, float) and (isinstance(value, bool) or
                                      not isinstance(value, (int, float))):
        raise ParameterError(f'parameter {name!r}: expected a number, got {shown(value)}')
    if spec.kind is int and not isinstance(value, int):
        raise ParameterError(f'parameter {name!r}: expected an integer, got {shown(value)}')
    if spec.kind is tuple:
        return _directories(name, value)
    if spec.kind in (str, bool) and not isinstance(value, spec.kind):
        raise ParameterError(
            f'parameter {name!r}: expected a {spec.kind.__name__}, got {shown(value)}')
    if spec.low is not None:
        _check_range(name, spec, value)
    if spec.pattern is not None:
        if len(value) > MAX_FRAME_NAME or not re.fullmatch(spec.pattern, value):
            raise ParameterError(f'parameter {name!r}: expected {spec.pattern_meaning}, at '
                                 f'most {MAX_FRAME_NAME} characters, got {shown(value)}')
    elif spec.kind is str:
        _check_text(name, value)
    return spec.kind(value)


def _check_range(name, spec, value):
    if not (math.isfinite(value) and spec.low <= value <= spec.high):
        raise ParameterError(f'parameter {name!r}: {value!r} outside the range '
                             f'[{spec.low:g}, {spec.high:g}]')
    if name == 'rate' and 0.0 < value < MIN_RATE:
        raise ParameterError(f'parameter {name!r}: {value!r} outside the range '
                             f'[{MIN_RATE:g}, {spec.high:g}]: neither 0 (no wall clock) nor '
                             f'at least {MIN_RATE:g} Hz')


def _check_text(name, value):
    if not value.strip():
        raise ParameterError(f'parameter {name!r}: must not be empty')
    if name == 'world_frame' and not (len(value) <= MAX_FRAME_NAME
                                      and FRAME_NAME.match(value)):
        raise ParameterError(f'parameter {name!r}: {shown(value)} is no frame name: name '
                             'tokens (letters, digits and _, not starting with a digit) '
                             f'joined by /, at most {MAX_FRAME_NAME} characters')
    if name == 'scene' and (len(value) > MAX_PATH or '\0' in value):
        raise ParameterError(f'parameter {name!r}: {shown(value)} is no file path (at most '
                             f'{MAX_PATH} characters, no NUL)')


def _directories(name, value):
    """Return a list of directory paths as a tuple, or raise ParameterError."""
    if isinstance(value, str) or not isinstance(value, (list, tuple)) \
            or not all(isinstance(item, str) for item in value):
        raise ParameterError(f'parameter {name!r}: expected a list of directory paths '
                             f'(strings), got {shown(value)}')
    if len(value) > MAX_RESOURCE_PATHS:
        raise ParameterError(f'parameter {name!r}: {len(value)} directories, more than '
                             f'{MAX_RESOURCE_PATHS}')
    for item in value:
        if not item.strip() or len(item) > MAX_PATH or '\0' in item:
            raise ParameterError(f'parameter {name!r}: {shown(item)} is no directory path '
                                 f'(not empty, at most {MAX_PATH} characters, no NUL)')
    return tuple(value)


def _check_integrator(name):
    if name not in REGISTRY:
        raise ParameterError(
            f"parameter 'integrator': unknown integrator {shown(name)}; "
            f'valid: {sorted(REGISTRY)}')


def declare(node):
    """Declare every parameter on ``node`` and return the validated Settings.

    ``time_step`` defaults to ``1 / rate`` and ``publish_rate`` to ``rate`` (with ``rate``
    0, to those of ``UNTIMED_DEFAULT_RATE``), so ``rate`` is
    read before they are declared.

    Raises
    ------
    ParameterError
        For a refused value, or an override that names no parameter of this node.
    """
    _check_unknown_overrides(node)
    values = {}
    defaults = {'scene': DEFAULT_SCENE, 'rate': 100.0, 'substeps': 1,
                'integrator': DEFAULT_INTEGRATOR, 'tolerance': 1.0e-6, 'error_control': True,
                'wrench_timeout': 0.5,
                'world_frame': 'world', 'publish_clock': True, 'start_paused': False,
                'step_ticks': 1, 'frame_prefix': '',
                'per_body_topics_limit': PER_BODY_TOPICS_LIMIT, **RESOURCE_LIMITS,
                'goal_horizon': 2.0, 'max_answer_states': MAX_ANSWER_STATES}
    for name in SPECS:
        if name == 'resource_paths':   # the operator chose the start scene's directory
            start_folder = os.path.dirname(values['scene'])
            defaults[name] = list(DEFAULT_RESOURCE_PATHS) + ([start_folder] if start_folder
                                                             else [])
        elif name == 'time_step':
            defaults[name] = 1.0 / (values['rate'] or UNTIMED_DEFAULT_RATE)
        elif name == 'publish_rate':
            defaults[name] = values['rate'] or UNTIMED_DEFAULT_RATE
        # Checked here before rclpy sees it, so a refusal at start gives the same reason
        # as at runtime; the declared value is the coerced one (50.0 for -p rate:=50).
        override = node._parameter_overrides.get(name)
        values[name] = coerce(name, defaults[name] if override is None else override.value)
        declared = list(values[name]) if SPECS[name].kind is tuple else values[name]
        node.declare_parameter(name, declared, descriptor(name), ignore_override=True)
    _check_integrator(values['integrator'])
    return Settings(**values)


def _check_unknown_overrides(node):
    # rclpy keeps the overrides of --params-file and -p only in this attribute (also read
    # by declare); without the check a misspelt name is silently ignored (docs/ros_notes.md).
    unknown = sorted(set(node._parameter_overrides) - set(SPECS) - set(NODE_BUILTINS))
    unknown = [name for name in unknown if not name.startswith('qos_overrides.')]
    if unknown:
        raise ParameterError(f'unknown parameter(s) {shown(unknown)}; '
                             f'this node has {sorted(SPECS)}')


def updated(settings, changes, at_start):
    """Return the settings with ``changes`` (rclpy Parameters) applied.

    Raises ParameterError saying why a change is refused. ``at_start`` are the settings the
    node started with: the operator's, the ceiling of its resource limits.

    Parameters that are not this node's own (``use_sim_time``) are passed over.
    """
    values = {change.name: coerce(change.name, change.value)
              for change in changes if change.name in SPECS}
    if values.get('resource_paths', settings.resource_paths) != settings.resource_paths:
        raise ParameterError("parameter 'resource_paths': read at start only; a client may "
                             'not widen what files the node reads')
    for name in OPERATOR_LIMITS:
        ceiling = getattr(at_start, name)
        if values.get(name, ceiling) > ceiling:
            raise ParameterError(
                f"parameter '{name}': {values[name]} is above {ceiling}, its value at start: "
                "a client may lower the node's resource limits, never raise them above the "
                "operator's")
    if values.get('start_paused', settings.start_paused) != settings.start_paused:
        raise ParameterError("parameter 'start_paused': read at start only; call ~/pause to "
                             'pause or resume the running node')
    if 'integrator' in values:
        _check_integrator(values['integrator'])
    return replace(settings, **values)
