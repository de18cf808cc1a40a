"""Wrench from joint torques on the PSM and on two example-robot-data arms (UR5, Panda).

    python examples/wrench_from_torques.py

Frames: PSM base = RCM (modified-DH frame 0); forces in N, moments in Nm, [force; moment].
A known wrench w is applied BY the environment ON the tool at the jaw tip, in base axes. The joint
torques it exerts are tau = J^T w; the motors would hold it with -tau (dVRK efforts). We recover w
at the jaw tip (base axes), the same load at the HEX10 origin in HEX10 axes and about the RCM, and
on UR5 / Panda at their tool frames (base axes: the robot's base, Pinocchio's world). Where a
wrench is expressed (``expressed_in``): "base", "base_at_frame" or "frame", the one vocabulary of
psmforce.robot.conventions for PSM.jacobian, PSM.wrench_from_torques and psmforce.robot.wrench alike.
"""

import numpy as np
import pinocchio as pin

from psmforce.robot import PSM
from psmforce.robot.example_robots import load_example_robot
from psmforce.robot.frames import base_to_hex10
from psmforce.robot.wrench import wrench_from_torques

np.set_printoptions(precision=4, suppress=True)

psm = PSM()
q = np.array([0.3, -0.2, 0.12, 0.5, 0.3, -0.4])  # yaw, pitch (rad), insertion (m), roll, wrist (rad)
w_tip = np.array([0.5, -1.0, 2.0, 0.0, 0.0, 0.0])  # 0.5, -1, 2 N at the jaw tip, base axes
tau = psm.jacobian(q, "jaw_tip", "base_at_frame").T @ w_tip
motor_efforts = -tau  # what the dVRK would report in statics, without gravity and friction

w_est, info = psm.wrench_from_torques(q, -motor_efforts, frame="jaw_tip", expressed_in="base_at_frame",
                                      return_info=True)
print("PSM joint torques of the load (Nm, N):", tau)
print("recovered wrench at jaw_tip, base axes:", w_est,
      f"(sigma_min {info.sigma_min:.3g}, damped {bool(info.damped)})")
w_hex = psm.wrench_from_torques(q, tau, frame="hex10", expressed_in="frame")
print("same load at the HEX10 origin, HEX10 axes:", w_hex)
print("same load as a spatial wrench (moment about the RCM, base axes; dVRK spatial Jacobian):",
      psm.wrench_from_torques(q, tau))
print("  force check via frames.base_to_hex10:", base_to_hex10(w_tip[:3], q, psm))
print("  moment about HEX10 = lever (jaw_tip - hex10) x force:",
      np.cross(psm.forward_kinematics(q, "jaw_tip")[:3, 3] - psm.forward_kinematics(q, "hex10")[:3, 3],
               w_tip[:3]) @ psm.rotation(q, "hex10"))

for name in ("ur5", "panda"):
    model, tool = load_example_robot(name)
    qr = pin.neutral(model) + 0.3
    J = pin.computeFrameJacobian(model, model.createData(), qr, model.getFrameId(tool),
                                 pin.LOCAL_WORLD_ALIGNED)
    w = np.array([3.0, 0.0, -5.0, 0.1, 0.2, 0.0])
    estimate = wrench_from_torques(model, qr, J.T @ w, tool, expressed_in="base_at_frame")
    print(f"{name}: wrench at {tool} (base axes) applied {w}, recovered {estimate}")
