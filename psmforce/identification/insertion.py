"""The insertion joint's internal effort, and the axial tip force it reveals.

The insertion joint is prismatic along the shaft, so its effort sees the external force's shaft
component directly: with ``d`` the unit shaft direction (base frame, towards the tip; the HEX10
z axis) and ``F`` the force the environment applies on the tool,

    tau_ins = -d . F + g_b . d + F_c tanh(v / v_s) + b v + c           (N; effort = what the motor
    applies)

``g_b . d`` is the gravity of everything the insertion stage carries (mass x gravity vector in
the base frame, 3 parameters, so no upright assumption), then the carriage's Coulomb (smooth
sign over v_s), viscous and offset terms of :mod:`psmforce.identification.friction` (no
Stribeck). Inertia (``m a``, below 0.1 N at teleoperation
accelerations) and the centripetal load of yaw/pitch rates are left out: the model stays
instantaneous, so a streaming loop needs no history. Everything is linear in the parameters
``(g_b, F_c, b, c)``, fitted by least squares on recordings whose external force is known
(``ati_fz``: the force in the HEX10 frame, whose z is ``d``); ``v_s`` is chosen among
:data:`SMOOTH_SIGN_CANDIDATES_MPS` by leave-recordings-out cross-validation.

The estimate ``d . F = internal(d, v) - tau_ins`` is in N, along the HEX10 z axis (tip-ward
positive, so a press on the jaw tip reads negative, like ``ati_fz``). It extrapolates to unseen
arm configurations through ``d`` because gravity enters as physics, not as a learned function of
the joint angles.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.friction import TERMS, FrictionShape, friction_regressor
from psmforce.identification.signals import check_finite_2d

SMOOTH_SIGN_CANDIDATES_MPS = (0.002, 0.005, 0.02, 0.05)
"""Coulomb transition velocities tried (m/s): from a stiff carriage to a compliant cable drive."""
_FOLDS = 5
NAMES = ("gravity_x", "gravity_y", "gravity_z", "coulomb", "viscous", "offset")
UNITS = ("N", "N", "N", "N", "N s/m", "N")


_FRICTION_COLUMNS = [TERMS.index(t) for t in ("coulomb", "viscous", "offset")]


def _regressors(d_shaft: np.ndarray, velocity: np.ndarray, smooth_sign_mps: float) -> np.ndarray:
    friction = friction_regressor(velocity, FrictionShape(smooth_sign_velocity=smooth_sign_mps))
    return np.column_stack([d_shaft, friction[:, _FRICTION_COLUMNS]])


@dataclass(frozen=True)
class InsertionEffortModel:
    """Fitted internal insertion effort; ``params`` in :data:`NAMES` order."""

    params: tuple[float, ...]
    smooth_sign_mps: float
    info: dict

    def internal(self, d_shaft, velocity_mps) -> np.ndarray:
        """(N,) effort (N) with no external force, from the shaft direction (N, 3) (base frame,
        unit) and the insertion velocity (N,) in m/s."""
        d = check_finite_2d(d_shaft, "shaft direction", width=3)
        v = np.asarray(velocity_mps, dtype=float).reshape(-1)
        if len(v) != len(d) or not np.isfinite(v).all():
            raise IdentificationInputError(f"insertion velocity must be {len(d)} finite values")
        return _regressors(d, v, self.smooth_sign_mps) @ np.asarray(self.params)

    def axial_force(self, d_shaft, velocity_mps, effort_N) -> np.ndarray:
        """(N,) external force along the shaft (N, HEX10 z): ``internal - effort``."""
        tau = np.asarray(effort_N, dtype=float).reshape(-1)
        internal = self.internal(d_shaft, velocity_mps)
        if len(tau) != len(internal) or not np.isfinite(tau).all():
            raise IdentificationInputError(f"insertion effort must be {len(internal)} finite values")
        return internal - tau

    def axial_force_one(self, d_shaft, velocity_mps: float, effort_N: float) -> float:
        """One sample in pure Python floats (the streaming path)."""
        gx, gy, gz, fc, b, c = self.params
        return (gx * d_shaft[0] + gy * d_shaft[1] + gz * d_shaft[2]
                + fc * math.tanh(velocity_mps / self.smooth_sign_mps) + b * velocity_mps + c
                - effort_N)

    @classmethod
    def fit(cls, d_shaft: list, velocity_mps: list, effort_N: list, axial_force_N: list
            ) -> InsertionEffortModel:
        """Least squares over recordings (lists of per-recording arrays): ``effort + axial
        force = internal``. ``v_s`` by cross-validation over recordings."""
        if not (len(d_shaft) == len(velocity_mps) == len(effort_N) == len(axial_force_N)) or \
                not d_shaft:
            raise IdentificationInputError("need the same non-zero number of recordings for "
                                           "shaft direction, velocity, effort and axial force")
        d = [check_finite_2d(x, "shaft direction", width=3) for x in d_shaft]
        arrays = []
        for name, xs in (("insertion velocity", velocity_mps), ("insertion effort", effort_N),
                         ("axial force", axial_force_N)):
            arrays.append([np.asarray(x, dtype=float).reshape(-1) for x in xs])
            for x, dd in zip(arrays[-1], d):
                if len(x) != len(dd) or not np.isfinite(x).all():
                    raise IdentificationInputError(f"{name}: {len(dd)} finite values expected")
        v, tau, f = arrays
        y = [t + a for t, a in zip(tau, f)]
        fold = np.arange(len(d)) % _FOLDS
        cv = {}
        for vs in SMOOTH_SIGN_CANDIDATES_MPS:
            x = [_regressors(dd, vv, vs) for dd, vv in zip(d, v)]
            if len(d) < 2:
                cv[vs] = float("nan")
                continue
            sq, count = 0.0, 0
            for k in range(min(_FOLDS, len(d))):
                fit_idx = [i for i in range(len(d)) if fold[i] != k]
                theta = np.linalg.lstsq(np.vstack([x[i] for i in fit_idx]),
                                        np.concatenate([y[i] for i in fit_idx]), rcond=None)[0]
                for i in np.flatnonzero(fold == k):
                    sq += float(((x[i] @ theta - y[i]) ** 2).sum())
                    count += len(y[i])
            cv[vs] = math.sqrt(sq / count)
        best = min(cv, key=lambda k: (math.isnan(cv[k]), cv[k]))
        x = np.vstack([_regressors(dd, vv, best) for dd, vv in zip(d, v)])
        yy = np.concatenate(y)
        if np.linalg.matrix_rank(x) < x.shape[1]:
            raise IdentificationInputError("the recordings do not excite the insertion model "
                                           "(shaft direction or insertion velocity constant)")
        theta = np.linalg.lstsq(x, yy, rcond=None)[0]
        info = {"cv_rmse_N_by_smooth_sign_mps": {str(k): val for k, val in cv.items()},
                "train_rmse_N": float(np.sqrt(np.mean((x @ theta - yy) ** 2))),
                "n_samples": int(len(yy)), "n_recordings": len(d)}
        return cls(tuple(float(t) for t in theta), float(best), info)

    def to_dict(self) -> dict:
        return {"model": "psmforce/identification/insertion.py module docstring",
                "smooth_sign_mps": self.smooth_sign_mps,
                "parameters": {n: {"value": p, "unit": u} for n, u, p in zip(NAMES, UNITS, self.params)},
                "info": self.info}

    @classmethod
    def from_dict(cls, d: dict) -> InsertionEffortModel:
        try:
            params = tuple(float(d["parameters"][n]["value"]) for n in NAMES)
            vs = float(d["smooth_sign_mps"])
        except (KeyError, TypeError, ValueError) as exc:
            raise IdentificationInputError(f"insertion model: missing or bad entry ({exc})") from exc
        if not (all(map(math.isfinite, params)) and vs > 0):
            raise IdentificationInputError("insertion model: non-finite parameter or v_s <= 0")
        return cls(params, vs, dict(d.get("info", {})))
