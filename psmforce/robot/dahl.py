"""The Dahl friction state: which way a cable's friction acts, with the memory a velocity's sign
lacks.

Dahl model of exponent 1 (rate independent), per channel of a displacement ``x`` (any unit; the
pre-sliding length ``x_c`` in the same unit)::

    dz/dx = (1 - z sgn(dx)) / x_c,          z in [-1, 1],

solved exactly for motion that is linear between samples::

    z_k = a_k z_(k-1) + (1 - a_k) sgn(dx_k),    a_k = exp(-|dx_k| / x_c),    z_(-1) = 0,
    dx_k = x_k - x_(k-1),   dx_0 = 0.

After a reversal the friction passes through zero over a few ``x_c`` of travel (pre-sliding);
at rest the state keeps the direction of the last motion, where a velocity's sign drops to 0.

The simulator's cables, roll and drive discs and the prior's capstan all read this one
recursion; :func:`dahl_states` (a recording) and :class:`DahlState` (a stream, one sample at a
time) give the same values.
"""

from __future__ import annotations

import math

import numpy as np


def dahl_states(x, presliding_length: float) -> np.ndarray:
    """(N, C) friction states of each column of the displacements ``x`` (N, C), in time order."""
    x = np.asarray(x, dtype=float)
    dx = np.diff(x, axis=0, prepend=x[:1])
    a = np.exp(-np.abs(dx) / presliding_length)
    b = (1.0 - a) * np.sign(dx)
    z = np.empty_like(x)
    for c in range(x.shape[1]):  # a recursion over time on plain floats: about 0.1 us a step
        out, state = [], 0.0
        for ak, bk in zip(a[:, c].tolist(), b[:, c].tolist()):
            state = ak * state + bk
            out.append(state)
        z[:, c] = out
    return z


class DahlState:
    """:func:`dahl_states` one sample at a time, on plain floats (a streaming estimator's path):
    :meth:`step` takes one sample's C displacements and returns the C states after it."""

    def __init__(self, channels: int, presliding_length: float):
        self._length = float(presliding_length)
        self._x: list[float] | None = None
        self._z = [0.0] * channels

    def step(self, x) -> list[float]:
        if self._x is not None:
            for i, (new, old) in enumerate(zip(x, self._x)):
                dx = new - old
                a = math.exp(-abs(dx) / self._length)
                self._z[i] = a * self._z[i] + (1.0 - a) * ((dx > 0) - (dx < 0))
        self._x = list(x)
        return self._z
