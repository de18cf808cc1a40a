"""Hysteresis with memory, driven by displacement (rate independent), for whole recordings:

* :func:`dahl_state`: the Dahl friction-direction state in [-1, 1] of one coordinate
  (:mod:`psmforce.robot.dahl`, the recursion the bench's cables and the prior's capstan read);
* :func:`play`: the backlash (play) operator;
* :func:`hold`: a first-order hold that follows its input only while the driving coordinate
  moves (a Maxwell-slip element with one slip width).

Each is a recursion on one scalar state per sample; arrays are 1-D over time.
"""

from __future__ import annotations

import numpy as np

from psmforce.robot.dahl import dahl_states


def dahl_state(theta: np.ndarray, presliding_rad: float) -> np.ndarray:
    """z_k = a_k z_{k-1} + (1 - a_k) sgn(dtheta_k), a_k = exp(-|dtheta_k| / phi): the exact
    rate-independent Dahl solution for piecewise-linear motion (z_0 = 0), of the 1-D
    ``theta``."""
    return dahl_states(np.asarray(theta, dtype=float)[:, None], presliding_rad)[:, 0]


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


def hold_coefficients(theta: np.ndarray, hold_rad: float) -> np.ndarray:
    """a_k of the stick hold; a_0 = 0: the first estimate is the law's."""
    return np.concatenate([[0.0], np.exp(-np.abs(np.diff(theta)) / hold_rad)])


def hold(model: np.ndarray, theta: np.ndarray, hold_rad: float) -> np.ndarray:
    """The displacement-driven hold of ``model`` (one Maxwell-slip element, slip angle
    ``hold_rad``): it follows only as fast as ``theta`` moves."""
    a = hold_coefficients(theta, hold_rad)
    return _recurrence(a, (1.0 - a) * model, 0.0)
