"""Numba's compiler flags compared without reading every option through its property.

While it types a kernel, numba looks up the implementation of every call to an
overloaded function (``np.empty``, ``min``, ``max``, an operator on arrays) in a cache
keyed by the compiler flags in force (``typing.templates._OverloadMethodTemplate``'s
``_get_impl``). A key's hash and equality read ``TargetConfig.values()``: a dict of
every option (about 40) built through the options' Python properties, twice per
comparison. A cold box_stack run (one process) did 110,000 such reads, 2.4 million
property calls, a few percent of its compiling.

``install`` gives ``TargetConfig`` the same three methods in closed form: ``values()``
is the class's defaults updated by the options set on the instance (``_values``, the
only place a property's setter writes), the same dict; ``__hash__`` is numba's, the
hash of the sorted option names (numba hashes the sorted keys of ``values()``, which
are the class's options whatever is set), computed once per class; ``__eq__`` compares
those dicts as numba's does. Same keys, same hits, the same compiled code, less time.
If numba's ``TargetConfig`` lacks the layout this relies on (``options``, ``_values``),
``install`` leaves it as it is.
"""

from __future__ import annotations

from typing import Any

from numba.core import targetconfig

__all__ = ["install"]

#: Per TargetConfig subclass: its options' defaults (name -> value) and numba's hash.
_DEFAULTS: dict[type, dict[str, Any]] = {}
_HASHES: dict[type, int] = {}


def _defaults(cls: type) -> dict[str, Any]:
    defaults = _DEFAULTS.get(cls)
    if defaults is None:
        defaults = _DEFAULTS[cls] = {name: option.default
                                     for name, option in cls.options.items()}
    return defaults


def values(self: targetconfig.TargetConfig) -> dict[str, Any]:
    """Every option's value (numba's ``TargetConfig.values``): the defaults, updated by
    the options set."""
    return {**_defaults(type(self)), **self._values}


def config_hash(self: targetconfig.TargetConfig) -> int:
    """Numba's ``TargetConfig.__hash__``: the hash of the sorted option names."""
    cls = type(self)
    h = _HASHES.get(cls)
    if h is None:
        h = _HASHES[cls] = hash(tuple(sorted(cls.options)))
    return h


def config_eq(self: targetconfig.TargetConfig, other: Any) -> bool:
    """Numba's ``TargetConfig.__eq__``: equal values of every option."""
    if isinstance(other, targetconfig.TargetConfig):
        return values(self) == values(other)
    return NotImplemented


def install() -> None:
    """Give numba's ``TargetConfig`` the methods above (idempotent; none if its layout is
    not the one they read)."""
    cls = targetconfig.TargetConfig
    if cls.values is values:
        return
    if not (hasattr(cls, "options") and "_values" in getattr(cls, "__slots__", ())):
        return
    cls.values = values
    cls.__hash__ = config_hash
    cls.__eq__ = config_eq
