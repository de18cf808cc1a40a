"""psmforce: tool-tip forces for the dVRK PSM with a shaft-integrated six-axis sensor.

One package in wings, bottom floor first (a module imports its own wing and the floors below):
``core`` (atomic writes, the integrity envelope, the evaluation's filters) and ``robot`` (the PSM
model: kinematics, frames, wrenches); ``io`` (recordings, ROS bags); ``sim`` (the simulated bench)
and ``identification`` (arm dynamics, the internal-force prior, the cable transmission);
``estimators`` (data, networks, training, evaluation, runtime); ``experiments`` (``psmforce
reproduce`` and what the studies run) and ``live`` (the ROS 2 node); ``cli`` (the command line).

Where a user starts: :class:`psmforce.robot.PSM`, :func:`psmforce.sim.simulate`,
:mod:`psmforce.identification`, :func:`psmforce.estimators.training.train.train` and
:class:`psmforce.estimators.StreamingEstimator`; the README shows each.

``__version__`` is the package's version, the one place it is written: ``pyproject.toml`` reads it
from here (``[tool.setuptools.dynamic]``) and ``psmforce --version`` prints it.
"""

__version__ = "0.2.0"
