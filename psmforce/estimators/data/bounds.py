"""The physical range of every recorded signal: what a real sample can hold.

:func:`physical_bounds` is shared by the dataset loader (:mod:`psmforce.estimators.data.dataset`
refuses recordings outside it, so no model is trained or scored on a sample streaming would refuse)
and the streaming estimator (:mod:`psmforce.estimators.runtime.streaming` flags samples outside it
``INVALID_INPUT``); :data:`MAX_FORCE_N` bounds the force an estimate may claim.
"""

from __future__ import annotations

import numpy as np

from psmforce.io.recording import (HEX10_FORCE, HEX10_TORQUE, JOINT_EFFORTS, JOINT_POSITIONS,
                                  JOINT_VELOCITIES, JOINTS)
from psmforce.sim.params import InstrumentParams

POSITION_MARGIN = 0.1
"""Joint positions may pass the URDF limits by this fraction of each joint's range: the dVRK's
limits are software limits that a backdriven or homing arm overshoots by a few degrees; beyond
that a value is not a pose but a corrupt sample."""
VELOCITY_FACTOR = 10.0
"""Joint velocities may reach this multiple of the URDF velocity limit: they are encoder
differences that spike on quantisation and impacts (the simulated bench reaches 3.8x on roll)."""
EFFORT_FACTOR = 3.0
"""Joint efforts may reach this multiple of the URDF effort limit (max current x torque constant x
gear ratio): joint efforts are coupled sums of saturated actuator currents (the bench: 1.04x)."""
HEX10_FACTOR = 1.5
"""HEX10 channels may reach this multiple of the sensor's overload range (clipped there), which
leaves room for a re-tared offset; a larger reading cannot come from the sensor."""
_HEX10 = InstrumentParams()  # the HEX10's data-sheet ranges, stated once with the simulated sensor
MAX_FORCE_N = HEX10_FACTOR * _HEX10.hex10_overload_n
"""An estimated force beyond this on an axis (N) cannot be carried through the shaft sensor: the
streaming estimate is flagged ``IMPLAUSIBLE``."""


def physical_bounds(psm=None) -> dict[str, tuple[float, float]]:
    """Per recorded column, the (low, high) range a real sample can take (units of
    :mod:`psmforce.io.recording`): the URDF's joint, velocity and effort limits of ``psm`` (default
    the bundled PSM) widened by :data:`POSITION_MARGIN`, :data:`VELOCITY_FACTOR`,
    :data:`EFFORT_FACTOR`, and the HEX10's overload times :data:`HEX10_FACTOR`."""
    if psm is None:
        from psmforce.robot import PSM
        psm = PSM()
    model = psm.model
    idx_v = [model.joints[model.getJointId(j)].idx_v for j in JOINTS]
    low, high = np.asarray(psm.lower_limits, float), np.asarray(psm.upper_limits, float)
    margin = POSITION_MARGIN * (high - low)
    velocity = VELOCITY_FACTOR * np.asarray(model.velocityLimit)[idx_v]
    effort = EFFORT_FACTOR * np.asarray(model.effortLimit)[idx_v]
    bounds = {}
    for k in range(len(JOINTS)):
        bounds[JOINT_POSITIONS[k]] = (low[k] - margin[k], high[k] + margin[k])
        bounds[JOINT_VELOCITIES[k]] = (-velocity[k], velocity[k])
        bounds[JOINT_EFFORTS[k]] = (-effort[k], effort[k])
    for names, limit in ((HEX10_FORCE, _HEX10.hex10_overload_n),
                         (HEX10_TORQUE, _HEX10.hex10_overload_moment_nm)):
        for c in names:
            bounds[c] = (-HEX10_FACTOR * limit, HEX10_FACTOR * limit)
    return bounds
