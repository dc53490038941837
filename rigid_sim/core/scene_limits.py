# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The resources one scene may use, and who sets the limits: the operator, not the file.

The operator's limits (the node's parameters of the same names, or the keyword arguments of
:func:`rigid_sim.core.scene.load_scene`) bound the file's size, its bodies, inertia samples,
mesh bytes and mesh faces. A scene's own ``limits:`` may lower the work limits for itself,
never raise them: a file asking for more than the operator allows is refused before any of
that work, so nothing a file holds makes the loader do more than the operator said. The
parsing limits (nesting, YAML nodes) are fixed in :mod:`rigid_sim.core.scene_file`.
"""
import numpy as np

from rigid_sim.core.inertia import load_mesh
from rigid_sim.core.scene_fields import Mistake
from rigid_sim.core.scene_file import check_file, FileRefused, MAX_SCENE_BYTES, MIB
from rigid_sim.core.text import clipped

# Work limits of one scene, the operator's defaults; a scene may lower each in `limits:`.
# Each is checked before the work it bounds: bodies before the first is built, samples and
# mesh bytes (all bodies together; a mesh file used twice is read once) before they are
# drawn or read, faces before the mesh integrals. Named points (all bodies together) are
# frames of the one /tf_static message every scene change publishes on the executor: about
# 22 us each on a loaded 2-core machine, so 100 000 held control 2.2 s; 1024 take ~25 ms.
WORK_LIMITS = {'max_bodies': 100_000, 'max_samples': 1 << 22,
               'max_mesh_bytes': 256 * MIB, 'max_mesh_faces': 2_000_000, 'max_points': 1024}
# Every limit the operator sets (documented in the README), with its default.
RESOURCE_LIMITS = {'max_scene_bytes': MAX_SCENE_BYTES, **WORK_LIMITS}


def operator_limits(given):
    """Return every resource limit: ``RESOURCE_LIMITS``, with those ``given`` replacing them.

    Parameters
    ----------
    given : dict
        Limit name -> positive int, as the operator sets it.

    Raises
    ------
    ValueError
        For a name not in ``RESOURCE_LIMITS`` or a value that is not a positive int.
    """
    unknown = sorted(set(given) - set(RESOURCE_LIMITS))
    if unknown:
        raise ValueError(f'unknown resource limit(s) {unknown}; valid: {list(RESOURCE_LIMITS)}')
    for name, value in given.items():
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise ValueError(f'resource limit {name} must be a positive int, got {value!r}')
    return {**RESOURCE_LIMITS, **given}


def raise_note(name):
    """Who may raise limit ``name``: words for a refusal."""
    return f"the operator's limit; the node's parameter {name} raises it"


class Budget:
    """What the bodies of one scene may still use: samples and mesh bytes, meshes read once.

    Parameters
    ----------
    asked : dict
        The work limits the scene's ``limits:`` gives (name -> int), any of them.
    allowed : dict
        The operator's limits (:func:`operator_limits`).
    base_dir : str
        The scene's directory, where relative mesh paths start.
    roots : sequence of str or None
        Real paths of the directories mesh files may be in; None: anywhere.

    Raises
    ------
    Mistake
        At ``limits.<name>`` when the scene asks for more than the operator allows.
    """

    def __init__(self, asked, allowed, base_dir, roots=None):
        for name, value in asked.items():
            if value > allowed[name]:
                raise Mistake(f'limits.{name}', f"{value} is above the operator's limit of "
                                                f'{allowed[name]}: a scene may lower its limits, '
                                                f"never raise them (the node's parameter {name} "
                                                'raises it)')
        self.limits = {name: asked.get(name, allowed[name]) for name in WORK_LIMITS}
        self._notes = {name: f"the scene's own limits.{name}" if name in asked
                       else raise_note(name) for name in WORK_LIMITS}
        self.base_dir, self.roots = base_dir, roots
        # What the scene's bodies may still take of the limits shared among them.
        self._left = {name: self.limits[name] for name in ('max_samples', 'max_points')}
        self.mesh_bytes = self.limits['max_mesh_bytes']
        self._meshes = {}   # (absolute path, scale) -> trimesh.Trimesh

    def above(self, name):
        """Words after a refusal at limit ``name``: its value and who sets it."""
        return f'above the limit of {self.limits[name]} ({self._notes[name]})'

    def draw(self, limit, count, key, what):
        """Take ``count`` of the shared ``limit`` for a body, or a Mistake at ``key``.

        ``what`` words the count and what earlier bodies did: ('samples', 'drawn').
        """
        left = self._left[limit]
        if count > left:
            noun, verb = what
            raise Mistake(key, f'{count} {noun}, with {self.limits[limit] - left} {verb} by '
                               f'earlier bodies, is {self.above(limit)}')
        self._left[limit] = left - count

    def mesh(self, shape, key):
        """Load the mesh of a mesh ``shape``, read at most once per scene."""
        path, scale = shape['file'], shape['scale']
        name = (path, tuple(np.broadcast_to(scale, 3).tolist()))
        if name not in self._meshes:
            try:
                size = check_file(path, self.mesh_bytes, f'mesh file {clipped(path)}',
                                  'all mesh files of the scene together; '
                                  f'{self._notes["max_mesh_bytes"]}')
            except FileRefused as refused:
                raise Mistake(f'{key}.file', refused.reason) from None
            try:
                loaded = load_mesh(path, scale)
            except (ValueError, OSError) as error:
                raise Mistake(key, str(error)) from None
            if len(loaded.faces) > self.limits['max_mesh_faces']:
                raise Mistake(key, f'{len(loaded.faces)} faces in {clipped(path)}, '
                                   f'{self.above("max_mesh_faces")}')
            self.mesh_bytes -= size
            self._meshes[name] = loaded
        return self._meshes[name]
