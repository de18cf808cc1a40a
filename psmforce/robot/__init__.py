"""The robot model: the dVRK Classic PSM with the Cadiere forceps and the HEX10 shaft sensor.

``from psmforce.robot import PSM``: kinematics, Jacobians and wrenches
(``psmforce.robot.kinematics``); force frame changes in ``psmforce.robot.frames``; the generic
wrench-from-torques for any Pinocchio model in ``psmforce.robot.wrench``. Conventions:
``docs/conventions.md``.
"""

from psmforce.robot.kinematics import PSM

__all__ = ["PSM"]
