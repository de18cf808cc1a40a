"""The arm dynamics model's columns: torques linear in the inertial and the linear parameters.

Rigid bodies. ``Y``: ``pinocchio.computeJointTorqueRegressor`` on an identification model built
in code from the bundled URDF's chain (six bodies: yaw, pitch, insertion, roll, wrist_pitch,
wrist_yaw; the jaw blades' grams are left out). The parallelogram: its back link turns by q2
about a pivot ON the yaw axis, which moves it exactly like a body turning about the RCM (part of
the pitch body); its end link turns about the RCM (pitch body); its coupler links translate
without rotating on a circle swept by q2, which the lumped model cannot represent (their
yaw-inertia terms linear in cos q2, sin q2). One extra body, ``parallelogram_coupler``, on a
massless crank (+q2 about the pitch axis, radius :data:`COUPLER_CRANK_M`) and a joint at -q2,
spans them: with its first moment free, any crank radius gives the same function span. The
identification model has 8 joints mapped to the chain by q_ext = G q, tau = G^T tau_ext
(docs/identification.md).

Linear terms. :func:`linear_terms` is the one list of the linear parameters phi (friction,
armature, springs, wrist-joint friction, Coulomb asymmetry, Maxwell-slip hysteresis, the
insertion counterweight's weightless mass (:func:`counterweight_columns`), chosen by
``DynamicsFitOptions``): each term carries its name, unit, lower bound and the function giving its
torque column, so that the parameters' names and the regressor's columns cannot part.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
import pinocchio as pin

from psmforce.robot.conventions import CHAIN_JOINTS, GRAVITY_UPRIGHT_MPS2, JOINTS, WRIST_JOINTS
from psmforce.identification.dynamics_options import (HYSTERESIS_BREAKAWAY_M,
                                                       HYSTERESIS_BREAKAWAY_RAD, INSERTION,
                                                       N_COORD, DynamicsFitOptions)
from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.friction import (LOWER_BOUNDS, TERM_UNITS, TERMS,
                                               friction_regressor, maxwell_slip_states)
from psmforce.robot.kinematics import PSM

CHAIN_BODIES = CHAIN_JOINTS
"""The six chain bodies, each named after the joint that moves it."""
BODIES = CHAIN_BODIES + ("parallelogram_coupler",)
"""Identified bodies: the six chain bodies and one translating parallelogram coupler."""
COUPLER_CRANK_M = 0.15
"""Crank radius of the coupler's circular translation (m; WPI PSM URDF back-to-bottom link)."""
_N_EXT = 8  # identification-model joints: 6 chain + crank (q2) + coupler (-q2)
_ROLL = JOINTS.index("roll")
_WRIST = tuple(JOINTS.index(j) for j in WRIST_JOINTS)


def identification_model() -> tuple[pin.Model, object]:
    """The 8-joint Pinocchio model whose bodies are identified, with the URDF prior's inertias,
    and the URDF it was built from."""
    psm = PSM()
    src = psm.model
    model = pin.Model()
    model.name = "psm_identification"
    parent = 0
    for name in CHAIN_BODIES:
        jid_src = src.getJointId(name)
        joint_model = src.joints[jid_src]
        shortname = joint_model.shortname()
        jm = {"JointModelRZ": pin.JointModelRZ, "JointModelPZ": pin.JointModelPZ}[shortname]()
        parent = model.addJoint(parent, jm, src.jointPlacements[jid_src], name)
        model.appendBodyToJoint(parent, src.inertias[jid_src], pin.SE3.Identity())
    # parallelogram coupler: turns with +q2 about the pitch axis (crank, massless), then -q2 at the
    # crank's end, so it translates on a circle without rotating (module docstring)
    pitch_id = src.getJointId("pitch")
    crank = model.addJoint(model.getJointId("yaw"), pin.JointModelRZ(),
                           src.jointPlacements[pitch_id], "parallelogram_crank")
    coupler = model.addJoint(crank, pin.JointModelRZ(),
                             pin.SE3(np.eye(3), np.array([COUPLER_CRANK_M, 0.0, 0.0])),
                             "parallelogram_coupler")
    # prior: 0.6 kg rod 0.5 m long along the arm (WPI URDF bottom + top links 0.62 kg)
    model.appendBodyToJoint(coupler, pin.Inertia(0.6, np.array([0.0, 0.25, 0.0]),
                                                 np.diag([0.0125, 1e-4, 0.0125])),
                            pin.SE3.Identity())
    return model, psm.urdf_path


def extended_joints(x6: np.ndarray) -> np.ndarray:
    """Chain joint values (N,6) -> identification-model joints (N,8): crank = q2, coupler = -q2."""
    return np.concatenate([x6, x6[:, 1:2], -x6[:, 1:2]], axis=1)


CONSTRAINT_JACOBIAN = extended_joints(np.eye(6)).T
"""G (8,6), the constraint Jacobian of the identification model: q_ext = G q (and dq, ddq)."""
_KEPT_COLUMNS = np.concatenate([np.arange(10) + 10 * j for j in (0, 1, 2, 3, 4, 5, 7)])
"""Regressor columns of the identified bodies (the crank is massless: its 10 are dropped)."""


def rigid_regressors(model, q6, dq6, ddq6):
    """Y0 (N,6,10nb) without gravity and Yg (3,N,6,4nb) gravity columns per unit g along x,y,z.

    Computed on the 8-joint identification model and mapped to the six chain joints by the
    constraint Jacobian G (q_ext = G q): tau = G^T tau_ext (virtual work)."""
    data = model.createData()
    n = q6.shape[0]
    nb = len(BODIES)
    q, dq, ddq = extended_joints(q6), extended_joints(dq6), extended_joints(ddq6)
    G = CONSTRAINT_JACOBIAN
    Y0 = np.empty((n, 6, 10 * nb))
    Yg = np.empty((3, n, 6, 4 * nb))
    mass_cols = np.concatenate([np.arange(4) + 10 * b for b in range(nb)])
    zero = np.zeros(_N_EXT)
    model.gravity = pin.Motion.Zero()
    for i in range(n):
        Y0[i] = G.T @ pin.computeJointTorqueRegressor(model, data, q[i], dq[i], ddq[i])[
            :, _KEPT_COLUMNS]
    for k in range(3):
        g = np.zeros(3)
        g[k] = 1.0
        model.gravity = pin.Motion(g, np.zeros(3))
        for i in range(n):
            Yg[k, i] = (G.T @ pin.computeJointTorqueRegressor(model, data, q[i], zero, zero)[
                :, _KEPT_COLUMNS])[:, mass_cols]
    model.gravity = pin.Motion(np.array(GRAVITY_UPRIGHT_MPS2), np.zeros(3))
    return Y0, Yg, mass_cols


COUNTERWEIGHT_PARAMETERS = (("mass", "kg", 0.0), ("first_moment", "kg m", -np.inf),
                            ("second_moment", "kg m^2", 0.0))
"""(name, unit, lower bound) of the insertion counterweight's weightless point mass on the
insertion axis: m, m z and m z^2, z along the insertion body's z axis (the axis of travel)."""


def counterweight_columns(y0: np.ndarray) -> np.ndarray:
    """(N, 6, 3) chain-joint torques per unit m, m z and m z^2 of a point mass on the insertion
    axis that moves with the insertion and has no weight (``DynamicsFitOptions.
    insertion_counterweight``), from ``y0``, the regressor without gravity of
    :func:`rigid_regressors`: the insertion body's m, m c_z and I_xx + I_yy (= m z^2 for a point
    on the z axis) columns; its weight columns are left out because a counterweight riding the
    axis the other way cancels them."""
    first = 10 * BODIES.index("insertion")
    return np.stack([y0[..., first], y0[..., first + 3], y0[..., first + 4] + y0[..., first + 6]],
                    axis=-1)


# ------------------------------------------------------------------ linear terms
@dataclass(frozen=True)
class TermSignals:
    """What the linear terms' columns are made of, for N samples in the coordinates c."""

    c: np.ndarray
    """(N,7) positions."""
    ddc: np.ndarray
    """(N,7) accelerations."""
    friction: np.ndarray
    """(N,7,nt) friction regressor of each coordinate's velocity (the options' friction terms)."""
    dq: np.ndarray
    """(N,7) dVRK joint velocities, T dc."""
    wrist_sign: np.ndarray
    """(N,7) smooth sign of dq (the revolute friction shape's velocity)."""
    coupling: np.ndarray
    """T (7,7): q = T c."""
    states: np.ndarray | None
    """(N,7,4) Maxwell-slip states; None when the options have no hysteresis terms."""
    counterweight: np.ndarray | None = None
    """(N,7,3) coordinate torques of :func:`counterweight_columns`; None without the option."""


@dataclass(frozen=True)
class LinearTerm:
    """One linear parameter phi_i: ``name``, ``unit``, ``lower`` bound (-inf: none) and
    ``torque``, its (N,7) column of coordinate torques per unit phi_i from :class:`TermSignals`."""

    name: str
    unit: str
    lower: float
    torque: Callable[[TermSignals], np.ndarray]


def _friction_terms(opts: DynamicsFitOptions) -> list[str]:
    return [t for t in TERMS if opts.stribeck or t != "stribeck"]


def _breakaways(k: int) -> tuple[float, ...]:
    return HYSTERESIS_BREAKAWAY_M if k == INSERTION else HYSTERESIS_BREAKAWAY_RAD


def _on_coordinate(k: int, values) -> Callable[[TermSignals], np.ndarray]:
    """A torque ``values(signals, k)`` (N,) on coordinate k alone."""
    def torque(s: TermSignals) -> np.ndarray:
        out = np.zeros((len(s.c), N_COORD))
        out[:, k] = values(s, k)
        return out
    return torque


def _on_dvrk_joint(j: int, values) -> Callable[[TermSignals], np.ndarray]:
    """A torque ``values(signals, j)`` (N,) on dVRK joint j, in coordinates: tau_c = T^T e_j f."""
    return lambda s: np.outer(values(s, j), s.coupling[j])


def _friction(i: int):
    return lambda s, k: s.friction[:, k, i]


def _position_of(column: int):
    return lambda s, k: s.c[:, column]


def _position_power(p: int):
    return lambda s, k: s.c[:, k] ** p


def _slip_state(e: int):
    return lambda s, k: s.states[:, k, e]


def linear_terms(opts: DynamicsFitOptions, coord_names) -> tuple[LinearTerm, ...]:
    """The linear parameters of the model chosen by ``opts``, in the order of phi, named after
    the coordinates ``coord_names`` (7)."""
    friction = _friction_terms(opts)
    terms = []

    def add(name, unit, lower, torque):
        terms.append(LinearTerm(name, unit, lower, torque))

    for k, cname in enumerate(coord_names):
        unit_v = "N" if k == INSERTION else "Nm"
        for i, t in enumerate(friction):
            add(f"{cname}.friction.{t}", TERM_UNITS[t].replace("Nm", unit_v)
                .replace("rad", "m" if k == INSERTION else "rad"), LOWER_BOUNDS[t],
                _on_coordinate(k, _friction(i)))
        add(f"{cname}.armature", "kg" if k == INSERTION else "kg m^2", 0.0,
            _on_coordinate(k, lambda s, k: s.ddc[:, k]))
    for k in opts.spring_coordinates:
        add(f"{coord_names[k]}.spring", "Nm/rad", -np.inf, _on_coordinate(k, _position_of(k)))
    if opts.roll_wrist_cross_springs:
        for k in _WRIST:
            add(f"{coord_names[_ROLL]}.spring_from_{coord_names[k]}", "Nm/rad", -np.inf,
                _on_coordinate(_ROLL, _position_of(k)))
    if opts.wrist_joint_friction:
        for j in _WRIST:
            add(f"joint_{JOINTS[j]}.friction.coulomb", "Nm", 0.0,
                _on_dvrk_joint(j, lambda s, j: s.wrist_sign[:, j]))
            add(f"joint_{JOINTS[j]}.friction.viscous", "Nm s/rad", 0.0,
                _on_dvrk_joint(j, lambda s, j: s.dq[:, j]))
    for k, degree in opts.spring_polynomial:
        for p in range(2, degree + 1):
            add(f"{coord_names[k]}.spring_power_{p}", "(N or Nm)/(m or rad)^" + str(p), -np.inf,
                _on_coordinate(k, _position_power(p)))
    for k in opts.asymmetric_coulomb:
        add(f"{coord_names[k]}.friction.coulomb_asymmetry", "N" if k == INSERTION else "Nm",
            -np.inf, _on_coordinate(k, lambda s, k: np.abs(s.friction[:, k, 0])))
    for r, k in opts.cross_springs:
        add(f"{coord_names[r]}.spring_from_{coord_names[k]}", "(N or Nm)/(m or rad)", -np.inf,
            _on_coordinate(r, _position_of(k)))
    if opts.insertion_counterweight:
        for p, (pname, unit, lower) in enumerate(COUNTERWEIGHT_PARAMETERS):
            add(f"insertion_counterweight.{pname}", unit, lower,
                lambda s, p=p: s.counterweight[:, :, p])
    for k in opts.hysteresis_coordinates:
        for e, d in enumerate(_breakaways(k)):
            add(f"{coord_names[k]}.friction.maxwell_slip_{d:g}{'m' if k == INSERTION else 'rad'}",
                "N" if k == INSERTION else "Nm", 0.0, _on_coordinate(k, _slip_state(e)))
    return tuple(terms)


def hysteresis_states(c) -> np.ndarray:
    """Maxwell-slip states (N, 7, 4) of every coordinate on its breakaway grid, along c (N, 7)
    taken as one time-ordered contiguous sequence (z = 0 at its first sample)."""
    c = np.asarray(c, dtype=float)
    return np.stack([maxwell_slip_states(c[:, k], _breakaways(k)) for k in range(N_COORD)],
                    axis=1)


def term_signals(opts: DynamicsFitOptions, T, c, dc, ddc, states=None,
                 rigid_y0=None) -> TermSignals:
    """:class:`TermSignals` of samples c, dc, ddc (N,7) with coupling T; ``states``: hysteresis
    states (N, 7, 4) of these rows (default: from c as one contiguous sequence); ``rigid_y0``:
    their regressor without gravity (:func:`rigid_regressors`), which the fit and the prediction
    have already computed (default: computed here when the counterweight needs it)."""
    n = c.shape[0]
    terms = [i for i, t in enumerate(TERMS) if t in _friction_terms(opts)]
    fr = friction_regressor(dc, opts.friction_shape)[:, :, terms]  # (N,7,nt)
    fr[:, INSERTION] = friction_regressor(dc[:, INSERTION],
                                          opts.friction_shape_prismatic)[:, terms]
    dq = dc @ T.T
    z = None
    if opts.hysteresis_coordinates:
        z = hysteresis_states(c) if states is None else np.asarray(states, dtype=float)
        if z.shape != (n, N_COORD, len(HYSTERESIS_BREAKAWAY_RAD)):
            raise IdentificationInputError(f"hysteresis states must be ({n}, {N_COORD}, "
                                           f"{len(HYSTERESIS_BREAKAWAY_RAD)}); got {z.shape}")
    counterweight = None
    if opts.insertion_counterweight:  # chain-joint torques to coordinates: tau_c = T[:6]^T tau
        if rigid_y0 is None:
            rigid_y0 = rigid_regressors(identification_model()[0], (c @ T.T)[:, :6], dq[:, :6],
                                        (ddc @ T.T)[:, :6])[0]
        counterweight = np.einsum("njp,jk->nkp", counterweight_columns(rigid_y0), T[:6])
    return TermSignals(c=c, ddc=ddc, friction=fr, dq=dq,
                       wrist_sign=np.tanh(dq / opts.friction_shape.smooth_sign_velocity),
                       coupling=T, states=z, counterweight=counterweight)


def linear_columns(opts: DynamicsFitOptions, T, c, dc, ddc, states=None,
                   rigid_y0=None) -> np.ndarray:
    """(N, 7, n_phi) columns of the linear terms (:func:`linear_terms`, same order) in
    coordinate space c; ``states`` and ``rigid_y0`` as in :func:`term_signals`."""
    signals = term_signals(opts, T, c, dc, ddc, states, rigid_y0)
    return np.stack([term.torque(signals) for term in linear_terms(opts, JOINTS)], axis=2)
