"""Identification: friction pieces, signal conditioning, the WPI loader, the arm dynamics fit
and the HEX10 internal-force prior. See docs/identification.md."""

from psmforce.identification.dynamics import ArmDynamicsModel, external_wrench_on_tool
from psmforce.identification.dynamics_fit import fit_arm_dynamics
from psmforce.identification.dynamics_options import DynamicsFitOptions
from psmforce.identification.dynamics_report import fit_dynamics_cli
from psmforce.identification.errors import IdentificationInputError, NotConvergedError
from psmforce.identification.prior import InternalForcePrior
from psmforce.identification.prior_remount import MountedPrior, recalibrate as recalibrate_prior
from psmforce.identification.prior_report import fit_prior_cli
from psmforce.identification.wpi import load_wpi

__all__ = ["ArmDynamicsModel", "DynamicsFitOptions", "fit_arm_dynamics", "fit_dynamics_cli",
           "external_wrench_on_tool", "InternalForcePrior", "fit_prior_cli", "load_wpi",
           "IdentificationInputError", "NotConvergedError", "MountedPrior", "recalibrate_prior"]
