"""Sensor models: HEX10 in the shaft, dVRK joint states, ATI Nano17 under the fixture.

Arrays are whole recordings (N, ...). Units SI. Frames: HEX10 readings in the HEX10 frame;
ATI raw readings in the ATI frame.
"""

from __future__ import annotations

import numpy as np

from psmforce.sim.params import Effects, InstrumentParams

COUPLING = np.array([[-1.5632, 0.0, 0.0, 0.0],
                     [0.0, 1.0186, 0.0, 0.0],
                     [0.0, -0.8306, 0.6089, 0.6089],
                     [0.0, 0.0, -1.2177, 1.2177]])
"""dVRK instrument coupling (Cadiere 400049): q_joint = C q_actuator for (roll, wrist_pitch,
wrist_yaw, jaw)."""

ENCODER_QUANTUM = (2 * np.pi / (14400 * 56.5), 2 * np.pi / (14400 * 56.5), 2 * np.pi / (14400 * 336.6))
"""Joint-space encoder step of yaw, pitch (rad) and insertion (m): counts per turn x gear ratio."""
DISC_QUANTUM = 2 * np.pi / (4000 * 11.71)
"""Instrument disc encoder step (rad of disc)."""


def hex10_reading(w_section: np.ndarray, dt: float, params: InstrumentParams, effects: Effects,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """HEX10 output (N, 6) [fx fy fz tx ty tz] and overload flag (N,) from the physical section
    wrench (N, 6) in the HEX10 frame.

    Where ``hex10_readout_lag_s`` > 0 the section wrench first passes the readout's low-pass
    (:func:`readout_lag`). w is then turned into the frame the sensor measures in, ``R^T`` of its force and moment
    with ``R = mount_rotation(params.hex10_mount_rotation_rad)`` (skipped while every angle is
    0, so the nominal bench is unchanged bit for bit); y = X w (cross-talk); forces beyond the
    nominal range get an extra gain error g (|y| - F_nom) sign(y); + residual tare bias +
    random-walk drift (+ the thermal settling of :func:`thermal_offset` where
    ``hex10_thermal_drift_n`` > 0) + white noise; then every channel is clipped at its overload
    limit and the flag set where any channel reached it.
    """
    n = len(w_section)
    if params.hex10_readout_lag_s > 0.0:  # simulator 2.3
        w_section = readout_lag(w_section, dt, params.hex10_readout_lag_s)
    if any(a != 0.0 for a in params.hex10_mount_rotation_rad):
        r = mount_rotation(params.hex10_mount_rotation_rad)
        w_section = np.concatenate([w_section[:, :3] @ r, w_section[:, 3:] @ r], axis=1)
    y = w_section @ np.asarray(params.hex10_crosstalk).T if effects.hex10_crosstalk else w_section.copy()
    if effects.hex10_range_error:
        f = y[:, :3]
        excess = np.maximum(np.abs(f) - params.hex10_nominal_range_n, 0.0)
        y[:, :3] = f + params.hex10_range_gain_error * excess * np.sign(f)
    if effects.hex10_bias:
        y[:, :3] += np.asarray(params.hex10_residual_bias_n)
    if effects.hex10_drift:
        step = params.hex10_bias_drift_n_per_sqrt_s * np.sqrt(dt)
        y[:, :3] += np.cumsum(rng.standard_normal((n, 3)), axis=0) * step
        if params.hex10_thermal_drift_n > 0.0:  # simulator 2.3; no draw while off
            y[:, :3] += thermal_offset(n, dt, params, rng)
    if effects.sensor_noise:
        y[:, :3] += params.hex10_force_noise_n * rng.standard_normal((n, 3))
        y[:, 3:] += params.hex10_moment_noise_nm * rng.standard_normal((n, 3))
    limit = np.array([params.hex10_overload_n] * 3 + [params.hex10_overload_moment_nm] * 3)
    overload = (np.abs(y) >= limit).any(axis=1)
    return np.clip(y, -limit, limit), overload


def readout_lag(w: np.ndarray, dt: float, tau_s: float) -> np.ndarray:
    """(N, C) ``w`` through a causal first-order low-pass of time constant ``tau_s`` (s), exact
    for a signal held over each sample: ``y_k = a y_{k-1} + (1 - a) w_k``, ``a = exp(-dt/tau)``,
    started at rest on the first sample (``y_0 = w_0``). A ramp of slope ``r`` is followed at a
    constant distance ``r dt a / (1 - a)`` (about ``r tau`` for ``tau`` >> ``dt``)."""
    from scipy.signal import lfilter, lfiltic

    a = float(np.exp(-dt / tau_s))
    w = np.asarray(w, dtype=float)
    zi = np.stack([lfiltic([1.0 - a], [1.0, -a], [w[0, c]], [w[0, c]])
                   for c in range(w.shape[1])], axis=1)
    y, _ = lfilter([1.0 - a], [1.0, -a], w, axis=0, zi=zi)
    return y


def thermal_offset(n: int, dt: float, params: InstrumentParams,
                   rng: np.random.Generator) -> np.ndarray:
    """(n, 3) force offset (N, HEX10 frame) of a sensor zeroed warm that settles to the bench's
    temperature over the recording: ``A (1 - exp(-t / tau))`` with ``t = k dt`` from the
    recording's first sample, ``tau = params.hex10_thermal_time_s`` (s, > 0) and ``A`` (3,) drawn
    from ``rng`` with std ``params.hex10_thermal_drift_n`` per axis: 0 at the start (the zero),
    ``A (1 - 1/e)`` after one time constant, ``A`` in the end."""
    tau = params.hex10_thermal_time_s
    if not tau > 0.0:
        raise ValueError(f"hex10_thermal_time_s must be > 0 with a thermal drift, got {tau}")
    amplitude = params.hex10_thermal_drift_n * rng.standard_normal(3)
    return -np.expm1(-np.arange(n) * dt / tau)[:, None] * amplitude[None, :]


def mount_rotation(angles_rad) -> np.ndarray:
    """(3, 3) ``Rz(c) Ry(b) Rx(a)`` for angles (a, b, c) rad about x, y, z: the orientation of
    the frame the HEX10 measures in, in the frame the section wrench is computed in (a row
    vector ``v @ R`` is ``R^T v``)."""
    a, b, c = (float(x) for x in angles_rad)
    rx = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(a), -np.sin(a)], [0.0, np.sin(a), np.cos(a)]])
    ry = np.array([[np.cos(b), 0.0, np.sin(b)], [0.0, 1.0, 0.0], [-np.sin(b), 0.0, np.cos(b)]])
    rz = np.array([[np.cos(c), -np.sin(c), 0.0], [np.sin(c), np.cos(c), 0.0], [0.0, 0.0, 1.0]])
    return rz @ ry @ rx


def quantise_joints(q: np.ndarray, effects: Effects) -> np.ndarray:
    """Encoder-quantised (N, 7) joint positions: arm joints directly, instrument joints through
    their disc encoders and the coupling."""
    if not effects.encoder_quantisation:
        return q.copy()
    out = q.copy()
    step = np.asarray(ENCODER_QUANTUM)
    out[:, :3] = np.round(q[:, :3] / step) * step
    discs = q[:, 3:] @ np.linalg.inv(COUPLING).T
    out[:, 3:] = (np.round(discs / DISC_QUANTUM) * DISC_QUANTUM) @ COUPLING.T
    return out


def filtered_velocity(q_measured: np.ndarray, dt: float, time_constant: float) -> np.ndarray:
    """Backward difference of the quantised positions through a first-order low-pass
    (the dVRK differentiates encoders and filters), causal."""
    from scipy.signal import lfilter

    raw = np.diff(q_measured, axis=0, prepend=q_measured[:1]) / dt
    a = dt / (time_constant + dt)
    return lfilter([a], [1.0, a - 1.0], raw, axis=0)


def ati_raw(force_on_tool: np.ndarray, moment_arm: np.ndarray, r_base_ati: np.ndarray,
            params: InstrumentParams, effects: Effects, rng: np.random.Generator) -> np.ndarray:
    """ATI Nano17 reading (N, 6) in its own frame: the load the fixture puts on the sensor, i.e.
    minus the force on the tool, and its moment about the sensor origin (``moment_arm`` (N, 3):
    attachment point minus ATI origin, base frame)."""
    f_base = -force_on_tool
    m_base = np.cross(moment_arm, f_base)
    out = np.concatenate([f_base @ r_base_ati, m_base @ r_base_ati], axis=1)
    if effects.sensor_noise:
        n = len(out)
        out[:, :3] += params.ati_force_noise_n * rng.standard_normal((n, 3))
        out[:, 3:] += params.ati_moment_noise_nm * rng.standard_normal((n, 3))
    return out
