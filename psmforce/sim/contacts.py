"""Contact laws between the jaw tip and the bench fixtures, vectorised over time.

All positions/velocities are of the jaw tip in the PSM base (RCM) frame, m and m/s, shaped (N, 3).
Every function returns the force the fixture applies ON THE TOOL (N, 3) in the base frame, N.
"""

from __future__ import annotations

import math
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
    """Coulomb coefficient mu: the shear a sticking contact can hold is at most mu F_n."""


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

POISSON_RATIO = 0.5
"""Silicone rubber and the printed plate's contact layer are treated as incompressible."""
MINDLIN_RATIO = 2.0 * (1.0 - POISSON_RATIO) / (2.0 - POISSON_RATIO)
"""Tangential / normal contact stiffness of a sticking circular contact (Mindlin 1949):
dF_t/du_t = MINDLIN_RATIO dF_n/dd, so 2/3 for nu = 0.5."""


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

    ``p_tip`` / ``v_tip`` are one recording in time order (the tangential law has memory).
    Normal: Hunt-Crossley, clipped at zero (a block cannot pull). Tangential: elasto-plastic
    stick-slip. Each contact episode (consecutive samples with penetration) starts stuck where
    the tip landed; the shear grows with the tangential tip displacement through the Mindlin
    stiffness k_t(d) = MINDLIN_RATIO * n k d^(n-1) and is capped at mu F_n (sliding). The shear is
    held while the tip dwells and is lost when the tip leaves the surface.
    """
    n = normal / np.linalg.norm(normal)
    depth = (point - p_tip) @ n
    rate = -(v_tip @ n)
    inside = depth > 0
    dpos = np.where(inside, depth, 0.0)
    fn = material.stiffness * dpos ** material.exponent * (1.0 + 1.5 * material.damping * rate)
    fn = np.where(inside, np.maximum(fn, 0.0), 0.0)
    force = fn[:, None] * n[None, :]
    if friction and inside.any():
        tangents = _tangent_basis(n)
        step_t = np.diff(p_tip, axis=0, prepend=p_tip[:1]) @ tangents.T
        k_t = MINDLIN_RATIO * material.exponent * material.stiffness * dpos ** (material.exponent - 1.0)
        force = force + _stick_slip(step_t, k_t, material.friction * fn, inside) @ tangents
    return force


def _tangent_basis(n: np.ndarray) -> np.ndarray:
    """(2, 3) orthonormal tangent directions of the plane with unit normal ``n``."""
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(n, helper)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(n, e1)])


def _stick_slip(step_t: np.ndarray, k_t: np.ndarray, cap: np.ndarray, inside: np.ndarray) -> np.ndarray:
    """Shear (N, 2) on the tool in tangent coordinates: F <- F - k_t du, then |F| <= cap.

    A return-mapping (elasto-plastic) scan; sequential by nature, so it runs over the in-contact
    samples only, on Python floats."""
    idx = np.flatnonzero(inside)
    fx = fy = 0.0
    last = -2
    out_x, out_y = [], []
    for i, sx, sy, k, c in zip(idx.tolist(), step_t[idx, 0].tolist(), step_t[idx, 1].tolist(),
                               k_t[idx].tolist(), cap[idx].tolist()):
        if i == last + 1:
            fx -= k * sx
            fy -= k * sy
        else:  # a new episode: stuck where the tip landed
            fx = fy = 0.0
        mag = math.hypot(fx, fy)
        if mag > c:
            fx, fy = fx * c / mag, fy * c / mag
        out_x.append(fx)
        out_y.append(fy)
        last = i
    shear = np.zeros((len(k_t), 2))
    shear[idx, 0] = out_x
    shear[idx, 1] = out_y
    return shear
