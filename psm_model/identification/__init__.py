"""Identification: friction pieces, signal conditioning, the WPI loader, the arm dynamics fit
and the HEX10 internal-force prior. See docs/identification.md."""

from psm_model.identification.dynamics import ArmDynamicsModel, external_wrench_on_tool
from psm_model.identification.dynamics_fit import fit_arm_dynamics
from psm_model.identification.dynamics_options import DynamicsFitOptions
from psm_model.identification.dynamics_report import fit_dynamics_cli
from psm_model.identification.errors import IdentificationInputError, NotConvergedError
from psm_model.identification.prior import InternalForcePrior
from psm_model.identification.prior_report import fit_prior_cli
from psm_model.identification.wpi import load_wpi

__all__ = ["ArmDynamicsModel", "DynamicsFitOptions", "fit_arm_dynamics", "fit_dynamics_cli",
           "external_wrench_on_tool", "InternalForcePrior", "fit_prior_cli", "load_wpi",
           "IdentificationInputError", "NotConvergedError"]
