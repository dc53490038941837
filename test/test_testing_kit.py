# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The public test kit: the README's example runs, and stepping is deterministic.

A controller that answers each pose with a constant force F acts from the second tick on:
rk4 integrates constant force exactly, so after n ticks of dt the box is at
x0 + F ((n - 1) dt)^2 / 2M, bit for bit the same on two runs.
"""
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
from geometry_msgs.msg import PoseStamped, WrenchStamped

ROOT = Path(__file__).resolve().parents[1]
DT, MASS, FORCE = 1 / 64, 2.0, 3.0
SCENE = f"""
bodies:
  - {{name: box, shape: {{type: box, size: [0.2, 0.2, 0.2]}}, mass: {MASS}}}
"""


def test_the_readme_controller_example_passes_as_a_users_pytest_file(tmp_path):
    """The README's code block, saved as a user's test file, passes with the plugin alone."""
    readme = (ROOT / 'README.md').read_text()
    section = readme[readme.index('**Testing your controller with pytest.**'):]
    example = re.search(r'```python\n(.*?)```', section, re.S).group(1)
    assert 'def test_' in example and 'rigid_sim' in example
    (tmp_path / 'test_controller.py').write_text(example)
    run = subprocess.run([sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                          'test_controller.py'], cwd=tmp_path, capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    assert '1 passed' in run.stdout


def pushed_run(rigid_sim, ticks):
    """Box pushed by F along x in answer to each pose; the stamps seen (ns), the end state."""
    sim = rigid_sim(yaml=SCENE, time_step=DT, integrator='rk4', wrench_timeout=0.0)
    node = sim.create_node('pusher')
    push = node.create_publisher(WrenchStamped, '/rigid_sim/box/wrench', 10)
    seen = []

    def answer(pose):
        seen.append(pose.header.stamp.sec * 10 ** 9 + pose.header.stamp.nanosec)
        wrench = WrenchStamped()
        wrench.header.frame_id = 'world'
        wrench.wrench.force.x = FORCE
        push.publish(wrench)

    node.create_subscription(PoseStamped, '/rigid_sim/box/pose', answer, 10)
    assert sim.step(ticks) == ticks * DT
    state = sim.state('box')
    sim.close()
    return seen, state


def test_step_lets_callbacks_answer_before_the_next_tick_and_repeats_exactly(rigid_sim):
    ticks = 40
    seen, state = pushed_run(rigid_sim, ticks)
    assert seen == [round(k * DT * 1e9) for k in range(1, ticks + 1)]   # ns, every tick
    pushed_for = (ticks - 1) * DT
    np.testing.assert_allclose(state.position, [FORCE * pushed_for ** 2 / (2 * MASS), 0, 0],
                               rtol=0, atol=1e-13)
    np.testing.assert_allclose(state.velocity, [FORCE * pushed_for / MASS, 0, 0],
                               rtol=0, atol=1e-13)
    again_seen, again = pushed_run(rigid_sim, ticks)
    assert again_seen == seen
    assert again.position.tolist() == state.position.tolist()
    assert again.orientation.tolist() == state.orientation.tolist()


def test_set_pose_from_a_users_node_is_applied_at_the_next_step(rigid_sim):
    """set_pose is subscribed to on demand: the kit connects it before stepping."""
    sim = rigid_sim(yaml=SCENE, time_step=DT)
    node = sim.create_node('placer')
    place = node.create_publisher(PoseStamped, '/rigid_sim/box/set_pose', 10)
    sim.step(1)
    message = PoseStamped()
    message.header.frame_id = 'world'
    message.pose.position.z = 2.5
    place.publish(message)
    sim.step(1)
    np.testing.assert_array_equal(sim.state('box').position, [0.0, 0.0, 2.5])
