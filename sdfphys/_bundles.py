"""``PlainFields``: the numba StructRef type of the package's bundles of arrays.

A kernel that takes many arrays takes them as a bundle by reference: one pointer to the
same arrays, read as ``rows.normal[k, 0]`` as from a NamedTuple (``solver.bundles``
gives the reasons and figures). Each bundle is a ``PlainFields`` subclass, a proxy class
and a maker compiled into the disk cache; here, below ``collide`` and ``solver``, so that
both layers define theirs.
"""

from __future__ import annotations

from numba.core import types

__all__ = ["PlainFields"]


class PlainFields(types.StructRef):
    """A StructRef type whose fields take their values' plain (not literal) types."""

    def preprocess_fields(self, fields):
        return tuple((name, types.unliteral(t)) for name, t in fields)
