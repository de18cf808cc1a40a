"""One cable transmission, motor to jaw: identified with CasADi from the signals a robot has.

The law every antagonistic cable pair of an EndoWrist follows, written for one pair: a motor
(current ``i``, encoder angle ``theta`` at the input spindle) drives a spindle; a pair of cables
runs along the shaft over idler pulleys to a jaw; the jaw is loaded. Frames and signs follow
:mod:`psmforce.identification.transmission.recording`: positive ``theta`` and positive current drive
the jaw towards closing; ``jaw_torque`` is the load's torque on the jaw (negative while it resists
closing). SI units throughout (Nm, A, rad, s).

Torque path (per sample; ``z`` in [-1, 1] the Dahl friction-direction state, rate independent,
driven by the motor displacement with pre-sliding angle ``phi_c``). Every torque parameter is
referred to the jaw (Nm at the jaw): a cable drive's torque ratio is the inverse of its angle
ratio ``n``, so the spindle-side figures are the jaw-side ones times ``n`` (the fit reports the
spindle current gain ``G n``)::

    tau_s = G i - b omega - J alpha - k_theta theta - f_m z   motor torque into the cables
    P_s   = smoothmax(P + a tau_s, |tau_s|)                   pair tension sum x pulley radius:
                                                              taut (asymmetric pair a) or slack
    m     = (mu (1 + mu_theta theta) + mu_a |q|) z            capstan exponent (wrap grows)
    tau_c = exp(-mu_q q z) (tau_s cosh m - P_s sinh m)        cable torque on the jaw (capstan)
    jaw_torque_model = -tau_c + c_0

The pair law is the one the internal-force prior uses for every pair of the Cadiere wrist
(:mod:`psmforce.identification.cable_pair`), here in torques: the tension sum times the pulley
radius as the pretension torque ``P = 2 T_0 r`` and the pair asymmetry ``a`` of the bench's loop
closure (``S = 2 T_0 + a D``): the friction grows with the load even while the pair is taut, at
a different rate closing (``cosh mu - a sinh mu``) and opening (``cosh mu + a sinh mu``).

Wrist pitch (``q``, rad: the recording's configuration, ``TransmissionRecording.pitch_rad``). The
jaw's two cables pass on opposite sides of the idler pulleys on the wrist's pitch axis (the design
behind the jaw-pitch coupling of the EndoWrist's coupling matrix): pitching the wrist by ``q``
wraps one cable ``q`` more and its partner ``q`` less around those idlers, 1:1 (design geometry,
not fitted). With per-cable exponents ``(mu + mu_q q) z`` (closing cable) and ``(mu - mu_q q) z``
(opening cable) the exact capstan of the pair, ``T_1 e^{-m_1} - T_2 e^{m_2}``, is the symmetric law
times ``exp(-mu_q q z)``. ``mu_q`` (``capstan_mu_pitch``, 1/rad) is the cable-on-idler friction
coefficient signed by which cable the routing wraps more at positive pitch (its sign is not known
from a drawing here, so it is fitted with the magnitude): a shared constant of the instrument. The
other reading of the routing (each cable running between idlers on both sides of the axis, as the
simulator's cable law has it, ``psmforce/sim/cables.py``): pitching either way wraps both cables
``|q|`` more, 1:1, which adds ``mu_a |q|`` to the pair's exponent (``capstan_mu_abs_pitch``, 1/rad,
the same friction per rad of wrap, non-negative). Neither has an effect at ``q = 0``;
:meth:`CableTransmission.fit` holds both at 0 (``info["unexcited"]``) when no recording is pitched,
since nothing can then pin them down. Measured on the real instrument, neither transfers
(docs/identification.md section 4.1), so both are behind a switch: :meth:`CableTransmission.fit`
holds them at 0 unless named in its ``pitch_wrap`` argument (the default model is the model
without them).

Stick. While the motor does not move, neither end of the transmission slides: the current
relaxes (the drive's position loop is satisfied) while the gearbox and the cables hold the last
torque. The estimate therefore follows the law only as fast as the motor moves (a displacement-
driven first-order hold, a Maxwell-slip element with one slip angle ``phi_h``)::

    jaw_torque_k = a_k jaw_torque_{k-1} + (1 - a_k) jaw_torque_model_k
    a_k = exp(-|dtheta_k| / phi_h)

The law is fitted through the hold on every sample (what is fitted is what is predicted): the
hold is linear in the law's output, ``M y = (1 - a) law`` with ``M`` lower bidiagonal, one sparse
solve per solver iteration.

Angle path (cable stretch and backlash between the motor encoder and the jaw)::

    jaw_angle = n play_h(theta) + kappa_tau jaw_torque - kappa_i i + kappa_z z + theta_0

``play_h`` the backlash (play) operator of half-width ``h`` on the motor angle; ``kappa_tau``
(rad/Nm) the cables' compliance under the load they carry (the held torque estimate above: the
jaw deflects about 7 degrees across the real instrument's load range), ``kappa_i`` (rad/A) the
stretch the motor's own torque adds while it drives, ``kappa_z`` (rad) the wind-up the friction
holds in the cables. Linear in its parameters given the widths: solved exactly.

Identifiability (stated, and checked from the fit's Fisher information in :attr:`info`):

* ``G`` (motor constant x 35:1 x gearbox efficiency / n) is identified only as a whole;
* the pretension torque ``P`` and the motor-side Coulomb friction ``f_m`` both give a friction
  in the direction of motion; they separate only through the load dependence of the pretension
  term (asymmetry, slack) within the data. When the information cannot split them (correlation
  above :data:`TIE_CORRELATION`), ``f_m`` is FIXED at 0 and the load-independent friction is
  carried by ``P`` (the fit's report says so);
* ``J`` (reflected inertia) needs accelerations the slow drives barely have; bounded to the
  motor's datasheet range.

Sessions. A parameter is a constant of the instrument (shared by every session and
configuration) or re-estimated per session (:data:`PER_SESSION`: the pretension and the pair's
asymmetry, the jaw torque sensor's zero and the jaw encoder's zero, which re-mounting changes).
:meth:`CableTransmission.fit` takes recordings of several sessions (``rec.session``) and fits the
shared parameters once and the per-session ones per session;
:meth:`CableTransmission.recalibrate` re-estimates only the per-session ones on a short segment
of a new session. Which parameters the data pin down is measured by a bootstrap over files in
:mod:`.roles`; the Fisher figures here assume white residuals and stay diagnostics.

Size: the law, its fit through the hold (one solver shared by the full fit and the
recalibration), the angle path and the strict file reader form one model; splitting them would
spread one set of parameter conventions over several modules.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from psmforce.core.files import write_json_atomic
from psmforce.identification.cable_pair import capstan, tension_sum
from psmforce.identification.errors import IdentificationInputError, NotConvergedError
from psmforce.identification.transmission.hysteresis import (dahl_state, hold, hold_coefficients,
                                                             play)
from psmforce.identification.model_file import check_sealed, read_model_json
from psmforce.core.integrity import seal
from psmforce.identification.transmission.checks import CURRENT_PER_COMMAND_A
from psmforce.identification.transmission.recording import TransmissionRecording

OMEGA_MOVING = 0.05
"""rad/s: motor speed above which the motor counts as moving (the data-sufficiency check)."""
SMOOTH_MAX_NM = 1e-3
"""Nm: width of the smooth max between the pretension torque and |tau_s|."""
TIE_CORRELATION = 0.95
BOUND_FRACTION = 1e-3
FORMAT = "psmforce.identification.CableTransmission/1"
FORMAT_VERSION = 3
"""3: per-session parameters (``sessions``, ``per_session``), the current source and the fixed
values; 2 (no sessions) is refused with the command that refits it."""

# name, unit, lower, upper, initial: the torque path's parameters (physical bounds)
TORQUE_PARAMETERS = (
    ("current_gain", "Nm/A", 0.05, 3.0, 0.7),   # Maxon k_t 0.02-0.04 Nm/A x 35 x efficiency / n
    ("viscous", "Nm s/rad", 0.0, 0.5, 0.0),
    ("inertia", "kg m^2", 0.0, 0.01, 0.0),
    ("position_stiffness", "Nm/rad", -0.5, 0.5, 0.0),
    ("motor_coulomb", "Nm", 0.0, 0.3, 0.02),
    ("capstan_mu", "1", 0.0, 2.0, 0.4),
    ("capstan_mu_per_rad", "1/rad", -1.0, 1.0, 0.0),
    ("capstan_mu_pitch", "1/rad", -1.0, 1.0, 0.0),   # friction per rad of wrap, x wrap sign
    ("capstan_mu_abs_pitch", "1/rad", 0.0, 1.0, 0.0),  # friction per rad of wrap (both cables)
    ("pretension_torque", "Nm", 0.0, 1.0, 0.1),
    ("pair_asymmetry", "1", -0.95, 0.95, 0.0),
    ("torque_bias", "Nm", -0.3, 0.3, 0.0),
)
TORQUE_NAMES = tuple(p[0] for p in TORQUE_PARAMETERS)
ANGLE_NAMES = ("ratio", "compliance_torque", "compliance_current", "windup", "angle_offset")
PER_SESSION = ("pretension_torque", "pair_asymmetry", "torque_bias", "angle_offset")
"""The parameters a session re-estimates; every other parameter is a constant of the
instrument, shared by all its sessions and configurations. Re-mounting re-seats the discs and
re-tensions the cables: the pretension changes, and with it how the pair's tension sum grows with
the load it carries (the asymmetry ``a`` of the loop closure ``S = 2 T_0 + a D``, set by how the
two runs share the stretch); it also moves the torque sensor's zero and the encoders' zero. The
asymmetry joined the set after the real instrument's sessions asked for it (docs/identification.md
section 4.1, the per-session sets tried)."""
CURRENT_SOURCES = ("measured", "command")
"""The drive current the law reads: the measured current, or the drive's command times its
current gain (:data:`.checks.CURRENT_PER_COMMAND_A`), the current the drive was told to make."""
PRESLIDING_GRID_RAD = (0.01, 0.02, 0.04, 0.08, 0.16)
HOLD_GRID_RAD = (0.005, 0.02, 0.05, 0.1, 0.2, 0.4, 0.8)
BACKLASH_GRID_RAD = (0.0, 0.005, 0.01, 0.02)


@dataclass(frozen=True)
class _Signals:
    current: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    z: np.ndarray
    pitch: np.ndarray
    abs_pitch: np.ndarray


PITCH_TERM = "capstan_mu_pitch"
ABS_PITCH_TERM = "capstan_mu_abs_pitch"
PITCH_TERMS = (PITCH_TERM, ABS_PITCH_TERM)
"""The wrist-pitch wrap terms' parameters (module docstring): antagonistic and symmetric wrap;
fixed at 0 when no recording of a fit is pitched."""


def _signals(rec: TransmissionRecording, presliding_rad: float,
             current_source: str = "measured") -> _Signals:
    omega = rec.motor_velocity_rad_s
    current = (rec.motor_current_a if current_source == "measured"
               else CURRENT_PER_COMMAND_A * rec.motor_command)
    return _Signals(current, rec.motor_angle_rad, omega,
                    np.diff(omega, prepend=omega[:1]) * rec.rate_hz,
                    dahl_state(rec.motor_angle_rad, presliding_rad),
                    np.full(len(rec.motor_angle_rad), float(rec.pitch_rad)),
                    np.full(len(rec.motor_angle_rad), abs(float(rec.pitch_rad))))


def _concat(sigs: Sequence[_Signals]) -> _Signals:
    return _Signals(*(np.concatenate([getattr(s, f) for s in sigs])
                      for f in _Signals.__dataclass_fields__))


def _torque_law(p, s, xp):
    """Jaw torque (Nm) before the stick hold; ``p`` in TORQUE_NAMES order (scalars, or
    per-sample columns for per-session parameters); ``xp`` numpy or casadi."""
    G, b, J, k_th, f_m, mu, mu_th, mu_q, mu_a, P, a, c0 = p
    tau_s = G * s.current - b * s.omega - J * s.alpha - k_th * s.theta - f_m * s.z
    p_s = tension_sum(P + a * tau_s, tau_s, SMOOTH_MAX_NM, xp)
    wrap = xp.exp(-mu_q * s.pitch * s.z)  # the pitch idlers' antagonistic wrap (docstring)
    exponent = (mu * (1.0 + mu_th * s.theta) + mu_a * s.abs_pitch) * s.z
    return -wrap * capstan(tau_s, p_s, exponent, xp) + c0


def at_bound(value: float, lower: float, upper: float) -> bool:
    """The one rule for "at a bound" (parameters and the hysteresis widths' grid edges alike):
    within :data:`BOUND_FRACTION` of the range from either end."""
    return bool(min(value - lower, upper - value) <= BOUND_FRACTION * (upper - lower))


@dataclass(frozen=True)
class TransmissionPrediction:
    """Causal estimates, (N,) each."""

    jaw_torque_nm: np.ndarray
    jaw_angle_rad: np.ndarray


@dataclass
class CableTransmission:
    """Identified motor-to-jaw transmission (module docstring). ``torque`` in TORQUE_NAMES order,
    ``angle`` in ANGLE_NAMES order: the instrument's values, with the per-session parameters at
    their mean over the fitted sessions (what an unseen session gets before it is
    recalibrated); ``sessions`` maps each fitted session to its own per-session values. The
    three hysteresis widths are chosen by :meth:`fit`; ``fixed`` names the torque parameters held
    at their value in ``torque``."""

    torque: np.ndarray = field(default_factory=lambda: np.array([p[4] for p in TORQUE_PARAMETERS]))
    angle: np.ndarray = field(default_factory=lambda: np.array([0.9, 0.0, 0.0, 0.0, 0.0]))
    presliding_rad: float = 0.02
    hold_rad: float = 0.05
    backlash_rad: float = 0.0
    fixed: tuple[str, ...] = ()
    info: dict = field(default_factory=dict)
    sessions: dict = field(default_factory=dict)
    per_session: tuple[str, ...] = PER_SESSION
    current_source: str = "measured"

    # ------------------------------------------------------------ prediction
    def parameters(self, session: str | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(torque, angle) vectors for ``session``: its own per-session values when it was fitted
        or recalibrated, else the instrument's (the fitted sessions' mean)."""
        torque, angle = self.torque.copy(), self.angle.copy()
        for name, value in self.sessions.get(session, {}).items():
            if name in TORQUE_NAMES:
                torque[TORQUE_NAMES.index(name)] = value
            else:
                angle[ANGLE_NAMES.index(name)] = value
        return torque, angle

    def predict(self, rec: TransmissionRecording) -> TransmissionPrediction:
        """Jaw torque and angle from the motor signals of ``rec`` (past and present samples
        only), with ``rec.session``'s per-session values when known."""
        torque_p, angle_p = self.parameters(rec.session)
        s = _signals(rec, self.presliding_rad, self.current_source)
        torque = hold(_torque_law(torque_p, s, np), s.theta, self.hold_rad)
        return TransmissionPrediction(torque, self._angle_columns(s, torque) @ angle_p)

    def _angle_columns(self, s: _Signals, torque: np.ndarray) -> np.ndarray:
        return np.stack([play(s.theta, self.backlash_rad), torque, -s.current, s.z,
                         np.ones_like(s.theta)], axis=1)

    # ------------------------------------------------------------ fit
    @classmethod
    def fit(cls, recordings: Sequence[TransmissionRecording], *,
            validation: Sequence[TransmissionRecording] = (),
            initial: "CableTransmission | None" = None, max_iter: int = 300,
            per_session: Sequence[str] = PER_SESSION, fixed: dict | None = None,
            current_source: str = "measured",
            pitch_wrap: Sequence[str] = ()) -> "CableTransmission":
        """Identify on ``recordings`` (one or several sessions, ``rec.session``): the shared
        parameters once over all of them, each ``per_session`` parameter once per session. For
        each pre-sliding and hold width the torque law (IPOPT through the hold, every sample),
        then for each backlash width the angle path (exact least squares, driven by the held
        torque estimate). The widths are chosen on ``validation`` when given (else on the fit
        data). ``fixed`` holds torque parameters at given values (names the data cannot pin
        down). With ``initial``, its widths are kept and its parameters start the solver.
        ``pitch_wrap`` names the wrist-pitch wrap terms (:data:`PITCH_TERMS`) to fit: the switch
        of the module docstring; the others are held at 0, as are all of them when no recording
        is pitched (``info["unexcited"]``)."""
        t0 = time.perf_counter()
        recordings = list(recordings)
        if not recordings:
            raise IdentificationInputError("no recordings to fit the transmission on")
        if current_source not in CURRENT_SOURCES:
            raise IdentificationInputError(f"current_source must be one of {CURRENT_SOURCES}, "
                                           f"got {current_source!r}")
        per_session = tuple(per_session)
        unknown = set(per_session) - set(TORQUE_NAMES) - {"angle_offset"}
        fixed = dict(fixed or {})
        if unknown or set(fixed) - set(TORQUE_NAMES) or set(fixed) & set(per_session):
            raise IdentificationInputError(f"per-session {per_session} and fixed {sorted(fixed)}"
                                           " must name distinct parameters (torque parameters, "
                                           "or angle_offset per session)")
        n_samples = sum(len(r) for r in recordings)
        if n_samples < 500:
            raise IdentificationInputError(f"{n_samples} samples is too short to fit the "
                                           "transmission (need 500)")
        pitch_wrap = tuple(pitch_wrap)
        if set(pitch_wrap) - set(PITCH_TERMS):
            raise IdentificationInputError(f"pitch_wrap must name terms of {PITCH_TERMS}, got "
                                           f"{pitch_wrap}")
        unexcited = [] if any(r.pitch_rad for r in recordings) else list(PITCH_TERMS)
        fixed.update({n: 0.0 for n in PITCH_TERMS
                      if (n in unexcited or n not in pitch_wrap) and n not in fixed})
        names = sorted({r.session for r in recordings})
        codes = np.concatenate([np.full(len(r), names.index(r.session)) for r in recordings])
        select_on = list(validation) or recordings
        if initial is not None:
            widths = [(initial.presliding_rad, initial.hold_rad)]
            backlashes = (initial.backlash_rad,)
        else:
            widths = [(phi, w) for phi in PRESLIDING_GRID_RAD for w in HOLD_GRID_RAD]
            backlashes = BACKLASH_GRID_RAD
        y = np.concatenate([r.jaw_torque_nm for r in recordings])
        y_angle = np.concatenate([r.jaw_angle_rad for r in recordings])
        best, scores = None, []
        by_presliding: dict = {}  # the signals depend on the pre-sliding width only
        for phi, hold_rad in widths:
            if phi not in by_presliding:
                sigs = [_signals(r, phi, current_source) for r in recordings]
                by_presliding[phi] = (sigs, _concat(sigs), {})
            sigs, s, columns = by_presliding[phi]
            if np.sum(np.abs(s.omega) > OMEGA_MOVING) < 200:
                raise IdentificationInputError("the motor hardly moves: fewer than 200 samples "
                                               f"faster than {OMEGA_MOVING} rad/s")
            hold_a = np.concatenate([hold_coefficients(x.theta, hold_rad) for x in sigs])
            start = initial.torque if initial is not None else None
            torque, per, tied, info = _solve_torque(s, y, hold_a, codes, len(names), start,
                                                    max_iter, fixed, per_session,
                                                    columns=columns)
            sessions = {n: dict(zip([q for q in per_session if q in TORQUE_NAMES], per[k]))
                        for k, n in enumerate(names)}
            for h in backlashes:
                model = cls(torque, np.zeros(len(ANGLE_NAMES)), phi, hold_rad, h,
                            tuple(sorted({*fixed, *tied})), dict(info),
                            {n: dict(v) for n, v in sessions.items()}, per_session,
                            current_source)
                model._fit_angle(recordings, sigs, y_angle, names, codes)
                score = model.score(select_on)
                scores.append({"presliding_rad": phi, "backlash_rad": h, "hold_rad": hold_rad,
                               **score})
                key = (score["jaw_torque_rmse_nm"] / 0.005
                       + score["jaw_angle_rmse_rad"] / math.radians(0.5))
                if best is None or key < best[0]:
                    best = (key, model)
        model = best[1]
        grid_edges = {"presliding_rad": PRESLIDING_GRID_RAD, "hold_rad": HOLD_GRID_RAD,
                      "backlash_rad": BACKLASH_GRID_RAD}
        model.info["identifiability"]["at_bound"] += [
            w for w, grid in grid_edges.items() if at_bound(getattr(model, w), grid[0], grid[-1])]
        model.info.update({"selection": "validation" if validation else "fit data",
                           "width_scores": scores, "fit_time_s": time.perf_counter() - t0,
                           "n_samples": n_samples, "fixed_values": fixed,
                           "unexcited": unexcited, "pitch_wrap": list(pitch_wrap),
                           "spindle_current_gain_nm_per_a": float(model.torque[0]
                                                                  * model.angle[0]),
                           "recordings": [r.name for r in recordings]})
        return model

    def _fit_angle(self, recordings, sigs, y_angle, names, codes) -> None:
        """The angle path by exact least squares, the offset per session when it is declared
        per session."""
        cols = np.concatenate([self._angle_columns(x, hold(
            _torque_law(self.parameters(r.session)[0], x, np), x.theta, self.hold_rad))
            for r, x in zip(recordings, sigs)])
        if "angle_offset" in self.per_session:
            cols = np.concatenate([cols[:, :-1], np.eye(len(names))[codes]], axis=1)
        coef, *_ = np.linalg.lstsq(cols, y_angle, rcond=None)
        self.angle = np.concatenate([coef[:4], [coef[4:].mean()]])
        if "angle_offset" in self.per_session:
            for k, n in enumerate(names):
                self.sessions[n]["angle_offset"] = float(coef[4 + k])
        if not 0.3 < self.angle[0] < 3.0:
            raise IdentificationInputError("the jaw angle does not follow the motor angle "
                                           f"(fitted ratio {self.angle[0]:.3g})")

    def recalibrate(self, recordings: Sequence[TransmissionRecording],
                    max_iter: int = 300) -> "CableTransmission":
        """A copy with the per-session parameters of the sessions in ``recordings``
        re-estimated from them (a short segment of a new session: re-mounting), every shared
        parameter and width kept."""
        recordings = list(recordings)
        if not recordings:
            raise IdentificationInputError("no recordings to recalibrate on")
        names = sorted({r.session for r in recordings})
        codes = np.concatenate([np.full(len(r), names.index(r.session)) for r in recordings])
        sigs = [_signals(r, self.presliding_rad, self.current_source) for r in recordings]
        s = _concat(sigs)
        hold_a = np.concatenate([hold_coefficients(x.theta, self.hold_rad) for x in sigs])
        torque_ps = [q for q in self.per_session if q in TORQUE_NAMES]
        shared = {n: float(v) for n, v in zip(TORQUE_NAMES, self.torque) if n not in torque_ps}
        y = np.concatenate([r.jaw_torque_nm for r in recordings])
        _, per, _, info = _solve_torque(s, y, hold_a, codes, len(names), self.torque, max_iter,
                                        shared, tuple(torque_ps), check_tie=False)
        out = CableTransmission(self.torque.copy(), self.angle.copy(), self.presliding_rad,
                                self.hold_rad, self.backlash_rad, self.fixed,
                                {**self.info, "solver_status": info["solver_status"],
                                 "converged": bool(self.info.get("converged", False)
                                                   and info["converged"]),
                                 "recalibration": {"recordings": [r.name for r in recordings],
                                                   "solver_status": info["solver_status"],
                                                   "converged": info["converged"]}},
                                {n: dict(v) for n, v in self.sessions.items()},
                                self.per_session, self.current_source)
        for k, n in enumerate(names):
            out.sessions[n] = dict(zip(torque_ps, map(float, per[k])))
        if "angle_offset" in self.per_session:
            for n in names:
                mine = [(r, x) for r, x in zip(recordings, sigs) if r.session == n]
                resid = np.concatenate([
                    r.jaw_angle_rad - out._angle_columns(x, out.predict(r).jaw_torque_nm)[:, :4]
                    @ out.angle[:4] for r, x in mine])
                out.sessions[n]["angle_offset"] = float(resid.mean())
        return out

    def score(self, recordings: Sequence[TransmissionRecording]) -> dict:
        """RMSE of the causal estimates over ``recordings`` (whole files)."""
        et, ea = [], []
        for r in recordings:
            p = self.predict(r)
            et.append(p.jaw_torque_nm - r.jaw_torque_nm)
            ea.append(p.jaw_angle_rad - r.jaw_angle_rad)
        et, ea = np.concatenate(et), np.concatenate(ea)
        return {"jaw_torque_rmse_nm": float(np.sqrt(np.mean(et ** 2))),
                "jaw_angle_rmse_rad": float(np.sqrt(np.mean(ea ** 2)))}

    # ------------------------------------------------------------ persistence
    def to_dict(self) -> dict:
        """Human-readable JSON content: every parameter with its unit and bounds."""
        return {"format": FORMAT,
                "frames_and_units": "inputs: motor current A (positive drives the jaw closed), "
                                    "motor angle rad at the input spindle; outputs: jaw torque Nm "
                                    "(the load's torque on the jaw), jaw angle rad; "
                                    "psmforce/identification/transmission/recording.py",
                "torque": {n: {"value": float(v), "unit": u, "lower": lo, "upper": hi}
                           for (n, u, lo, hi, _), v in zip(TORQUE_PARAMETERS, self.torque)},
                "angle": dict(zip(ANGLE_NAMES, map(float, self.angle))),
                "presliding_rad": self.presliding_rad, "hold_rad": self.hold_rad,
                "backlash_rad": self.backlash_rad, "fixed": list(self.fixed),
                "per_session": list(self.per_session), "current_source": self.current_source,
                "sessions": {n: {k: float(v) for k, v in d.items()}
                             for n, d in self.sessions.items()},
                "info": {k: v for k, v in self.info.items() if k != "width_scores"}}

    def save(self, path) -> None:
        """Write the JSON atomically, sealed (:data:`FORMAT_VERSION`); refuses a fit whose
        solver did not converge."""
        if not self.info.get("converged", False):
            raise NotConvergedError("refusing to save a transmission whose fit did not converge "
                                    f"({self.info.get('solver_status', 'no fit')})")
        write_json_atomic(path, seal({**self.to_dict(), "format_version": FORMAT_VERSION}))

    @classmethod
    def load(cls, path) -> "CableTransmission":
        """Read a file :meth:`save` wrote. Refuses, naming the file and the entry: unreadable
        JSON, another format, an edited field or a format version that is not the integer
        :data:`FORMAT_VERSION` (:func:`.model_file.check_sealed`; version 2 with the command that
        refits it), a missing or unknown parameter, a torque parameter that is not a finite
        number inside its bounds (per-session values alike), an angle parameter that is not
        finite (the ratio within (0.3, 3)), a width that is not a finite number in its range."""
        d = read_model_json(path, FORMAT, "a CableTransmission")
        if type(d.get("format_version")) is int and d["format_version"] == 2:
            raise IdentificationInputError(
                f"{path}: a format-2 transmission (before per-session parameters); refit it with "
                "`psmforce fit-transmission SESSION_DIR --out FILE`")
        check_sealed(d, path, "CableTransmission", FORMAT_VERSION)

        def number(value, name, lo=-math.inf, hi=math.inf) -> float:
            if (isinstance(value, bool) or not isinstance(value, (int, float))
                    or not math.isfinite(value) or not lo <= value <= hi):
                raise IdentificationInputError(f"{path}: '{name}' must be a finite number in "
                                               f"[{lo:g}, {hi:g}], got {value!r}")
            return float(value)

        bounds = {n: (lo - 1e-6 * (hi - lo), hi + 1e-6 * (hi - lo))
                  for n, _, lo, hi, _ in TORQUE_PARAMETERS}  # the solver's own tolerance
        torque, angle = d.get("torque"), d.get("angle")
        if isinstance(torque, dict):  # written before the pitch terms: they were 0
            torque = {**{n: {"value": 0.0} for n in PITCH_TERMS}, **torque}
        if not isinstance(torque, dict) or set(torque) != set(TORQUE_NAMES):
            raise IdentificationInputError(f"{path}: 'torque' must hold exactly {TORQUE_NAMES}")
        if not isinstance(angle, dict) or set(angle) != set(ANGLE_NAMES):
            raise IdentificationInputError(f"{path}: 'angle' must hold exactly {ANGLE_NAMES}")
        params = [number(torque[n].get("value") if isinstance(torque[n], dict) else None, n,
                         *bounds[n]) for n in TORQUE_NAMES]
        angles = [number(angle[n], n) for n in ANGLE_NAMES]
        number(angles[0], "ratio", 0.3, 3.0)
        fixed = d.get("fixed", [])
        if not isinstance(fixed, list) or not set(fixed) <= set(TORQUE_NAMES):
            raise IdentificationInputError(f"{path}: 'fixed' must list torque parameters")
        per_session = d.get("per_session", [])
        if (not isinstance(per_session, list)
                or not set(per_session) <= set(TORQUE_NAMES) | {"angle_offset"}):
            raise IdentificationInputError(f"{path}: 'per_session' must list parameters")
        if d.get("current_source") not in CURRENT_SOURCES:
            raise IdentificationInputError(f"{path}: 'current_source' must be one of "
                                           f"{CURRENT_SOURCES}")
        sessions = d.get("sessions", {})
        if not isinstance(sessions, dict):
            raise IdentificationInputError(f"{path}: 'sessions' must map sessions to values")
        for session, values in sessions.items():
            if not isinstance(values, dict) or set(values) - set(per_session):
                raise IdentificationInputError(f"{path}: session {session!r} must hold only "
                                               f"per-session parameters {per_session}")
            for n, v in values.items():
                number(v, f"{session}: {n}", *bounds.get(n, (-math.inf, math.inf)))
        info = d.get("info", {})
        return cls(np.array(params), np.array(angles),
                   number(d.get("presliding_rad"), "presliding_rad", 1e-6, 1.0),
                   number(d.get("hold_rad"), "hold_rad", 1e-6, 10.0),
                   number(d.get("backlash_rad"), "backlash_rad", 0.0, 1.0), tuple(fixed),
                   info if isinstance(info, dict) else {},
                   {n: {k: float(v) for k, v in vals.items()} for n, vals in sessions.items()},
                   tuple(per_session), d["current_source"])


def _solve_torque(s: _Signals, y: np.ndarray, hold_a: np.ndarray, codes: np.ndarray,
                  n_sessions: int, start, max_iter: int, fixed: dict,
                  per_session: tuple[str, ...], check_tie: bool = True,
                  columns: dict | None = None):
    """IPOPT through the hold on every sample. Returns (instrument values in TORQUE_NAMES order,
    with per-session entries at their mean; per-session values (n_sessions, k) in the order of
    the torque names in ``per_session``; names the tie fixed; info with the white-noise Fisher
    diagnostics). ``codes`` (N,) the session index of each sample. When the information cannot
    split the motor Coulomb friction from the pretension term, refits with the former fixed at
    0 (module docstring). ``columns``: a dict kept by the caller for as long as ``s`` and ``y``
    stay the same, where their CasADi copies are kept between calls (the width grid's)."""
    import casadi as ca
    from scipy import sparse

    lo = np.array([p[2] for p in TORQUE_PARAMETERS])
    hi = np.array([p[3] for p in TORQUE_PARAMETERS])
    x0 = np.clip(np.array(start if start is not None else [p[4] for p in TORQUE_PARAMETERS],
                          dtype=float), lo, hi)
    span = np.maximum(hi - lo, 1e-12)
    n = len(y)
    one_hot = ca.DM(sparse.csc_matrix((np.ones(n), (np.arange(n), codes)),
                                      shape=(n, n_sessions)))
    variables, labels, v_lo, v_hi, v_span, v0, p = [], [], [], [], [], [], []
    for k, name in enumerate(TORQUE_NAMES):
        if name in fixed:
            p.append(ca.DM(float(fixed[name])))
            continue
        count = n_sessions if name in per_session else 1
        u = ca.MX.sym(name, count)
        variables.append(u)
        labels += [name] if count == 1 else [f"{name}[{j}]" for j in range(count)]
        v_lo += [lo[k]] * count
        v_hi += [hi[k]] * count
        v_span += [span[k]] * count
        v0 += [(x0[k] - lo[k]) / span[k]] * count
        value = lo[k] + u * span[k]
        p.append(ca.mtimes(one_hot, value) if count > 1 else value)
    u_all = ca.vertcat(*variables)
    hold_matrix = ca.DM(sparse.csc_matrix(sparse.eye(n) - sparse.diags(hold_a[1:], -1)))
    columns = {} if columns is None else columns
    if not columns:
        columns["s"] = _Signals(*(ca.DM(getattr(s, f)) for f in _Signals.__dataclass_fields__))
        columns["y"] = ca.DM(y)
    held = ca.solve(hold_matrix, ca.DM(1.0 - hold_a) * _torque_law(p, columns["s"], ca),
                    "csparse")
    resid = held - columns["y"]
    cost = ca.sumsqr(resid) / n / 1e-6  # in mNm^2: O(1)-O(100) numbers for IPOPT
    solver = ca.nlpsol("transmission", "ipopt", {"x": u_all, "f": cost}, {
        "ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": max_iter,
        "ipopt.tol": 1e-10, "ipopt.sb": "yes"})
    sol = solver(x0=v0, lbx=0.0, ubx=1.0)
    stats = solver.stats()
    if not stats["success"] and stats["return_status"] != "Maximum_Iterations_Exceeded":
        raise NotConvergedError(f"transmission fit: IPOPT {stats['return_status']}")
    u_hat = np.clip(np.array(sol["x"]).ravel(), 0.0, 1.0)  # IPOPT's bound tolerance
    values = np.array(v_lo) + u_hat * np.array(v_span)
    params, per, j = x0.copy(), np.zeros((n_sessions, 0)), 0
    torque_ps = [q for q in per_session if q in TORQUE_NAMES]
    per = np.zeros((n_sessions, len(torque_ps)))
    for k, name in enumerate(TORQUE_NAMES):
        if name in fixed:
            params[k] = fixed[name]
        elif name in per_session:
            per[:, torque_ps.index(name)] = values[j:j + n_sessions]
            params[k] = values[j:j + n_sessions].mean()
            j += n_sessions
        else:
            params[k] = values[j]
            j += 1
    jac_r = ca.Function("j", [u_all], [ca.jacobian(resid, u_all), resid])
    jac, r_hat = (np.array(x) for x in jac_r(u_hat))
    sigma2 = float(np.sum(r_hat ** 2) / max(n - len(values), 1))
    ident = _fisher(jac, sigma2, labels, values, np.array(v_lo), np.array(v_hi),
                    np.array(v_span))
    pair = ("motor_coulomb", "pretension_torque")
    tie = max((abs(v) for k, v in ident["correlations"].items()
               if k.startswith(pair[0] + "|") and pair[1] in k), default=0.0)
    if check_tie and pair[0] not in fixed and tie > TIE_CORRELATION:
        params, per, _, info = _solve_torque(s, y, hold_a, codes, n_sessions, params, max_iter,
                                             {**fixed, pair[0]: 0.0}, per_session,
                                             columns=columns)
        info["tied"] = (f"{pair[0]} fixed at 0: the data cannot split it from {pair[1]} "
                        f"(correlation {tie:.3f}); the load-independent friction is carried "
                        "by the pretension term")
        return params, per, (pair[0],), info
    info = {"solver": "CasADi IPOPT", "solver_status": stats["return_status"],
            "converged": bool(stats["success"]), "iterations": int(stats["iter_count"]),
            "train_rmse_nm": float(np.sqrt(np.mean(r_hat ** 2))),
            "identifiability": ident}
    return params, per, (), info


def _fisher(jac, sigma2, names, values, lo, hi, span) -> dict:
    """White-noise Fisher diagnostics of the scaled parameters (each on [0, 1] over its bounds)
    from the residual Jacobian and the residual variance ``sigma2`` (Nm^2): the condition
    number, the parameter correlations and the parameters at a bound (:func:`at_bound`). Its
    standard deviations assume independent residuals, which a hysteretic model's are not: the
    uncertainty reported is the bootstrap over files (:mod:`.roles`)."""
    fim = jac.T @ jac / sigma2
    cov = np.linalg.pinv(fim)
    sd = np.sqrt(np.maximum(np.diag(cov), 1e-300))
    corr = cov / np.outer(sd, sd)
    pairs = {f"{names[a]}|{names[b]}": float(corr[a, b])
             for a in range(len(names)) for b in range(a + 1, len(names))}
    return {"fisher_condition_number": float(np.linalg.cond(fim)),
            "correlations": pairs,
            "strongly_correlated": [k for k, v in pairs.items() if abs(v) > TIE_CORRELATION],
            "at_bound": [nm for nm, v, a, b in zip(names, values, lo, hi) if at_bound(v, a, b)],
            "white_noise_relative_sd": {nm: float(s_ * w / max(abs(v), 1e-12)) for nm, s_, w, v
                                        in zip(names, sd, span, values)}}
