"""The law of one antagonistic cable pair, shared by the internal-force prior (each of the three
pairs of the Cadiere wrist, in tensions, N) and the transmission model (one pair from motor to
jaw, in torques: tensions times the pulley radius, Nm).

A pair carries a differential ``D = T+ - T-`` (what turns the pulley) and a sum ``S = T+ + T-``
(what loads the shaft and the pulley pins). The loop is one cable of fixed length, so while both
sides are taut the sum is the pretension plus the pair's asymmetry times the differential,
``S = 2 T_0 + a D``; once the unloaded side goes slack the whole load is on one side,
``S = |D|``. Across an idler with friction (the capstan), the differential passed on is
``D cosh(m) - S sinh(m)`` with ``m = mu z`` the wrap's friction exponent signed by the friction
direction ``z`` in [-1, 1].

Every function takes an ``xp`` namespace with ``sqrt``, ``cosh`` and ``sinh`` (numpy, or casadi
for the fits) and works elementwise.
"""

from __future__ import annotations


def tension_sum(taut_sum, differential, width, xp):
    """Pair sum: a smooth max (transition ``width``, same units) of the taut-loop sum
    ``2 T_0 + a D`` and the slack sum ``|D|``."""
    mag = xp.sqrt(differential * differential + 1e-12)
    gap = taut_sum - mag
    return 0.5 * (taut_sum + mag + xp.sqrt(gap * gap + width * width))


def capstan(differential, total, exponent, xp):
    """Differential passed across a wrap with friction exponent ``mu z`` (signed)."""
    return differential * xp.cosh(exponent) - total * xp.sinh(exponent)
