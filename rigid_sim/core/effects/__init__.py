# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""Effects: each adds world-axes forces and torques about the centre of mass for all bodies.

An effect is one module here with one subclass of
:class:`~rigid_sim.core.effects.base.Effect` (which holds the defaults), entered in
:data:`REGISTRY` under its scene key. It declares, as class attributes,

``name`` : str
    its key under the scene's ``effects:``;
``scene_fields``
    the checker of its scene entry, made of :mod:`rigid_sim.core.scene_fields` checkers
    (a ``table`` of fields, a ``list_of`` tables), which gives every message its key;
``parts`` : tuple of NamedTuple classes
    what its ``parameters`` may be, each with its compiled kernel registered for it: with
    :func:`~rigid_sim.core.effects.base.body_kernel_for` when a body's wrench depends only
    on that body's state, else (it couples bodies) with
    :func:`~rigid_sim.core.effects.base.kernel_for`;

and on each instance

``parameters``
    its arrays, an instance of one of its ``parts``;
``velocity_dependent`` : bool
    whether its wrench depends on momenta (dampers): splitting methods then integrate
    their kicks to full order instead of taking one explicit step (False by default);
``torqued`` : (N,) bool
    which bodies it may apply a torque to (the rest stay torque-free, which lets
    integrators use the exact free-rotation flow for them);
``fastest_rate()`` : float
    the fastest frequency or decay rate it imposes, 1/s, which bounds the step;
``potential_energy(snapshot)`` : float
    stored energy, J (0 for dissipative or external effects).

The scene loader checks each listed entry with ``scene_fields``, then ``resolve`` (for
settings that name bodies; by default the settings as checked), and the world is given
``from_settings(bodies, settings)`` of each (by default ``cls(bodies, **settings)``). Only
the effects a scene lists are built, and the kernels are compiled for exactly those: an
unlisted effect is not in the compiled step at all. Held wrenches are not an effect but the
world's inputs (:mod:`rigid_sim.core.inputs`).
"""
from rigid_sim.core.effects.base import BODY_KERNELS, KERNELS
from rigid_sim.core.effects.damping import Damping
from rigid_sim.core.effects.gravity import Gravity
from rigid_sim.core.effects.springs import Springs


def registry(*classes):
    """Map each effect class's scene key ``name`` to it, in the order given.

    The order is the scene's: its effects are built and summed in it. Raises TypeError for
    a class that declares no ``name``, ``scene_fields`` or ``parts``, or a part with no
    compiled kernel registered: a scene could list it but no step could evaluate it.
    """
    for cls in classes:
        if not isinstance(cls.name, str) or cls.scene_fields is None or not cls.parts:
            raise TypeError(f'effect {cls.__name__} must declare the class attributes name '
                            '(its scene key), scene_fields (the checker of its entry) and '
                            'parts (the NamedTuple classes of its parameters)')
        for part in cls.parts:
            if part not in KERNELS and part not in BODY_KERNELS:
                raise TypeError(f'effect {cls.__name__}: no compiled kernel is registered for '
                                f'its part {part.__name__} (kernel_for or body_kernel_for)')
    return {cls.name: cls for cls in classes}


REGISTRY = registry(Gravity, Damping, Springs)
