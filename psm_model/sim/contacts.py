"""Contact laws between the jaw tip and the bench fixtures, vectorised over time.

All positions/velocities are of the jaw tip in the PSM base (RCM) frame, m and m/s, shaped (N, 3).
Every function returns the force the fixture applies ON THE TOOL (N, 3) in the base frame, N.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

TRACTION_SPRING_N_PER_M = 154.0
"""Paper: linear spring element of 0.154 N/mm, in series with a nylon string."""


@dataclass(frozen=True)
class Material:
    """Hunt-Crossley contact: F_n = k d^n (1 + 1.5 c d_dot) for penetration d > 0 (never pulls)."""

    name: str
    stiffness: float
    """k in N / m^n."""
    exponent: float
    damping: float
    """c in s/m (Hunt-Crossley alpha)."""
    friction: float
    """Coulomb coefficient of the tangential friction (regularised)."""


# Stiffness chosen so that the paper's 8 mm palpation depth gives about 4 / 1.9 / 0.6 N
# (test-set axial range -4.1 N): F(8 mm) = k * 0.008^1.5. Docs list the derivation.
MATERIALS = {
    "shore_22a": Material("shore_22a", 4.0 / 0.008 ** 1.5, 1.5, 0.3, 0.8),
    "shore_8a": Material("shore_8a", 1.9 / 0.008 ** 1.5, 1.5, 0.5, 0.9),
    "shore_00_10": Material("shore_00_10", 0.6 / 0.008 ** 1.5, 1.5, 1.0, 1.0),
    "rigid": Material("rigid", 2500.0, 1.0, 0.05, 0.3),
}
"""Silicone blocks of the automated protocol and the teleoperation interfaces (rigid: printed
plate on the ATI, 2.5 N/mm with the tool's own compliance in series)."""

_SLIP_VELOCITY = 2e-3
"""m/s; regularisation of the friction direction (micro-slip on a compliant surface)."""


def traction(p_tip: np.ndarray, anchor: np.ndarray, rest_length: float,
             stiffness: float = TRACTION_SPRING_N_PER_M) -> np.ndarray:
    """Spring + string from the jaw-tip hook to the anchor (D-ring on the ATI fixture).

    F = -k max(0, |p - a| - L0) (p - a) / |p - a|: pulls towards the anchor, a string cannot push.
    """
    d = p_tip - anchor
    length = np.linalg.norm(d, axis=1, keepdims=True)
    stretch = np.maximum(length - rest_length, 0.0)
    return -stiffness * stretch * d / np.maximum(length, 1e-9)


def surface(p_tip: np.ndarray, v_tip: np.ndarray, point: np.ndarray, normal: np.ndarray,
            material: Material, friction: bool = True) -> np.ndarray:
    """Nonlinear viscoelastic contact with the plane through ``point`` with outward ``normal``.

    Normal: Hunt-Crossley, clipped at zero (a block cannot pull). Tangential: Coulomb friction
    mu F_n opposing the tangential slip velocity, regularised v_t / sqrt(|v_t|^2 + v_s^2).
    """
    n = normal / np.linalg.norm(normal)
    depth = (point - p_tip) @ n
    rate = -(v_tip @ n)
    inside = depth > 0
    dpos = np.where(inside, depth, 0.0)
    fn = material.stiffness * dpos ** material.exponent * (1.0 + 1.5 * material.damping * rate)
    fn = np.where(inside, np.maximum(fn, 0.0), 0.0)
    force = fn[:, None] * n[None, :]
    if friction:
        vt = v_tip - (v_tip @ n)[:, None] * n[None, :]
        speed = np.sqrt((vt ** 2).sum(axis=1) + _SLIP_VELOCITY ** 2)
        force = force - material.friction * (fn / speed)[:, None] * vt
    return force
