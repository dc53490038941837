# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Parameters: declared defaults, integer literals, refusals at start and at runtime.

A refused value at start raises ParameterError (the executable turns it into a message and
exit status 1, see test_process.py); at runtime it is refused with a reason and the node
keeps running with its previous values.
"""
import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from rclpy.parameter import Parameter

import ros_tools
from rigid_sim.core.scene import SceneError
from rigid_sim.core.scene_limits import WORK_LIMITS
from rigid_sim.node import RigidSimNode
from rigid_sim.parameters import SPECS, ParameterError

SHIPPED_PARAMETERS = Path(__file__).resolve().parents[1] / 'config' / 'rigid_sim.yaml'
SCENE = """
bodies:
  - name: box
    shape: {type: box, size: [0.4, 0.2, 0.1]}
    mass: 2.0
    twist: {linear: [1.0, 0.0, 0.0]}
"""
OTHER_SCENE = """
bodies:
  - name: puck
    shape: {type: cylinder, radius: 0.1, length: 0.05}
    mass: 0.5
    pose: {position: [0.0, 0.0, 2.0]}
"""
MALFORMED_SCENE = """
bodies:
  - name: box
    shape: {type: box, size: [0.4, 0.2]}
    mass: 2.0
"""


def clock_nanoseconds(probe):
    return [m.clock.sec * 10 ** 9 + m.clock.nanosec for m in probe.heard['/clock']]


def test_integer_literals_accepted_and_time_step_defaults_to_one_over_rate(
        ros_context, write_scene):
    """-p rate:=50 (an integer) is 50 Hz; time_step = 1/rate keeps the real-time factor 1."""
    node = RigidSimNode(context=ros_context, cli_args=[
        '--ros-args', '-p', 'rate:=50', '-p', 'wrench_timeout:=2', '-p', 'tolerance:=1',
        '-p', f'scene:={write_scene(SCENE)}'])
    settings = node.settings
    assert (settings.rate, settings.wrench_timeout, settings.tolerance) == (50.0, 2.0, 1.0)
    assert settings.time_step == 1 / 50 and settings.publish_rate == 50.0
    assert node.loop.timer.timer_period_ns == 20_000_000
    node.destroy_node()


def test_clock_advances_by_time_step_per_tick(rigid_sim):
    """/clock and every stamp advance by time_step per tick, whatever the substeps."""
    sim = rigid_sim(yaml=SCENE, rate=50, substeps=4)
    probe = ros_tools.Probe(sim, 'box')
    sim.step(5)
    steps = np.diff([0] + clock_nanoseconds(probe))
    np.testing.assert_allclose(steps, 2 * 10 ** 7, atol=1)
    assert probe.latest('box/pose').header.stamp == probe.latest('/clock').clock


def test_outputs_go_out_at_publish_rate_while_physics_ticks_at_rate(rigid_sim):
    """At rate 100 Hz and publish_rate 25 Hz: one state message per 4 ticks, /clock every tick."""
    sim = rigid_sim(yaml=SCENE, rate=100.0, publish_rate=25.0, time_step=0.125)
    probe = ros_tools.Probe(sim, 'box')
    sim.step(8)
    assert len(probe.heard['/clock']) == 8
    assert probe.stamps('box/pose') == [0.125, 0.625]
    assert len(probe.heard['poses']) == 2


@pytest.mark.parametrize('name, value, reason', [
    ('rate', -1.0, 'outside the range'), ('rate', 'fast', 'expected a number'),
    ('rate', True, 'expected a number'), ('time_step', 0.0, 'outside the range'),
    ('substeps', 0, 'outside the range'), ('substeps', 2.5, 'expected an integer'),
    ('publish_rate', float('nan'), 'outside the range'),
    ('integrator', 'leapfrog', 'unknown integrator'), ('tolerance', 0, 'outside the range'),
    ('wrench_timeout', -0.1, 'outside the range'), ('world_frame', ' ', 'must not be empty'),
    ('publish_clock', 'yes', 'expected a bool'),
    ('frame_prefix', '1/', 'not starting with a digit'), ('frame_prefix', 'sim/2b/', 'name '),
    ('max_bodies', 0, 'outside the range'), ('max_samples', 2.5, 'expected an integer'),
    ('max_scene_bytes', -1, 'outside the range'),
])
def test_bad_value_at_start_is_refused_naming_parameter_and_reason(
        ros_context, write_scene, name, value, reason):
    """A value outside a parameter's type or range stops the node before it simulates."""
    overrides = [Parameter('scene', value=write_scene(SCENE)), Parameter(name, value=value)]
    with pytest.raises(ParameterError, match=f"parameter '{name}'.*{reason}"):
        RigidSimNode(context=ros_context, parameter_overrides=overrides)


def test_world_frame_naming_a_body_is_refused_at_start(ros_context, write_scene):
    """world_frame 'box' would make a wrench with frame_id 'box' both world and body axes."""
    overrides = [Parameter('scene', value=write_scene(SCENE)), Parameter('world_frame',
                                                                         value='box')]
    with pytest.raises(ParameterError, match="world_frame: world_frame 'box' is a frame of "
                                             "body 'box'"):
        RigidSimNode(context=ros_context, parameter_overrides=overrides)


def test_misspelt_parameter_in_params_file_is_refused(ros_context, write_scene, tmp_path):
    """A params-file key that names no parameter (rat for rate) is refused, not ignored."""
    params = tmp_path / 'params.yaml'
    params.write_text(yaml.safe_dump({'/**': {'ros__parameters': {
        'scene': write_scene(SCENE), 'rat': 200.0}}}))
    with pytest.raises(ParameterError, match=r"unknown parameter\(s\) \['rat'\]"):
        RigidSimNode(context=ros_context, cli_args=['--ros-args', '--params-file', str(params)])


def test_shipped_parameter_file_lists_every_parameter_at_its_default(ros_context):
    """Check config/rigid_sim.yaml names each parameter once, at its default value.

    The two that follow rate (time_step = 1/rate, publish_rate = rate) are only named in a
    comment: the file with -p rate:=50 still runs at real-time factor 1, 50 Hz outputs; so is
    resource_paths, which follows the scene (its directory is allowed).
    """
    text = SHIPPED_PARAMETERS.read_text()
    listed = yaml.safe_load(text)['/**']['ros__parameters']
    follow = {'time_step', 'publish_rate', 'resource_paths'}
    assert sorted(listed) == sorted(set(SPECS) - follow)
    assert all(f'# {name}:' in text for name in follow)
    for rate in ([], ['-p', 'rate:=50']):
        with_file = RigidSimNode(context=ros_context, cli_args=[
            '--ros-args', '--params-file', str(SHIPPED_PARAMETERS), *rate])
        without_file = RigidSimNode(context=ros_context, cli_args=['--ros-args', *rate])
        assert with_file.settings == without_file.settings
        with_file.destroy_node()
        without_file.destroy_node()
    assert with_file.settings.real_time_factor == 1.0
    assert (with_file.settings.rate, with_file.settings.publish_rate) == (50.0, 50.0)


def test_refused_runtime_values_leave_the_node_running_unchanged(rigid_sim, write_scene):
    """ros2 param set with a bad value or a malformed scene.

    Refused with the reason, and the node keeps simulating its scene with its previous settings.
    """
    sim = rigid_sim(yaml=SCENE, time_step=0.125)
    probe = ros_tools.Probe(sim, 'box')
    before = sim.node.settings
    rate, = sim.set_parameters(rate=-5.0)
    assert not rate.successful and 'rate' in rate.reason
    integrator, = sim.set_parameters(integrator='leapfrog')
    assert not integrator.successful and 'rk4' in integrator.reason
    malformed = write_scene(MALFORMED_SCENE, 'malformed.yaml')
    assert sim.set_parameters(scene=malformed)[0].successful   # loaded beside, then refused
    refusal = probe.diagnostics.values()['last refused change']
    assert malformed in refusal and 'bodies[0].shape.size' in refusal
    assert 'list of 3 numbers' in refusal
    assert sim.node.get_parameter('scene').value == before.scene   # set back
    frame, = sim.set_parameters(world_frame='box')
    assert not frame.successful and "is a frame of body 'box'" in frame.reason
    assert sim.node.settings == before and sim.node.get_parameter('rate').value == before.rate
    sim.step(8)
    position, _, velocity, _, t = probe.state('box')
    assert t == 1.0 and position[0] == pytest.approx(1.0) and velocity[0] == 1.0


# (name, value, reason): hostile values a runtime change must refuse, and the reason given.
HOSTILE = [
    ('world_frame', 'bad frame!', 'no frame name'), ('world_frame', 'w' * 100_000, 'no frame'),
    ('time_step', 1e-300, 'outside the range'), ('substeps', 10_000, 'outside the range'),
    ('rate', 1e-300, 'at least 0.001 Hz'), ('publish_rate', 1e-300, 'outside the range'),
    ('tolerance', 1e-300, 'outside the range'), ('scene', 's' * 100_000, 'no file path'),
    ('scene', 'a\0b', 'no file path'), ('integrator', 'x' * 100_000, 'unknown integrator')]


@pytest.mark.parametrize('name, value, reason', HOSTILE,
                         ids=[f'{n}-{str(v)[:12]}'
                              for n, v, _ in HOSTILE])
def test_hostile_value_is_refused_at_start_with_a_short_reason(
        ros_context, write_scene, name, value, reason):
    """Bounds hold at start as at runtime, and a huge value is quoted by its ends only."""
    overrides = [Parameter('scene', value=write_scene(SCENE)), Parameter(name, value=value)]
    with pytest.raises(ParameterError, match=f"parameter '{name}'.*{reason}") as refusal:
        RigidSimNode(context=ros_context, parameter_overrides=overrides)
    assert len(str(refusal.value)) < 1000


def test_hostile_runtime_values_are_refused_and_the_clock_keeps_advancing(rigid_sim):
    """Each is refused with its reason, quoted short, and the node runs on unchanged."""
    sim = rigid_sim(yaml=SCENE, time_step=0.125)
    probe = ros_tools.Probe(sim)
    before = sim.node.settings
    for name, value, reason in HOSTILE:
        result, = sim.set_parameters(**{name: value})
        assert not result.successful, name
        assert len(result.reason) < 1000 and (reason in result.reason or 'range' in
                                              result.reason), result.reason
    assert sim.node.settings == before
    sim.step(8)
    assert clock_nanoseconds(probe)[-1] == 1_000_000_000


def test_runtime_changes_take_effect(rigid_sim, write_scene):
    """Accepted changes apply at once.

    ``rate`` (an integer literal) sets the timer period, ``world_frame`` the stamps' frame,
    ``integrator`` the method, ``scene`` a new world at time 0.
    """
    sim = rigid_sim(yaml=SCENE, time_step=0.125)
    probe = ros_tools.Probe(sim, 'box', 'puck')
    sim.step(2)
    assert all(r.successful for r in sim.set_parameters(rate=20, world_frame='map',
                                                        integrator='euler'))
    assert sim.node.loop.timer.timer_period_ns == 50_000_000
    assert sim.node.world.integrator.name == 'euler'
    sim.step(1)
    assert probe.latest('box/odom').header.frame_id == 'map'
    assert probe.state('box')[4] == 0.375  # the integrator changed, not the state or time
    result, = sim.set_parameters(scene=write_scene(OTHER_SCENE, 'other.yaml'))
    assert result.successful
    assert [body.name for body in sim.node.scene.bodies] == ['puck']
    sim.step(1)
    position, _, _, _, t = probe.state('puck')
    assert t == 0.125 and position.tolist() == [0.0, 0.0, 2.0]


def test_hostile_scene_files_at_runtime_are_refused_naming_file_and_reason(
        rigid_sim, write_scene, tmp_path):
    """Refuse each hostile scene naming the file, and run the old scene on.

    Each of these once stopped the node: a RecursionError, a 1e12-sample array, a read of
    /dev/zero.
    """
    sim = rigid_sim(yaml=SCENE, time_step=0.125)
    probe = ros_tools.Probe(sim, 'box')
    sampled = SCENE.replace('mass: 2.0', 'mass: 2.0\n    inertia: {method: sampling, '
                                         'samples: 1000000000000}')
    (tmp_path / 'latin1.yaml').write_bytes(SCENE.encode() + b'# caf\xe9\n')
    fifo = tmp_path / 'pipe.yaml'
    os.mkfifo(fifo)
    for path, reason in [(write_scene('bodies: ' + '[' * 100_000, 'deep.yaml'), 'nest'),
                         (write_scene(sampled, 'sampled.yaml'), 'above the limit'),
                         (str(tmp_path / 'latin1.yaml'), 'not UTF-8'),
                         (str(fifo), 'not a regular file'), ('/dev/zero', 'not a regular'),
                         (str(tmp_path), 'not a regular file')]:
        assert sim.set_parameters(scene=path)[0].successful   # loaded beside, then refused
        refusal = sim.node.reconfiguration.last_refusal
        assert path in refusal and reason in refusal, refusal
        assert sim.node.get_parameter('scene').value == sim.node.settings.scene != path
    sim.step(8)
    position, _, velocity, _, t = probe.state('box')
    assert t == 1.0 and position[0] == pytest.approx(1.0) and velocity[0] == 1.0


# 150 bytes asking for 1e8 samples (~45 s and 9.6 GB) in its own limits: block.
GREEDY = ('limits: {max_samples: 100000000}\nbodies:\n  - {name: b, mass: 1.0, shape: {type: '
          'box, size: [1.0, 1.0, 1.0]}, inertia: {method: sampling, samples: 100000000}}\n')


def test_a_scene_cannot_raise_its_limits_at_start_or_at_runtime(
        ros_context, rigid_sim, write_scene, monkeypatch):
    """A scene asking for more than the node's limit parameters is refused before any work.

    At start the node does not start; at runtime the change is prepared beside the running
    scene, refused, and the parameter set back while the old scene runs on. A runtime scene
    change is held to the limits the parameters have then.
    """
    def never(*args, **kwargs):
        raise AssertionError('sampled an inertia')
    monkeypatch.setattr('rigid_sim.core.inertia.sampling_estimate', never)
    greedy = write_scene(GREEDY, 'greedy.yaml')
    refusal = (f"limits.max_samples: 100000000 is above the operator's limit of "
               f"{WORK_LIMITS['max_samples']}: a scene may lower its limits, never raise them "
               "(the node's parameter max_samples raises it)")
    with pytest.raises(SceneError) as refused:
        RigidSimNode(context=ros_context, parameter_overrides=[Parameter('scene', value=greedy)])
    assert refusal in str(refused.value)
    sim = rigid_sim(yaml=SCENE, time_step=0.125)
    assert sim.set_parameters(scene=greedy)[0].successful   # accepted for preparing
    assert refusal in sim.node.reconfiguration.last_refusal
    assert sim.node.get_parameter('scene').value == sim.node.settings.scene != greedy
    three = write_scene('bodies:\n' + ''.join(
        f'  - {{name: b{i}, mass: 1.0, shape: {{type: sphere, radius: 0.1}}}}\n'
        for i in range(3)), 'three.yaml')
    lowered, scene = sim.set_parameters(max_bodies=2, scene=three)
    assert lowered.successful and sim.node.settings.max_bodies == 2
    assert '3 bodies, above the limit of 2' in sim.node.reconfiguration.last_refusal
    assert sim.node.get_parameter('scene').value != three
    raised, scene = sim.set_parameters(max_bodies=3, scene=three)
    assert raised.successful and scene.successful
    assert [body.name for body in sim.node.scene.bodies] == ['b0', 'b1', 'b2']


@pytest.mark.parametrize('name', ['max_samples', 'max_answer_states', 'per_body_topics_limit'])
def test_a_client_may_lower_a_resource_limit_but_never_raise_it_above_the_start(
        rigid_sim, name):
    """Anyone on the graph may set parameters: the operator's limits are a ceiling.

    Raised by a client, max_samples would let one spawned body sample for minutes and take
    gigabytes (the GREEDY body above: 1e8 samples, ~45 s, 9.6 GB).
    """
    sim = rigid_sim(yaml=SCENE, time_step=0.125)
    start = getattr(sim.node.settings, name)
    raised, = sim.set_parameters(**{name: start + 1})
    assert not raised.successful
    assert f"'{name}': {start + 1} is above {start}, its value at start" in raised.reason
    assert getattr(sim.node.settings, name) == sim.node.get_parameter(name).value == start
    lowered, = sim.set_parameters(**{name: start // 2})
    assert lowered.successful and getattr(sim.node.settings, name) == start // 2
    back, = sim.set_parameters(**{name: start})
    assert back.successful and getattr(sim.node.settings, name) == start


def test_start_paused_set_at_runtime_is_refused_pointing_at_pause(rigid_sim):
    """start_paused is read at start only: a change at runtime is refused, not ignored."""
    sim = rigid_sim(yaml=SCENE, time_step=0.125)
    probe = ros_tools.Probe(sim)
    result, = sim.set_parameters(start_paused=True)
    assert not result.successful
    assert result.reason == ("parameter 'start_paused': read at start only; call ~/pause to "
                             'pause or resume the running node')
    assert not sim.node.paused and sim.node.get_parameter('start_paused').value is False
    same, = sim.set_parameters(start_paused=False)
    assert same.successful
    sim.step(8)
    assert clock_nanoseconds(probe)[-1] == 1_000_000_000
