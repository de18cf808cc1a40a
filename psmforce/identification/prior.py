"""Internal-force prior: the wrench the HEX10 reads with no external force, from wrist states.

A simplified, identifiable physical model of the cable-driven wrist (the physics of
docs/simulator.md sections 5-7 read as a datasheet; no simulator code or truth is used). Frames:
HEX10 frame (z along the shaft towards the tip); output [fx, fy, fz, tx, ty, tz] in N and Nm, the
HEX10 sign convention (compression negative fz). Inputs per sample:

* ``positions = (roll, wrist_pitch)`` (rad); wrist efforts ``e = (wrist_pitch, wrist_yaw, jaw)``
  (Nm, dVRK joint space, what the motors apply); wrist velocities ``v`` (rad/s, same joints);
* ``g_hex`` (m/s^2): gravity in the HEX10 frame, ``R_PSM_HEX10(q)^T (0, 0, -9.81)`` with the
  rotation from ``PSM.rotation(q, "hex10")`` (base frame upright).
* ``direction`` (in [-1, 1]): each pair's friction direction, a Dahl state over the recording's
  wrist positions (:func:`~psmforce.identification.prior_law.friction_direction`; a stream
  carries it with :meth:`InternalForcePrior.friction_state`).

Model::

    tau_d  = (e_wp, e_wy/2 - e_jaw, e_wy/2 + e_jaw)   generalized torques on (pitch, blade1, blade2)
    u      = K^-T tau_d,  K = [[1,0,0],[k,1,0],[k,0,1]], k = 0.8306/1.0186    (dVRK coupling)
    D_i    = u_i / r_i,   r = (r_pitch, r_blade, r_blade)   pair differential at the pulleys (N)
    T0     = T_tot/6 * (1 + g_twist roll^2)           per-cable pretension with roll twist
             (+ c_pp (1 - cos wrist_pitch) on the blade pairs: their path's stretch, gone with
             the pair's slack; the load path's form of S_path below)
    D     += K^-T (c_pin r_i S'_i z_i) / r_i          the pulleys' pins: a torque c_pin r S z
                                                      against the motion, S'_i the pair's sum
                                                      at the section below without it (one
                                                      fixed-point pass)
    mu_i   = mu (1 + g_q |wrist_pitch| [i blade]) (1 + g_r |roll|)
                                                      the capstan's exponent over the wrist
                                                      idlers: the blade cables wrap |pitch|
                                                      more, roll twist presses every cable
    c_i, s_i = cosh(mu_i z_i), sinh(mu_i z_i)         z_i the pair's friction direction (a Dahl
                                                      state)
    P_i    = smoothmax((2 T0 + D_i (a_i c_i - s_i)) / (c_i - a_i s_i), |D_i|)
             pair sum at the pulleys: taut, the loop closed at the section (S_i - a_i E_i = 2 T0,
             pair asymmetry a_i), or slack (the pair law of
             psmforce.identification.cable_pair, shared with the transmission)
    S_i    = P_i c_i + D_i s_i + c_dir tanh(dx_i / v_eps)
             pair sum at the section (T+ and T- gain exp(+mu z_i) and exp(-mu z_i) across the
             idlers), plus a direction-dependent tension along the path, dx = K v the
             cable-coordinate velocity
    E_i    = D_i c_i + P_i s_i                        pair differential at the section
    S_path = 4 c_pm (1 - cos wrist_pitch)             blade cables' path over the pitch pulleys
    f      = m_d g_hex - (0, 0, S_path + sum_i S_i) + b_f + (x_x, x_y, 0) (fz_read - b_fz)
             the last term the sensor's cross-talk x of the axial force it reads (fz_read, its
             own fz channel: the section's internal and external axial force alike) into its
             lateral forces
    t      = sum_i rho (-sin phi_i, cos phi_i, 0) E_i + l_d e_z x (m_d g_hex) + b_t
             + (x_tx, x_ty, x_tz) (fz_read - b_fz)     the same leak into the moments (m)
    w     += X_fx (fx_read - b_fx) + X_fy (fy_read - b_fy)
             the sensor's cross-talk of its lateral forces into its other channels (the fx and
             fy columns of its matrix, ``crosstalk_<into>_from_<source>``, 5 each)

With ``mu = 0`` (``capstan_mu``: what priors written before it load with, and what the efforts
reading holds, :data:`HELD_BY_READING`), ``S_i = smoothmax(2 T0 + a_i D_i, |D_i|) + ...`` and
``E_i = D_i``: the law before the capstan; with ``g_q = g_r = 0`` (``capstan_pitch_gain``,
``capstan_roll_gain``, loaded and held the same way) the capstan is one constant, the law before
its configuration terms; with ``x = 0`` (``crosstalk_fx`` ... ``crosstalk_tz``,
held and loaded the same way) the law before the cross-talk, with ``X = 0`` (the lateral
columns, likewise) the law before them; with ``c_pin = 0``
(``pin_friction``, likewise) the law before the pins, whose friction its capstan then carries;
with ``c_pp = 0`` (``pitch_path_pretension``, likewise) the law before it, the path's tension
added outside the pairs (``c_pm``, which the load path holds at 0 instead).

with the cable angles phi = (0, 60, 120) deg of the pairs' "+" cables (datasheet). Parameters
(:data:`PARAMETERS`) have physical bounds. What the data pin down is reported with every fit
(``info["identifiability"]``, :func:`identifiability`: Fisher information, standard errors,
correlations, the efforts' noise against the regressors, slack samples); ``fit(fixed=...)``
holds parameters at given values (:data:`DATASHEET`). On a bench inside this family with noisy
efforts (docs/identification.md section 2.1, "Parameter recovery on an in-family bench"): m_d, l_d
and the lateral biases are identified from free-space data; T_tot (apart from bias_fz),
g_twist and the pulley radii only from loaded data (external force subtracted) that drive
|D_i| past 2 T0 by more than the efforts' noise (slack); the asymmetries and the cable radius
multiply the pair differentials, which the efforts' noise dominates where they are fitted, and
least squares shrinks them towards zero (errors in variables).

The model reads the wrist efforts as cable torques. On a dVRK they are motor currents: they also
carry the instrument discs' own friction with stiction (proximal of the HEX10, so it tensions no
cable at the sensor) and a disturbance of the real arm's size (docs/simulator.md section 8).
An effort error of 0.01 Nm on wrist pitch is 5 N of pair differential at a 2 mm pulley, which in
the slack regime is 5 N of axial force: the fit then trades the effort-dependent terms against
the rest level, and T_tot and bias_fz stop being physical (their difference, the rest level, is).
What that leaves on the bench: docs/identification.md section 2. Where the tip force is known
(an ATI, a hung weight, free space), ``fit(..., inputs="load_path")`` reads the cables from the
torques that force demands instead (:mod:`psmforce.identification.load_path`): an
identification of the instrument, which an estimator, not knowing the force, cannot run on.

**Axis weights.** A prediction is ``w * law`` per component, ``w``
(:attr:`InternalForcePrior.axis_weights`, ones as fitted) set on recordings the fit did not see by
:func:`psmforce.identification.prior_support.supported_weights`: where the law's variation does not
explain the held-out internal wrench (a lateral internal force outside its family, a component it
predicts as a constant) the weight goes to 0 and the prior stays out of that component; the hybrid
then reads the raw HEX10 there.

The law (parameters, bounds, the vectorised model) is :mod:`psmforce.identification.prior_law`;
what the fit reports about identifiability, :mod:`psmforce.identification.prior_identifiability`;
holding what the data cannot identify at design values and refitting the rest (what
``psmforce fit-prior`` runs), :mod:`psmforce.identification.prior_selection`.

Size: the prior as one record (law, weights, fit, persistence, strict loading), each part
short; the law and the identifiability report already live in their own modules.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from psmforce.robot.conventions import GRAVITY_UPRIGHT_MPS2, INSERTION_JOINT, WRIST_JOINTS
from psmforce.core.files import write_text_atomic
from psmforce.identification.errors import IdentificationInputError, NotConvergedError
from psmforce.identification.insertion import InsertionEffortModel
from psmforce.identification.model_file import parse_model_json, read_model_json
from psmforce.identification.prior_identifiability import identifiability
from psmforce.identification.prior_law import (ADDED_TERMS, CABLE_ANGLES_RAD,  # noqa: F401
                                                CAPSTAN, CROSSTALK, CROSSTALK_LATERAL,
                                                FRICTION, KAPPA, NAMES, MIN_SAMPLES,
                                                PARAMETERS, SENSOR_CROSSTALK,
                                                _CasadiOps, _model, FrictionDirection,
                                                active_leaks,
                                                at_bound, friction_direction,
                                                pair_differentials)
from psmforce.identification.signals import check_finite_2d
from psmforce.robot.kinematics import PSM
from psmforce.io.recording import (HEX10, JOINT_POSITIONS, OVERLOAD, TARGETS, joint_column,
                                 read_recording)

FORMAT = "psmforce.identification.InternalForcePrior/1"
FORMAT_VERSION = 9
"""9: the sensor's cross-talk of its lateral forces (:data:`~.prior_law.CROSSTALK_LATERAL`).
8: the blade cables' path stretch as their pretension (``pitch_path_pretension``). 7: the
wrist pulleys' pin friction (``pin_friction``). 6: the capstan's growth with the wrist's
configuration (``capstan_pitch_gain``, ``capstan_roll_gain``). 5: the axial force's cross-talk into the moments (``crosstalk_tx``,
``crosstalk_ty``, ``crosstalk_tz``). 4: the sensor's cross-talk of the axial force
(``crosstalk_fx``, ``crosstalk_fy``). 3: the law's capstan (``capstan_mu``). 2: the integrity
envelope (:mod:`psmforce.core.integrity`: a SHA-256 over every field) and this integer; a file with neither was written before them and
still loads (its parameters checked against their bounds, as every prior's are). A file lacks
the terms added after it was written (:data:`_ADDED_IN`) and loads with them at 0, the law it
was fitted with."""
_ADDED_IN = {3: {"capstan_mu": 0.0}, 4: {"crosstalk_fx": 0.0, "crosstalk_fy": 0.0},
             5: {"crosstalk_tx": 0.0, "crosstalk_ty": 0.0, "crosstalk_tz": 0.0},
             6: {"capstan_pitch_gain": 0.0, "capstan_roll_gain": 0.0},
             7: {"pin_friction": 0.0}, 8: {"pitch_path_pretension": 0.0},
             9: dict.fromkeys(CROSSTALK_LATERAL, 0.0)}
"""Format version -> the parameters it added, with the value that gives the law before them."""

_MIN_SAMPLES = MIN_SAMPLES
_CAPSTAN = NAMES.index("capstan_mu")
_PINS = NAMES.index("pin_friction")
_FRICTION_STATE = [_CAPSTAN, _PINS]
"""The terms that read the pairs' friction states: with both 0 the law reads none."""
_CROSSTALK = [NAMES.index(n) for n in SENSOR_CROSSTALK]
_NO_DIRECTION = (0.0, 0.0, 0.0)
_WRIST_EFFORTS = tuple(joint_column(j, "effort") for j in WRIST_JOINTS)
_WRIST_VELOCITIES = tuple(joint_column(j, "velocity") for j in WRIST_JOINTS)
_INSERTION_VELOCITY = joint_column(INSERTION_JOINT, "velocity")
_INSERTION_EFFORT = joint_column(INSERTION_JOINT, "effort")


def gravity_in_hex10(q, psm=None) -> np.ndarray:
    """(N,3) gravity (m/s^2) in the HEX10 frame for joint vectors q (N,6|7), base upright."""
    return _gravity_in_frame((psm or PSM()).rotation(q, "hex10"))


def _gravity_in_frame(r_base_frame: np.ndarray) -> np.ndarray:
    """(N,3) gravity of the upright base, R^T (0, 0, -g), in frames with rotations (N,3,3)."""
    return np.einsum("nji,j->ni", r_base_frame, np.array(GRAVITY_UPRIGHT_MPS2))


def arrays_from_frame(frame, psm=None, direction: bool = True) -> dict:
    """Model inputs (positions (N,2) roll and wrist_pitch, efforts (N,3), velocities (N,3),
    g_hex (N,3), direction (N,3) the pairs' friction direction states of
    :func:`~psmforce.identification.prior_law.friction_direction`) from a recording frame, and
    ``d_shaft`` (N,3): the HEX10 z axis (the shaft, towards the tip) in the base frame, for the
    insertion model. ``direction=False``: ``direction`` None (zeros to the law), for a law
    without a capstan, which does not read it. ``hex10_force`` (N, 3): the HEX10's fx, fy, fz
    readings (N), which the law's cross-talk terms read (None where the frame has no HEX10
    columns)."""
    q = frame[list(JOINT_POSITIONS)].to_numpy(dtype=float)
    e = frame[list(_WRIST_EFFORTS)].to_numpy(dtype=float)
    v = frame[list(_WRIST_VELOCITIES)].to_numpy(dtype=float)
    r = (psm or PSM()).rotation(q, "hex10")
    return {"positions": q[:, [3, 4]], "efforts": e, "velocities": v,
            "g_hex": _gravity_in_frame(r),
            "direction": friction_direction(q[:, 4:7]) if direction else None,
            "hex10_force": frame[list(HEX10[:3])].to_numpy(dtype=float)
            if set(HEX10[:3]) <= set(frame.columns) else None,
            "d_shaft": r[:, :, 2]}


def internal_wrench_target(frame) -> tuple[np.ndarray, np.ndarray]:
    """(y, mask), (N, 6) each: what the prior should predict in a recording, the HEX10 reading
    with the known external force (``ati_fx..ati_fz``, HEX10 frame, where the recording has
    them) subtracted from its force channels, and a 0/1 mask of the samples that count: not
    the moments of samples with an external force above 0.05 N (they would need the contact
    point), nothing of an overloaded sample."""
    y = frame[list(HEX10)].to_numpy(dtype=float, copy=True)  # a view is read-only (pandas 3)
    mask = np.ones_like(y)
    if all(t in frame.columns for t in TARGETS):
        ext = frame[list(TARGETS)].to_numpy(dtype=float)
        y[:, :3] -= ext
        mask[np.linalg.norm(ext, axis=1) > 0.05, 3:] = 0.0
    if OVERLOAD in frame.columns:
        mask[frame[OVERLOAD].to_numpy() > 0] = 0.0
    return y, mask


INPUTS = ("efforts", "load_path")
"""What a prior reads as the wrist torques that load its cables (:attr:`InternalForcePrior.inputs`)."""
HELD_BY_READING = {"efforts": {**{n: 0.0 for n in FRICTION},
                               **{n: 0.0 for n in SENSOR_CROSSTALK}, "pitch_path_pretension": 0.0},
                   "load_path": {"pitch_path_tension": 0.0,
                                 **{n: 0.0 for n in CROSSTALK_LATERAL}}}
"""Parameters each reading holds (SI) unless the caller fixes them otherwise, at the value that
gives the law before them (:data:`HELD_BY_READING_REASON` says why). The friction terms
(:data:`~.prior_law.FRICTION`): the capstan turns the differential the wrist's pulleys demand
into the section's, and the pins add their friction to that demand; the load path gives the
demand, but the motor efforts are the differential at the motor, after the pins, the proximal
path's own capstan and the discs' friction, which the law does not model: read from them, the
terms only bend the curve fit. The blade cables' path tension: the efforts reading adds it
outside the pair law (``pitch_path_tension``, the law its priors were trained with), the load
path as the blade pairs' pretension (``pitch_path_pretension``), which a slack pair loses: its
weights take blade pairs slack at pitched wrists, where the two forms part. The cross-talk
(:data:`~.prior_law.CROSSTALK`)
is the sensor's, and reads its own fz, so any reading can fit it; the efforts reading is the
estimators' prior, and every committed comparison was trained with it held, so it holds it
unless asked (``crosstalk=True``, :func:`held_by_reading`): the default efforts prior stays
the law it was. The lateral columns (:data:`~.prior_law.CROSSTALK_LATERAL`) are held by both
readings unless asked (``crosstalk="full"``): every committed load-path fit was made without
them."""
_CROSSTALK_HELD = ("held by the reading: the estimators' prior holds the sensor's cross-talk "
                   "unless asked to fit it (crosstalk=True; the load path fits it)")
_LATERAL_HELD = ("held by the reading: the sensor's lateral cross-talk is fitted when asked "
                 "(crosstalk='full')")
HELD_BY_READING_REASON = {
    **{n: "held by the reading: the motor efforts are the differential after the proximal "
          "path and the discs, not the wrist's demand" for n in FRICTION},
    **{n: _CROSSTALK_HELD for n in CROSSTALK},
    **{n: _LATERAL_HELD for n in CROSSTALK_LATERAL},
    "pitch_path_pretension": "held by the reading: the estimators' prior adds the blade cables' "
                             "path tension outside the pair law (pitch_path_tension), the law "
                             "every committed comparison was trained with",
    "pitch_path_tension": "held by the reading: the load path reads the blade cables' path "
                          "tension as their pretension (pitch_path_pretension), which a slack "
                          "pair loses"}


CROSSTALK_CHOICES = (None, False, True, "full")
"""What a fit does with the sensor's cross-talk (``crosstalk``): None as the reading does
(:data:`HELD_BY_READING`), False holds every term at 0, True fits the axial column
(:data:`~.prior_law.CROSSTALK`) and holds the lateral ones, ``"full"`` fits both."""


def held_by_reading(inputs: str, crosstalk: bool | str | None = None) -> dict[str, float]:
    """What a fit reading ``inputs`` holds (name -> SI value): :data:`HELD_BY_READING`, with the
    sensor's cross-talk as ``crosstalk`` says (:data:`CROSSTALK_CHOICES`)."""
    if inputs not in INPUTS:
        raise IdentificationInputError(f"unknown prior inputs {inputs!r}; known: "
                                       f"{', '.join(INPUTS)}")
    if type(crosstalk) not in (type(None), bool, str) or crosstalk not in CROSSTALK_CHOICES:
        raise IdentificationInputError(f"crosstalk must be one of {CROSSTALK_CHOICES}, got "
                                       f"{crosstalk!r}")
    if crosstalk is False:
        return {**HELD_BY_READING[inputs], **dict.fromkeys(SENSOR_CROSSTALK, 0.0)}
    fitted = {True: CROSSTALK, "full": SENSOR_CROSSTALK}.get(crosstalk, ())
    return {n: x for n, x in HELD_BY_READING[inputs].items() if n not in fitted}


def fit_arrays(frame, inputs: str, psm=None, targets: bool = True, direction: bool = True,
               compliance=None, clenched_lateral: bool = False):
    """(model inputs, target, mask) of one recording for a prior reading ``inputs``
    (:data:`INPUTS`); ``targets=False`` skips the target (None, None); ``direction``: as
    :func:`arrays_from_frame`; ``compliance``: the wrist's
    (:class:`~psmforce.identification.load_path.WristCompliance`) the load path sags it with
    (None: the design's). The load path leaves clenched samples out; ``clenched_lateral`` keeps
    their lateral force channels: a grip internal to the jaws loads the cables, which cross the
    section along the shaft, and no lateral force, so there the HEX10's fx and fy read what the
    law has (the distal weight, the cross-talk of the axial reading the grip moves)."""
    a = arrays_from_frame(frame, psm, direction)
    y, mask = internal_wrench_target(frame) if targets else (None, None)
    if inputs == "load_path":
        from psmforce.identification.load_path import clenched, load_path_inputs
        efforts, tip_moment = load_path_inputs(frame, psm, compliance)
        a = {**a, "efforts": efforts}
        if targets:  # the tip force's moment is known: every sample's moments count
            y[:, 3:] -= tip_moment
            mask[:, 3:] = mask[:, :1]
            # an unknown grip loads the blade pairs: the axial force and the moments
            mask[clenched(frame), 2 if clenched_lateral else 0:] = 0.0
    return a, y, mask


def _compliance(compliance, inputs: str):
    """The wrist compliance a fit reading ``inputs`` sags the wrist with: ``compliance``, or
    the design's (:meth:`~psmforce.identification.load_path.WristCompliance.design`) when None;
    None for the efforts reading, which has no sag (refuses a compliance given to it)."""
    from psmforce.identification.load_path import WristCompliance
    if inputs != "load_path":
        if compliance is not None:
            raise IdentificationInputError(f"a wrist compliance sags the load path only; the "
                                           f"{inputs!r} reading takes none")
        return None
    if compliance is None:
        return WristCompliance.design()
    if not isinstance(compliance, WristCompliance):
        raise IdentificationInputError(f"compliance must be a WristCompliance, got "
                                       f"{type(compliance).__name__}")
    return compliance


def _check_reading(hex10_force, n: int) -> np.ndarray | None:
    """The HEX10's force readings (N, 3) checked (finite, three columns fx fy fz, ``n``
    samples); None stays None (a law without cross-talk reads none)."""
    if hex10_force is None:
        return None
    f = check_finite_2d(hex10_force, "hex10_force (the HEX10's fx, fy, fz readings)", width=3)
    if len(f) != n:
        raise IdentificationInputError(f"hex10_force has {len(f)} samples but positions has {n}")
    return f


def _check_arrays(positions, efforts, velocities, g_hex, direction=None):
    """The law's input arrays checked (finite, widths, one length); ``direction`` None gives
    zeros (no capstan friction), otherwise it is checked too."""
    pos = check_finite_2d(positions, "positions (roll, wrist_pitch)", width=2)
    n = len(pos)
    arrs = []
    direction = np.zeros((n, 3)) if direction is None else direction
    for x, name in ((efforts, "efforts"), (velocities, "velocities"), (g_hex, "g_hex"),
                    (direction, "direction (friction states)")):
        a = check_finite_2d(x, name, width=3)
        if len(a) != n:
            raise IdentificationInputError(f"{name} has {len(a)} samples but positions has {n}")
        arrs.append(a)
    return pos, *arrs


@dataclass
class InternalForcePrior:
    """Fitted internal-force prior. ``params`` in :data:`NAMES` order."""

    params: np.ndarray = field(default_factory=lambda: np.array([p[4] for p in PARAMETERS]))
    converged: bool = False
    info: dict = field(default_factory=dict)
    insertion: InsertionEffortModel | None = None
    """The insertion joint's internal effort (:mod:`psmforce.identification.insertion`), fitted
    alongside when the recordings carry the external force; None otherwise."""
    axis_weights: np.ndarray = field(default_factory=lambda: np.ones(6))
    """(6,) in [0, 1]: the share of each output component [fx .. tz] that predictions carry, as
    held-out recordings support it (:mod:`psmforce.identification.prior_support`); ones (the
    law as fitted) until :meth:`with_axis_weights` sets them."""

    def insertion_axial_force(self, frame, psm=None) -> np.ndarray:
        """(N,) external force along the shaft (N, HEX10 z) from the insertion effort."""
        if self.insertion is None:
            raise IdentificationInputError("this prior has no insertion model (it was fitted "
                                           "without known external forces)")
        q = frame[list(JOINT_POSITIONS)].to_numpy(dtype=float)
        d = (psm or PSM()).rotation(q, "hex10")[:, :, 2]
        return self.insertion.axial_force(d, frame[_INSERTION_VELOCITY].to_numpy(dtype=float),
                                          frame[_INSERTION_EFFORT].to_numpy(dtype=float))

    # ------------------------------------------------------------ prediction
    def predict_arrays(self, positions, efforts, velocities, g_hex, direction=None,
                       hex10_force=None) -> np.ndarray:
        """(N,6) HEX10 wrench [fx, fy, fz, tx, ty, tz] (N, Nm) from (N,2) and (N,3) arrays;
        ``direction`` (N,3) the pairs' friction states (:func:`friction_direction` of the
        recording), needed only when the law has a capstan (:meth:`_needs_direction`);
        ``hex10_force`` (N, 3) the HEX10's fx, fy, fz readings, needed only when it has a
        cross-talk (:meth:`_needs_reading`)."""
        self._needs_direction(direction)
        self._needs_reading(hex10_force)
        pos, e, v, g, z = _check_arrays(positions, efforts, velocities, g_hex, direction)
        return self.law_arrays(pos, e, v, g, z, _check_reading(hex10_force, len(pos))) \
            * self.axis_weights

    def law_arrays(self, positions, efforts, velocities, g_hex, direction=None,
                   hex10_force=None) -> np.ndarray:
        """(N,6) the fitted law's output before :attr:`axis_weights` (checked arrays)."""
        self._needs_direction(direction)
        self._needs_reading(hex10_force)
        z = np.zeros((len(positions), 3)) if direction is None else direction
        out = _model(self.params, positions.T, efforts.T, velocities.T, g_hex.T, z.T, np,
                     None if hex10_force is None else hex10_force.T)
        return np.stack([np.broadcast_to(c, (len(positions),)) for c in out], axis=1)

    def friction_state(self) -> FrictionDirection | None:
        """A fresh :class:`~psmforce.identification.prior_law.FrictionDirection` for a stream
        (its :meth:`step` gives :meth:`predict_one`'s ``direction``), or None when the law has
        no friction and needs none."""
        return FrictionDirection() if self.has_friction else None

    @property
    def has_friction(self) -> bool:
        """Whether the law has a capstan or the pins' friction (``capstan_mu`` or
        ``pin_friction`` > 0) and so reads the pairs' friction states; without either it is the
        law before the terms, and skips them."""
        return bool(np.any(self.params[_FRICTION_STATE] != 0.0))

    @property
    def has_crosstalk(self) -> bool:
        """Whether the law has the sensor's cross-talk (a
        :data:`~.prior_law.SENSOR_CROSSTALK` term not 0) and so reads the HEX10's forces;
        without it, it is the law before the terms."""
        return bool(np.any(self.params[_CROSSTALK] != 0.0))

    @property
    def crosstalk(self) -> bool | str:
        """The sensor's cross-talk this law has, as a fit's ``crosstalk`` names it
        (:data:`CROSSTALK_CHOICES`): ``"full"`` with a lateral column term, True with axial
        terms only, False with none. A refit with it keeps the law's terms."""
        if np.any(self.params[[NAMES.index(n) for n in CROSSTALK_LATERAL]] != 0.0):
            return "full"
        return self.has_crosstalk

    def _needs_reading(self, hex10_force) -> None:
        """A law with the sensor's cross-talk reads the HEX10's forces: refused without them."""
        if hex10_force is None and self.has_crosstalk:
            terms = ", ".join(f"{NAMES[i]} {self.params[i]:.4g}" for i in _CROSSTALK
                              if self.params[i] != 0.0)
            raise IdentificationInputError(f"this prior has the HEX10's cross-talk ({terms}): "
                                           f"pass the HEX10's force readings (hex10_force)")

    def _needs_direction(self, direction) -> None:
        """A law with friction (``capstan_mu`` or ``pin_friction`` > 0) depends on the friction
        direction's history: refused without it rather than evaluated as if the wrist had never
        moved."""
        if direction is None and self.has_friction:
            terms = ", ".join(f"{NAMES[i]} {self.params[i]:.4g}" for i in _FRICTION_STATE
                              if self.params[i] != 0.0)
            raise IdentificationInputError(
                f"this prior has friction ({terms}): pass the pairs' friction direction states "
                "(prior_law.friction_direction of the recording's wrist positions)")

    def predict(self, frame_or_arrays, psm=None) -> np.ndarray:
        """(N,6) prediction for a recording DataFrame or a dict of :func:`arrays_from_frame`."""
        arrays = frame_or_arrays if isinstance(frame_or_arrays, dict) else fit_arrays(
            frame_or_arrays, self.inputs, psm, targets=False,
            direction=self.has_friction, compliance=self.wrist_compliance)[0]
        return self.predict_arrays(arrays["positions"], arrays["efforts"], arrays["velocities"],
                                   arrays["g_hex"], arrays.get("direction"),
                                   arrays.get("hex10_force"))

    def fit_metrics(self, recordings, psm=None) -> dict:
        """Per HEX10 channel, RMS and R^2 (:func:`channel_metrics`) of the law (before
        :attr:`axis_weights`) on recording frames read as its fit reads them (:attr:`inputs`,
        the fit's sample mask): the figure ``info["train_metrics"]`` holds, on any
        recordings."""
        parts = [fit_arrays(f, self.inputs, psm, direction=self.has_friction,
                            compliance=self.wrist_compliance,
                            clenched_lateral=self.info.get("clenched_lateral", False))
                 for f in recordings]
        law = [self.law_arrays(*_check_arrays(a["positions"], a["efforts"], a["velocities"],
                                              a["g_hex"], a["direction"]),
                               a["hex10_force"] if self.has_crosstalk else None)
               for a, _, _ in parts]
        return channel_metrics(np.concatenate([y for _, y, _ in parts]), np.concatenate(law),
                               np.concatenate([m for _, _, m in parts]))

    @property
    def inputs(self) -> str:
        """What the law reads as wrist torques (:data:`INPUTS`): ``"efforts"`` (the motor
        efforts, what a streaming estimator has) or ``"load_path"`` (those the known tip force
        demands; :meth:`predict` on a recording then reads its ``ati_*`` force)."""
        return self.info.get("inputs", "efforts")

    @property
    def wrist_compliance(self):
        """The :class:`~psmforce.identification.load_path.WristCompliance` a load-path prior
        sagged the wrist with (``info["wrist_compliance"]``; the design's where a prior written
        before it was recorded has none), which :meth:`predict` sags it with again; None for an
        efforts prior."""
        if self.inputs != "load_path":
            return None
        from psmforce.identification.load_path import WristCompliance
        d = self.info.get("wrist_compliance")
        return WristCompliance.design() if d is None else WristCompliance.from_dict(
            d, "the prior's info.wrist_compliance")

    def predict_one(self, positions, efforts, velocities, g_hex, direction=None,
                    hex10_force=None) -> tuple:
        """Per-sample fast path (pure Python floats): 6-tuple wrench from 2-, 3-, 3-, 3-sequences
        and the pairs' friction states (3; the caller carries :func:`friction_direction`'s
        recursion, as :class:`~psmforce.estimators.data.hybrid_inputs.SamplePrior` does), and
        the HEX10's (fx, fy, fz) readings where the law has a cross-talk."""
        plist, friction, leaks = self._plist_terms
        if direction is None:  # the hot path of a stream: plain floats, no numpy
            if friction:
                self._needs_direction(direction)
            direction = _NO_DIRECTION
        if hex10_force is None and leaks:
            self._needs_reading(hex10_force)
        out = _model(plist, positions, efforts, velocities, g_hex, direction, math, hex10_force,
                     leaks)
        weights = self._wlist
        if weights is None:
            return out
        return tuple(w * x for w, x in zip(weights, out))

    def with_axis_weights(self, weights, report: dict | None = None) -> InternalForcePrior:
        """A copy predicting ``weights * law`` per component (:attr:`axis_weights`);
        ``report`` goes to ``info["axis_weights"]``."""
        w = _check_weights(weights, "axis weights")
        info = {**self.info, **({"axis_weights": report} if report is not None else {})}
        return InternalForcePrior(params=self.params.copy(), converged=self.converged,
                                  info=info, insertion=self.insertion, axis_weights=w)

    # predict_one runs once per sample of a stream: what it reads of the parameters and the
    # weights is converted to Python floats once per array (a new array is converted again;
    # the arrays are not changed in place)
    @property
    def _wlist(self) -> list[float] | None:
        """:attr:`axis_weights` as floats; None when every weight is 1 (nothing to apply)."""
        cached = getattr(self, "_wlist_cache", None)
        if cached is None or cached[0] is not self.axis_weights:
            w = [float(x) for x in self.axis_weights]
            cached = self._wlist_cache = (self.axis_weights, None if w == [1.0] * 6 else w)
        return cached[1]

    @property
    def _plist_terms(self) -> tuple[list[float], bool, list]:
        """:attr:`params` as floats, whether the law has friction (:attr:`has_friction`) and
        its sensor's cross-talk terms (:func:`~.prior_law.active_leaks`; empty without
        :attr:`has_crosstalk`), found once rather than per sample."""
        cached = getattr(self, "_plist_cache", None)
        if cached is None or cached[0] is not self.params:
            plist = [float(x) for x in self.params]
            cached = self._plist_cache = (self.params, (
                plist, plist[_CAPSTAN] != 0.0 or plist[_PINS] != 0.0, active_leaks(plist)))
        return cached[1]

    # ------------------------------------------------------------ fit
    @classmethod
    def fit(cls, recordings, *, psm=None, provenance=None, max_iter: int = 500,
            fixed: dict[str, float] | None = None, initial: dict[str, float] | None = None,
            report: bool = True, inputs: str = "efforts",
            crosstalk: bool | str | None = None, compliance=None,
            reference: InternalForcePrior | None = None,
            held_tolerance: dict[str, float] | None = None,
            clenched_lateral: bool = False) -> InternalForcePrior:
        """Fit on recordings (DataFrames of ``psmforce.io.recording`` or paths).

        Where target columns ``ati_fx..ati_fz`` exist, the known external force (HEX10 frame) is
        subtracted from the force channels, and samples with an external force above 0.05 N are
        fitted on forces only (their moments would need the contact point).

        ``fixed``: parameters (names of :data:`NAMES`, SI values inside their bounds) held at the
        given values instead of fitted: those the data cannot pin down, set from the instrument's
        datasheet (:data:`DATASHEET`). ``info["identifiability"]`` reports which of the others
        the data do pin down (:func:`identifiability`); ``report=False`` skips it (the trial
        jackknife of :mod:`.prior_selection` refits many times). ``initial``: starting values
        (SI) for some free parameters instead of :data:`PARAMETERS`' (a warm start).
        ``info["bounds_hit"]``: the free parameters at a bound by
        :func:`~psmforce.identification.prior_law.at_bound`, the rule the report uses too.
        Choosing what to fix from the report: :func:`.prior_selection.fit_identified`.
        ``inputs`` (:data:`INPUTS`): ``"load_path"`` reads the cables from the known tip force
        instead of the motor efforts, and fits the moments of loaded samples too, with the tip
        force's moment subtracted (:mod:`psmforce.identification.load_path`; every recording
        must carry ``ati_fx..ati_fz``). ``crosstalk``: fit the sensor's cross-talk of its axial
        force (True) or of every force (``"full"``), hold it at 0 (False), or as the reading
        does (None): :func:`held_by_reading`.
        ``compliance``: with the load path, the
        :class:`~psmforce.identification.load_path.WristCompliance` that sags the wrist (None:
        the design's), kept in ``info["wrist_compliance"]``.
        ``clenched_lateral``: with the load path, the clenched samples' lateral force channels
        count (:func:`fit_arrays`), ``info["clenched_lateral"]`` says so.
        ``reference``: fit the law to that prior's law (before its axis weights) on the
        recordings' own inputs instead of to their readings, with the same samples counted: the
        projection of one law onto the law as ``fixed`` holds it (a parameter's truth as a held
        law can carry it, ``psmforce.experiments.prior_recovery.projected_truth``); it reads
        what ``inputs`` give, and ``info["reference"]`` records its parameters.
        ``held_tolerance``: how far each held value may be off its truth (name -> SI), for the
        report's check of what rests on held values (:func:`identifiability`); a friction or
        cross-talk term held at 0 with a tolerance is read (its state, the readings) for that
        check only, the fitted law still does without it.
        """
        import casadi as ca

        held = held_by_reading(inputs, crosstalk)
        compliance = _compliance(compliance, inputs)
        if clenched_lateral is not False and (clenched_lateral is not True
                                              or inputs != "load_path"):
            raise IdentificationInputError(f"clenched_lateral: True only with inputs='load_path' "
                                           f"(the efforts reading counts clenched samples), got "
                                           f"{clenched_lateral!r} with {inputs!r}")
        if reference is not None and not isinstance(reference, InternalForcePrior):
            raise IdentificationInputError(f"reference must be an InternalForcePrior, got "
                                           f"{type(reference).__name__}")
        t0 = time.perf_counter()
        if len(recordings) == 0:
            raise IdentificationInputError("no recordings to fit the prior on")
        fixed = _check_fixed({**held, **(fixed or {})})
        # both friction terms held at 0: the law then reads no friction state
        no_friction = all(fixed.get(NAMES[i]) == 0.0 for i in _FRICTION_STATE)
        no_crosstalk = all(fixed.get(NAMES[i]) == 0.0 for i in _CROSSTALK)  # nor the readings
        # the reference law reads the friction state and the readings if it has the terms
        guarded = {n for n, t in (held_tolerance or {}).items() if t > 0} if report else set()
        read_direction = (not no_friction or (reference is not None and reference.has_friction)
                          or bool(guarded & {NAMES[i] for i in _FRICTION_STATE}))
        read_force = (not no_crosstalk or (reference is not None and reference.has_crosstalk)
                      or bool(guarded & {NAMES[i] for i in _CROSSTALK}))
        parts, axial = [], []
        sources = []
        for rec in recordings:
            if isinstance(rec, (str, Path)):
                sources.append(str(rec))
                rec = read_recording(rec)
            else:
                sources.append("<DataFrame>")
            a, y, mask = fit_arrays(rec, inputs, psm, direction=read_direction,
                                    compliance=compliance, clenched_lateral=clenched_lateral)
            parts.append((a, y, mask))
            if all(t in rec.columns for t in TARGETS) and \
                    {_INSERTION_VELOCITY, _INSERTION_EFFORT} <= set(rec.columns):
                axial.append((a["d_shaft"], rec[_INSERTION_VELOCITY].to_numpy(dtype=float),
                              rec[_INSERTION_EFFORT].to_numpy(dtype=float),
                              rec[TARGETS[2]].to_numpy(dtype=float)))
        pos = np.concatenate([p[0]["positions"] for p in parts])
        e = np.concatenate([p[0]["efforts"] for p in parts])
        v = np.concatenate([p[0]["velocities"] for p in parts])
        g = np.concatenate([p[0]["g_hex"] for p in parts])
        zd = np.concatenate([np.zeros((len(p[0]["positions"]), 3)) if not read_direction
                             else p[0]["direction"] for p in parts])
        force_read = None if not read_force else _check_reading(
            np.concatenate([p[0]["hex10_force"] for p in parts]), len(zd))
        y = np.concatenate([p[1] for p in parts])
        mask = np.concatenate([p[2] for p in parts])
        pos, e, v, g, zd = _check_arrays(pos, e, v, g, zd)
        roll = pos[:, 0]
        check_finite_2d(y, "HEX10 readings", width=6)
        if reference is not None:  # the reference's law, on the same inputs and samples
            y = reference.law_arrays(pos, e, v, g, zd if reference.has_friction else None,
                                     force_read if reference.has_crosstalk else None)
        # what the report reads: the held-value check (held_tolerance) also the states and
        # readings of the terms it moves; without it, what the fitted law reads (below)
        seen = (zd, force_read)
        if no_friction:
            zd = np.zeros_like(zd)  # the fitted law reads no friction state
        if no_crosstalk:
            force_read = None
        if len(roll) < _MIN_SAMPLES:
            raise IdentificationInputError(
                f"{len(roll)} samples is too short to fit the prior (need {_MIN_SAMPLES})")
        if np.ptp(roll) < 1e-3 and np.ptp(g, axis=0).max() < 1e-3:
            raise IdentificationInputError(
                "the recordings do not move the instrument (roll and orientation constant): "
                "twist gain, distal mass and biases are not identifiable")

        lo = np.array([p[2] for p in PARAMETERS])
        hi = np.array([p[3] for p in PARAMETERS])
        scale = np.maximum(np.abs(hi - lo), 1e-12)
        z = ca.MX.sym("z", len(PARAMETERS))
        p = lo + z * scale  # optimise on [0, 1] per parameter: IPOPT sees O(1) numbers
        cols = [ca.DM(x) for x in (e.T.tolist())]
        vcols = [ca.DM(x) for x in (v.T.tolist())]
        gcols = [ca.DM(x) for x in (g.T.tolist())]
        # an added term held at 0 enters as the number: the law's graph is the one without it
        law_p = [0.0 if name in ADDED_TERMS and fixed.get(name) == 0.0 else p[i]
                 for i, name in enumerate(NAMES)]
        zcols = None if no_friction else [ca.DM(x) for x in (zd.T.tolist())]
        pred = _model(law_p, [ca.DM(pos[:, 0]), ca.DM(pos[:, 1])], cols, vcols, gcols, zcols,
                      _CasadiOps(),
                      None if no_crosstalk else [ca.DM(c) for c in force_read.T.tolist()])
        ch_scale = np.sqrt(np.sum(mask * (y - (y * mask).sum(0) / np.maximum(mask.sum(0), 1)) ** 2,
                                  axis=0) / np.maximum(mask.sum(0), 1))
        ch_scale = np.maximum(ch_scale, [0.02] * 3 + [2e-4] * 3)  # noise floors, N and Nm
        cost = 0
        for k in range(6):
            r = (pred[k] - ca.DM(y[:, k])) * ca.DM(mask[:, k] / ch_scale[k])
            cost = cost + ca.sumsqr(r)
        cost = cost / len(roll)
        solver = ca.nlpsol("prior", "ipopt", {"x": z, "f": cost}, {
            "ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": max_iter,
            "ipopt.tol": 1e-9, "ipopt.sb": "yes"})
        start = {**(initial or {}), **fixed}
        z0 = (np.clip([start.get(n, p_[4]) for n, p_ in zip(NAMES, PARAMETERS)], lo, hi) - lo
              ) / scale
        is_fixed = np.array([n in fixed for n in NAMES])
        sol = solver(x0=z0, lbx=np.where(is_fixed, z0, 0.0), ubx=np.where(is_fixed, z0, 1.0))
        stats = solver.stats()
        params = lo + np.array(sol["x"]).ravel() * scale
        params[is_fixed] = [fixed[n] for n in NAMES if n in fixed]  # exact, not via z
        insertion = (InsertionEffortModel.fit(*map(list, zip(*axial)))
                     if len(axial) == len(parts) else None)
        prior = cls(params=params, converged=bool(stats["success"]), insertion=insertion)
        fitted = prior.predict_arrays(pos, e, v, g, zd, force_read)
        prior.info = {
            "solver": "CasADi IPOPT", "solver_status": stats["return_status"],
            "iterations": int(stats["iter_count"]), "fit_time_s": time.perf_counter() - t0,
            "n_samples": int(len(roll)),
            "bounds_hit": _bounds_hit(params, fixed),
            "fixed": {n: float(x) for n, x in fixed.items()},
            "inputs": inputs,
            **({"wrist_compliance": asdict(compliance)} if compliance is not None else {}),
            **({"clenched_lateral": True} if clenched_lateral else {}),
            **({"reference": dict(zip(NAMES, map(float, reference.params)))}
               if reference is not None else {}),
            **({"identifiability": identifiability(params, fixed,
                                                   (pos, e, v, g, *(seen if guarded else
                                                                    (zd, force_read))),
                                                   y, mask, ch_scale,
                                                   efforts_read=inputs == "efforts",
                                                   held_tolerance=held_tolerance)}
               if report else {}),
            "slack_samples_fraction": float(np.mean(_slack_any(prior.params, roll, e))),
            "train_metrics": channel_metrics(y, fitted, mask),
            "provenance": provenance or {"recordings": sources},
        }
        return prior

    # ------------------------------------------------------------ persistence
    def to_dict(self) -> dict:
        return {"format": FORMAT, "converged": bool(self.converged),
                "frames_and_units": "output: HEX10 wrench [fx,fy,fz,tx,ty,tz] in N, Nm, HEX10 frame, "
                                    "compression negative fz; inputs: roll and wrist_pitch rad, wrist efforts Nm "
                                    "(dVRK joints), wrist velocities rad/s, gravity in HEX10 m/s^2, "
                                    "pair friction directions in [-1, 1]",
                "model": "see psmforce/identification/prior.py module docstring",
                "parameters": {n: {"value": float(x), "unit": u, "lower": lo, "upper": hi}
                               for (n, u, lo, hi, _), x in zip(PARAMETERS, self.params)},
                "axis_weights": [float(x) for x in self.axis_weights],
                "info": self.info,
                **({"insertion": self.insertion.to_dict()} if self.insertion is not None else {})}

    def save(self, path) -> None:
        """Write human-readable JSON atomically; refuses a non-converged fit."""
        write_text_atomic(path, self.to_json())

    def to_json(self) -> str:
        """The text :meth:`save` writes, in memory (a checkpoint keeps it); refuses a
        non-converged fit."""
        if not self.converged:
            raise NotConvergedError("refusing to save a prior whose fit did not converge "
                                    f"({self.info.get('solver_status')})")
        from psmforce.core.integrity import seal
        return json.dumps(seal({**self.to_dict(), "format_version": FORMAT_VERSION}), indent=2,
                          allow_nan=False) + "\n"

    @classmethod
    def load(cls, path) -> InternalForcePrior:
        """Read a prior JSON written by :meth:`save`. Refuses, naming the file: unreadable or
        invalid JSON, another format, a field that does not match the file's SHA-256 envelope
        or a format version that is not the integer :data:`FORMAT_VERSION` (files written
        before the envelope carry neither and load), a missing parameter, and any parameter
        that is not a finite number inside its physical bounds (:data:`PARAMETERS`; the same
        bounds the fit uses, so a prior the fit wrote always loads): a NaN predicts NaN
        everywhere, a negative pulley radius trains a model on nonsense."""
        return cls.from_dict(read_model_json(path, FORMAT, "an InternalForcePrior"), path)

    @classmethod
    def from_json(cls, text: str, source: str = "prior JSON") -> InternalForcePrior:
        """:meth:`load` on the text :meth:`to_json` gives, in memory; ``source`` names it in
        the refusals."""
        return cls.from_dict(parse_model_json(text, FORMAT, "an InternalForcePrior", source),
                             source)

    @classmethod
    def from_dict(cls, d: dict, path) -> InternalForcePrior:
        """The checks of :meth:`load` on the parsed JSON ``d``; ``path`` names its source."""
        if "format_version" in d or "sha256" in d:  # a file without both predates them
            from psmforce.core.integrity import check_version, verify
            check_version(d.get("format_version"), range(2, FORMAT_VERSION + 1), str(path),
                          "prior", IdentificationInputError)
            verify(d, str(path), "prior", IdentificationInputError)
        entries = d.get("parameters")
        if not isinstance(entries, dict):
            raise IdentificationInputError(f"{path}: no 'parameters' object")
        version = d.get("format_version") or 1
        if version != FORMAT_VERSION:
            absent = {n: {"value": x} for v, added in _ADDED_IN.items() if v > version
                      for n, x in added.items()}
            entries = {**absent, **entries}
        missing = [n for n in NAMES if n not in entries]
        if missing:
            raise IdentificationInputError(f"{path}: missing parameters {missing}")
        params = []
        for name, unit, lo, hi, _ in PARAMETERS:
            entry = entries[name]
            value = entry.get("value") if isinstance(entry, dict) else None
            # the fit's solver may sit on a bound within its own tolerance
            slack = 1e-6 * (hi - lo)
            if (isinstance(value, bool) or not isinstance(value, (int, float))
                    or not math.isfinite(value) or not lo - slack <= value <= hi + slack):
                raise IdentificationInputError(
                    f"{path}: parameter '{name}' must be a finite number in [{lo:g}, {hi:g}] "
                    f"{unit}, got {value!r}")
            params.append(float(value))
        try:
            insertion = (InsertionEffortModel.from_dict(d["insertion"]) if "insertion" in d
                         else None)
        except IdentificationInputError as err:
            raise IdentificationInputError(f"{path}: {err}") from None
        try:  # priors written before the weights predict the law as fitted
            weights = _check_weights(d.get("axis_weights", [1.0] * 6), "'axis_weights'")
        except IdentificationInputError as err:
            raise IdentificationInputError(f"{path}: {err}") from None
        info = d.get("info", {})
        if isinstance(info, dict) and info.get("inputs", "efforts") not in INPUTS:
            raise IdentificationInputError(f"{path}: 'info.inputs' must be one of {INPUTS}, "
                                           f"got {info.get('inputs')!r}")
        if isinstance(info, dict) and info.get("clenched_lateral", True) is not True:
            raise IdentificationInputError(f"{path}: 'info.clenched_lateral' must be true where "
                                           f"present, got {info['clenched_lateral']!r}")
        if isinstance(info, dict) and "wrist_compliance" in info:
            from psmforce.identification.load_path import WristCompliance
            WristCompliance.from_dict(info["wrist_compliance"],
                                      f"{path}: 'info.wrist_compliance'")
        return cls(params=np.array(params), converged=bool(d.get("converged")),
                   info=info if isinstance(info, dict) else {}, insertion=insertion,
                   axis_weights=weights)


DATASHEET = {"cable_radius": 1.2e-3, "pulley_radius_pitch": 2.0e-3, "pulley_radius_blade": 1.5e-3}
"""Geometry the datasheet states (docs/simulator.md sections 7 and 10: cables cross the bore at
1.2 mm; pulley radii 2.0 / 1.5 mm), for ``fit(fixed=...)``: the values to hold a parameter at
when the data cannot pin it down. The cable radius, for one, is fitted from moments only where no
external force acts, and there the pair differentials are the wrist efforts' noise alone (nothing
loads the wrist): least squares then shrinks it towards zero (``input_reliability`` of
:func:`identifiability`). The pulley radii are pinned only by slack samples."""
def _check_weights(weights, name: str) -> np.ndarray:
    """Six finite numbers in [0, 1], or a one-line refusal naming ``name``."""
    if (not isinstance(weights, (list, tuple, np.ndarray)) or len(weights) != 6
            or any(isinstance(w, bool) or not isinstance(w, (int, float, np.floating))
                   for w in weights)):
        raise IdentificationInputError(f"{name} must be a list of 6 numbers (fx .. tz), "
                                       f"got {weights!r}")
    w = np.asarray(weights, dtype=float)
    if not (np.isfinite(w).all() and (w >= 0).all() and (w <= 1).all()):
        raise IdentificationInputError(f"{name} must lie in [0, 1], got {w.tolist()}")
    return w


def _bounds_hit(params, fixed) -> list[str]:
    """The free parameters at a bound, by :func:`~psmforce.identification.prior_law.at_bound`
    (the rule the identifiability report uses): ``info["bounds_hit"]``."""
    return [n for n, hit in zip(NAMES, at_bound(params)) if hit and n not in fixed]


def _check_fixed(fixed) -> dict[str, float]:
    if fixed is None:
        return {}
    if not isinstance(fixed, dict):
        raise IdentificationInputError(
            f"fixed: expected a dict name -> value, got {type(fixed).__name__}")
    out = {}
    for name, value in fixed.items():
        if name not in NAMES:
            raise IdentificationInputError(f"fixed: unknown parameter {name!r} (one of {NAMES})")
        _, unit, lo, hi, _ = PARAMETERS[NAMES.index(name)]
        if (isinstance(value, bool) or not isinstance(value, (int, float, np.floating))
                or not math.isfinite(value) or not lo <= value <= hi):
            raise IdentificationInputError(f"fixed: '{name}' must be a finite number in "
                                           f"[{lo:g}, {hi:g}] {unit}, got {value!r}")
        out[name] = float(value)
    if len(out) == len(NAMES):
        raise IdentificationInputError("fixed: every parameter is fixed, nothing to fit")
    return out


def _slack_any(params, roll, e):
    T_tot, r_p, r_b, g_tw = params[:4]
    D = np.abs(np.stack(pair_differentials(e[:, 0], e[:, 1], e[:, 2], r_p, r_b), axis=1))
    return (D > (T_tot / 3.0 * (1 + g_tw * roll ** 2))[:, None]).any(axis=1)


def channel_metrics(y, y_hat, mask=None) -> dict:
    """Per channel: RMS residual and R^2 (over samples where ``mask`` is 1)."""
    mask = np.ones_like(y) if mask is None else mask
    out = {}
    for k, name in enumerate(HEX10):
        m = mask[:, k] > 0
        if not m.any():
            continue
        r = y[m, k] - y_hat[m, k]
        var = np.var(y[m, k])
        out[name] = {"rms": float(np.sqrt(np.mean(r ** 2))),
                     "r2": float(1.0 - np.mean(r ** 2) / var) if var > 0 else None}
    return out
