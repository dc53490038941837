# Copyright 2026 rigid_sim maintainers
# SPDX-License-Identifier: Apache-2.0
"""The set of collision shape kinds a scene has, as a compile-time constant of the stage.

A scene's stage only ever meets the pairs its shapes can make, so the compiled stage is
specialised on that set: a :class:`ShapeKinds` value rides in the stage's parameters, its
numba type carries the set, and the narrow-phase dispatch (:mod:`.stage`) reads the set when
it is typed. A branch for a kind not in the set is pruned before its callee is typed, so a
scene of spheres and boxes compiles none of the capsule, cylinder or GJK/EPA code (about
half of the stage's cold compile, docs/contact.md "Cost"). The value holds no data at run
time; each set is its own type, so numba's disk cache keeps one stage per set, and a
spawn that brings a new kind in gets (and warms up) the stage of the new set.
"""
from numba.core import types
from numba.extending import models, NativeValue, register_model, typeof_impl, unbox


class ShapeKinds:
    """The kinds (``narrow.SPHERE``... ; 0, no shape, left out) the stage is compiled for."""

    def __init__(self, kinds):
        self.kinds = frozenset(int(kind) for kind in kinds if kind != 0)

    def __repr__(self):
        return f'ShapeKinds({sorted(self.kinds)})'


class ShapeKindsType(types.Type):
    """numba's type of a :class:`ShapeKinds`: one type per set, the set in its name."""

    def __init__(self, kinds):
        self.kinds = frozenset(kinds)
        super().__init__(name=f'ShapeKinds{tuple(sorted(self.kinds))}')


@typeof_impl.register(ShapeKinds)
def _typeof(value, context):
    return ShapeKindsType(value.kinds)


# Nothing is read at run time: an opaque pointer that is never dereferenced.
register_model(ShapeKindsType)(models.OpaqueModel)


@unbox(ShapeKindsType)
def _unbox(typ, obj, c):
    return NativeValue(c.context.get_dummy_value())
