"""Build a field from the nested dicts of a scene file (``sdf.field(spec)``).

A FIELD is either a primitive ``{type = "box", size = [2, 1]}`` or an operator
``{op = "smooth_union", k = 0.2, of = [FIELD, FIELD]}``; any FIELD may carry
``offset = [x, y]`` and ``angle`` (radians), applied as rotate-then-translate.
Every problem raises one ``SpecError`` naming the key path.
"""

from __future__ import annotations

import difflib
from collections.abc import Mapping
from typing import Any

from ..errors import SpecError, check_number, check_vec2
from .base import _OPERATOR_ENTRIES, _PRIMITIVE_ENTRIES, Entry, Field

__all__ = ["field", "suggest"]

_PLACEMENT = ("offset", "angle")


def suggest(word: str, known: list[str] | tuple[str, ...]) -> str:
    """`` (did you mean 'x'?)`` for the nearest known word, or an empty string."""
    close = difflib.get_close_matches(word, list(known), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def field(spec: Any, path: str = "field") -> Field:
    """A Field from a FIELD dict (see the module docstring); ``path`` prefixes errors."""
    if isinstance(spec, Field):
        return spec
    if not isinstance(spec, Mapping):
        raise SpecError(path, f"must be a table with 'type' or 'op', got {spec!r}")
    if "type" in spec and "op" in spec:
        raise SpecError(path, "has both 'type' and 'op'; a FIELD is one or the other")
    if "type" in spec:
        entry = _lookup(spec["type"], _PRIMITIVE_ENTRIES, f"{path}.type", "primitive")
    elif "op" in spec:
        entry = _lookup(spec["op"], _OPERATOR_ENTRIES, f"{path}.op", "operator")
    else:
        raise SpecError(path, "needs 'type' (a primitive) or 'op' (an operator)")

    key = "type" if "type" in spec else "op"
    known = [p.name for p in entry.params]
    for name in spec:
        if name != key and name not in known and name not in _PLACEMENT:
            raise SpecError(f"{path}.{name}", f"unknown key for {entry.name!r}"
                            + suggest(name, known + list(_PLACEMENT)))
    kwargs: dict[str, Any] = {}
    canonical: dict[str, Any] = {key: entry.name}
    for param in entry.params:
        sub = f"{path}.{param.name}"
        if param.name not in spec:
            if param.required:
                raise SpecError(sub, f"is required for {entry.name!r}")
            kwargs[param.name] = param.default
            continue
        value = spec[param.name]
        if param.kind == "field":
            kwargs[param.name] = field(value, sub)
            canonical[param.name] = kwargs[param.name].spec
        elif param.kind == "fields":
            if not isinstance(value, (list, tuple)) or len(value) < 2:
                raise SpecError(sub, f"must be a list of at least two FIELDs, got {value!r}")
            kwargs[param.name] = [field(v, f"{sub}[{i}]") for i, v in enumerate(value)]
            canonical[param.name] = [f.spec for f in kwargs[param.name]]
        else:
            kwargs[param.name] = param.check(value, sub)
            canonical[param.name] = _plain(kwargs[param.name])
    result = _construct(entry, kwargs, path)
    result.spec = canonical
    return _place(result, spec, path)


def _lookup(name: Any, entries: dict[str, Entry], path: str, what: str) -> Entry:
    if not isinstance(name, str):
        raise SpecError(path, f"must be a string naming a {what}, got {name!r}")
    if name not in entries:
        raise SpecError(path, f"unknown {what} {name!r}" + suggest(name, list(entries)))
    return entries[name]


def _construct(entry: Entry, kwargs: dict[str, Any], path: str) -> Field:
    try:
        return entry.cls(**kwargs)
    except SpecError as err:
        raise err.under(path) from None
    except ValueError as err:
        raise SpecError(path, str(err)) from None


def _place(result: Field, spec: Mapping, path: str) -> Field:
    """Wrap ``result`` in the rigid placement given by ``offset`` / ``angle``, if any."""
    if "offset" not in spec and "angle" not in spec:
        return result
    from .base import OPERATORS

    offset = check_vec2(spec.get("offset", (0.0, 0.0)), f"{path}.offset")
    angle = check_number(spec.get("angle", 0.0), f"{path}.angle")
    placed = OPERATORS["transform"](result, offset=offset, angle=angle)
    placed.spec = dict(result.spec or {}, offset=list(offset), angle=angle)
    return placed


def _plain(value: Any) -> Any:
    """Tuples to lists, so a canonical spec compares equal to its TOML form."""
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    return value
