# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""What a first start compiles: each function once, only what the scene needs, no wrappers.

A first start's wait is numba compiling the kernels a scene's step uses, function by function,
so these pin the mechanisms that keep that short (docs/performance.md, "Compile cost") by what
gets compiled, never by how long it takes: the sum over a scene's effects is one function
(a recursion over the tuple of effects compiled a function per remaining tuple, over and
over); helpers get no Python wrapper and one specialisation per argument type, never one per
constant they are called with; array copies in kernels compile no string formatting; the
net wrench and IMU readings are compiled for a scene with IMUs only, and before its first
tick; the contact stage compiles the narrow-phase pairs of the scene's shape kinds alone. The
cold start runs in a child process with a cache directory of its own.
"""
import json
import os
from pathlib import Path
import subprocess
import sys

import pytest

import rigid_sim
from rigid_sim.core import kinematics
from rigid_sim.core.compiled import CompiledOnly

PACKAGE = Path(rigid_sim.__file__).resolve().parent
# The default scene with the default integrator compiled 98 kernels when the sum over its
# effects recursed; 65 since. The bound leaves room for a few new helpers, not for another
# function compiled once per effect or per stage.
DEFAULT_SCENE_KERNELS = 75
# The child warms up a scene's world (with its IMUs when asked), then reads the IMUs, and
# prints each phase's compilations as (module, qualified name) pairs, the helpers holding a
# specialisation on a constant argument, and whether a helper's (kin.cross) and a kernel's
# (largest_spin) machine code include a CPython wrapper.
CHILD = '''
import json, sys
from numba import types
from numba.core import event
from rigid_sim.core import kinematics
from rigid_sim.core.compiled import CompiledOnly
from rigid_sim.core.imu import scene_imus
from rigid_sim.core.scene import build_world, load_scene
from rigid_sim.core.warm_up import warm_up
from rigid_sim.resources import find_scene

class Names(event.Listener):
    def __init__(self):
        self.names = []
    def on_start(self, event):
        function = event.data['dispatcher'].py_func
        self.names.append((function.__module__, function.__qualname__))
    def on_end(self, event):
        pass

def wrapped(dispatcher):
    return [bool(compiled.library.get_pointer_to_function(
        compiled.fndesc.llvm_cpython_wrapper_name)) for compiled in dispatcher.overloads.values()]

scene = load_scene(find_scene(sys.argv[1], ['/']))   # the test is the operator
world = build_world(scene, 'exact_split')
imus = scene_imus(scene, world) if sys.argv[2] == 'imus' else None
report = {}
for phase in ('warm_up', 'imu_readings'):
    names = Names()
    with event.install_listener('numba:compile', names):
        if phase == 'warm_up':
            warm_up(world, imus=imus)
        elif imus is not None:
            imus.read(world, imus.due(world.time))
    report[phase] = names.names
helpers = [value for module in list(sys.modules.values())
           if (getattr(module, '__name__', None) or '').startswith('rigid_sim.core')
           for value in vars(module).values() if isinstance(value, CompiledOnly)]
report['on_constants'] = sorted({helper.py_func.__qualname__ for helper in helpers
                                 for signature in helper.overloads
                                 if any(isinstance(a, types.Literal) for a in signature)})
report['helpers'] = len(helpers)
report['wrapped'] = [wrapped(kinematics.cross), wrapped(kinematics.largest_spin)]
print(json.dumps(report))
'''


def cold_start(directory, scene, imus):
    """Return the child's report from a fresh process with an empty cache under ``directory``."""
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(directory / 'cache'))
    done = subprocess.run([sys.executable, '-c', CHILD, scene, 'imus' if imus else 'none'],
                          env=environment, cwd=PACKAGE.parent, capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, done.stderr
    report = json.loads(done.stdout)
    for phase in ('warm_up', 'imu_readings'):
        report[phase] = [tuple(name) for name in report[phase]]
    return report


def formatting_code(names):
    """Return the compiled functions among ``names`` that format strings or errors (numba's)."""
    return [(module, name) for module, name in names
            if any(word in f'{module} {name}' for word in ('unicode', 'repr', 'shape_context'))]


@pytest.fixture(scope='module')
def default_scene(tmp_path_factory):
    """Return the report of a cold start of the default scene (no IMU)."""
    return cold_start(tmp_path_factory.mktemp('default'), 'default.yaml', imus=False)


def test_a_cold_start_compiles_each_function_once_and_only_what_it_needs(default_scene):
    """The default scene, cold: each of our functions at most twice, no formatting code.

    At most DEFAULT_SCENE_KERNELS in all; a function of the core (or a sum written out for
    the scene's effects, which has no module) compiles once per argument type, and the
    kernels use two (kin.store of a 3- and a 4-tuple). None of numba's unicode, repr or
    shape-error code is compiled, and neither is the net wrench (accumulate): no IMU reads it.
    """
    names = default_scene['warm_up']
    assert 0 < len(names) <= DEFAULT_SCENE_KERNELS
    ours = [name for name in names if name[0] is None or name[0].startswith('rigid_sim')]
    assert max(ours.count(name) for name in ours) <= 2, sorted(ours)
    assert len(set(ours)) >= len(ours) - 1
    assert not formatting_code(names)
    assert ('rigid_sim.core.effects.base', 'accumulate') not in names


def test_a_helper_has_no_python_wrapper_and_refuses_a_python_call(default_scene):
    """kin.cross is compiled for compiled callers only; largest_spin, a kernel, for Python.

    The helper's machine code holds no CPython wrapper function (the kernel's does), and a
    call from Python raises TypeError instead of jumping to the missing wrapper.
    """
    assert default_scene['wrapped'] == [[False], [True]]
    assert isinstance(kinematics.cross, CompiledOnly)
    with pytest.raises(TypeError, match='compiled callers only'):
        kinematics.cross((1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def test_helpers_are_never_specialised_on_a_constant_argument(default_scene):
    """No helper holds a specialisation on a literal (constant) argument after a cold start.

    kin.vector alone is called with the constant columns 0, 3, 7 and 10 of the state.
    """
    assert default_scene['helpers'] > 40
    assert default_scene['on_constants'] == []


# Two bodies on a spring between them (the kick-by-kick kernel, with its array copies) and an
# IMU on one of them.
COUPLED_WITH_IMU = """
effects:
  gravity: {acceleration: [0.0, 0.0, -9.81]}
  springs:
    - {body: a, point: [0.0, 0.0, 0.0], other: b, other_point: [0.0, 0.0, 0.0],
       stiffness: 10.0, damping: 0.2, rest_length: 0.5}
bodies:
  - name: a
    shape: {type: sphere, radius: 0.1}
    mass: 1.0
    imu: {point: [0.1, 0.0, 0.0], seed: 1}
  - name: b
    shape: {type: sphere, radius: 0.1}
    mass: 1.0
    pose: {position: [1.0, 0.0, 0.0]}
"""


def test_a_scene_with_an_imu_has_its_readings_compiled_before_its_first_reading(tmp_path):
    """A coupled scene with an IMU, cold: the warm-up compiles the net wrench and readings.

    The first reading of its IMU then compiles nothing (it would have compiled inside the
    node's first tick, unannounced), and the kick-by-kick kernel of the coupling spring,
    which copies arrays, compiles none of numba's unicode, repr or shape-error code either.
    """
    scene = tmp_path / 'coupled.yaml'
    scene.write_text(COUPLED_WITH_IMU)
    report = cold_start(tmp_path, str(scene), imus=True)
    names = report['warm_up']
    assert ('rigid_sim.core.integrators.splitting', 'exact_flow_splitting') in names
    assert ('rigid_sim.core.effects.base', 'accumulate') in names
    assert ('rigid_sim.core.imu_kinematics', 'readings') in names
    assert report['imu_readings'] == []
    assert not formatting_code(names)


# The modules of the shapes beyond spheres and boxes: their pairs and the GJK/EPA path.
SHAPE_MODULES = ('rigid_sim.core.contact.capsule', 'rigid_sim.core.contact.cylinder',
                 'rigid_sim.core.contact.convex')
# Spheres and boxes, then a capsule and a cylinder with them, as a spawn would bring in.
ALL_KINDS = """
effects:
  gravity: {acceleration: [0.0, 0.0, -9.81]}
  contact:
    planes: [{normal: [0.0, 0.0, 1.0], offset: 0.0}]
bodies:
  - {name: ball, shape: {type: sphere, radius: 0.1}, mass: 1.0}
  - {name: crate, shape: {type: box, size: [0.2, 0.2, 0.2]}, mass: 1.0}
  - name: pill
    shape: {type: sphere, radius: 0.05}
    collision: {type: capsule, radius: 0.05, length: 0.2}
    mass: 1.0
  - {name: can, shape: {type: cylinder, radius: 0.05, length: 0.2}, mass: 1.0}
"""


def test_a_contact_scene_compiles_the_pairs_of_its_shape_kinds_alone(tmp_path):
    """The packaged contact scene (spheres and boxes), cold: no capsule, cylinder or GJK code.

    Its stage is compiled (contact_step), and so are the sphere and box pairs, but none of
    the functions of the capsule, cylinder and convex modules. A scene that brings a capsule
    and a cylinder in, on the same cache (a spawn's new set of kinds), then compiles their
    plane and pair functions and the GJK/EPA path, and loads the sphere and box pairs from
    the cache, compiling none of them again.
    """
    names = cold_start(tmp_path, 'contact.yaml', imus=False)['warm_up']
    assert ('rigid_sim.core.contact.stage', 'contact_step') in names
    assert ('rigid_sim.core.contact.narrow', 'box_box') in names
    assert [name for name in names if name[0] in SHAPE_MODULES] == []
    scene = tmp_path / 'all_kinds.yaml'
    scene.write_text(ALL_KINDS)
    names = cold_start(tmp_path, str(scene), imus=False)['warm_up']
    assert ('rigid_sim.core.contact.stage', 'contact_step') in names
    for module, function in (('capsule', 'capsule_plane'), ('capsule', 'capsule_capsule'),
                             ('cylinder', 'cylinder_plane'), ('convex', 'convex_pair')):
        assert (f'rigid_sim.core.contact.{module}', function) in names
    assert [name for name in names if name[0] == 'rigid_sim.core.contact.narrow'] == []
