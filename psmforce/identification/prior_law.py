"""The internal-force prior's law: parameters with their physical bounds and the vectorised
model (numpy or CasADi), as described in :mod:`psmforce.identification.prior`. Its own module so
that the fit (``prior.py``) and its identifiability report (``prior_identifiability.py``) read
one law without importing each other.
"""

from __future__ import annotations

import math

import numpy as np

from psmforce.identification.cable_pair import tension_sum
from psmforce.robot.conventions import wrist_torques_to_distal
from psmforce.robot.dahl import DahlState, dahl_states

KAPPA = 0.8306 / 1.0186
CABLE_ANGLES_RAD = np.deg2rad([0.0, 60.0, 120.0])
SMOOTH_MAX_N = 0.05
"""Width (N) of the smooth max between 2 T0 and |D| (slack transition)."""
DIRECTION_VELOCITY = 0.02
"""v_eps (rad/s of cable coordinate per metre of radius) of the friction-direction smooth sign."""
# name, unit, lower, upper, initial
PARAMETERS = (
    ("pretension_total", "N", 0.0, 60.0, 5.0),
    ("pulley_radius_pitch", "m", 0.5e-3, 5e-3, 1.8e-3),
    ("pulley_radius_blade", "m", 0.5e-3, 5e-3, 1.8e-3),
    ("twist_gain", "1/rad^2", 0.0, 0.5, 0.01),
    ("direction_tension", "N", -2.0, 2.0, 0.0),
    ("asymmetry_pitch", "1", -0.8, 0.8, 0.0),
    ("asymmetry_blade", "1", -0.8, 0.8, 0.0),
    ("pitch_path_tension", "N", 0.0, 10.0, 0.1),
    ("distal_mass", "kg", 0.0, 0.05, 0.005),
    ("distal_com_distance", "m", -0.05, 0.05, 0.02),
    ("cable_radius", "m", 0.0, 4e-3, 1e-3),
    ("bias_fx", "N", -5.0, 5.0, 0.0),
    ("bias_fy", "N", -5.0, 5.0, 0.0),
    # +-100 N (the HEX10 overload), not the +-5 N of the lateral biases: T_tot is both the rest
    # level and the slack threshold, and where the wrist efforts carry friction and disturbance
    # that the cables do not (docs/simulator.md section 8) the fit raises the threshold (no
    # spurious slack from effort noise) and bias_fz carries the level back. At +-5 N this bound
    # capped that split and the Free fit was worse than a constant on its own training fz
    # (studies/prior_accuracy.py; docs/identification.md section 2).
    ("bias_fz", "N", -100.0, 100.0, 0.0),
    ("bias_tx", "Nm", -0.5, 0.5, 0.0),
    ("bias_ty", "Nm", -0.5, 0.5, 0.0),
    ("bias_tz", "Nm", -0.5, 0.5, 0.0),
    # Last, so that the 17 before keep their indices in files written before it (they load with
    # 0, the law without it). Friction coefficient x wrap angle over the wrist idlers between
    # the pulleys and the HEX10 section (a capstan); 1 is a wrap of 1 rad at mu = 1.
    ("capstan_mu", "1", 0.0, 1.0, 0.0),
    # The HEX10's cross-talk of the axial force it reads into its lateral force channels (N per
    # N): the axial force is the one large load on the section (tens of N of cable compression,
    # and the tip's push), so a 1 % leak moves the lateral readings by tenths of a newton, with
    # the load. A miniature six-axis cell's uncompensated cross-talk is a few %; +-5 % bounds it.
    # The law reads the sensor's own fz for it (a sensor term, not a cable one): the internal
    # and the external axial force leak alike. Added after the capstan, for the same reason.
    ("crosstalk_fx", "1", -0.05, 0.05, 0.0),
    ("crosstalk_fy", "1", -0.05, 0.05, 0.0),
    # The same leak into the moment channels (Nm per N, a lever in m): a miniature cell's moment
    # full scale over its force full scale is about 10 mm (the HEX10's 0.25 Nm / 25 N), so a
    # few % of it is a fraction of a millimetre; +-2 mm bounds it. Added after the force ones.
    ("crosstalk_tx", "m", -2e-3, 2e-3, 0.0),
    ("crosstalk_ty", "m", -2e-3, 2e-3, 0.0),
    ("crosstalk_tz", "m", -2e-3, 2e-3, 0.0),
    # How the capstan's exponent grows with the wrist's configuration, relative to its value at
    # the straight wrist (the form of docs/simulator.md section 7, read as a datasheet).
    # Pitching the wrist wraps each blade cable further round the pitch idlers (both cables of
    # a pair alike, |pitch| more: the "symmetric" routing the real jaw transmission's
    # leave-one-configuration-out fit leaned to, docs/identification.md section 4): a wrap of
    # 2 rad at the straight wrist grows by half per rad. Rolling the shaft twists the cables
    # round each other, pressing them on their guides. Added after the cross-talk; with them 0
    # the capstan is the one constant it was.
    ("capstan_pitch_gain", "1/rad", 0.0, 2.0, 0.0),
    ("capstan_roll_gain", "1/rad", 0.0, 2.0, 0.0),
    # The wrist pulleys' pins: each pulley turns on a pin that the cables press with their sum
    # S, so turning it takes a torque c r S against the motion (a journal's friction, c its
    # coefficient times the pin's radius over the pulley's). It adds c S z to a pair's
    # differential before the idlers' capstan: a capstan changes the section's sum by D mu z as
    # well, a pin does not, which a hold after a move shows in fz. Added after the growth terms;
    # at 0 the law's one capstan carries both frictions, as it did.
    ("pin_friction", "1", 0.0, 0.5, 0.0),
    # The blade cables' path over the pitch pulleys is longer than its compensation when the
    # wrist pitches: each blade cable is stretched by it, a pretension of c (1 - cos pitch) on
    # top of T0. As pretension it goes with the pair's law: taut, the pair's sum gains 2 c
    # (1 - cos pitch), as pitch_path_tension adds it; slack, the pair's sum is |D| and the
    # stretch is gone, where pitch_path_tension still adds it. The load path, whose weights
    # take blade pairs slack at pitched wrists, reads it this way and holds pitch_path_tension
    # at 0; the efforts reading holds this one at 0, the law it was. Added after the pins.
    ("pitch_path_pretension", "N", 0.0, 10.0, 0.0),
    # The sensor's cross-talk of its lateral forces (its fx and fy columns), read from its own
    # fx and fy as the axial one is from fz. Inside the instrument the lateral forces are small
    # (the distal weight, tenths of a newton), but a known load at the tip (an ATI's, a hung
    # weight) is lateral in most poses, and a leak the law does not have is read as the cables'
    # (docs/identification.md section 2.3 traces a load-path miss to it). Bounds as the axial
    # column's: +-5 % N per N, +-2 mm Nm per N. Added after the path pretension.
    *((f"crosstalk_{into}_from_{src}", unit, -bound, bound, 0.0)
      for src in ("fx", "fy")
      for into, unit, bound in (("fx", "1", 0.05), ("fy", "1", 0.05), ("fz", "1", 0.05),
                                ("tx", "m", 2e-3), ("ty", "m", 2e-3), ("tz", "m", 2e-3))
      if into != src),
)
NAMES = tuple(p[0] for p in PARAMETERS)
CROSSTALK = ("crosstalk_fx", "crosstalk_fy", "crosstalk_tx", "crosstalk_ty", "crosstalk_tz")
"""The sensor's cross-talk of its axial reading into its other five channels (fx, fy, tx, ty,
tz, in that order): the fz column of its cross-talk matrix."""
CROSSTALK_LATERAL = tuple(p[0] for p in PARAMETERS if "_from_" in p[0])
"""The sensor's cross-talk of its lateral readings (fx, then fy) into its other five channels:
the fx and fy columns of its cross-talk matrix, ``crosstalk_<into>_from_<source>``."""
SENSOR_CROSSTALK = CROSSTALK + CROSSTALK_LATERAL
"""Every cross-talk term of the law: each reads one of the sensor's force readings."""
_CHANNEL = {c: k for k, c in enumerate(("fx", "fy", "fz", "tx", "ty", "tz"))}
CROSSTALK_ENTRIES = {n: (_CHANNEL[n.split("_")[1]],
                         _CHANNEL[n.split("_")[-1]] if "_from_" in n else 2)
                     for n in SENSOR_CROSSTALK}
"""Each :data:`SENSOR_CROSSTALK` term's entry (row: the channel it leaks into, column: the
force reading it leaks from) of the sensor's cross-talk matrix (reading = X wrench), channels
in the order fx fy fz tx ty tz."""
_LEAKS = tuple((NAMES.index(n), *CROSSTALK_ENTRIES[n]) for n in SENSOR_CROSSTALK)
_FORCE_BIASES = tuple(NAMES.index(n) for n in ("bias_fx", "bias_fy", "bias_fz"))
CAPSTAN = ("capstan_mu", "capstan_pitch_gain", "capstan_roll_gain")
"""The capstan's terms: its exponent at the straight wrist (``capstan_mu``; 0: no capstan, and
the law reads no friction state) and that exponent's relative growth per rad of |wrist pitch|
on the blade pairs and per rad of |roll| on every pair."""
FRICTION = (*CAPSTAN, "pin_friction")
"""The law's friction terms, the capstan's and the pins'; with ``capstan_mu`` and
``pin_friction`` both 0 the law reads no friction state."""
ADDED_TERMS = ("capstan_mu", *CROSSTALK, "capstan_pitch_gain", "capstan_roll_gain",
               "pin_friction", "pitch_path_pretension", *CROSSTALK_LATERAL)
"""The terms added to the law after its first 17 parameters. Each is 0 in the law before it,
and one held at exactly 0 enters the fit's graph as the number (:func:`_model` then leaves the
term out): a fit that holds them is the fit it was before they existed."""
MIN_SAMPLES = 200
"""Fewest samples (or slack samples) a fit or an identifiability verdict rests on."""
PRESLIDING_RAD = 0.02
"""Travel (rad of distal coordinate: cable travel over the pulley radius) over which the capstan's
friction reverses after a reversal of motion (the Dahl model's pre-sliding length,
:func:`friction_direction`). Assumed, not fitted: about 40 um of cable on a 1.5-2 mm pulley, the
pre-sliding of a braided cable on a steel pulley; the fit cannot separate it from the capstan's
coefficient at the rates the wrist moves."""
BOUND_TOLERANCE = 1e-3
"""A parameter within this fraction of its bounds' span of a bound is "at its bound": the one
rule of :func:`at_bound`, which the fit's ``info["bounds_hit"]``, the identifiability report and
the verdict line all use."""


def at_bound(params) -> np.ndarray:
    """(P,) bool: each parameter (SI, :data:`NAMES` order) within :data:`BOUND_TOLERANCE` of its
    bounds' span of its lower or upper bound."""
    p = np.asarray(params, dtype=float)
    lo = np.array([q[2] for q in PARAMETERS])
    hi = np.array([q[3] for q in PARAMETERS])
    return np.minimum(p - lo, hi - p) <= BOUND_TOLERANCE * (hi - lo)


def pair_differentials(effort_pitch, effort_yaw, effort_jaw, r_pitch, r_blade):
    """The pairs' differentials (N; pitch, blade 1, blade 2) that wrist torques demand: dVRK
    efforts of (wrist_pitch, wrist_yaw, jaw) (Nm) to torques on (pitch, blade_1, blade_2), then
    ``u = K^-T tau`` (``K^T = [[1, k, k], [0, 1, 0], [0, 0, 1]]``), over the pulley radii (m).
    Arrays, floats or CasADi expressions; the one place the law, its slack count and the load
    path's sag turn torques into differentials."""
    tau_p, tau_b1, tau_b2 = wrist_torques_to_distal(effort_pitch, effort_yaw, effort_jaw)
    return ((tau_p - KAPPA * (tau_b1 + tau_b2)) / r_pitch, tau_b1 / r_blade, tau_b2 / r_blade)


def _pair_travel(wrist_pitch, wrist_yaw, jaw):
    """The pairs' cable travel over their pulley radius (rad): ``K p``, ``p = (pitch, yaw - jaw/2,
    yaw + jaw/2)``, ``K`` the coupling of the module docstring (arrays or floats)."""
    return (wrist_pitch, KAPPA * wrist_pitch + wrist_yaw - 0.5 * jaw,
            KAPPA * wrist_pitch + wrist_yaw + 0.5 * jaw)


def friction_direction(wrist_positions) -> np.ndarray:
    """(N, 3) friction direction state ``z`` in [-1, 1] of each pair (pitch, blade 1, blade 2)
    over a recording, from its wrist joint positions (N, 3) (wrist_pitch, wrist_yaw, jaw; rad,
    dVRK joints, in time order): the Dahl state (:mod:`psmforce.robot.dahl`) of each pair's
    cable travel over its pulley radius, pre-sliding :data:`PRESLIDING_RAD`, from ``z = 0``.
    It remembers the direction of the last motion while the wrist is at rest, which a
    velocity's sign does not.
    """
    q = np.asarray(wrist_positions, dtype=float)
    return dahl_states(np.column_stack(_pair_travel(q[:, 0], q[:, 1], q[:, 2])), PRESLIDING_RAD)


def pair_section(d, two_t0, asym, mu_z, xp):
    """A pair's (differential, sum, taut sum) at the HEX10 section (N) for the differential
    ``d`` its wrist pulleys demand: pretension ``two_t0`` (the pair's 2 T0), asymmetry
    ``asym``, capstan exponent ``mu_z`` (the coefficient times the friction state; the plain
    number 0: no capstan). Between the pulleys and the section the tensions gain ``exp(+-mu
    z)``; the loop closes at the section (``S - a D = 2 T0`` while taut); the taut sum at the
    pulleys is the third value, the pair slack where it falls below ``|d|``. Arrays, floats or
    CasADi expressions (``xp``: numpy or :class:`_CasadiOps`); the one place the law and the
    load path's sag map a pulley differential to the section."""
    if _is_zero(mu_z):
        taut = two_t0 + asym * d
        return d, tension_sum(taut, d, SMOOTH_MAX_N, xp), taut
    c, s = xp.cosh(mu_z), xp.sinh(mu_z)
    taut = (two_t0 + d * (asym * c - s)) / (c - asym * s)
    s_pulley = tension_sum(taut, d, SMOOTH_MAX_N, xp)
    return d * c + s_pulley * s, s_pulley * c + d * s, taut


def with_pins(D, pin_terms, r_pitch, r_blade):
    """The pairs' differentials (pitch, blade 1, blade 2; N) once the pulley pins' friction adds
    ``pin_terms`` (N; ``c S z`` of each pair, its torque ``c r S z`` over its radius): each to
    its own pair, and through ``K^-T`` the blade pairs' share off the pitch pair's."""
    return (D[0] + pin_terms[0] - KAPPA * (r_blade / r_pitch) * (pin_terms[1] + pin_terms[2]),
            D[1] + pin_terms[1], D[2] + pin_terms[2])


class FrictionDirection:
    """:func:`friction_direction` one sample at a time (pure Python floats), for a streaming
    estimator: :meth:`step` takes one sample's (wrist_pitch, wrist_yaw, jaw) (rad) and returns
    the three states after it, the values the batch function gives."""

    def __init__(self):
        self._state = DahlState(3, PRESLIDING_RAD)

    def step(self, wrist_pitch: float, wrist_yaw: float, jaw: float) -> list[float]:
        return self._state.step(_pair_travel(wrist_pitch, wrist_yaw, jaw))


def active_leaks(p) -> list:
    """The :data:`SENSOR_CROSSTALK` terms of the parameters ``p`` that are not the plain number
    0, as (value, channel it leaks into, reading it leaks from)."""
    return [(p[i], into, src) for i, into, src in _LEAKS if not _is_zero(p[i])]


def sensor_crosstalk(wrench, p, hex10_force, leaks=None):
    """The six channels ``wrench`` (fx fy fz tx ty tz; N, Nm) with the sensor's cross-talk
    added: each :data:`SENSOR_CROSSTALK` term of the parameters ``p`` (the law's, :data:`NAMES`
    order) times the force reading it leaks from, less that channel's bias (``hex10_force``:
    the sensor's (fx, fy, fz) readings, N; arrays, floats or CasADi expressions). A term that
    is the plain number 0 is left out; with none left the reading is not needed (None).
    ``leaks``: :func:`active_leaks` of ``p``, where the caller keeps it (a stream, per sample)."""
    leaks = active_leaks(p) if leaks is None else leaks
    if not leaks:
        return list(wrench)
    if hex10_force is None:
        raise ValueError("the law's cross-talk terms read the HEX10's forces: pass hex10_force")
    section = [hex10_force[k] - p[i] for k, i in enumerate(_FORCE_BIASES)]
    out = list(wrench)
    for x, into, src in leaks:
        out[into] = out[into] + x * section[src]
    return out


def _model(p, pos, e, v, g_hex, z, xp, hex10_force=None, leaks=None):
    """Vectorised model; ``xp`` is numpy or a CasADi-like namespace (see ``_CasadiOps``);
    ``z`` the pairs' friction direction states (:func:`friction_direction`); ``hex10_force``
    the HEX10's (fx, fy, fz) readings (N), which only the cross-talk terms read
    (:func:`sensor_crosstalk`, with ``leaks``; None: they must be 0)."""
    (T_tot, r_p, r_b, g_tw, c_dir, a_p, a_b, c_pm, m_d, l_d, rho,
     bfx, bfy, bfz, btx, bty, btz, mu, *rest) = [p[i] for i in range(len(PARAMETERS))]
    g_pitch, g_roll, c_pin, c_pp = rest[len(CROSSTALK):len(CROSSTALK) + 4]
    roll, wrist_pitch = pos[0], pos[1]
    D = pair_differentials(e[0], e[1], e[2], r_p, r_b)
    vp, vb1, vb2 = v[0], v[1] - 0.5 * v[2], v[1] + 0.5 * v[2]
    dx = (vp, KAPPA * vp + vb1, KAPPA * vp + vb2)
    two_t0 = T_tot / 3.0 * (1.0 + g_tw * roll * roll)
    # the blade cables' path stretch as pretension of the blade pairs (gone when one is slack)
    two_t0_blade = two_t0 if _is_zero(c_pp) else two_t0 + 2.0 * c_pp * (1.0 - xp.cos(wrist_pitch))
    pair_two_t0 = (two_t0, two_t0_blade, two_t0_blade)
    # blade cables' path over the pitch pulleys: 4 cables each gain c_pm (1 - cos pitch)
    S_sum = 4.0 * c_pm * (1.0 - xp.cos(wrist_pitch))
    asym = (a_p, a_b, a_b)
    tx = 0.0
    ty = 0.0
    # a term held at 0 (a plain number: the efforts reading's) costs nothing in the fit's graph
    no_capstan = _is_zero(mu)
    if not no_capstan:  # each pair's exponent at this configuration (blade pairs wrap |pitch|)
        mu_roll = mu if _is_zero(g_roll) else mu * (1.0 + g_roll * abs(roll))
        mu_blade = mu_roll if _is_zero(g_pitch) else mu_roll * (1.0 + g_pitch * abs(wrist_pitch))
        mu_pair = (mu_roll, mu_blade, mu_blade)

    def section(i, d):
        """Pair i's (differential, sum) at the section for differential ``d`` at its pulleys."""
        return pair_section(d, pair_two_t0[i], asym[i], 0.0 if no_capstan
                            else mu_pair[i] * z[i], xp)[:2]

    if not _is_zero(c_pin):
        # the pins' torque c r S z on each pulley, S the pair's sum without it (one fixed-point
        # pass, as the bench takes it)
        D = with_pins(D, [c_pin * section(i, D[i])[1] * z[i] for i in range(3)], r_p, r_b)
    for i in range(3):
        d_section, s_section = section(i, D[i])
        S_sum = S_sum + s_section + c_dir * xp.tanh(dx[i] / DIRECTION_VELOCITY)
        tx = tx - rho * math.sin(CABLE_ANGLES_RAD[i]) * d_section
        ty = ty + rho * math.cos(CABLE_ANGLES_RAD[i]) * d_section
    gx, gy, gz = g_hex[0], g_hex[1], g_hex[2]
    # moment of the distal weight at l_d e_z: (0,0,l) x (m g) = l m (-gy, gx, 0)
    wrench = (m_d * gx + bfx, m_d * gy + bfy, m_d * gz - S_sum + bfz,
              tx - l_d * m_d * gy + btx, ty + l_d * m_d * gx + bty, 0.0 * gz + btz)
    return tuple(sensor_crosstalk(wrench, p, hex10_force, leaks))


def _is_zero(x) -> bool:
    """A parameter given as the plain number 0 (not a symbol): its term is left out."""
    return isinstance(x, (int, float)) and x == 0.0


class _CasadiOps:
    def __init__(self):
        import casadi as ca

        self.sqrt, self.tanh, self.cos = ca.sqrt, ca.tanh, ca.cos
        self.cosh, self.sinh = ca.cosh, ca.sinh
