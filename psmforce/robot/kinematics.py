"""Kinematics of the dVRK Classic PSM with the Cadiere forceps and the HEX10 shaft sensor.

Frames, units and signs are those of ``docs/conventions.md`` (values:
``psmforce.robot.conventions``); in short:

* Base frame = the remote centre of motion (RCM) = modified-DH frame 0 of the dVRK.
* ``cp``: the dVRK control point, exactly what the dVRK reports as the local ``measured_cp``
  (wrist-yaw DH frame times ``[[0,-1,0],[0,0,1],[-1,0,0]]``; at q = 0 its z axis, the shaft
  direction, is -z0).
* ``jaw_tip``: ``cp`` translated by :attr:`PSM.jaw_length` along cp z.
* ``roll``: DH frame 4 (origin on the wrist-pitch axis, z along the shaft towards the tip, turns
  with roll); ``rotation(q, "roll")`` is the seed paper's R_PSM_Roll(q).
* ``hex10``: ``roll`` rotated about z by :attr:`PSM.hex10_clocking` and moved proximally along the
  shaft by :attr:`PSM.hex10_distance`.
* Joints in dVRK order: yaw, pitch, insertion, roll, wrist_pitch, wrist_yaw (+ jaw, which moves no
  chain frame). rad and m; wrenches [force; moment] in N and Nm.

The URDF (``psmforce/robot/urdf/psm_cadiere.urdf``, package data) is the single source of truth: the
chain used here is read from the Pinocchio model built from it (joint placements and axes, frame
placements). Poses and Jacobians are composed in numpy over a whole batch of configurations at once
(``psmforce.robot.serial_chain``; several times the throughput of a per-sample Pinocchio loop in
Python, ``benchmarks/kinematics.py`` prints both), and the tests check the numpy chain against
Pinocchio.
"""

from __future__ import annotations

import warnings
from functools import lru_cache
from importlib import resources
from pathlib import Path

import numpy as np
import pinocchio as pin

import psmforce.robot.wrench as _wrench
from psmforce.robot.conventions import (CHAIN_JOINTS, DEPRECATED_EXPRESSED_IN, EXPRESSED_IN, JOINTS,
                                   NAMED_FRAMES, canonical_expressed_in)
from psmforce.robot.serial_chain import (JOINT_AXES, chain_pose, express_jacobian, homogeneous,
                                    rot_z)

BUNDLED_URDF = resources.files("psmforce.robot") / "urdf" / "psm_cadiere.urdf"
"""The bundled URDF of the Classic PSM + Cadiere forceps + HEX10: package data, found through
``importlib.resources`` so that an installed wheel carries it (a path on disk for every ordinary
install; read as text, so a zipped install works too)."""

_LIMIT_SLACK = 1e-9  # rad or m; absorbs the rounding of limits written with 6 decimals


class KinematicsInputError(ValueError):
    """Joint vectors, torques or frame names that cannot be used; the message names the problem."""


class JointLimitError(KinematicsInputError):
    """A joint value outside its limits with ``strict=True``."""


class JointLimitWarning(UserWarning):
    """A joint value outside its limits (computation goes on; ``strict=True`` raises instead)."""


class PSM:
    """The PSM model: forward kinematics, Jacobians and wrenches, vectorised over configurations.

    ``PSM()`` loads the bundled URDF; ``PSM(urdf_path)`` another one with the same joint and frame
    names. ``jaw_length``, ``hex10_distance`` (m) and ``hex10_clocking`` (rad) override the URDF's
    values for the ``jaw_tip`` and ``hex10`` frames (geometry only; the HEX10's 3 g stay where the
    URDF put them).

    Every method taking ``q`` accepts (6,), (7,), (N,6) or (N,7) (the jaw, 7th, never moves a chain
    frame) and returns one result or N stacked results. Values outside the joint limits give a
    :class:`JointLimitWarning` naming the joint, or :class:`JointLimitError` with ``strict=True``.
    """

    def __init__(self, urdf_path: str | Path | None = None, *, jaw_length: float | None = None,
                 hex10_distance: float | None = None, hex10_clocking: float | None = None):
        self.urdf_path = Path(urdf_path) if urdf_path is not None else BUNDLED_URDF
        if not self.urdf_path.is_file():
            raise FileNotFoundError(f"PSM URDF not found: {self.urdf_path}")
        self.model = pin.buildModelFromXML(self.urdf_path.read_text(), mimic=True)
        self.joint_names = CHAIN_JOINTS
        self._joint_ids = []
        for name in JOINTS:
            if not self.model.existJointName(name):
                raise KinematicsInputError(f"{self.urdf_path}: no joint named '{name}'")
            self._joint_ids.append(self.model.getJointId(name))
        chain_ids = self._joint_ids[:6]
        for parent, child in zip([0] + chain_ids[:-1], chain_ids):
            if self.model.parents[child] != parent:
                raise KinematicsInputError(
                    f"{self.urdf_path}: joint '{self.model.names[child]}' is not the child of "
                    f"'{self.model.names[parent]}'; the chain must be serial in dVRK order")
        idx_q = [self.model.joints[j].idx_q for j in self._joint_ids]
        self.lower_limits = self.model.lowerPositionLimit[idx_q].copy()
        """Lower limits of yaw .. wrist_yaw, jaw (rad, insertion m)."""
        self.upper_limits = self.model.upperPositionLimit[idx_q].copy()
        """Upper limits, same order."""
        self._placements = []
        self._axes = []
        for j in chain_ids:
            shortname = self.model.joints[j].shortname()
            if shortname not in JOINT_AXES:
                raise KinematicsInputError(
                    f"{self.urdf_path}: joint '{self.model.names[j]}' is {shortname}; the PSM chain "
                    "supports revolute/prismatic joints about a frame axis only")
            placement = self.model.jointPlacements[j]
            self._placements.append((placement.rotation.copy(), placement.translation.copy()))
            self._axes.append(JOINT_AXES[shortname])
        for name in NAMED_FRAMES:
            self._chain_frame(name)
        if jaw_length is not None:
            self._set_frame_placement(
                "jaw_tip", self._frame_placement("cp")
                * pin.SE3(np.eye(3), np.array([0.0, 0.0, _positive(jaw_length, "jaw_length")])))
        if hex10_distance is not None or hex10_clocking is not None:
            distance = self.hex10_distance if hex10_distance is None else _positive(
                hex10_distance, "hex10_distance")
            clocking = self.hex10_clocking if hex10_clocking is None else _finite_scalar(
                hex10_clocking, "hex10_clocking")
            self._set_frame_placement(
                "hex10", self._frame_placement("roll")
                * pin.SE3(rot_z(clocking), np.array([0.0, 0.0, -distance])))
        # a custom URDF must place jaw_tip and hex10 as documented: fail at load, not at first use
        self._jaw_length_in_cp()
        self._hex10_in_roll()

    # ------------------------------------------------------------------ parameters
    @property
    def jaw_length(self) -> float:
        """Distance (m) from cp to jaw_tip along cp z."""
        return self._jaw_length_in_cp()

    def _jaw_length_in_cp(self) -> float:
        rel = self._frame_placement("cp").actInv(self._frame_placement("jaw_tip"))
        if not (np.allclose(rel.rotation, np.eye(3), atol=1e-9)
                and np.allclose(rel.translation[:2], 0.0, atol=1e-9)):
            raise KinematicsInputError("jaw_tip is not cp translated along cp z in this URDF")
        return float(rel.translation[2])

    @property
    def hex10_distance(self) -> float:
        """Distance (m) of the HEX10 frame origin proximal of the wrist-pitch axis, along the shaft."""
        return self._hex10_in_roll()[0]

    @property
    def hex10_clocking(self) -> float:
        """Rotation (rad) of the HEX10 frame about the shaft axis relative to the roll frame."""
        return self._hex10_in_roll()[1]

    @property
    def R_roll_hex10(self) -> np.ndarray:
        """Constant rotation (3,3) of the HEX10 axes in the roll frame (the paper's R_Roll_HEX10)."""
        return rot_z(self.hex10_clocking)

    def _hex10_in_roll(self) -> tuple[float, float]:
        rel = self._frame_placement("roll").actInv(self._frame_placement("hex10"))
        R, p = rel.rotation, rel.translation
        if not (abs(R[2, 2] - 1.0) < 1e-9 and np.allclose(p[:2], 0.0, atol=1e-9)):
            raise KinematicsInputError(
                "hex10 is not the roll frame turned about and moved along the shaft axis")
        return float(-p[2]), float(np.arctan2(R[1, 0], R[0, 0]))

    # ------------------------------------------------------------------ public kinematics
    def forward_kinematics(self, q, frame: str = "cp", *, strict: bool = False) -> np.ndarray:
        """Pose (4,4) or (N,4,4) of ``frame`` in the base (RCM) frame; translation in m."""
        R, p = self._frame_pose(self._check_q(q, strict), frame)
        return self._shape_out(homogeneous(R, p), q)

    def rotation(self, q, frame: str = "cp", *, strict: bool = False) -> np.ndarray:
        """Rotation (3,3) or (N,3,3) of ``frame`` in the base frame (``"roll"``: R_PSM_Roll(q))."""
        R, _ = self._frame_pose(self._check_q(q, strict), frame)
        return self._shape_out(R, q)

    def spatial_jacobian(self, q, frame: str = "cp", *, strict: bool = False) -> np.ndarray:
        """Spatial Jacobian (6,6) or (N,6,6) of the body carrying ``frame``, Pinocchio WORLD convention.

        Columns: yaw .. wrist_yaw. Rows ``[v; w]``: ``w`` is the body's angular velocity and ``v``
        the velocity of the body point that coincides with the base origin (the RCM), both in base
        coordinates (``pinocchio.getFrameJacobian(..., WORLD)``). It does not depend on where the
        frame sits on its body; for ``roll``/``hex10`` the wrist columns are zero.

        The dVRK (cisst ``robManipulator``) publishes for cp:

        * ``spatial/jacobian`` = Ad(T_base_cp) @ body Jacobian, the Murray-Li-Sastry spatial
          Jacobian, which is this matrix: ``J_dvrk_spatial = spatial_jacobian(q)``;
        * ``body/jacobian`` = twist of cp in cp axes = Pinocchio LOCAL at cp. With
          p = ``forward_kinematics(q)[:3, 3]``, R = ``rotation(q)`` and [p]x the cross-product
          matrix of p::

            J_lwa       = [[I, -[p]x], [0, I]] @ J_world   # = jacobian(q, "cp", "base_at_frame")
            J_dvrk_body = blockdiag(R.T, R.T) @ J_lwa      # = jacobian(q, "cp", "frame")

          (``J_lwa``: velocity of the cp origin in base axes, the body Jacobian rotated to base.)
        """
        return self.jacobian(q, frame, "base", strict=strict)

    def jacobian(self, q, frame: str = "cp", expressed_in: str = "base", *,
                 strict: bool = False, reference: str | None = None) -> np.ndarray:
        """Jacobian (6,6)/(N,6,6) of the body carrying ``frame``, rows [v; w], columns yaw .. wrist_yaw.

        ``expressed_in`` (``psmforce.robot.conventions``): ``"base"`` (Pinocchio WORLD, see
        :meth:`spatial_jacobian`), ``"base_at_frame"`` (LOCAL_WORLD_ALIGNED: v = velocity of the
        frame origin, both in base coordinates) or ``"frame"`` (LOCAL: the same in frame
        coordinates). Deprecated for one release, with a DeprecationWarning: the argument's
        earlier name ``reference`` and its values ``"world"``, ``"local_world_aligned"``,
        ``"local"``.
        """
        if reference is not None:
            if expressed_in != "base":
                raise KinematicsInputError("give expressed_in or reference (deprecated), not both")
            expressed_in = DEPRECATED_EXPRESSED_IN.get(reference, reference)
            warnings.warn(f"PSM.jacobian(reference={reference!r}) is deprecated; say "
                          f"expressed_in={expressed_in!r} (same arrays)", DeprecationWarning,
                          stacklevel=2)
        expressed_in = canonical_expressed_in(expressed_in)
        if expressed_in not in EXPRESSED_IN:
            raise KinematicsInputError(f"unknown Jacobian reference {expressed_in!r}; "
                                       f"expressed_in must be one of {EXPRESSED_IN}")
        qc = self._check_q(q, strict)
        R, p, J = self._frame_pose_and_jacobian(qc, frame)
        return self._shape_out(express_jacobian(J, R, p, expressed_in), q)

    def forward_kinematics_and_jacobian(self, q, frame: str = "cp", *, strict: bool = False
                                        ) -> tuple[np.ndarray, np.ndarray]:
        """Pose and spatial (WORLD) Jacobian in one pass over the chain: ((4,4), (6,6)) or batched."""
        qc = self._check_q(q, strict)
        R, p, J = self._frame_pose_and_jacobian(qc, frame)
        return self._shape_out(homogeneous(R, p), q), self._shape_out(J, q)

    def wrench_from_torques(self, q, tau, tau_internal=None, frame: str = "cp",
                            expressed_in: str = "base", *, return_info: bool = False,
                            strict: bool = False,
                            sigma_threshold: float = _wrench.DEFAULT_SIGMA_THRESHOLD,
                            max_damping: float = _wrench.DEFAULT_MAX_DAMPING):
        """Wrench [force N; moment Nm] w on the tool with ``J^T w = tau - tau_internal`` (6 joints).

        Sign: w is the wrench applied BY the environment ON the distal body of the chain (the
        wrist-yaw body: jaws, cp, jaw tip) whose joint torques are ``tau - tau_internal``, i.e.
        ``tau`` is read as the torques that the wrench exerts at the joints. dVRK measured efforts
        are the torques the MOTORS apply; in statics they balance the load (motor torque = -J^T w),
        so the external wrench on the tool from dVRK efforts is ``-wrench_from_torques(q, tau,
        tau_internal)``.

        Reference point and axes (the force part is the same for all three, up to rotation):

        * ``"base"`` (default): Pinocchio WORLD, the dual of :meth:`spatial_jacobian`: moment about
          the base origin (RCM), base axes; ``frame`` plays no role. Round trip:
          ``wrench_from_torques(q, spatial_jacobian(q).T @ w) == w``. With the dVRK's published
          spatial Jacobian (the same matrix) this is the seed paper's F = J_s^-T (tau - tau_hat)
          = ``wrench_from_torques(q, tau, tau_hat)``, i.e. the wrench the tool applies on the
          environment.
        * ``"base_at_frame"``: Pinocchio LOCAL_WORLD_ALIGNED: moment about the origin of
          ``frame``, base axes.
        * ``"frame"``: Pinocchio LOCAL: moment about the origin of ``frame``, ``frame``'s axes
          (``frame="hex10"``: the load in the HEX10 frame; ``frame="cp"``: the dVRK body wrench).

        J is the distal body's Jacobian for that point and those axes; see
        :func:`psmforce.robot.wrench.solve_wrench` for the damped least squares (damping only when
        the smallest singular value of J drops below ``sigma_threshold``, default 1e-3) and for the
        conditioning report returned with ``return_info=True`` (a
        :class:`psmforce.robot.wrench.WrenchConditioning`).

        ``tau`` and ``tau_internal``: (6,), (7,), (N,6) or (N,7) joint torques in dVRK joint space
        (Nm, insertion N; a jaw column is ignored), with q's batch size.
        """
        if expressed_in not in EXPRESSED_IN:
            raise KinematicsInputError(
                f"expressed_in must be one of {EXPRESSED_IN}, got {expressed_in!r}")
        qc = self._check_q(q, strict)
        tau_net = self._check_tau(tau, "tau", qc.shape[0])
        if tau_internal is not None:
            tau_net = tau_net - self._check_tau(tau_internal, "tau_internal", qc.shape[0])
        R_tip, p_tip, J_world = self._frame_pose_and_jacobian(qc, "cp")
        R, p = (R_tip, p_tip) if frame == "cp" else self._frame_pose(qc, frame)
        J = express_jacobian(J_world, R, p, expressed_in)
        w, info = _wrench.solve_wrench(J, tau_net, sigma_threshold=sigma_threshold,
                                       max_damping=max_damping)
        if np.ndim(q) == 1:
            w, info = w[0], info.sample(0)
        return (w, info) if return_info else w

    # ------------------------------------------------------------------ internals
    def _frame_id(self, name: str) -> int:
        """Frame id, preferring the link (BODY) frame: "roll" is both a joint and a link name."""
        if self.model.existFrame(name, pin.FrameType.BODY):
            return self.model.getFrameId(name, pin.FrameType.BODY)
        return self.model.getFrameId(name)

    def _frame_placement(self, name: str) -> pin.SE3:
        return self.model.frames[self._frame_id(name)].placement

    def _set_frame_placement(self, name: str, placement: pin.SE3) -> None:
        self.model.frames[self._frame_id(name)].placement = placement

    def _chain_frame(self, frame) -> tuple[int, np.ndarray, np.ndarray]:
        """(number of chain joints that move the frame, R, p of the frame in that joint's frame)."""
        if not isinstance(frame, str) or not self.model.existFrame(frame):
            raise KinematicsInputError(
                f"unknown frame {frame!r}; expected one of {NAMED_FRAMES} or another frame of the "
                f"chain in {self.urdf_path.name}")
        f = self.model.frames[self._frame_id(frame)]
        chain_ids = self._joint_ids[:6]
        if f.parentJoint == 0:
            depth = 0
        elif f.parentJoint in chain_ids:
            depth = chain_ids.index(f.parentJoint) + 1
        else:
            raise KinematicsInputError(
                f"frame '{frame}' is carried by joint '{self.model.names[f.parentJoint]}', which is "
                "not one of the six chain joints")
        return depth, f.placement.rotation, f.placement.translation

    def _check_q(self, q, strict: bool) -> np.ndarray:
        """(N,7) float array (jaw 0 where absent), validated; raises or warns naming the problem."""
        arr = np.asarray(q)
        if arr.dtype.kind not in "fiu":
            raise KinematicsInputError(f"q must be numeric, got dtype {arr.dtype}")
        if arr.ndim not in (1, 2) or arr.shape[-1] not in (6, 7) or (arr.ndim == 2
                                                                      and arr.shape[0] == 0):
            raise KinematicsInputError(
                f"q must have shape (6,), (7,), (N,6) or (N,7) with N >= 1; got {arr.shape}")
        arr = np.atleast_2d(arr).astype(float, copy=False)
        if not np.isfinite(arr).all():
            row, col = np.argwhere(~np.isfinite(arr))[0]
            raise KinematicsInputError(
                f"q has a non-finite value ({arr[row, col]}) for joint "
                f"'{JOINTS[col]}' at sample {row}")
        ncol = arr.shape[1]
        below = arr < self.lower_limits[:ncol] - _LIMIT_SLACK
        above = arr > self.upper_limits[:ncol] + _LIMIT_SLACK
        if below.any() or above.any():
            self._report_limits(arr, below | above, strict)
        return arr

    def _report_limits(self, arr, outside, strict):
        parts = []
        for col in np.flatnonzero(outside.any(axis=0)):
            rows = np.flatnonzero(outside[:, col])
            parts.append(
                f"'{JOINTS[col]}' = {arr[rows[0], col]:.6g} at sample {rows[0]} "
                f"(limits [{self.lower_limits[col]:.6g}, {self.upper_limits[col]:.6g}], "
                f"{rows.size} sample(s) outside)")
        message = "joint values outside the limits: " + "; ".join(parts)
        if strict:
            raise JointLimitError(message)
        warnings.warn(message, JointLimitWarning, stacklevel=4)

    @staticmethod
    def _check_tau(tau, name: str, n: int) -> np.ndarray:
        arr = np.asarray(tau, dtype=float)
        if arr.ndim not in (1, 2) or arr.shape[-1] not in (6, 7):
            raise KinematicsInputError(
                f"{name} must have shape (6,), (7,), (N,6) or (N,7); got {arr.shape}")
        arr = np.atleast_2d(arr)[:, :6]
        if arr.shape[0] != n:
            raise KinematicsInputError(f"{name} has {arr.shape[0]} sample(s) but q has {n}")
        if not np.isfinite(arr).all():
            row, col = np.argwhere(~np.isfinite(arr))[0]
            raise KinematicsInputError(
                f"{name} has a non-finite value for joint '{CHAIN_JOINTS[col]}' at sample {row}")
        return arr

    @staticmethod
    def _shape_out(x: np.ndarray, q) -> np.ndarray:
        return x[0] if np.ndim(q) == 1 else x

    def _frame_pose(self, q: np.ndarray, frame: str):
        R, p, _ = chain_pose(self._placements, self._axes, q, *self._chain_frame(frame),
                             with_jacobian=False)
        return R, p

    def _frame_pose_and_jacobian(self, q: np.ndarray, frame: str):
        return chain_pose(self._placements, self._axes, q, *self._chain_frame(frame),
                          with_jacobian=True)


@lru_cache(maxsize=1)
def default_psm() -> PSM:
    """The PSM of the bundled URDF, built once (callers must not modify it)."""
    return PSM()


def _finite_scalar(value, name: str) -> float:
    x = float(value)
    if not np.isfinite(x):
        raise KinematicsInputError(f"{name} must be finite, got {value!r}")
    return x


def _positive(value, name: str) -> float:
    x = _finite_scalar(value, name)
    if x <= 0.0:
        raise KinematicsInputError(f"{name} must be > 0 m, got {value!r}")
    return x
