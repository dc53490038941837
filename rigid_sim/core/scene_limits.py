# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The work one scene may cause: bodies, inertia samples, mesh bytes and faces.

The parsing limits (file size, nesting, YAML nodes) are fixed in
:mod:`rigid_sim.core.scene_file`; these apply to what the parsed scene asks for, so a scene
raises them in its own ``limits:`` when it needs more.
"""
import numpy as np

from rigid_sim.core.inertia import load_mesh
from rigid_sim.core.scene_fields import Mistake
from rigid_sim.core.scene_file import check_file, FileRefused, MIB
from rigid_sim.core.text import clipped

# Work limits of one scene, raised in its `limits:` (documented in the README). Each is
# checked before the work it bounds: bodies before the first is built, samples and mesh
# bytes (all bodies together; a mesh file used twice is read once) before they are drawn
# or read, faces before the mesh integrals.
WORK_LIMITS = {'max_bodies': 100_000, 'max_samples': 1 << 22,
               'max_mesh_bytes': 256 * MIB, 'max_mesh_faces': 2_000_000}


class Budget:
    """What the bodies of one scene may still use: samples and mesh bytes, meshes read once."""

    def __init__(self, limits, base_dir):
        self.limits, self.base_dir = limits, base_dir
        self.samples = limits['max_samples']
        self.mesh_bytes = limits['max_mesh_bytes']
        self._meshes = {}   # (absolute path, scale) -> trimesh.Trimesh

    def draw_samples(self, samples, key):
        """Take ``samples`` from the budget, or a Mistake at ``key`` before any is drawn."""
        if samples > self.samples:
            drawn = self.limits['max_samples'] - self.samples
            raise Mistake(key, f'{samples} samples, with {drawn} drawn by earlier bodies, is '
                               f'above the limit of {self.limits["max_samples"]} (raise '
                               'limits.max_samples)')
        self.samples -= samples

    def mesh(self, shape, key):
        """Load the mesh of a mesh ``shape``, read at most once per scene."""
        path, scale = shape['file'], shape['scale']
        name = (path, tuple(np.broadcast_to(scale, 3).tolist()))
        if name not in self._meshes:
            try:
                size = check_file(path, self.mesh_bytes, f'mesh file {clipped(path)}',
                                  'all mesh files of the scene together; raise '
                                  'limits.max_mesh_bytes')
            except FileRefused as refused:
                raise Mistake(f'{key}.file', refused.reason) from None
            try:
                loaded = load_mesh(path, scale)
            except (ValueError, OSError) as error:
                raise Mistake(key, str(error)) from None
            if len(loaded.faces) > self.limits['max_mesh_faces']:
                raise Mistake(key, f'{len(loaded.faces)} faces in {clipped(path)}, above the '
                                   f'limit of {self.limits["max_mesh_faces"]} (raise '
                                   'limits.max_mesh_faces)')
            self.mesh_bytes -= size
            self._meshes[name] = loaded
        return self._meshes[name]
