"""Cable transmission of the wrist: antagonistic pairs, pretension, slack, capstan friction with
Dahl pre-sliding memory, elasticity, roll twist.

Coordinates. Distal generalized coordinates ``p = (wrist_pitch, blade_1, blade_2)`` with
``blade_1 = wrist_yaw - jaw/2`` and ``blade_2 = wrist_yaw + jaw/2`` (rad). Cable coordinates
``x = G p`` (m of cable pulled in by the motor on the "+" cable of each pair)::

    G = diag(r_pitch, r_blade, r_blade) @ [[1, 0, 0], [kappa, 1, 0], [kappa, 0, 1]]

with ``kappa = 0.8306 / 1.0186`` the blade cables' pick-up over the pitch pulleys: this is exactly
the dVRK coupling matrix of the Cadiere / LND instrument written with pulley radii (disc radius
``R_k`` = coupling gain x distal radius). A pair's differential tension ``D = T+ - T-`` (N)
supplies generalized torque ``G^T D`` to the wrist; its sum ``S = T+ + T-`` pulls the wrist
towards the shaft, i.e. compresses the HEX10 section (``fz = -sum S``).

Every function here works on whole recordings: arrays shaped (N, 3) over time.
"""

from __future__ import annotations

import numpy as np

from psmforce.robot.conventions import JAW_CLOSED_RAD as CONVENTIONS_JAW_CLOSED_RAD
from psmforce.robot.dahl import dahl_states
from psmforce.sim.cable_laws import quadratic_pair
from psmforce.sim.params import Effects, InstrumentParams

BLADE_PITCH_PICKUP = 0.8306 / 1.0186
"""kappa: blade-cable path change per rad of wrist pitch, in units of the blade pulley radius."""

CABLE_ANGLES_RAD = np.deg2rad([[0.0, 180.0], [60.0, 240.0], [120.0, 300.0]])
"""Angular position in the HEX10 frame of the (+, -) cable of each pair where it crosses the section."""


def coupling_matrix(params: InstrumentParams) -> np.ndarray:
    """G (3, 3): cable displacement (m) per distal coordinate (rad)."""
    k = BLADE_PITCH_PICKUP
    radii = np.diag([params.pulley_radius_pitch_m, params.pulley_radius_blade_m,
                     params.pulley_radius_blade_m])
    return radii @ np.array([[1.0, 0.0, 0.0], [k, 1.0, 0.0], [k, 0.0, 1.0]])


def joints_to_distal(wrist_pitch, wrist_yaw, jaw) -> np.ndarray:
    """(N, 3) distal coordinates (pitch, blade_1, blade_2) from dVRK joint angles."""
    return np.stack([wrist_pitch, wrist_yaw - 0.5 * jaw, wrist_yaw + 0.5 * jaw], axis=-1)


def distal_to_joints(p: np.ndarray) -> np.ndarray:
    """(N, 3) (wrist_pitch, wrist_yaw, jaw) from distal coordinates (angles or small deflections)."""
    return np.stack([p[:, 0], 0.5 * (p[:, 1] + p[:, 2]), p[:, 2] - p[:, 1]], axis=-1)


def distal_torque_to_joints(tau_p: np.ndarray) -> np.ndarray:
    """Generalized torques on (pitch, blade_1, blade_2) -> torques on (wrist_pitch, wrist_yaw, jaw)
    (virtual work with blade_1,2 = yaw -+ jaw/2); the inverse of
    :func:`psmforce.robot.conventions.wrist_torques_to_distal`."""
    return np.stack([tau_p[:, 0], tau_p[:, 1] + tau_p[:, 2], 0.5 * (tau_p[:, 2] - tau_p[:, 1])], axis=-1)


def dahl_direction(x: np.ndarray, presliding_length: float, hysteresis: bool) -> np.ndarray:
    """Friction direction state z in [-1, 1] per column of ``x`` (N, C), driven by displacement:
    the Dahl state of :mod:`psmforce.robot.dahl` (after a reversal the friction passes through
    zero over a few ``x_c`` of travel, and the state remembers the last direction while the
    cable is at rest). Without ``hysteresis`` z = tanh(dx / x_c): the direction of the current
    motion, no memory.
    """
    if not hysteresis:
        return np.tanh(np.diff(x, axis=0, prepend=x[:1]) / presliding_length)
    return dahl_states(x, presliding_length)


def pair_pretension(q_roll: np.ndarray, q_pitch: np.ndarray, params: InstrumentParams,
                    effects: Effects) -> np.ndarray:
    """(N, 3) per-cable pretension T0 of each pair (N) in the current configuration.

    T0 = T_total / 6 * (1 + g_twist roll^2)                      (roll twists the cables)
         + k_cable * e_mismatch * (1 - cos pitch)   [blade pairs]  (uncompensated path length)
    """
    n = len(q_roll)
    if not effects.pretension:
        return np.zeros((n, 3))
    t0 = np.full((n, 3), params.pretension_total_n / 6.0)
    if effects.roll_twist:
        t0 *= (1.0 + params.twist_tension_gain_per_rad2 * q_roll ** 2)[:, None]
    if effects.pitch_path_mismatch:
        extra = params.cable_stiffness_n_per_m * params.pitch_path_mismatch_m * (1.0 - np.cos(q_pitch))
        t0[:, 1:] += extra[:, None]
    return t0


JAW_CLOSED_RAD = CONVENTIONS_JAW_CLOSED_RAD
"""Jaw angle (rad) at which the two blades touch (:data:`psmforce.robot.conventions.JAW_CLOSED_RAD`)."""


def jaw_grip_torque(jaw_cmd: np.ndarray, t0_blade: np.ndarray, params: InstrumentParams) -> np.ndarray:
    """(N,) grip torque (Nm, >= 0) with which each blade presses on the other when the jaw is
    commanded past closed (``jaw_cmd`` (N,) rad, motor side, below :data:`JAW_CLOSED_RAD`).

    The blades stop where they touch (taken as rigid: blade on blade is far stiffer than the
    cables); the motor side goes on to ``jaw_cmd``, so each blade's cable pair is stretched by
    ``e = r_b (closed - jaw_cmd) / 2`` (m of cable; each blade takes half the jaw angle,
    blade_1,2 = yaw -+ jaw/2). The pair's differential follows the elastic law of
    :func:`transmission` (taut: ``e = D / (2 k)``, slack: ``e = (|D| - T0) / k``) with both
    cables of a pair equally stiff, continuous at ``D = 2 T0``: ``D = min(2 k e, k e + T0)`` (N),
    ``T0`` = ``t0_blade`` (N,) the blade pairs' per-cable pretension. Grip torque ``r_b D``.
    The capstan and pin friction between the stretched run and the blades are left out of the
    grip (the load then passes through :func:`transmission`, which applies them to the cables);
    so is the jaw joint's own deflection under it. Without the ``pretension`` effect
    (``T0`` = 0) one cable carries the grip, ``D = k e``. Zero for ``jaw_cmd`` at or above closed.
    """
    r_b, k = params.pulley_radius_blade_m, params.cable_stiffness_n_per_m
    e = 0.5 * r_b * np.maximum(JAW_CLOSED_RAD - np.asarray(jaw_cmd, dtype=float), 0.0)
    return r_b * np.minimum(2.0 * k * e, k * e + t0_blade)


def jaw_command_for_grip(grip_nm, t0_blade, params: InstrumentParams) -> np.ndarray:
    """The jaw command (rad, at or below closed) that gives grip torque ``grip_nm`` (>= 0):
    the inverse of :func:`jaw_grip_torque` at per-cable pretension ``t0_blade`` (N)."""
    r_b, k = params.pulley_radius_blade_m, params.cable_stiffness_n_per_m
    d = np.asarray(grip_nm, dtype=float) / r_b
    e = np.where(d <= 2.0 * t0_blade, d / (2.0 * k), (d - t0_blade) / k)
    return JAW_CLOSED_RAD - 2.0 * e / r_b


def _capstan_pair(d_in, mu_z, alpha, t0, slack):
    """Tensions on the shaft side of an idler with capstan factor exp(+-mu_z) on (+, -) cables.

    Inputs are (N, 3). ``d_in``: differential required on the distal side. Taut loop closure:
    S_shaft = 2 T0 + alpha D_shaft (elastic loop of fixed length, asymmetric pair). Returns the
    shaft-side (S, D) and a boolean "slack" mask.
    """
    c, s = np.cosh(mu_z), np.sinh(mu_z)
    s_dist = (2.0 * t0 + d_in * (alpha * c - s)) / (c - alpha * s)
    d_sh = s_dist * s + d_in * c
    s_sh = 2.0 * t0 + alpha * d_sh
    is_slack = np.zeros(d_in.shape, dtype=bool)
    if slack:
        is_slack = s_sh < np.abs(d_sh)
        tight = np.abs(d_in) * np.exp(mu_z * np.sign(d_in))
        s_sh = np.where(is_slack, tight, s_sh)
        d_sh = np.where(is_slack, np.sign(d_in) * tight, d_sh)
    return s_sh, d_sh, is_slack


def capstan_exponents(q_roll: np.ndarray, q_pitch: np.ndarray, params: InstrumentParams,
                      effects: Effects) -> tuple[np.ndarray, np.ndarray]:
    """(mu_distal (N, 3), mu_proximal (N, 1)): friction coefficient x wrap angle of each pair over
    the wrist idlers (the blade pairs' wrap grows with |wrist pitch|) and along the proximal
    path, both raised by roll twist; zeros (N, 1) without the ``capstan`` effect."""
    n = len(q_roll)
    if not effects.capstan:
        return np.zeros((n, 1)), np.zeros((n, 1))
    twist = (1.0 + params.twist_friction_gain_per_rad * np.abs(q_roll) if effects.roll_twist
             else np.ones(n))[:, None]
    wrap = np.ones((n, 3))
    wrap[:, 1:] += params.capstan_wrap_pitch_gain * np.abs(q_pitch)[:, None]
    return params.capstan_mu_wrap_distal * wrap * twist, params.capstan_mu_wrap_proximal * twist


def transmission(q: np.ndarray, tau_load_distal: np.ndarray, params: InstrumentParams,
                 effects: Effects) -> dict[str, np.ndarray]:
    """Static cable forces for a whole recording.

    ``q`` (N, 7): motor-side (encoder) joint positions, dVRK order. ``tau_load_distal`` (N, 3):
    generalized torques (Nm) that the environment and gravity apply on (pitch, blade_1, blade_2).
    The cables supply ``tau_demand = -tau_load + tau_pin`` (pin friction opposes motion).

    Returns (all (N, 3) unless noted): ``s_shaft`` and ``d_shaft`` tension sum/differential where
    the cables cross the HEX10 section; ``tensions`` (N, 3, 2) (+, -) cable tensions there;
    ``slack`` mask; ``deflection`` (wrist_pitch, wrist_yaw, jaw) rad with
    true = encoder - deflection; ``effort`` dVRK joint-space efforts of (wrist_pitch, wrist_yaw,
    jaw) in Nm from the motor-side differentials; ``z`` Dahl direction states.

    Load-independent friction (simulator 2.2; ``params.cable_coulomb_n = f`` > 0, with the
    ``capstan`` effect): the motor-side differential gains ``+ f z`` (N; the motor pulls the
    moving cable harder by f whatever the load) and the cable run that stretches carries
    ``share x f z`` of it (``cable_coulomb_stretch_share``); the section's tensions do not.
    """
    g = coupling_matrix(params)
    g_inv_t = np.linalg.inv(g).T
    p = joints_to_distal(q[:, 4], q[:, 5], q[:, 6])
    x = p @ g.T
    z = dahl_direction(x, params.presliding_length_m, effects.hysteresis)
    roll, pitch = q[:, 3], q[:, 4]
    t0 = pair_pretension(roll, pitch, params, effects)
    alpha = np.array(params.cable_asymmetry) if effects.cable_asymmetry else np.zeros(3)
    mu_distal, mu_proximal = capstan_exponents(roll, pitch, params, effects)
    radii = np.array([params.pulley_radius_pitch_m, params.pulley_radius_blade_m,
                      params.pulley_radius_blade_m])

    tau_demand = -tau_load_distal
    d_dist = tau_demand @ g_inv_t.T
    pair = quadratic_pair if params.pair_law == "quadratic" else _capstan_pair  # cable_laws.py
    s_sh, d_sh, is_slack = pair(d_dist, mu_distal * z, alpha, t0, effects.slack)
    if effects.pin_friction:
        # Pin friction torque grows with the load the cables put on the pulley pins (~ S).
        tau_pin = params.pin_friction_coefficient * radii * s_sh * z
        tau_demand = tau_demand + tau_pin
        d_dist = tau_demand @ g_inv_t.T
        s_sh, d_sh, is_slack = pair(d_dist, mu_distal * z, alpha, t0, effects.slack)

    # Simulator 2.2: the cable path's Coulomb friction proximal of the section (N of pair
    # differential, along z); off at 0 or with the capstan (the path's friction) switched off.
    coulomb = (params.cable_coulomb_n * z if params.cable_coulomb_n and effects.capstan
               else None)
    if effects.elasticity:
        k = params.cable_stiffness_n_per_m
        d_run = d_sh if coulomb is None else d_sh + params.cable_coulomb_stretch_share * coulomb
        e = np.where(is_slack, np.sign(d_run) * np.maximum(np.abs(d_run) - t0, 0.0) / k,
                     d_run / (2.0 * k))
        deflection = distal_to_joints(e @ np.linalg.inv(g).T)
    else:
        deflection = np.zeros((len(q), 3))

    mz = mu_proximal * z
    d_motor = d_sh * np.cosh(mz) + s_sh * np.sinh(mz)
    if coulomb is not None:
        d_motor = d_motor + coulomb
    effort = distal_torque_to_joints(d_motor @ g)
    tensions = np.stack([(s_sh + d_sh) / 2.0, (s_sh - d_sh) / 2.0], axis=-1)
    return {"s_shaft": s_sh, "d_shaft": d_sh, "tensions": tensions, "slack": is_slack,
            "deflection": deflection, "effort": effort, "z": z, "pretension": t0}


def section_wrench(tensions: np.ndarray, params: InstrumentParams) -> np.ndarray:
    """(N, 6) wrench [f; m] the cables apply on the distal body across the HEX10 section, in the
    HEX10 frame. Cable (pair i, side s) crosses at r = rho (cos phi, sin phi, 0), phi from
    CABLE_ANGLES_RAD, and pulls with T along u = (sin b t, -cos b), t = (-sin phi, cos phi, 0)
    the tangent, b = ``cable_crossing_angle_rad`` (0: straight along -z). Force T u; moment
    r x T u = (-ry, rx, 0) T cos b + (0, 0, rho) T sin b. So a pair adds sin b (T+ - T-) t
    laterally and every cable rho T sin b about the shaft."""
    rho, b = params.cable_radius_in_section_m, params.cable_crossing_angle_rad
    cx, cy = rho * np.cos(CABLE_ANGLES_RAD), rho * np.sin(CABLE_ANGLES_RAD)
    n = tensions.shape[0]
    w = np.zeros((n, 6))
    axial = tensions * np.cos(b)
    w[:, 2] = -axial.sum(axis=(1, 2))
    # m = r x (0, 0, -T) = (-ry T, rx T, 0)
    w[:, 3] = -(axial * cy).sum(axis=(1, 2))
    w[:, 4] = (axial * cx).sum(axis=(1, 2))
    if b != 0.0:
        lateral = tensions * np.sin(b)
        w[:, 0] = -(lateral * np.sin(CABLE_ANGLES_RAD)).sum(axis=(1, 2))
        w[:, 1] = (lateral * np.cos(CABLE_ANGLES_RAD)).sum(axis=(1, 2))
        w[:, 5] = rho * lateral.sum(axis=(1, 2))
    return w
