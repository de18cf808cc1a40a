"""Robots of the example-robot-data package, for showing the generic wrench code on other arms.

example-robot-data 6.0.0 ships no Python module; its URDFs live in the wheel's
``cmeel.prefix/share/example-robot-data/robots`` folder, found here through the installed
distribution's metadata.
"""

from __future__ import annotations

import importlib.metadata
from pathlib import Path

import pinocchio as pin

EXAMPLE_ROBOTS = {
    "ur5": ("ur_description/urdf/ur5_robot.urdf", "tool0"),
    "panda": ("panda_description/urdf/panda.urdf", "panda_hand_tcp"),
}
"""name -> (URDF path inside the robots folder, tool frame name)."""


def example_robot_urdf(name: str) -> Path:
    """Path of the URDF of ``name`` (a key of :data:`EXAMPLE_ROBOTS`)."""
    if name not in EXAMPLE_ROBOTS:
        raise ValueError(f"unknown example robot {name!r}; expected one of {sorted(EXAMPLE_ROBOTS)}")
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        raise FileNotFoundError("the example-robot-data package is not installed") from None
    path = Path(dist.locate_file(f"cmeel.prefix/share/example-robot-data/robots/"
                                 f"{EXAMPLE_ROBOTS[name][0]}"))
    if not path.is_file():
        raise FileNotFoundError(f"example-robot-data has no {path}")
    return path


def load_example_robot(name: str) -> tuple[pin.Model, str]:
    """(Pinocchio model, tool frame name) of an example-robot-data robot, kinematics + inertias only."""
    return pin.buildModelFromUrdf(str(example_robot_urdf(name))), EXAMPLE_ROBOTS[name][1]
