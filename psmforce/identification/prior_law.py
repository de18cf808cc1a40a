"""The internal-force prior's law: parameters with their physical bounds and the vectorised
model (numpy or CasADi), as described in :mod:`psmforce.identification.prior`. Its own module so
that the fit (``prior.py``) and its identifiability report (``prior_identifiability.py``) read
one law without importing each other.
"""

from __future__ import annotations

import math

import numpy as np

from psmforce.identification.cable_pair import tension_sum

KAPPA = 0.8306 / 1.0186
CABLE_ANGLES_RAD = np.deg2rad([0.0, 60.0, 120.0])
SMOOTH_MAX_N = 0.05
"""Width (N) of the smooth max between 2 T0 and |D| (slack transition)."""
DIRECTION_VELOCITY = 0.02
"""v_eps (rad/s of cable coordinate per metre of radius) of the friction-direction smooth sign."""
# name, unit, lower, upper, initial
PARAMETERS = (
    ("pretension_total", "N", 0.0, 60.0, 5.0),
    ("pulley_radius_pitch", "m", 0.5e-3, 5e-3, 1.8e-3),
    ("pulley_radius_blade", "m", 0.5e-3, 5e-3, 1.8e-3),
    ("twist_gain", "1/rad^2", 0.0, 0.5, 0.01),
    ("direction_tension", "N", -2.0, 2.0, 0.0),
    ("asymmetry_pitch", "1", -0.8, 0.8, 0.0),
    ("asymmetry_blade", "1", -0.8, 0.8, 0.0),
    ("pitch_path_tension", "N", 0.0, 10.0, 0.1),
    ("distal_mass", "kg", 0.0, 0.05, 0.005),
    ("distal_com_distance", "m", -0.05, 0.05, 0.02),
    ("cable_radius", "m", 0.0, 4e-3, 1e-3),
    ("bias_fx", "N", -5.0, 5.0, 0.0),
    ("bias_fy", "N", -5.0, 5.0, 0.0),
    # +-100 N (the HEX10 overload), not the +-5 N of the lateral biases: T_tot is both the rest
    # level and the slack threshold, and where the wrist efforts carry friction and disturbance
    # that the cables do not (docs/simulator.md section 8) the fit raises the threshold (no
    # spurious slack from effort noise) and bias_fz carries the level back. At +-5 N this bound
    # capped that split and the Free fit was worse than a constant on its own training fz
    # (studies/prior_accuracy.py; docs/identification.md section 2).
    ("bias_fz", "N", -100.0, 100.0, 0.0),
    ("bias_tx", "Nm", -0.5, 0.5, 0.0),
    ("bias_ty", "Nm", -0.5, 0.5, 0.0),
    ("bias_tz", "Nm", -0.5, 0.5, 0.0),
)
NAMES = tuple(p[0] for p in PARAMETERS)
MIN_SAMPLES = 200
"""Fewest samples (or slack samples) a fit or an identifiability verdict rests on."""
BOUND_TOLERANCE = 1e-3
"""A parameter within this fraction of its bounds' span of a bound is "at its bound": the one
rule of :func:`at_bound`, which the fit's ``info["bounds_hit"]``, the identifiability report and
the verdict line all use."""


def at_bound(params) -> np.ndarray:
    """(17,) bool: each parameter (SI, :data:`NAMES` order) within :data:`BOUND_TOLERANCE` of its
    bounds' span of its lower or upper bound."""
    p = np.asarray(params, dtype=float)
    lo = np.array([q[2] for q in PARAMETERS])
    hi = np.array([q[3] for q in PARAMETERS])
    return np.minimum(p - lo, hi - p) <= BOUND_TOLERANCE * (hi - lo)


def _model(p, pos, e, v, g_hex, xp):
    """Vectorised model; ``xp`` is numpy or a CasADi-like namespace (see ``_CasadiOps``)."""
    (T_tot, r_p, r_b, g_tw, c_dir, a_p, a_b, c_pm, m_d, l_d, rho,
     bfx, bfy, bfz, btx, bty, btz) = [p[i] for i in range(17)]
    roll, wrist_pitch = pos[0], pos[1]
    tau_p, tau_b1, tau_b2 = e[0], 0.5 * e[1] - e[2], 0.5 * e[1] + e[2]
    # u = K^-T tau_d: K^T = [[1,k,k],[0,1,0],[0,0,1]] -> u1 = tau_b1, u2 = tau_b2, u0 = tau_p - k(u1+u2)
    u1, u2 = tau_b1, tau_b2
    u0 = tau_p - KAPPA * (u1 + u2)
    D = (u0 / r_p, u1 / r_b, u2 / r_b)
    vp, vb1, vb2 = v[0], v[1] - 0.5 * v[2], v[1] + 0.5 * v[2]
    dx = (vp, KAPPA * vp + vb1, KAPPA * vp + vb2)
    two_t0 = T_tot / 3.0 * (1.0 + g_tw * roll * roll)
    # blade cables' path over the pitch pulleys: 4 cables each gain c_pm (1 - cos pitch)
    S_sum = 4.0 * c_pm * (1.0 - xp.cos(wrist_pitch))
    asym = (a_p, a_b, a_b)
    tx = 0.0
    ty = 0.0
    for i in range(3):
        S_sum = S_sum + tension_sum(two_t0 + asym[i] * D[i], D[i], SMOOTH_MAX_N, xp)
        S_sum = S_sum + c_dir * xp.tanh(dx[i] / DIRECTION_VELOCITY)
        tx = tx - rho * math.sin(CABLE_ANGLES_RAD[i]) * D[i]
        ty = ty + rho * math.cos(CABLE_ANGLES_RAD[i]) * D[i]
    gx, gy, gz = g_hex[0], g_hex[1], g_hex[2]
    fx = m_d * gx + bfx
    fy = m_d * gy + bfy
    fz = m_d * gz - S_sum + bfz
    # moment of the distal weight at l_d e_z: (0,0,l) x (m g) = l m (-gy, gx, 0)
    return fx, fy, fz, tx - l_d * m_d * gy + btx, ty + l_d * m_d * gx + bty, 0.0 * gz + btz


class _CasadiOps:
    def __init__(self):
        import casadi as ca

        self.sqrt, self.tanh, self.cos = ca.sqrt, ca.tanh, ca.cos
