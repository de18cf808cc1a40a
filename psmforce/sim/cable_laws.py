"""A second pair law for the cable transmission, selectable by ``InstrumentParams.pair_law``: a
bench variant outside the internal-force prior's family (docs/identification.md section 2.1;
the linear law is docs/simulator.md section 6).

``"linear"`` (the default; :func:`psmforce.sim.cables._capstan_pair`): each cable of a pair is a
linear spring on a loop of fixed length, so while both are taut the pair's tension sum at the
shaft is ``S = 2 T0 + alpha D`` and a pair goes slack with a kink at ``|D| = S``.

``"quadratic"`` (:func:`quadratic_pair`): each cable is strain-stiffening, tension growing with the
square of its stretch, ``T = c e^2`` (a braided cable whose strands come taut one after another).
On a loop of fixed length ``e+ + e- = 2 e0``, ``T0 = c e0^2``, so ``D = T+ - T- = 4 c e0 (e+ - e0)``
and ``S = T+ + T- = 2 T0 + D^2 / (8 T0)`` while both are taut; the "-" cable reaches zero
tension at ``|D| = 4 T0``, where ``S = |D|`` with the same slope: the pair goes slack smoothly and
at twice the linear law's differential. The law is symmetric (no linear term): the instrument's
``cable_asymmetry`` is not used. Units: N; arrays (N, 3) over time, pairs (pitch, blade_1,
blade_2).
"""

from __future__ import annotations

import numpy as np

PAIR_LAWS = ("linear", "quadratic")
"""The values of ``InstrumentParams.pair_law``."""


def quadratic_pair(d_in, mu_z, alpha, t0, slack):
    """Shaft-side (S, D) and the slack mask of a pair with the quadratic law, through the
    distal capstan ``exp(+-mu_z)``: same arguments and returns as
    :func:`psmforce.sim.cables._capstan_pair` (``alpha`` is ignored: the law is symmetric).

    With ``c = cosh mu_z``, ``s = sinh mu_z`` the shaft side is ``D_s = S_d s + D_d c``,
    ``S_s = S_d c + D_d s``; the closure ``S_s = 2 T0 + D_s^2 / (8 T0)`` is a quadratic in the
    distal sum ``S_d``, ``A S_d^2 + B S_d + C = 0``; the root that tends to the linear
    solution ``-C / B`` as the capstan vanishes is ``2 C / (-B + sqrt(B^2 - 4 A C))``. Taut
    while ``|D_s| <= 4 T0`` (and a real root exists); beyond, the loaded cable alone:
    ``S_s = |D_s| = |D_d| exp(mu_z sgn D_d)``, continuous with the taut branch."""
    del alpha
    c, s = np.cosh(mu_z), np.sinh(mu_z)
    dc = d_in * c
    inv = 1.0 / (8.0 * t0)
    a = s * s * inv
    b = -c + 2.0 * s * dc * inv
    cc = 2.0 * t0 - d_in * s + dc * dc * inv
    disc = b * b - 4.0 * a * cc
    root = np.sqrt(np.maximum(disc, 0.0))
    s_dist = 2.0 * cc / (-b + root)
    d_sh = s_dist * s + dc
    s_sh = 2.0 * t0 + d_sh * d_sh * inv
    is_slack = np.zeros(np.broadcast(d_in, t0).shape, dtype=bool)
    if slack:
        is_slack = (np.abs(d_sh) > 4.0 * t0) | (disc < 0.0)
        tight = np.abs(d_in) * np.exp(mu_z * np.sign(d_in))
        s_sh = np.where(is_slack, tight, s_sh)
        d_sh = np.where(is_slack, np.sign(d_in) * tight, d_sh)
    return s_sh, d_sh, is_slack
