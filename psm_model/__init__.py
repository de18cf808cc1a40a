"""PSM model: the dVRK Classic PSM with the Cadiere forceps and the HEX10 shaft sensor.

``from psm_model import PSM``: kinematics, Jacobians and wrenches (``psm_model.kinematics``);
force frame changes in ``psm_model.frames``; the generic wrench-from-torques for any Pinocchio
model in ``psm_model.wrench``. Conventions: ``docs/conventions.md``.
"""

from psm_model.kinematics import PSM

__all__ = ["PSM"]
