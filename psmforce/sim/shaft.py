"""The roll drive between the roll encoder and the shaft: its lost motion (simulator 2.3).

The dVRK's roll encoder sits on the motor; the instrument's roll disc turns the shaft through the
instrument's own cable drive in the housing. Like the wrist's cables (whose lost motion the MRD
Lab recordings show, docs/simulator.md section 12b), that drive loses motion at each reversal:
the motor turns through a dead band of width ``w`` (``InstrumentParams.roll_backlash_rad``)
before the shaft follows. Modelled as a play (backlash) operator on the roll angle:

    q_shaft_k = min(max(q_shaft_{k-1}, q_enc_k - w/2), q_enc_k + w/2),   q_shaft_0 = q_enc_0

so ``q_enc - q_shaft`` lies in ``[-w/2, w/2]``: ``+w/2`` after a positive roll motion (the shaft
trails), ``-w/2`` after a negative one, and it holds its value while the roll rests. Units rad;
arrays over time (N,). The shaft carries the HEX10, so everything distal of the roll drive (the
sensor's frame, the wrist, the jaw tip) turns with ``q_shaft``, while the dVRK reports
``q_enc``: the targets are expressed in the HEX10 frame the encoders give (paper eq. 4), the
sensor measures in the one the shaft has, turned about the shaft by ``q_shaft - q_enc``.
"""

from __future__ import annotations

import numpy as np

from psmforce.sim.drive import play
from psmforce.sim.params import InstrumentParams

ROLL = 3
"""Column of the roll joint in dVRK order."""


def distal_roll(q_roll_enc: np.ndarray, backlash_rad: float) -> np.ndarray:
    """(N,) roll of the shaft (rad) for encoder roll ``q_roll_enc`` (N,) through a dead band of
    width ``backlash_rad`` (>= 0); the shaft starts at the encoder's first value. Width 0: the
    encoder's values themselves (the same array, not a copy)."""
    if backlash_rad < 0:
        raise ValueError(f"backlash_rad must be >= 0, got {backlash_rad}")
    q = np.asarray(q_roll_enc, dtype=float)
    if backlash_rad == 0.0 or len(q) == 0:
        return q
    half = 0.5 * backlash_rad
    shaft = play(q - half, q + half)
    shaft[0] = q[0]  # play starts at the middle of the first interval: the encoder's value
    return shaft


def distal_joints(q_enc: np.ndarray, params: InstrumentParams) -> np.ndarray:
    """(N, 7) joint positions of the physical arm and instrument for encoder positions ``q_enc``
    (N, 7), dVRK order: the roll through :func:`distal_roll`, every other joint as the encoder
    says (the wrist's own lost motion is the cable law's deflection,
    :func:`psmforce.sim.cables.transmission`). Without roll backlash: ``q_enc`` itself."""
    if params.roll_backlash_rad == 0.0:
        return q_enc
    out = np.array(q_enc, dtype=float, copy=True)
    out[:, ROLL] = distal_roll(q_enc[:, ROLL], params.roll_backlash_rad)
    return out
