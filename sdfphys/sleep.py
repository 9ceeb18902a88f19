"""Sleeping: islands at rest cost nothing until something reaches them (Box2D v3).

A dynamic body rests while its sleep speed max(|v|, |w| r), r its bounding radius
about the centre of mass (a bound on its points' speed about the centre, Box2D's
``maxExtent``), and the same of its displacement over the step, stay under
``Settings.sleep_speed``; its sleep time counts how long
it has rested (``rest_times``), and a contact with a moving kinematic body resets
it (a platform carries its passengers). An island (``islands``) falls asleep when
every body in it has rested ``Settings.time_to_sleep`` (``falling_asleep``): its
bodies stop (v = w = 0) and leave the step: no integration, no contact among
themselves or with static bodies, and zero inverse mass to the contacts of awake
bodies. Their contacts and impulses are kept, to warm-start the island when it wakes.

An island wakes whole (``World``): when an awake dynamic or a moving kinematic body
comes within contact range of one of its bodies (their pair has a contact: closer
than the speculative margin plus reach), when ``set_state`` or ``remove_body`` acts
on one of its bodies or on a body it touches, when gravity changes, or on
``World.wake``. Box2D v3's defaults: 0.05 m/s, 0.5 s (``b2_defaultSleepThreshold``,
``B2_TIME_TO_SLEEP``).
"""

from __future__ import annotations

import numpy as np

from ._jit import njit

__all__ = ["falling_asleep", "rest_times"]


@njit(cache=True, error_model="numpy")
def rest_times(velocity, angular_velocity, com, angle, start_com, start_angle, radius, awake,
               sleep_time, dt, sleep_speed, time_to_sleep):
    """Advance ``sleep_time`` (B,) s in place: + dt for each awake body whose sleep
    speed is under ``sleep_speed`` (m/s), 0 for the others that are awake. Returns
    whether some awake body has now rested ``time_to_sleep`` s (else no island can
    fall asleep this step).

    Sleep speed: the larger of max(|v|, |w| r) (velocity (B, 2) m/s, angular_velocity
    (B,) rad/s, radius (B,) m) and the same of the step's displacement over dt (com,
    angle against start_com, start_angle): overlap pushed out by the split rows moves a
    body without velocity ("Split push-out" in ``solver``), and such a body is not at rest.
    """
    rested = False
    for i in range(awake.shape[0]):
        if not awake[i]:
            continue
        dx = (com[i, 0] - start_com[i, 0]) / dt
        dy = (com[i, 1] - start_com[i, 1]) / dt
        turn = abs(angle[i] - start_angle[i]) / dt
        spin = max(abs(angular_velocity[i]), turn) * radius[i]
        # Squared speeds against the squared threshold: the norms' test (up to rounding
        # at the threshold) without a call of hypot per speed.
        speed2 = max(velocity[i, 0] * velocity[i, 0] + velocity[i, 1] * velocity[i, 1],
                     dx * dx + dy * dy, spin * spin)
        sleep_time[i] = sleep_time[i] + dt if speed2 < sleep_speed * sleep_speed else 0.0
        rested = rested or sleep_time[i] >= time_to_sleep
    return rested


@njit(cache=True, error_model="numpy")
def falling_asleep(root, awake, sleep_time, time_to_sleep):
    """(B,) bool: the awake bodies whose island (``root``: ``islands.island_roots``)
    has rested ``time_to_sleep`` s in every body."""
    n = root.shape[0]
    least = np.full(n, np.inf)
    for i in range(n):
        if awake[i]:
            least[root[i]] = min(least[root[i]], sleep_time[i])
    out = np.zeros(n, np.bool_)
    for i in range(n):
        out[i] = awake[i] and least[root[i]] >= time_to_sleep
    return out
