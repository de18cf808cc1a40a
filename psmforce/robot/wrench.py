"""External wrench from joint torques, for any Pinocchio model, vectorised over samples.

Convention: the wrench ``w = [f; m]`` (N; Nm) is applied BY the environment ON the body that
carries the frame, and ``tau = J^T w`` are the joint torques it exerts, with ``J`` the frame
Jacobian for the same reference point and axes (``expressed_in``, the vocabulary of
:mod:`psmforce.robot.conventions`; the base is the model's world):

* ``"base"``: Pinocchio WORLD, moment about the base origin, base axes (spatial wrench);
* ``"base_at_frame"``: Pinocchio LOCAL_WORLD_ALIGNED, moment about the frame's origin, base axes;
* ``"frame"``: Pinocchio LOCAL, moment about the frame's origin, the frame's axes.

``"world"`` and ``"world_at_frame"``, the earlier names, still work for one release and warn.

Motor torques that hold the load in statics are ``-J^T w`` (Pinocchio: ``rnea(q, 0, 0, fext)``
without gravity), so pass their negative to get the wrench on the robot.

Solving ``J^T w = tau`` (``J`` is 6 x nv) uses the SVD ``J = U S V^T``:
``w = U diag(s / (s^2 + lambda^2)) V^T tau``, the least-squares solution (exact when nv = 6 and J
is regular, least-squares for redundant robots). Damping switches on only near singularities:
``lambda^2 = max_damping^2 * (1 - (sigma_min / sigma_threshold)^2)`` when the smallest of the six
singular values ``sigma_min`` is below ``sigma_threshold``, else 0 (continuous in sigma_min). The
singular values carry the Jacobian's mixed units (m for the moment arms, 1 for axes), so the
threshold is in those units; the defaults suit arms whose lever arms are centimetres to a metre.
With fewer than six joints the wrench is not identifiable: sigma_min is 0 and every sample is
reported as damped.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from psmforce.robot.conventions import EXPRESSED_IN, canonical_expressed_in

DEFAULT_SIGMA_THRESHOLD = 1e-3
"""Smallest singular value of J below which damping switches on (Jacobian units: m or 1)."""

DEFAULT_MAX_DAMPING = 1e-3
"""Damping lambda reached when sigma_min = 0."""


class WrenchInputError(ValueError):
    """Shapes, values or names that cannot be used; the message names the problem."""


@dataclass(frozen=True)
class WrenchConditioning:
    """How well each sample's wrench is determined by its torques; arrays of shape (N,) or ().

    ``sigma_min`` / ``sigma_max``: smallest / largest of the six singular values of J (0 when the
    model has fewer than six joints); ``condition_number`` = sigma_max / sigma_min (inf when 0);
    ``damping``: the lambda used; ``damped``: True where sigma_min < ``sigma_threshold`` (the
    result is biased towards small wrenches there); ``residual``: |J^T w - tau| (Nm or N), non-zero
    where the torques are not explained by any wrench (redundant robots, damping).
    """

    sigma_min: np.ndarray
    sigma_max: np.ndarray
    condition_number: np.ndarray
    damping: np.ndarray
    damped: np.ndarray
    residual: np.ndarray
    sigma_threshold: float

    def sample(self, index: int) -> WrenchConditioning:
        """The report of one sample (fields of shape ())."""
        return WrenchConditioning(
            self.sigma_min[index], self.sigma_max[index], self.condition_number[index],
            self.damping[index], self.damped[index], self.residual[index], self.sigma_threshold)


def solve_wrench(jacobian: np.ndarray, tau: np.ndarray, *,
                 sigma_threshold: float = DEFAULT_SIGMA_THRESHOLD,
                 max_damping: float = DEFAULT_MAX_DAMPING) -> tuple[np.ndarray, WrenchConditioning]:
    """Solve ``J^T w = tau`` for a batch: J (N,6,nv), tau (N,nv) -> w (N,6) and the conditioning.

    See the module docstring for the damping law.
    """
    J = np.asarray(jacobian, dtype=float)
    tau = np.asarray(tau, dtype=float)
    if J.ndim != 3 or J.shape[1] != 6:
        raise WrenchInputError(f"jacobian must have shape (N,6,nv); got {J.shape}")
    if tau.shape != (J.shape[0], J.shape[2]):
        raise WrenchInputError(
            f"tau must have shape {(J.shape[0], J.shape[2])} to match the jacobian; got {tau.shape}")
    if not (np.isfinite(sigma_threshold) and np.isfinite(max_damping)
            and sigma_threshold >= 0.0 and max_damping >= 0.0):
        raise WrenchInputError(f"sigma_threshold and max_damping must be finite and >= 0; got "
                               f"{sigma_threshold!r}, {max_damping!r}")
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    n_sv = s.shape[1]
    sigma_max = s[:, 0]
    sigma_min = s[:, -1] if n_sv == 6 else np.zeros(J.shape[0])
    ratio = (np.clip(sigma_min / sigma_threshold, 0.0, 1.0) if sigma_threshold > 0
             else np.ones_like(sigma_min))
    damping_sq = max_damping ** 2 * (1.0 - ratio ** 2)
    damped = sigma_min < sigma_threshold
    with np.errstate(divide="ignore", invalid="ignore"):
        gain = np.where(s > 0, s / (s ** 2 + damping_sq[:, None]), 0.0)
        condition = np.where(sigma_min > 0, sigma_max / sigma_min, np.inf)
    w = np.einsum("nik,nk->ni", U, gain * np.einsum("nkj,nj->nk", Vt, tau))
    residual = np.linalg.norm(np.einsum("nij,ni->nj", J, w) - tau, axis=1)
    info = WrenchConditioning(sigma_min, sigma_max, condition, np.sqrt(damping_sq), damped,
                              residual, float(sigma_threshold))
    return w, info


_PINOCCHIO_REFERENCE = {"base": pin.ReferenceFrame.WORLD,
                        "base_at_frame": pin.ReferenceFrame.LOCAL_WORLD_ALIGNED,
                        "frame": pin.ReferenceFrame.LOCAL}


def wrench_from_torques(model: pin.Model, q, tau, frame: str, *, tau_internal=None,
                        expressed_in: str = "base", return_info: bool = False,
                        sigma_threshold: float = DEFAULT_SIGMA_THRESHOLD,
                        max_damping: float = DEFAULT_MAX_DAMPING):
    """External wrench [f; m] on the body carrying ``frame``, from joint torques (``J^T w = tau``).

    ``q``: (nq,) or (N,nq); ``tau`` and ``tau_internal``: (nv,) or (N,nv) (Nm / N). Returns (6,) or
    (N,6), plus a :class:`WrenchConditioning` with ``return_info=True``. ``expressed_in``:
    ``"base"``, ``"base_at_frame"`` or ``"frame"`` (module docstring). The Jacobians come from
    one Pinocchio call per sample; the solve is batched.
    """
    if not isinstance(frame, str) or not model.existFrame(frame):
        raise WrenchInputError(f"unknown frame {frame!r} in model '{model.name}'")
    expressed_in = canonical_expressed_in(expressed_in)
    if expressed_in not in EXPRESSED_IN:
        raise WrenchInputError(f"expressed_in must be one of {EXPRESSED_IN}, got {expressed_in!r}")
    qs = _batch(q, model.nq, "q")
    tau_net = _batch(tau, model.nv, "tau", qs.shape[0])
    if tau_internal is not None:
        tau_net = tau_net - _batch(tau_internal, model.nv, "tau_internal", qs.shape[0])
    data = model.createData()
    frame_id = model.getFrameId(frame)
    J = np.empty((qs.shape[0], 6, model.nv))
    for k, qk in enumerate(qs):
        J[k] = pin.computeFrameJacobian(model, data, qk, frame_id,
                                        _PINOCCHIO_REFERENCE[expressed_in])
    w, info = solve_wrench(J, tau_net, sigma_threshold=sigma_threshold, max_damping=max_damping)
    if np.ndim(q) == 1:
        w, info = w[0], info.sample(0)
    return (w, info) if return_info else w


def _batch(x, width: int, name: str, n: int | None = None) -> np.ndarray:
    arr = np.asarray(x, dtype=float)
    if arr.ndim not in (1, 2) or arr.shape[-1] != width:
        raise WrenchInputError(f"{name} must have shape ({width},) or (N,{width}); got {arr.shape}")
    arr = np.atleast_2d(arr)
    if n is not None and arr.shape[0] != n:
        raise WrenchInputError(f"{name} has {arr.shape[0]} sample(s) but q has {n}")
    if not np.isfinite(arr).all():
        row, col = np.argwhere(~np.isfinite(arr))[0]
        raise WrenchInputError(f"{name} has a non-finite value at sample {row}, index {col}")
    return arr
