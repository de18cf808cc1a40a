"""The dVRK joint-effort channels beyond rigid-body physics: drive (and port) friction with
stiction, the disturbance an identified model cannot explain, and the current measurement.

Conventions (as the rest of the bench): efforts are what the motors apply, in Nm (revolute) or N
(insertion); joint order yaw, pitch, insertion, roll, wrist_pitch, wrist_yaw, jaw; velocities in
rad/s or m/s; a friction level is positive and the friction the motor overcomes has the sign of
the motion. Whole recordings are arrays over time (N, ...). Equations and the numbers' sources:
docs/simulator.md, section 8.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter

from psmforce.sim.params import InstrumentParams
from psmforce.sim.sensors import COUPLING


def play(lower: np.ndarray, upper: np.ndarray) -> np.ndarray:
    """u_k = min(max(u_{k-1}, lower_k), upper_k), u_0 = the middle of the first interval: the
    output stays where it was while it lies in the moving interval and is dragged by the nearer
    bound otherwise (a play / backlash operator; lower <= upper). Sequential by nature: a tight
    loop over Python floats (about 0.15 us a sample), like the Dahl recursion of the cables."""
    lo, hi = lower.tolist(), upper.tolist()
    out = [0.0] * len(lo)
    u = 0.5 * (lo[0] + hi[0]) if lo else 0.0
    for k in range(len(lo)):
        if u < lo[k]:
            u = lo[k]
        elif u > hi[k]:
            u = hi[k]
        out[k] = u
    return np.asarray(out)


@dataclass(frozen=True)
class FrictionLaw:
    """One friction element of a joint (levels N or Nm, (N,) arrays or scalars): kinetic Coulomb
    level ``coulomb``, breakaway ``static``, Stribeck velocity, viscous coefficient."""

    coulomb: np.ndarray
    static: np.ndarray
    stribeck_velocity: float
    viscous: float

    def kinetic(self, velocity: np.ndarray, direction: np.ndarray) -> np.ndarray:
        """Sliding friction ``(F_c + (F_s - F_c) exp(-(v/v_s)^2)) z + b v``; ``direction`` z in
        [-1, 1] says which way it acts: a smooth sign of the velocity, or a Dahl pre-sliding state
        (:func:`psmforce.sim.cables.dahl_direction`: after a reversal the friction crosses zero
        over a few pre-sliding lengths of travel, a hysteresis)."""
        decay = np.exp(-(velocity / self.stribeck_velocity) ** 2)
        return (self.coulomb + (self.static - self.coulomb) * decay) * direction + self.viscous * velocity


def stick_slip_effort(load: np.ndarray, velocity: np.ndarray,
                      elements: list[tuple[FrictionLaw, np.ndarray]], stick_velocity: float) -> np.ndarray:
    """(N,) motor effort of a position-controlled joint that must balance ``load`` (N,) (every
    other effort term) and the friction ``elements``, (law, direction) pairs acting together
    (the drive's own, the port's seal).

    Moving (|v| >= v_stick): effort = load + sum of the elements' :meth:`FrictionLaw.kinetic`.
    At rest the joint is stuck: the controller's effort stays where it was until
    ``|effort - load|`` would exceed the summed breakaway level ``F_s`` (the deadband), so a load
    change smaller than that does not show in the effort, and what the effort holds depends on
    the load's history. Between, the admissible interval
    ``load + [sigma f_k - (1 - sigma) F_s, sigma f_k + (1 - sigma) F_s]``, ``sigma = |v|/v_stick``,
    narrows continuously; :func:`play` keeps the effort in it.
    """
    v = np.asarray(velocity, dtype=float)
    kinetic = sum(law.kinetic(v, z) for law, z in elements)
    static = np.broadcast_to(sum(law.static for law, _ in elements), v.shape)
    sigma = np.clip(np.abs(v) / stick_velocity, 0.0, 1.0)
    centre = load + sigma * kinetic
    half = (1.0 - sigma) * static
    return play(centre - half, centre + half)


def drive_laws(q: np.ndarray, external_load: np.ndarray, params: InstrumentParams) -> list[FrictionLaw]:
    """Friction laws of yaw, pitch, insertion, roll along a recording: levels rippling with
    position, ``(1 + a sin(2 pi q / lambda))``, and growing with the joint's external load,
    ``+ mu |tau_ext|``. ``q`` (N, >= 4) joint positions, ``external_load`` (N, 4)."""
    kinetic = (*params.arm_coulomb, params.roll_friction_nm)
    viscous = (*params.arm_viscous, 0.0)
    laws = []
    for j in range(4):
        ripple = 1.0 + params.drive_position_friction * np.sin(
            2 * np.pi * q[:, j] / params.drive_position_wavelength[j])
        extra = params.drive_load_friction_gain * np.abs(external_load[:, j])
        laws.append(FrictionLaw(kinetic[j] * ripple + extra,
                                params.drive_static_ratio * kinetic[j] * ripple + extra,
                                params.drive_stribeck_velocity[j], viscous[j]))
    return laws


def disc_friction_efforts(joint_effort: np.ndarray, q_wrist: np.ndarray, dt: float,
                          params: InstrumentParams, hysteresis: bool) -> np.ndarray:
    """(N, 3) efforts of (wrist_pitch, wrist_yaw, jaw) once the three wrist discs' own friction
    is added: ``joint_effort`` (N, 3) is what the cables demand, ``q_wrist`` (N, 3) the joint
    angles. The discs turn ``c = M^-1 q`` (M the lower block of :data:`COUPLING`), carry the
    load ``M^T tau`` and each adds a :func:`stick_slip_effort` law; back to joints by ``M^-T``."""
    from psmforce.sim.cables import dahl_direction

    m = COUPLING[1:, 1:]
    c = q_wrist @ np.linalg.inv(m).T
    load = joint_effort @ m
    dc = np.gradient(c, dt, axis=0)
    z = dahl_direction(c, params.disc_presliding_rad, hysteresis)
    out = np.empty_like(load)
    for k in range(3):
        law = FrictionLaw(params.disc_coulomb[k], params.drive_static_ratio * params.disc_coulomb[k],
                          params.disc_stribeck_velocity, params.disc_viscous[k])
        out[:, k] = stick_slip_effort(load[:, k], dc[:, k], [(law, z[:, k])], params.disc_stick_velocity)
    return out @ np.linalg.inv(m)


def resonator(frequency_hz: float, damping: float, dt: float) -> np.ndarray:
    """Denominator ``a`` (3,) of the discrete second-order resonator ``1 / a(z)``: the poles of
    ``s^2 + 2 zeta w s + w^2`` (w = 2 pi f) mapped by ``exp(s dt)``; any damping (over-damped:
    two real poles, a low-pass band; light: a narrow peak at f)."""
    w = 2 * np.pi * frequency_hz
    root = np.sqrt(complex(damping ** 2 - 1.0))
    poles = np.exp(np.array([-damping + root, -damping - root]) * w * dt)
    return np.real(np.poly(poles))


def resonator_noise(frequency_hz: float, damping: float, n: int, dt: float,
                    rng: np.random.Generator) -> np.ndarray:
    """(n,) unit-variance white noise through :func:`resonator`, stationary from the first
    sample (the filter runs ``settle`` samples first, dropped)."""
    a = resonator(frequency_hz, damping, dt)
    settle = int(10.0 / (min(damping, 1.0) * 2 * np.pi * frequency_hz * dt))
    x = lfilter([1.0], a, rng.standard_normal(n + settle))[settle:]
    impulse = lfilter([1.0], a, np.r_[1.0, np.zeros(settle + 100)])
    return x / np.sqrt(np.sum(impulse ** 2))


def coloured_disturbance(n: int, dt: float, params: InstrumentParams, rng: np.random.Generator) -> np.ndarray:
    """(n, 7) effort disturbance: per joint band noise of std ``effort_band_noise`` shaped by a
    :func:`resonator` (``effort_band_hz``, ``effort_band_damping``); on insertion also the
    stage's lightly damped mode (``insertion_resonance_*``)."""
    out = np.zeros((n, 7))
    for j in range(7):
        out[:, j] = params.effort_band_noise[j] * resonator_noise(
            params.effort_band_hz[j], params.effort_band_damping[j], n, dt, rng)
    out[:, 2] += params.insertion_resonance_n * resonator_noise(
        params.insertion_resonance_hz, params.insertion_resonance_damping, n, dt, rng)
    return out


def quantise_currents(effort: np.ndarray, params: InstrumentParams) -> np.ndarray:
    """(N, 7) efforts as the controller reports them: each motor's torque in steps of
    ``current_quantum x torque constant x gear``. Arm joints directly; the instrument joints'
    efforts come from the four disc motors (tau_disc = C^T tau_joint), so those are quantised."""
    step = params.current_quantum_a * params.torque_constant_nm_per_a * np.asarray(params.gear_ratios)
    out = effort.copy()
    out[:, :3] = np.round(effort[:, :3] / step[:3]) * step[:3]
    discs = effort[:, 3:] @ COUPLING
    discs = np.round(discs / step[3:]) * step[3:]
    out[:, 3:] = discs @ np.linalg.inv(COUPLING)
    return out


def remount_offset(params: InstrumentParams, rng: np.random.Generator) -> np.ndarray:
    """(7,) constant effort offset of one recording: zero on the arm joints, drawn on roll, wrist
    pitch, wrist yaw and jaw (the tool is mounted anew)."""
    out = np.zeros(7)
    out[3:] = np.asarray(params.remount_effort_offset) * rng.standard_normal(4)
    return out
