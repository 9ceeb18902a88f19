"""Ranges that keep a run meaningful, and the one validator of body values.

Scenes (``scene.read_scene``) and the Python API (``World.add_body``, ``set_state``,
``World.gravity``; every later public setter) check values here, so both reject the
same things with the same one-line ``SpecError`` naming the key or argument:
``body[1].position[0]: must be finite, got nan`` from a scene, ``position[0]: must be
finite, got nan`` from ``add_body``. Settings knobs carry their own ranges
(``settings.Settings.check``, the same checkers).

The ranges, and why (SI units):

- lengths: a circle's radius, a box's sides, the extent of a polygon or field
  ``MIN_SIZE`` (1 mm) to ``MAX_SIZE`` (10 km) (``shapes.shape_from_spec``): the
  solver's length scales are the 5 mm slop and a 0.07 mm resting sag;
- positions: every coordinate within ``FAR`` = 2^17 m = 131,072 m of the origin.
  The far-origin stability test (a pyramid at (1e5, 1e5) m behaves as at the origin
  to 5e-10 m, ``tests/stability``) ran where float64 coordinates are 2^-36 m = 1.5e-11
  m apart; that spacing holds up to 2^17 m and doubles beyond;
- angles: ``|angle| <= FAR`` rad (the same spacing, in radians);
- speeds: ``|velocity| <= MAX_SPEED`` (10 km/s), ``|angular_velocity| <=
  MAX_ANGULAR_SPEED`` (1e4 rad/s); gravity ``|g| <= MAX_GRAVITY`` (1e4 m/s^2);
- density ``DENSITY`` (1e-6 to 1e6 kg/m^2), mass ``MASS`` (1e-9 to 1e12 kg): every
  product a step forms (m v^2, m g h, impulses, inverse masses) stays finite by many
  decades; mass ratios beyond 1000:1 lose accuracy long before (stability study);
- collision filter: ``category`` and ``mask`` 64-bit fields (0 to 2^64 - 1), ``group``
  a signed 64-bit integer (``collide.filter``); ``gravity_scale`` within
  +-``MAX_GRAVITY_SCALE`` (1e3: 1e3 g is the largest gravity, ``MAX_GRAVITY``);
- friction 0 to ``MAX_FRICTION`` (100: a friction cone of 89.4 degrees already holds
  whatever it touches); restitution 0 to 1; damping 0 to ``MAX_DAMPING`` (1e6 1/s);
- time: ``settings.dt`` from ``MIN_DT`` (1 us) to 1 s; a duration at most
  ``MAX_DURATION`` (1e7 s); and a command-line run of more than ``MAX_STEPS`` (10
  million) steps or frames needs an explicit ``--max-steps``.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

from .errors import SpecError, check_int, check_number, check_vec2

__all__ = ["DENSITY", "FAR", "KINDS", "MASS", "MAX_ANGULAR_SPEED", "MAX_DAMPING",
           "MAX_DURATION", "MAX_FRICTION", "MAX_GRAVITY", "MAX_GRAVITY_SCALE", "MAX_SIZE",
           "MAX_SPEED", "MAX_STEPS", "MIN_DT", "MIN_SIZE", "BodyValues", "check_angle",
           "check_angular_velocity", "check_body", "check_flag", "check_gravity",
           "check_position", "check_positive", "check_steps", "check_velocity"]

#: Largest |coordinate| of a position (m) and |angle| (rad): 2^17, see the module docstring.
FAR = 2.0 ** 17
#: Smallest circle radius or box side, m. The solver's length scales are the 5 mm contact
#: slop and the soft contact's resting sag g / (2 pi 60 Hz)^2 = 69 um: a body of 1e-9 m
#: rests tens of thousands of its own radii deep and is thrown out of contact. A
#: millimetre is still 14 sags.
MIN_SIZE = 1e-3
#: Largest radius, box side or polygon/field extent from the body's origin, m.
MAX_SIZE = 1e4
#: Largest speed of a body's centre of mass, m/s.
MAX_SPEED = 1e4
#: Largest |angular velocity|, rad/s.
MAX_ANGULAR_SPEED = 1e4
#: Largest |gravity|, m/s^2.
MAX_GRAVITY = 1e4
#: Largest |gravity_scale| of a body (1e3 g ~ MAX_GRAVITY).
MAX_GRAVITY_SCALE = 1e3
#: Largest category or mask (64 bits) and group (signed 64 bits).
MAX_BITS = (1 << 64) - 1
MAX_GROUP = (1 << 63) - 1
#: Density range, kg/m^2.
DENSITY = (1e-6, 1e6)
#: Mass range, kg.
MASS = (1e-9, 1e12)
#: Largest friction coefficient.
MAX_FRICTION = 100.0
#: Largest linear or angular damping, 1/s.
MAX_DAMPING = 1e6
#: Smallest step, s (``settings.dt``).
MIN_DT = 1e-6
#: Largest ``sim.duration`` or ``--seconds``, s.
MAX_DURATION = 1e7
#: Steps or frames a command-line run may take without an explicit ``--max-steps``.
MAX_STEPS = 10_000_000

#: Body kinds, in the order of the World's integer codes.
KINDS = ("dynamic", "static", "kinematic")


def _under(prefix: str, name: str) -> str:
    return f"{prefix}.{name}" if prefix else name


def check_position(value: Any, path: str) -> tuple[float, float]:
    """A finite point (m) with both coordinates within ``FAR`` of the origin."""
    x, y = check_vec2(value, path)
    for i, c in enumerate((x, y)):
        if abs(c) > FAR:
            raise SpecError(f"{path}[{i}]", f"must be within {FAR:.0f} m of the origin "
                            f"(float64 resolution), got {c:g}")
    return x, y


def check_angle(value: Any, path: str) -> float:
    """A finite angle (rad), ``|angle| <= FAR``."""
    angle = check_number(value, path)
    if abs(angle) > FAR:
        raise SpecError(path, f"must be within +-{FAR:.0f} rad, got {angle:g}")
    return angle


def check_velocity(value: Any, path: str) -> tuple[float, float]:
    """A finite velocity (m/s) of magnitude at most ``MAX_SPEED``."""
    v = check_vec2(value, path)
    speed = math.hypot(*v)
    if speed > MAX_SPEED:
        raise SpecError(path, f"speed must be <= {MAX_SPEED:g} m/s, got {speed:g}")
    return v


def check_angular_velocity(value: Any, path: str) -> float:
    """A finite angular velocity (rad/s), ``|w| <= MAX_ANGULAR_SPEED``."""
    w = check_number(value, path)
    if abs(w) > MAX_ANGULAR_SPEED:
        raise SpecError(path, f"must be within +-{MAX_ANGULAR_SPEED:g} rad/s, got {w:g}")
    return w


def check_gravity(value: Any, path: str) -> tuple[float, float]:
    """A finite acceleration (m/s^2) of magnitude at most ``MAX_GRAVITY``."""
    g = check_vec2(value, path)
    size = math.hypot(*g)
    if size > MAX_GRAVITY:
        raise SpecError(path, f"magnitude must be <= {MAX_GRAVITY:g} m/s^2, got {size:g}")
    return g


def check_positive(value: Any, path: str, low: float, high: float, unit: str) -> float:
    """A finite number > 0 within ``[low, high]`` (``unit`` for the message)."""
    x = check_number(value, path, low=0.0, low_open=True, high=high)
    if x < low:
        raise SpecError(path, f"must be >= {low:g} {unit}, got {x:g}")
    return x


def check_steps(steps: int, what: str, max_steps: int | None) -> None:
    """Refuse a run of ``steps`` steps or frames over ``max_steps`` (default ``MAX_STEPS``)
    with a SpecError that says how to allow it."""
    limit = MAX_STEPS if max_steps is None else max_steps
    if steps > limit:
        hint = ("pass --max-steps to allow it" if max_steps is None
                else "raise --max-steps to allow it")
        raise SpecError("--max-steps", f"the run needs {steps:,} {what}, more than "
                        f"{limit:,}; {hint}")


class BodyValues(NamedTuple):
    """Validated values of one body (what ``check_body`` returns), SI units."""

    position: tuple[float, float]
    angle: float
    velocity: tuple[float, float]
    angular_velocity: float
    density: float
    mass: float | None
    friction: float
    restitution: float
    kind: str
    linear_damping: float
    angular_damping: float
    category: int = 1
    mask: int = MAX_BITS
    group: int = 0
    sensor: bool = False
    gravity_scale: float = 1.0


def check_body(prefix: str = "", *, position: Any = (0.0, 0.0), angle: Any = 0.0,
               velocity: Any = (0.0, 0.0), angular_velocity: Any = 0.0,
               density: Any = 1.0, mass: Any = None, friction: Any = 0.5,
               restitution: Any = 0.0, kind: Any = "dynamic", linear_damping: Any = 0.0,
               angular_damping: Any = 0.0, category: Any = 1, mask: Any = MAX_BITS,
               group: Any = 0, sensor: Any = False, gravity_scale: Any = 1.0) -> BodyValues:
    """Every value of a body checked against the ranges above.

    ``prefix`` is the key path of the body (``body[2]`` in a scene, empty for the API):
    errors name ``{prefix}.{key}``. A static body may not be given a velocity.
    category, mask: 0 to 2^64 - 1; group: a signed 64-bit integer (``collide.filter``);
    sensor: a bool; gravity_scale: within +-MAX_GRAVITY_SCALE.
    """
    if kind not in KINDS:
        raise SpecError(_under(prefix, "kind"),
                        f"must be one of {', '.join(KINDS)}, got {kind!r}")
    velocity = check_velocity(velocity, _under(prefix, "velocity"))
    angular_velocity = check_angular_velocity(angular_velocity,
                                              _under(prefix, "angular_velocity"))
    if kind == "static" and (velocity != (0.0, 0.0) or angular_velocity != 0.0):
        raise SpecError(_under(prefix, "velocity"), "a static body cannot move; use "
                        "kinematic (kinematic = true in a scene) for moving platforms")
    if mass is not None:
        mass = check_positive(mass, _under(prefix, "mass"), *MASS, "kg")
    return BodyValues(
        position=check_position(position, _under(prefix, "position")),
        angle=check_angle(angle, _under(prefix, "angle")),
        velocity=velocity, angular_velocity=angular_velocity,
        density=check_positive(density, _under(prefix, "density"), *DENSITY, "kg/m^2"),
        mass=mass,
        friction=check_number(friction, _under(prefix, "friction"), low=0.0,
                              high=MAX_FRICTION),
        restitution=restitution if _is_default(restitution, 0.0) else check_number(
            restitution, _under(prefix, "restitution"), low=0.0, high=1.0),
        kind=kind,
        linear_damping=linear_damping if _is_default(linear_damping, 0.0) else check_number(
            linear_damping, _under(prefix, "linear_damping"), low=0.0, high=MAX_DAMPING),
        angular_damping=angular_damping if _is_default(angular_damping, 0.0) else check_number(
            angular_damping, _under(prefix, "angular_damping"), low=0.0, high=MAX_DAMPING),
        category=category if _is_default(category, 1) else check_int(
            category, _under(prefix, "category"), low=0, high=MAX_BITS),
        mask=mask if _is_default(mask, MAX_BITS) else check_int(
            mask, _under(prefix, "mask"), low=0, high=MAX_BITS),
        group=group if _is_default(group, 0) else check_int(
            group, _under(prefix, "group"), low=-MAX_GROUP, high=MAX_GROUP),
        sensor=sensor if _is_default(sensor, False) else check_flag(
            sensor, _under(prefix, "sensor")),
        gravity_scale=gravity_scale if _is_default(gravity_scale, 1.0) else check_number(
            gravity_scale, _under(prefix, "gravity_scale"), low=-MAX_GRAVITY_SCALE,
            high=MAX_GRAVITY_SCALE))


def _is_default(value: Any, default: Any) -> bool:
    """Whether ``value`` is the (valid) default itself: same type, equal (a NaN never
    is). Loading 100,000 circles checks each key of each body: the defaults skip it."""
    return type(value) is type(default) and value == default


def check_flag(value: Any, path: str) -> bool:
    """A bool (true or false in a scene)."""
    if not isinstance(value, bool):
        raise SpecError(path, f"must be true or false, got {value!r}")
    return value
