"""Force frame changes used by the seed paper: base (RCM) <-> roll <-> HEX10, and ATI -> HEX10.

Forces are 3-vectors in N, shape (3,) or (N,3); only their components change (a force is a free
vector: no reference point). ``q``: (6,), (7,), (N,6) or (N,7) joint vectors (see
:class:`psmforce.robot.PSM`); a single ``q`` applies to every force, otherwise force and ``q`` batches
must have the same N. Rotations ``R_a_b`` hold the axes of frame b in frame a, so
``f_a = R_a_b f_b``:

* ``R_PSM_Roll(q) = psm.rotation(q, "roll")`` (DH frame 4, turns with roll),
* ``R_Roll_HEX10 = psm.R_roll_hex10`` (constant: the HEX10 clocking about the shaft),
* ``R_ati_PSM``: the ATI Nano17 axes relative to the PSM base, a calibration input (3,3).

The paper's eq. 2-3: ``F' = [R_PSM_Roll R_Roll_HEX10]^T F`` (:func:`base_to_hex10`) and eq. 4:
``F'_ATI = [R_ati_PSM R_PSM_Roll R_Roll_HEX10]^T F_ATI`` (:func:`ati_force_in_hex10`).

The frames' names, gravity and where a wrench or Jacobian is expressed (``expressed_in``:
``"base"``, ``"base_at_frame"``, ``"frame"``) are written once in :mod:`psmforce.robot.conventions`,
which ``PSM`` imports (so they cannot live here, beside these functions that need ``PSM``).
"""

from __future__ import annotations

import numpy as np

from psmforce.robot.kinematics import PSM, KinematicsInputError, default_psm


def base_to_roll(force_base, q, psm: PSM | None = None) -> np.ndarray:
    """Force in the base frame -> roll frame: ``R_PSM_Roll(q)^T f``."""
    psm = psm or default_psm()
    return _apply(np.swapaxes(psm.rotation(q, "roll"), -1, -2), force_base, "force_base")


def roll_to_base(force_roll, q, psm: PSM | None = None) -> np.ndarray:
    """Force in the roll frame -> base frame: ``R_PSM_Roll(q) f``."""
    psm = psm or default_psm()
    return _apply(psm.rotation(q, "roll"), force_roll, "force_roll")


def roll_to_hex10(force_roll, psm: PSM | None = None) -> np.ndarray:
    """Force in the roll frame -> HEX10 frame: ``R_Roll_HEX10^T f`` (no q: both on the shaft)."""
    psm = psm or default_psm()
    return _apply(psm.R_roll_hex10.T, force_roll, "force_roll")


def hex10_to_roll(force_hex10, psm: PSM | None = None) -> np.ndarray:
    """Force in the HEX10 frame -> roll frame: ``R_Roll_HEX10 f``."""
    psm = psm or default_psm()
    return _apply(psm.R_roll_hex10, force_hex10, "force_hex10")


def base_to_hex10(force_base, q, psm: PSM | None = None) -> np.ndarray:
    """Force in the base frame -> HEX10 frame (paper eq. 3): ``[R_PSM_Roll R_Roll_HEX10]^T f``."""
    psm = psm or default_psm()
    return _apply(np.swapaxes(psm.rotation(q, "hex10"), -1, -2), force_base, "force_base")


def hex10_to_base(force_hex10, q, psm: PSM | None = None) -> np.ndarray:
    """Force in the HEX10 frame -> base frame: ``R_PSM_Roll R_Roll_HEX10 f``."""
    psm = psm or default_psm()
    return _apply(psm.rotation(q, "hex10"), force_hex10, "force_hex10")


def ati_force_in_hex10(force_ati, q, R_ati_psm, psm: PSM | None = None, *,
                       sign: float = 1.0) -> np.ndarray:
    """ATI force (N) in the ATI frame -> the HEX10 frame, paper eq. 4.

    ``F'_ATI = sign * [R_ati_PSM R_PSM_Roll(q) R_Roll_HEX10]^T F_ATI``. ``R_ati_psm`` (3,3): the PSM
    base axes expressed in the ATI frame (calibration). ``sign`` = +1 when ``force_ati`` already is
    the force applied by the environment on the tool (eq. 4 as printed); -1 when it is the ATI's
    own reading, i.e. the force the tool applies on the sensor (Newton's third law). The result is
    the recording's target ``ati_fx, ati_fy, ati_fz`` (force on the tool, HEX10 frame).
    """
    psm = psm or default_psm()
    R = check_rotation(R_ati_psm, "R_ati_psm")
    if sign not in (1.0, -1.0):
        raise KinematicsInputError(f"sign must be +1 or -1, got {sign!r}")
    R_ati_hex10 = R @ psm.rotation(q, "hex10")
    return sign * _apply(np.swapaxes(R_ati_hex10, -1, -2), force_ati, "force_ati")


def _apply(R: np.ndarray, force, name: str) -> np.ndarray:
    """R (3,3) or (N,3,3) times force (3,) or (N,3); batches must agree unless one is single."""
    f = np.asarray(force, dtype=float)
    if f.ndim not in (1, 2) or f.shape[-1] != 3:
        raise KinematicsInputError(f"{name} must have shape (3,) or (N,3); got {f.shape}")
    if not np.isfinite(f).all():
        row = int(np.argwhere(~np.isfinite(np.atleast_2d(f)))[0, 0])
        raise KinematicsInputError(f"{name} has a non-finite value at sample {row}")
    if R.ndim == 3 and f.ndim == 2 and R.shape[0] != f.shape[0]:
        raise KinematicsInputError(
            f"{name} has {f.shape[0]} samples but q has {R.shape[0]}")
    return np.einsum("...ij,...j->...i", R, f)


def check_rotation(R, name: str) -> np.ndarray:
    """``R`` as a (3, 3) float array if it is a finite proper rotation, else
    KinematicsInputError naming it ``name``."""
    R = np.asarray(R, dtype=float)
    if R.shape != (3, 3):
        raise KinematicsInputError(f"{name} must have shape (3,3); got {R.shape}")
    if not np.isfinite(R).all():
        raise KinematicsInputError(f"{name} has non-finite entries")
    if not (np.allclose(R.T @ R, np.eye(3), atol=1e-6) and np.linalg.det(R) > 0):
        raise KinematicsInputError(f"{name} is not a proper rotation matrix (R^T R = I, det = +1)")
    return R
