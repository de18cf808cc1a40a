"""The identifiability report's errors-in-variables bound (``prior_identifiability``): Frisch's
reverse regression sees a disturbance in a measured regressor that the white-noise estimate from
its steps does not."""

from __future__ import annotations

import numpy as np

from psmforce.identification.prior_identifiability import (_reverse_regression_bound,
                                                           _white_noise)

N = 20000
SLOPE = 1.2e-3


def _regression(disturbance_std: float, seed: int = 0):
    """y = SLOPE x + 0.3 w + white noise in channel 0 of six, the slope's regressor read as x
    plus a slow disturbance; least squares on (x_read, w). Returns the fitted slope, the
    per-channel grams, the residual excess beyond the readings' white noise, the true slope."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) / 1000.0
    x = 3.0 * np.sin(2 * np.pi * 0.7 * t) + 2.0 * np.sin(2 * np.pi * 1.9 * t + 1.0)
    w = np.cos(2 * np.pi * 0.31 * t)
    slow = np.convolve(rng.normal(size=N + 400), np.hanning(400) / np.hanning(400).sum(),
                       "valid")[:N]
    x_read = x + disturbance_std * slow / slow.std()
    y = np.zeros((N, 6))
    y[:, 0] = SLOPE * x + 0.3 * w + rng.normal(0.0, 2e-4, N)
    cols = np.stack([x_read, w], axis=1)
    coef, *_ = np.linalg.lstsq(cols, y[:, 0], rcond=None)
    residual = y[:, 0] - cols @ coef
    gram = np.zeros((6, 2, 2))
    gram[0] = cols.T @ cols
    used = np.zeros((N, 6), bool)
    used[:, 0] = True
    white = _white_noise(y, used)
    excess = np.zeros(6)
    excess[0] = max(np.sum(residual ** 2) - N * white[0] ** 2, 0.0)
    return coef[0], gram, excess, white


def test_the_readings_white_noise_is_found_under_a_smooth_signal():
    _, _, _, white = _regression(0.0)
    assert abs(white[0] / 2e-4 - 1.0) < 0.05
    assert (white[1:] == 0).all()


def test_a_slow_disturbance_in_the_regressor_is_bounded_from_below():
    fitted, gram, excess, _ = _regression(2.0)
    true_reliability = fitted / SLOPE  # least squares shrinks the slope by it
    assert true_reliability < 0.8  # the shrinkage the check must see
    bound = _reverse_regression_bound(0, fitted, gram, excess)
    assert bound < 0.9  # not identifiable
    assert bound <= true_reliability + 0.02  # a lower bound of the shrinkage


def test_an_exact_regressor_keeps_its_reliability():
    fitted, gram, excess, _ = _regression(0.0)
    assert abs(fitted / SLOPE - 1.0) < 0.01
    assert _reverse_regression_bound(0, fitted, gram, excess) > 0.97


def test_a_channel_the_parameter_does_not_carry_does_not_count():
    fitted, gram, excess, _ = _regression(0.0)
    excess[3] = 1e3  # a large misfit in a channel the slope's column does not reach
    assert _reverse_regression_bound(0, fitted, gram, excess) > 0.97



def _law_values() -> dict:
    """The design values as the efforts reading holds its law (what it holds at 0, at 0)."""
    from psmforce.identification.prior import HELD_BY_READING
    from psmforce.identification.prior_selection import DESIGN
    return {**DESIGN, **HELD_BY_READING["efforts"]}


def _efforts_recording(disturbance_nm: float, n: int = 4000, seed: int = 0):
    """A free-space recording the efforts reading fits: the wrist moving with small efforts
    (every pair taut), its HEX10 columns the law's wrench at :func:`_law_values` from the true
    efforts plus the sensor's white noise (0.02 N, 0.2 mNm); the recorded efforts carry a slow
    disturbance of ``disturbance_nm`` (std, Nm) on top, as the discs' friction does, which
    tensions no cable."""
    import pandas as pd

    from psmforce.identification.prior import InternalForcePrior
    from psmforce.identification.prior_law import NAMES
    from psmforce.io.recording import (HEX10, JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES,
                                       TARGETS, TIME)
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 40.0, n)
    # every joint moving (the insertion model needs the shaft and the insertion to), rad / m
    centre = np.array([0.0, 0.0, 0.12, 0.0, 0.0, 0.0, 0.6])
    amplitude = np.array([0.3, 0.2, 0.02, 0.8, 0.6, 0.5, 0.3])
    rate_rad_s = np.array([0.23, 0.37, 0.6, 0.31, 0.53, 0.9, 1.7])
    q = centre + amplitude * np.sin(rate_rad_s * t[:, None])
    tau = np.zeros((n, 7))
    tau[:, 4] = 2e-3 * np.sin(0.8 * t) + 1e-3 * np.sin(2.3 * t)
    tau[:, 5] = 2e-3 * np.cos(0.6 * t) + 1e-3 * np.sin(1.9 * t + 1.0)
    tau[:, 6] = 1e-3 * np.sin(1.3 * t)
    frame = pd.DataFrame({TIME: t, **dict(zip(JOINT_POSITIONS, q.T)),
                          **dict(zip(JOINT_VELOCITIES, np.gradient(q, t, axis=0).T)),
                          **dict(zip(JOINT_EFFORTS, tau.T)), **dict.fromkeys(HEX10, np.zeros(n)),
                          **dict.fromkeys(TARGETS, np.zeros(n))})
    law = InternalForcePrior(params=np.array([_law_values()[n] for n in NAMES]), converged=True)
    noise_std = np.array([0.02] * 3 + [2e-4] * 3)
    frame[list(HEX10)] = law.predict(frame) + rng.normal(size=(n, 6)) * noise_std
    width = 400  # a disturbance that changes over about 0.4 s of the 100 Hz recording
    for k in (4, 5, 6):
        slow = np.convolve(rng.normal(size=n + width), np.hanning(width), "valid")[:n]
        frame[JOINT_EFFORTS[k]] = tau[:, k] + disturbance_nm * slow / slow.std()
    return frame


def _fitted_radius(disturbance_nm: float) -> tuple[float, dict]:
    """The efforts reading's cable radius (m) and identifiability report, everything but the
    radius and the moments' offsets held at :func:`_law_values`."""
    from psmforce.identification.prior import InternalForcePrior
    from psmforce.identification.prior_law import NAMES
    free = ("cable_radius", "bias_tx", "bias_ty", "bias_tz")
    prior = InternalForcePrior.fit([_efforts_recording(disturbance_nm)], inputs="efforts",
                                   fixed={n: v for n, v in _law_values().items()
                                          if n not in free})
    return float(dict(zip(NAMES, prior.params))["cable_radius"]), prior.info["identifiability"]


def test_the_efforts_reading_lists_a_radius_its_slow_disturbance_shrinks():
    """The steps see the efforts' white part only (here none): the reliability from them passes
    the radius, the reverse regression on the moments does not, and the fit is far short."""
    radius, report = _fitted_radius(1.5e-3)
    assert radius < 0.8 * _law_values()["cable_radius"]  # shrunk by the disturbance
    assert report["input_reliability"]["cable_radius"] > 0.9  # the steps do not see it
    assert report["input_reliability_bound"]["cable_radius"] < 0.9
    assert "reverse regression" in report["not_identifiable"]["cable_radius"]


def test_undisturbed_efforts_leave_the_radius_identified():
    radius, report = _fitted_radius(0.0)
    assert abs(radius / _law_values()["cable_radius"] - 1.0) < 0.02
    assert report["input_reliability_bound"]["cable_radius"] > 0.95
    assert "cable_radius" not in report["not_identifiable"]
