"""The identified arm dynamics model: prediction, persistence, and the external wrench it gives.

Model (joint space of the PSM's six chain joints + jaw; frames and units as in ``psmforce.robot``)::

    tau_c = T^T [ Y(q, dq, ddq; g) pi ; 0 ]                   rigid bodies (jaw row: no body)
            + sum_k F(dc_k) phi_k                               friction per actuated coordinate +
            T_w^T (Fc_w s(dq_w) + Fv_w dq_w)                  wrist-joint (pulley) friction + Ia *
            ddc + K * c                                  armature, cable/torsion springs + sum_i
            F_ki z_ki(c_k history)                      pre-sliding hysteresis (Maxwell-slip) + T^T
            [ Y_cw(q, dq, ddq) (m, m z, m z^2)_cw ; 0 ]   insertion counterweight (no weight)

* ``q = T c``: dVRK joints q (7) from the actuated ("recorder") coordinates c. For the WPI data T
  is identity on yaw .. roll and ``wpi.WRIST_MOTOR_TO_DVRK`` on the wrist; for library recordings
  (dVRK joints) T = identity. ``tau_c = T^T tau_q`` (virtual work).
* ``Y``: the rigid-body regressor of seven bodies (the chain's six and a parallelogram coupler;
  :mod:`.dynamics_regressor`), pi their inertial parameters. Gravity g (m/s^2, base = RCM frame)
  is identified (|g| = ``psmforce.robot.conventions.GRAVITY_MPS2``) because the arm's mounting
  relative to gravity is not recorded with the data.
* Insertion counterweight (``DynamicsFitOptions.insertion_counterweight``, default): a point
  mass on the insertion axis with inertia and no weight (its weight balanced along the stroke),
  ``dynamics_regressor.counterweight_columns``.
* Optional terms (``DynamicsFitOptions``, :mod:`.dynamics_options`): polynomial springs,
  direction-dependent Coulomb levels (Fc + a, Fc - a, both >= 0), cross springs, Maxwell-slip
  pre-sliding hysteresis (``friction.maxwell_slip_states`` on the grids
  ``HYSTERESIS_BREAKAWAY_RAD`` / ``HYSTERESIS_BREAKAWAY_M``, levels >= 0); the linear parameters
  phi are listed, with their columns, by ``dynamics_regressor.linear_terms``. The hysteresis
  states depend on the position history: functions that take conditioned samples take them as
  ``states`` (from ``dynamics_fit.condition_signals(..., with_states=True)``, computed before any
  subset of rows is taken); where none are given they are computed from ``c`` as one
  time-ordered contiguous sequence.

The fit: :mod:`.dynamics_fit`; model selection: :mod:`.dynamics_validation`; what ``psmforce
fit-dynamics`` runs: :mod:`.dynamics_report`.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from psmforce.core.files import write_json_atomic
from psmforce.identification.dynamics_options import (HYSTERESIS_BREAKAWAY_M,
                                                       HYSTERESIS_BREAKAWAY_RAD, N_COORD,
                                                       DynamicsFitOptions)
from psmforce.identification.dynamics_regressor import (BODIES, identification_model,
                                                         linear_columns, linear_terms,
                                                         rigid_regressors)
from psmforce.identification.errors import IdentificationInputError, NotConvergedError
from psmforce.identification.friction import FrictionShape
from psmforce.identification.inertia import (PARAMETER_NAMES, PARAMETER_UNITS,
                                              consistency_report)
from psmforce.identification.model_file import check_sealed, read_model_json
from psmforce.identification.signals import check_finite_2d
from psmforce.core.integrity import seal
from psmforce.robot.kinematics import PSM

MODEL_FORMAT = "psmforce.identification.ArmDynamicsModel/1"
FORMAT_VERSION = 2
"""2: the integrity envelope (:mod:`psmforce.core.integrity`: a SHA-256 over every field) and this
integer; a file with neither was written before them and still loads (its fields checked as
every model's are); one with only one of them is refused."""


def file_digest(path) -> str:
    """First 16 hex digits of the SHA-256 of a file: a path or an ``importlib.resources`` file."""
    source = Path(path) if isinstance(path, str) else path
    return hashlib.sha256(source.read_bytes()).hexdigest()[:16]


@dataclass
class ArmDynamicsModel:
    """An identified arm model. ``predict`` maps dVRK joint states to dVRK joint torques (N,7)."""

    body_parameters: np.ndarray        # (7, 10) Pinocchio order per body of BODIES
    gravity: np.ndarray                # (3,) m/s^2 in the base (RCM) frame
    linear_parameters: np.ndarray      # (n_phi,)
    coupling: np.ndarray               # T (7,7): q_dvrk = T c
    coordinate_names: tuple
    options: DynamicsFitOptions
    converged: bool
    info: dict = field(default_factory=dict)

    def __post_init__(self):
        self._model, self._urdf = identification_model()
        self._terms = linear_terms(self.options, self.coordinate_names)

    @property
    def linear_parameter_names(self) -> tuple[str, ...]:
        """Names of :attr:`linear_parameters`, same order (``dynamics_regressor.linear_terms``)."""
        return tuple(t.name for t in self._terms)

    # -------------------------------------------------------------- prediction
    def predict_coordinates(self, c, dc, ddc, states=None) -> np.ndarray:
        """Torques (N,7) in the actuated coordinates c from c, dc, ddc (N,7) (recorder space).

        ``states``: hysteresis states (N,7,4) of these rows (``condition_signals(...,
        with_states=True)``); default: computed from c as one time-ordered contiguous sequence."""
        c, dc, ddc = (check_finite_2d(x, n, width=N_COORD) for x, n in
                      ((c, "c"), (dc, "dc"), (ddc, "ddc")))
        if not (c.shape == dc.shape == ddc.shape):
            raise IdentificationInputError(
                f"c, dc, ddc must have the same shape; got {c.shape}, {dc.shape}, {ddc.shape}")
        T = self.coupling
        q, dq, ddq = c @ T.T, dc @ T.T, ddc @ T.T
        Y0, Yg, mass_cols = rigid_regressors(self._model, q[:, :6], dq[:, :6], ddq[:, :6])
        pi = self.body_parameters.ravel()
        tau_q6 = Y0 @ pi + np.einsum("k,knjp,p->nj", self.gravity, Yg, pi[mass_cols])
        tau_c = np.concatenate([tau_q6, np.zeros((len(q), 1))], axis=1) @ T
        lin = linear_columns(self.options, T, c, dc, ddc, states, Y0) @ self.linear_parameters
        return tau_c + lin

    def predict(self, q, dq, ddq) -> np.ndarray:
        """dVRK joint torques (N,7) (Nm; insertion N) from dVRK joint q, dq, ddq (N,7), one
        time-ordered contiguous sequence where the model has hysteresis terms."""
        Tinv = np.linalg.inv(self.coupling)
        q, dq, ddq = (check_finite_2d(x, n, width=N_COORD) for x, n in
                      ((q, "q"), (dq, "dq"), (ddq, "ddq")))
        tau_c = self.predict_coordinates(q @ Tinv.T, dq @ Tinv.T, ddq @ Tinv.T)
        return tau_c @ Tinv  # tau_q = T^-T tau_c

    def fit_summary(self) -> dict:
        """The part of the fit report every data format shares (``psmforce fit-dynamics``)."""
        bodies = {n: consistency_report(p) for n, p in zip(BODIES, self.body_parameters)}
        return {"coordinates": list(self.coordinate_names), "converged": self.converged,
                "solver_status": self.info["solver_status"],
                "fit_time_s": self.info["fit_time_s"],
                "n_parameters": self.info["n_parameters"],
                "n_base_parameters": self.info["n_base_parameters"],
                "gravity_mps2": self.gravity.tolist(),
                "physically_consistent": all(r["physically_consistent"]
                                             for r in bodies.values()),
                "bodies": {n: {k: r[k] for k in ("mass_kg", "com_m")} for n, r in bodies.items()},
                **self._counterweight_summary(),
                "train_relative_error_percent": [100 * e for e in
                                                 self.info["train_relative_error"]]}

    def _counterweight_summary(self) -> dict:
        """The insertion counterweight's mass (kg), position along the insertion axis (m, from
        the insertion frame) and second moment (kg m^2), when the model has one."""
        if not self.options.insertion_counterweight:
            return {}
        names = self.linear_parameter_names
        m, mz, mzz = (float(self.linear_parameters[names.index(f"insertion_counterweight.{p}")])
                      for p in ("mass", "first_moment", "second_moment"))
        return {"insertion_counterweight": {"mass_kg": m, "position_m": mz / m if m > 0 else None,
                                            "second_moment_kg_m2": mzz}}

    # -------------------------------------------------------------- persistence
    def to_dict(self) -> dict:
        bodies = {}
        for name, pi in zip(BODIES, self.body_parameters):
            bodies[name] = {"parameters": dict(zip(PARAMETER_NAMES, map(float, pi))),
                            "units": dict(zip(PARAMETER_NAMES, PARAMETER_UNITS)),
                            **consistency_report(pi)}
        lin = {t.name: {"value": float(v), "unit": t.unit,
                        "lower_bound": None if not np.isfinite(t.lower) else float(t.lower)}
               for t, v in zip(self._terms, self.linear_parameters)}
        opts = dict(self.options.__dict__)
        opts["friction_shape"] = dict(self.options.friction_shape.__dict__)
        opts["friction_shape_prismatic"] = dict(self.options.friction_shape_prismatic.__dict__)
        opts["spring_coordinates"] = list(opts["spring_coordinates"])
        opts["hysteresis_breakaway"] = {"rad": list(HYSTERESIS_BREAKAWAY_RAD),
                                        "m": list(HYSTERESIS_BREAKAWAY_M)}
        return {"format": MODEL_FORMAT, "converged": bool(self.converged),
                "frames_and_units": "body parameters about each joint frame origin (Pinocchio "
                                    "order m, m*c, I); gravity in the base = RCM frame, m/s^2; "
                                    "torques Nm, insertion N",
                "urdf": str(self._urdf), "urdf_sha256_16": file_digest(self._urdf),
                "coordinate_names": list(self.coordinate_names),
                "coupling_q_from_c": self.coupling.tolist(),
                "gravity_mps2": self.gravity.tolist(), "bodies": bodies,
                "linear_parameters": lin, "options": opts, "info": self.info}

    def save(self, path: str | Path) -> None:
        """Write the model as JSON atomically, sealed (:data:`FORMAT_VERSION`); refuses a
        non-converged model."""
        if not self.converged:
            raise NotConvergedError("refusing to save a dynamics model whose fit did not converge")
        write_json_atomic(path, seal({**self.to_dict(), "format_version": FORMAT_VERSION}))

    @classmethod
    def load(cls, path: str | Path) -> ArmDynamicsModel:
        """Read a model written by :meth:`save`. Refuses, naming the file: unreadable or invalid
        JSON, another format, a field that does not match the file's SHA-256 envelope or a
        format version that is not the integer :data:`FORMAT_VERSION` (files written before the
        envelope carry neither and load), missing or malformed fields, non-finite parameters."""
        d = read_model_json(path, MODEL_FORMAT, "an ArmDynamicsModel")
        check_sealed(d, path, "ArmDynamicsModel", FORMAT_VERSION)
        try:
            model = cls._from_dict(d)
        except (KeyError, TypeError, ValueError, AttributeError) as err:
            raise IdentificationInputError(f"{path}: malformed ArmDynamicsModel file "
                                           f"({type(err).__name__}: {err})") from None
        if not all(np.isfinite(v).all() for v in (model.body_parameters, model.gravity,
                                                   model.linear_parameters, model.coupling)):
            raise IdentificationInputError(f"{path}: non-finite parameters")
        return model

    @classmethod
    def _from_dict(cls, d: dict) -> ArmDynamicsModel:
        o = dict(d["options"])
        o.pop("hysteresis_breakaway", None)  # module constants; written for the reader
        o.setdefault("insertion_counterweight", False)  # files from before the option had none
        o["friction_shape"] = FrictionShape(**o["friction_shape"])
        o["friction_shape_prismatic"] = FrictionShape(**o["friction_shape_prismatic"])
        for key in ("spring_coordinates", "asymmetric_coulomb", "hysteresis_coordinates"):
            o[key] = tuple(o.get(key, ()))
        for key in ("spring_polynomial", "cross_springs"):
            o[key] = tuple(tuple(pair) for pair in o.get(key, ()))
        o["gravity"] = None if o.get("gravity") is None else tuple(o["gravity"])
        bodies = np.array([[d["bodies"][b]["parameters"][p] for p in PARAMETER_NAMES]
                           for b in BODIES])
        return cls(body_parameters=bodies, gravity=np.array(d["gravity_mps2"]),
                   linear_parameters=np.array([v["value"] for v in d["linear_parameters"].values()]),
                   coupling=np.array(d["coupling_q_from_c"]),
                   coordinate_names=tuple(d["coordinate_names"]),
                   options=DynamicsFitOptions(**o), converged=bool(d["converged"]), info=d["info"])


def external_wrench_on_tool(model: ArmDynamicsModel, q, dq, ddq, tau, *, psm=None,
                            frame: str = "cp", expressed_in: str = "base",
                            return_info: bool = False):
    """Model-based external wrench [f N; m Nm] applied BY the environment ON the tool.

    ``q, dq, ddq, tau``: (N,7) dVRK joint space (tau = measured efforts, what the motors apply).
    With tau_hat = ``model.predict(q, dq, ddq)``, statics give tau - tau_hat = -J^T w, so
    ``w = -PSM.wrench_from_torques(q, tau, tau_internal=tau_hat)`` (the seed paper's
    F = J_s^-T (tau - tau_hat) is -w, the force the tool applies). ``frame`` / ``expressed_in``
    choose the reference point and axes exactly as in ``PSM.wrench_from_torques`` (default
    ``"base"``: the dual of the spatial Jacobian, moment about the RCM, base axes); damping near
    singularities as there.
    """
    psm = psm or PSM()
    tau = check_finite_2d(tau, "tau", width=N_COORD)
    tau_hat = model.predict(q, dq, ddq)
    if len(tau) != len(tau_hat):
        raise IdentificationInputError(f"tau has {len(tau)} samples but q has {len(tau_hat)}")
    out = psm.wrench_from_torques(np.asarray(q, dtype=float), tau, tau_internal=tau_hat,
                                  frame=frame, expressed_in=expressed_in, return_info=return_info)
    if return_info:
        return -out[0], out[1]
    return -out
