"""Friction models as reusable pieces, identical in numpy, CasADi and torch.

Per coordinate (a joint, or a coupled coordinate such as one instrument motor), velocity v
(rad/s or m/s), the friction torque (Nm or N, the torque the actuator spends on friction, so it
has the sign of v) is linear in its parameters::

    tau_f = Fc * s(v) + Fv * v + Fs * s(v) * exp(-(v / vs)^2) + Fo
    s(v)  = tanh(v / v_eps)                       (smooth sign)

* ``Fc`` Coulomb level, ``Fv`` viscous coefficient, ``Fs`` Stribeck excess (static minus
  Coulomb; optional), ``Fo`` constant offset (current-sensor bias, unmodelled static load).
* ``v_eps`` (smooth-sign velocity scale) and ``vs`` (Stribeck velocity) are fixed shape constants,
  not fitted, so that the model stays linear in (Fc, Fv, Fs, Fo) and the identification problem is a
  least-squares problem in those.

``TERMS`` is the column order of :func:`friction_regressor` and of every parameter vector here.
Physical bounds used by the fits: Fc >= 0, Fv >= 0, Fs >= 0; Fo free.

Pre-sliding hysteresis (:func:`maxwell_slip_states`): a Maxwell-slip model (Lampaert, Al-Bender,
Swevers 2003), m elasto-plastic elements in parallel, element i sticking until the coordinate has
moved ``delta_i`` (rad or m) since the last reversal and slipping at its level ``F_i`` after::

    tau_h = sum_i F_i z_i,   z_i(t) = clip(z_i(t - 1) + (x(t) - x(t - 1)) / delta_i, -1, 1)

z_i is dimensionless and has the sign of the recent motion, so ``F_i >= 0`` (Nm or N) is
friction the actuator spends, like Coulomb. The breakaway displacements are fixed (a log-spaced
grid), which keeps the model linear in F_i. Unlike the smooth sign, whose transition is a
velocity band, z turns over a travel after each reversal, whatever the speed: the hysteresis of
cable and belt transmissions (cable stretch and pulley pre-sliding) in the torque-position
plane. z depends on the position history, so it is computed along a time-ordered contiguous
sequence, from the relaxed state z = 0 at its first sample.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from psmforce.identification.errors import IdentificationInputError

TERMS = ("coulomb", "viscous", "stribeck", "offset")
"""Parameter / regressor column order."""

TERM_UNITS = {"coulomb": "Nm", "viscous": "Nm s/rad", "stribeck": "Nm", "offset": "Nm"}
"""Units for a revolute coordinate (N, N s/m for a prismatic one)."""

LOWER_BOUNDS = {"coulomb": 0.0, "viscous": 0.0, "stribeck": 0.0, "offset": -np.inf}


@dataclass(frozen=True)
class FrictionShape:
    """Fixed shape constants of the friction model (same units as the velocity)."""

    smooth_sign_velocity: float = 0.01
    """v_eps: velocity at which tanh reaches 76 % of the Coulomb level."""
    stribeck_velocity: float = 0.05
    """vs: velocity scale of the Stribeck decay."""

    def __post_init__(self):
        if not (self.smooth_sign_velocity > 0 and self.stribeck_velocity > 0):
            raise IdentificationInputError("friction shape velocities must be > 0")


def friction_regressor(velocity, shape: FrictionShape = FrictionShape()) -> np.ndarray:
    """Columns of the friction model, (N, k, 4) for velocities (N, k) (or (N, 4) for (N,)).

    ``friction_regressor(v) @ p`` (p of length 4 in :data:`TERMS` order) is the friction torque.
    """
    v = np.asarray(velocity, dtype=float)
    s = np.tanh(v / shape.smooth_sign_velocity)
    return np.stack([s, v, s * np.exp(-(v / shape.stribeck_velocity) ** 2), np.ones_like(v)],
                    axis=-1)


def friction_torque(velocity, params, shape: FrictionShape = FrictionShape()) -> np.ndarray:
    """Friction torque (N, k) for velocities (N, k) and params (k, 4) (or (N,) with (4,))."""
    p = np.asarray(params, dtype=float)
    return np.einsum("...t,...t->...", friction_regressor(velocity, shape), p)


def friction_torque_casadi(velocity, params, shape: FrictionShape = FrictionShape()):
    """CasADi expression of the same model for one coordinate: velocity (SX/MX/DM scalar or
    column), params a length-4 vector in :data:`TERMS` order."""
    import casadi as ca

    s = ca.tanh(velocity / shape.smooth_sign_velocity)
    return (params[0] * s + params[1] * velocity
            + params[2] * s * ca.exp(-(velocity / shape.stribeck_velocity) ** 2) + params[3])


def friction_torque_torch(velocity, params, shape: FrictionShape = FrictionShape()):
    """Torch version (differentiable in velocity and params): velocity (..., k), params (k, 4)."""
    import torch

    s = torch.tanh(velocity / shape.smooth_sign_velocity)
    cols = torch.stack([s, velocity, s * torch.exp(-(velocity / shape.stribeck_velocity) ** 2),
                        torch.ones_like(velocity)], dim=-1)
    return (cols * params).sum(dim=-1)


def maxwell_slip_states(position, breakaway) -> np.ndarray:
    """Maxwell-slip element states z (N, m) in [-1, 1] along a time-ordered contiguous position
    sequence (N,) (rad or m), for breakaway displacements (m,) in the same unit; z = 0 at the
    first sample (module docstring)."""
    x = np.asarray(position, dtype=float)
    delta = np.asarray(breakaway, dtype=float)
    if x.ndim != 1 or delta.ndim != 1 or not (np.isfinite(delta).all() and (delta > 0).all()):
        raise IdentificationInputError("maxwell_slip_states: position (N,) and breakaway "
                                       "displacements (m,) > 0")
    step = np.diff(x, prepend=x[:1])[:, None] / delta[None, :]
    z = np.empty((len(x), len(delta)))
    zi = np.zeros(len(delta))
    for i, s in enumerate(step):  # clipping makes it a scan, not a cumulative sum
        zi = np.clip(zi + s, -1.0, 1.0)
        z[i] = zi
    return z
