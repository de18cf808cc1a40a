"""One cable transmission, motor to jaw: identified with CasADi from the signals a robot has.

The law every antagonistic cable pair of an EndoWrist follows, written for one pair: a motor
(current ``i``, encoder angle ``theta`` at the input spindle) drives a spindle; a pair of cables
runs along the shaft over idler pulleys to a jaw; the jaw is loaded. Frames and signs follow
:mod:`psm_model.transmission_recording`: positive ``theta`` and positive current drive the jaw
towards closing; ``jaw_torque`` is the load's torque on the jaw (negative while it resists
closing). SI units throughout (Nm, A, rad, s).

Torque path (per sample; ``z`` in [-1, 1] the Dahl friction-direction state, rate independent,
driven by the motor displacement with pre-sliding angle ``phi_c``)::

    tau_s  = G i - b omega - J alpha - k_theta theta - f_m z          spindle torque into the cables
    P_s    = smoothmax(P + a tau_s, |tau_s|)                          pair tension sum x spindle radius:
                                                                      taut (pretension, asymmetric
                                                                      pair a) or slack
    m      = mu (1 + mu_theta theta) z                                capstan exponent, wrap grows with angle
    tau_c  = (tau_s cosh m - P_s sinh m) / n                          cable torque on the jaw (capstan)
    jaw_torque_model = -tau_c + c_0

The capstan step is the pair law of the bench (``psm_model/sim/cables.py``, ``_capstan_pair``)
with the tension sum times the spindle radius as the pretension torque ``P = 2 T_0 r_s`` and the
pair asymmetry ``a`` of the bench's loop closure (``S = 2 T_0 + a D``): the friction grows with the
load even while the pair is taut, at a different rate closing (``cosh mu - a sinh mu``) and
opening (``cosh mu + a sinh mu``).

Stick. While the motor does not move, neither end of the transmission slides: the current
relaxes (the drive's position loop is satisfied) while the gearbox and the cables hold the last
torque. The estimate therefore follows the law only as fast as the motor moves (a displacement-
driven first-order hold, a Maxwell-slip element with one slip angle ``phi_h``)::

    jaw_torque_k = a_k jaw_torque_{k-1} + (1 - a_k) jaw_torque_model_k,   a_k = exp(-|dtheta_k| / phi_h)

and the law is fitted on the samples where the motor slides (``|omega| > OMEGA_SLIDING``).

Angle path (cable stretch and backlash between the motor encoder and the jaw)::

    jaw_angle = n play_h(theta) - kappa_i i + kappa_z z + theta_0

``play_h`` the backlash (play) operator of half-width ``h`` on the motor angle, ``kappa_i`` the
compliance seen through the current (rad/A: the cable stretch under the torque the current
makes), ``kappa_z`` the wind-up the friction holds in the cables (rad). Linear in (n, kappa_i,
kappa_z, theta_0) given ``h`` and ``phi_c``: solved exactly.

Identifiability (stated, and checked from the fit's Fisher information in :attr:`info`):

* the kinematic ratio ``n`` is identified by the angle path and TIED into the torque path (a
  cable drive's torque ratio is the inverse of its angle ratio); the current gain ``G`` (motor
  constant x 35:1 x gearbox efficiency) is identified only as seen at the spindle;
* the pretension torque ``P`` and the motor-side Coulomb friction ``f_m`` both give a friction
  in the direction of motion that does not scale with load; they separate only where the pair
  goes slack (|tau_s| > P) within the data. When the information cannot split them (correlation
  above :data:`TIE_CORRELATION`), ``f_m`` is FIXED at 0 and the load-independent friction is
  carried by ``P`` (the fit's report says so);
* ``J`` (reflected inertia) needs accelerations the slow drives barely have; bounded to the
  motor's datasheet range.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from psm_model.identification.errors import IdentificationInputError, NotConvergedError
from psm_model.transmission_recording import TransmissionRecording

OMEGA_SLIDING = 0.05
"""rad/s: motor speed above which the transmission is taken to slide (fit samples)."""
SMOOTH_MAX_NM = 1e-3
"""Nm: width of the smooth max between the pretension torque and |tau_s|."""
TIE_CORRELATION = 0.95
FORMAT = "psm_model.identification.CableTransmission/1"

# name, unit, lower, upper, initial: the torque path's parameters (physical bounds)
TORQUE_PARAMETERS = (
    ("current_gain", "Nm/A", 0.05, 3.0, 0.7),          # Maxon k_t ~0.02-0.04 Nm/A x 35 x efficiency
    ("viscous", "Nm s/rad", 0.0, 0.5, 0.0),
    ("inertia", "kg m^2", 0.0, 0.01, 0.0),
    ("position_stiffness", "Nm/rad", -0.5, 0.5, 0.0),
    ("motor_coulomb", "Nm", 0.0, 0.3, 0.02),
    ("capstan_mu", "1", 0.0, 2.0, 0.4),
    ("capstan_mu_per_rad", "1/rad", -1.0, 1.0, 0.0),
    ("pretension_torque", "Nm", 0.0, 1.0, 0.1),
    ("pair_asymmetry", "1", -0.95, 0.95, 0.0),
    ("torque_bias", "Nm", -0.3, 0.3, 0.0),
)
TORQUE_NAMES = tuple(p[0] for p in TORQUE_PARAMETERS)
ANGLE_NAMES = ("ratio", "compliance_current", "windup", "angle_offset")
PRESLIDING_GRID_RAD = (0.01, 0.02, 0.04, 0.08)
HOLD_GRID_RAD = (0.02, 0.05, 0.1, 0.2)
BACKLASH_GRID_RAD = (0.0, 0.005, 0.01, 0.02)


def dahl_state(theta: np.ndarray, presliding_rad: float) -> np.ndarray:
    """z_k = a_k z_{k-1} + (1 - a_k) sgn(dtheta_k), a_k = exp(-|dtheta_k| / phi): the exact
    rate-independent Dahl solution for piecewise-linear motion (z_0 = 0)."""
    dx = np.diff(theta, prepend=theta[:1])
    a = np.exp(-np.abs(dx) / presliding_rad)
    return _recurrence(a, (1.0 - a) * np.sign(dx), 0.0)


def play(theta: np.ndarray, half_width_rad: float) -> np.ndarray:
    """Backlash (play) operator: the output follows the input only when pushed from one side."""
    out = np.empty_like(theta)
    y = float(theta[0])
    for k, x in enumerate(theta.tolist()):
        y = min(max(y, x - half_width_rad), x + half_width_rad)
        out[k] = y
    return out


def _recurrence(a: np.ndarray, b: np.ndarray, y0: float) -> np.ndarray:
    out = [0.0] * len(a)
    y = y0
    for k, (ak, bk) in enumerate(zip(a.tolist(), b.tolist())):
        y = ak * y + bk
        out[k] = y
    return np.asarray(out)


def _hold(model: np.ndarray, theta: np.ndarray, hold_rad: float) -> np.ndarray:
    a = np.exp(-np.abs(np.diff(theta, prepend=theta[:1])) / hold_rad)
    return _recurrence(a, (1.0 - a) * model, float(model[0]) if len(model) else 0.0)


@dataclass(frozen=True)
class _Signals:
    current: np.ndarray
    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    z: np.ndarray


def _signals(rec: TransmissionRecording, presliding_rad: float) -> _Signals:
    omega = rec.motor_velocity_rad_s
    return _Signals(rec.motor_current_a, rec.motor_angle_rad, omega,
                    np.diff(omega, prepend=omega[:1]) * rec.rate_hz,
                    dahl_state(rec.motor_angle_rad, presliding_rad))


def _concat(sigs: Sequence[_Signals]) -> _Signals:
    return _Signals(*(np.concatenate([getattr(s, f) for s in sigs]) for f in _Signals.__dataclass_fields__))


def _torque_law(p, s, ratio, xp):
    """Jaw torque (Nm) before the stick hold; ``p`` in TORQUE_NAMES order; ``xp`` numpy or casadi."""
    G, b, J, k_th, f_m, mu, mu_th, P, a, c0 = p
    tau_s = G * s.current - b * s.omega - J * s.alpha - k_th * s.theta - f_m * s.z
    mag = xp.sqrt(tau_s * tau_s + 1e-12)
    taut = P + a * tau_s
    p_s = 0.5 * (taut + mag + xp.sqrt((taut - mag) * (taut - mag) + SMOOTH_MAX_NM ** 2))
    m = mu * (1.0 + mu_th * s.theta) * s.z
    return -(tau_s * xp.cosh(m) - p_s * xp.sinh(m)) / ratio + c0


@dataclass(frozen=True)
class TransmissionPrediction:
    """Causal estimates, (N,) each."""

    jaw_torque_nm: np.ndarray
    jaw_angle_rad: np.ndarray


@dataclass
class CableTransmission:
    """Identified motor-to-jaw transmission (module docstring). ``torque`` in TORQUE_NAMES order,
    ``angle`` in ANGLE_NAMES order; the three hysteresis widths are chosen by :meth:`fit`."""

    torque: np.ndarray = field(default_factory=lambda: np.array([p[4] for p in TORQUE_PARAMETERS]))
    angle: np.ndarray = field(default_factory=lambda: np.array([0.885, 0.0, 0.0, 0.0]))
    presliding_rad: float = 0.02
    hold_rad: float = 0.05
    backlash_rad: float = 0.0
    fixed: tuple[str, ...] = ()
    info: dict = field(default_factory=dict)

    # ------------------------------------------------------------ prediction
    def predict(self, rec: TransmissionRecording) -> TransmissionPrediction:
        """Jaw torque and angle from the motor signals of ``rec`` (past and present samples only)."""
        s = _signals(rec, self.presliding_rad)
        law = _torque_law(self.torque, s, self.angle[0], np)
        torque = _hold(law, s.theta, self.hold_rad)
        angle = self._angle_columns(s) @ self.angle
        return TransmissionPrediction(torque, angle)

    def _angle_columns(self, s: _Signals) -> np.ndarray:
        return np.stack([play(s.theta, self.backlash_rad), -s.current, s.z,
                         np.ones_like(s.theta)], axis=1)

    # ------------------------------------------------------------ fit
    @classmethod
    def fit(cls, recordings: Sequence[TransmissionRecording], *,
            validation: Sequence[TransmissionRecording] = (),
            initial: "CableTransmission | None" = None, max_iter: int = 300) -> "CableTransmission":
        """Identify on ``recordings``. The pre-sliding, hold and backlash widths are chosen on
        ``validation`` when given (else on the fit data). With ``initial`` (few-shot
        recalibration on another instrument), its widths are kept and its parameters start the
        solver."""
        t0 = time.perf_counter()
        recordings = list(recordings)
        if not recordings:
            raise IdentificationInputError("no recordings to fit the transmission on")
        n_samples = sum(len(r) for r in recordings)
        if n_samples < 500:
            raise IdentificationInputError(f"{n_samples} samples is too short to fit the "
                                           "transmission (need 500)")
        select_on = list(validation) or recordings
        if initial is not None:
            grid = [(initial.presliding_rad, initial.backlash_rad, initial.hold_rad)]
        else:
            grid = [(phi, h, hold) for phi in PRESLIDING_GRID_RAD for h in BACKLASH_GRID_RAD
                    for hold in HOLD_GRID_RAD]
        best, scores, fits = None, [], {}
        for phi, h, hold in grid:
            if (phi, h) not in fits:
                fits[(phi, h)] = cls._fit_fixed_widths(recordings, phi, h, initial, max_iter)
            model = fits[(phi, h)]
            model = cls(model.torque, model.angle, phi, hold, h, model.fixed, dict(model.info))
            score = model.score(select_on)
            scores.append({"presliding_rad": phi, "backlash_rad": h, "hold_rad": hold, **score})
            key = score["jaw_torque_rmse_nm"] / 0.005 + score["jaw_angle_rmse_rad"] / math.radians(0.5)
            if best is None or key < best[0]:
                best = (key, model)
        model = best[1]
        model.info.update({"selection": "validation" if validation else "fit data",
                           "width_scores": scores, "fit_time_s": time.perf_counter() - t0,
                           "n_samples": n_samples,
                           "recordings": [r.name for r in recordings]})
        return model

    @classmethod
    def _fit_fixed_widths(cls, recordings, phi, h, initial, max_iter) -> "CableTransmission":
        sigs = [_signals(r, phi) for r in recordings]
        s = _concat(sigs)
        probe = cls(presliding_rad=phi, backlash_rad=h)
        a_cols = np.concatenate([probe._angle_columns(x) for x in sigs])
        y_angle = np.concatenate([r.jaw_angle_rad for r in recordings])
        angle, *_ = np.linalg.lstsq(a_cols, y_angle, rcond=None)
        if not 0.3 < angle[0] < 3.0:
            raise IdentificationInputError(f"the jaw angle does not follow the motor angle "
                                           f"(fitted ratio {angle[0]:.3g})")
        y = np.concatenate([r.jaw_torque_nm for r in recordings])
        sliding = np.abs(s.omega) > OMEGA_SLIDING
        if sliding.sum() < 200:
            raise IdentificationInputError("the motor hardly moves: fewer than 200 sliding samples")
        start = initial.torque if initial is not None else None
        torque, fixed, info = _solve_torque(s, y, sliding, angle[0], start, max_iter)
        return cls(torque, angle, phi, 0.05, h, fixed, info)

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
        return {"format": FORMAT,
                "torque": {n: {"value": float(v), "unit": u, "lower": lo, "upper": hi}
                           for (n, u, lo, hi, _), v in zip(TORQUE_PARAMETERS, self.torque)},
                "angle": dict(zip(ANGLE_NAMES, map(float, self.angle))),
                "presliding_rad": self.presliding_rad, "hold_rad": self.hold_rad,
                "backlash_rad": self.backlash_rad, "fixed": list(self.fixed),
                "info": {k: v for k, v in self.info.items() if k != "width_scores"}}


def _solve_torque(s: _Signals, y: np.ndarray, sliding: np.ndarray, ratio: float, start,
                  max_iter: int, fixed: tuple[str, ...] = ()):
    """IPOPT on the sliding samples; returns (params, fixed names, info with identifiability).
    When the Fisher information cannot split the motor Coulomb friction from the pretension
    term, refits with the former fixed at 0 (module docstring)."""
    import casadi as ca

    lo = np.array([p[2] for p in TORQUE_PARAMETERS])
    hi = np.array([p[3] for p in TORQUE_PARAMETERS])
    x0 = np.array(start if start is not None else [p[4] for p in TORQUE_PARAMETERS], dtype=float)
    x0 = np.clip(x0, lo, hi)
    for name in fixed:
        k = TORQUE_NAMES.index(name)
        lo[k] = hi[k] = x0[k] = 0.0
    span = np.maximum(hi - lo, 1e-12)
    free = [k for k, n in enumerate(TORQUE_NAMES) if n not in fixed]
    u = ca.MX.sym("u", len(free))
    p = [ca.DM(lo[k]) for k in range(len(lo))]
    for j, k in enumerate(free):
        p[k] = lo[k] + u[j] * span[k]
    idx = np.flatnonzero(sliding)
    cols = _Signals(*(ca.DM(getattr(s, f)[idx]) for f in _Signals.__dataclass_fields__))
    resid = _torque_law(p, cols, ratio, ca) - ca.DM(y[idx])
    cost = ca.sumsqr(resid) / len(idx) / 1e-6  # in mNm^2: O(1)-O(100) numbers for IPOPT
    solver = ca.nlpsol("transmission", "ipopt", {"x": u, "f": cost}, {
        "ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": max_iter,
        "ipopt.tol": 1e-10, "ipopt.sb": "yes"})
    sol = solver(x0=((x0 - lo) / span)[free], lbx=0.0, ubx=1.0)
    stats = solver.stats()
    if not stats["success"] and stats["return_status"] != "Maximum_Iterations_Exceeded":
        raise NotConvergedError(f"transmission fit: IPOPT {stats['return_status']}")
    u_hat = np.array(sol["x"]).ravel()
    params = lo.copy()
    params[free] = lo[free] + u_hat * span[free]
    jac_r = ca.Function("j", [u], [ca.jacobian(resid, u), resid])
    jac, r_hat = (np.array(x) for x in jac_r(u_hat))
    sigma2 = float(np.sum(r_hat ** 2) / max(len(idx) - len(free), 1))
    ident = _identifiability(jac, sigma2, [TORQUE_NAMES[k] for k in free], params[free],
                             lo[free], hi[free], span[free])
    pair = ("motor_coulomb", "pretension_torque")
    if not fixed and abs(ident["correlations"].get(f"{pair[0]}|{pair[1]}", 0.0)) > TIE_CORRELATION:
        params, fixed_out, info = _solve_torque(s, y, sliding, ratio, params, max_iter,
                                                fixed=(pair[0],))
        info["tied"] = (f"{pair[0]} fixed at 0: the data cannot split it from {pair[1]} "
                        f"(correlation {ident['correlations'][f'{pair[0]}|{pair[1]}']:.3f}); "
                        "the load-independent friction is carried by the pretension term")
        return params, fixed_out, info
    info = {"solver": "CasADi IPOPT", "solver_status": stats["return_status"],
            "converged": bool(stats["success"]), "iterations": int(stats["iter_count"]),
            "sliding_samples": int(len(idx)),
            "train_sliding_rmse_nm": float(np.sqrt(np.mean(r_hat ** 2))),
            "identifiability": ident}
    return params, tuple(fixed), info


def _identifiability(jac, sigma2, names, values, lo, hi, span) -> dict:
    """Fisher information of the scaled parameters (each on [0, 1] over its bounds) from the
    residual Jacobian and the residual variance ``sigma2`` (Nm^2): its condition number, the
    parameter correlations, each parameter's standard deviation relative to its value, and
    the parameters pinned at a bound."""
    fim = jac.T @ jac / sigma2
    cond = float(np.linalg.cond(fim))
    cov = np.linalg.pinv(fim)
    sd = np.sqrt(np.maximum(np.diag(cov), 1e-300))
    corr = cov / np.outer(sd, sd)
    pairs = {f"{names[a]}|{names[b]}": float(corr[a, b])
             for a in range(len(names)) for b in range(a + 1, len(names))}
    return {"fisher_condition_number": cond,
            "correlations": pairs,
            "strongly_correlated": [k for k, v in pairs.items() if abs(v) > TIE_CORRELATION],
            "at_bound": [n for n, v, a, b in zip(names, values, lo, hi)
                         if min(v - a, b - v) <= 1e-4 * (b - a)],
            "relative_sd": {n: float(s_ * w / max(abs(v), 1e-12)) for n, s_, w, v in
                            zip(names, sd, span, values)}}
