"""Options of the arm dynamics model and its fit, and the variants model selection compares.

An option either chooses a term of the model (:mod:`.dynamics_regressor` turns the options into
its columns; coordinates are indexed 0..6 in the recorder's order, yaw .. jaw or its wrist
motors) or a choice of the fit and its signal conditioning (:mod:`.dynamics_fit`).
"""

from __future__ import annotations

from dataclasses import dataclass

from psmforce.robot.conventions import INSERTION_JOINT, JOINTS
from psmforce.identification.friction import FrictionShape

N_COORD = len(JOINTS)
"""Coordinates of the model: the six chain joints and the jaw, or the recorder's seven."""
INSERTION = JOINTS.index(INSERTION_JOINT)
"""Index of the prismatic coordinate (m, N); the others are revolute (rad, Nm)."""

HYSTERESIS_BREAKAWAY_RAD = (0.01, 0.03, 0.1, 0.3)
"""Breakaway displacements (rad) of the Maxwell-slip elements of a revolute coordinate: a fixed
log-spaced grid (factor ~3) from cable pre-sliding (0.01 rad, a fraction of a mm of cable at the
instrument's pulleys) to a large part of the joint's range; the fit weighs them (levels >= 0)."""
HYSTERESIS_BREAKAWAY_M = (0.0005, 0.0015, 0.005, 0.015)
"""The same for the prismatic insertion (m): 0.5 mm to 15 mm of travel (a tenth of the stroke)."""


@dataclass(frozen=True)
class DynamicsFitOptions:
    """Choices of the fit; the defaults are the published WPI protocol plus our model terms."""

    cutoff_hz: float = 5.4
    filter_order: int = 4
    trim: int = 200
    friction_shape: FrictionShape = FrictionShape(smooth_sign_velocity=0.01,
                                                  stribeck_velocity=0.02)
    """Smooth-sign and Stribeck velocities of the revolute coordinates (rad/s). A sharp Coulomb
    transition: the gradual one (0.1 rad/s) stood in for pre-sliding, which the Maxwell-slip
    terms now model by displacement; sharp won the phase cross-validation
    (:data:`SELECTION_CANDIDATES`)."""
    friction_shape_prismatic: FrictionShape = FrictionShape(smooth_sign_velocity=0.002,
                                                            stribeck_velocity=0.004)
    """The same for the insertion (m/s)."""
    stribeck: bool = False
    """Stribeck columns off by default: on the WPI training file every Stribeck term hit its 0 bound."""
    spring_coordinates: tuple[int, ...] = (3, 4, 5, 6)
    """Coordinates with a linear position term K*c (Nm/rad): roll torsion (Wang et al.) and the
    wrist cables' elasticity. Springs on yaw/pitch/insertion too (unmodelled position-dependent
    loads): the default before the hysteresis terms; with them, worse in the phase
    cross-validation (:data:`SELECTION_CANDIDATES`, benchmark ``--selection``)."""
    roll_wrist_cross_springs: bool = True
    """Roll torque linear in the wrist coordinates (the wrist cables run along the roll axis and
    twist with it); kept from the earlier (in-sample) 60/40 selection."""
    spring_polynomial: tuple[tuple[int, int], ...] = ((3, 2),)
    """(coordinate, degree) pairs: position terms c_k^2 .. c_k^degree on coordinate k besides the
    linear spring. Default: roll torque quadratic in roll (torsion stiffness that differs between
    the two twist directions). Chosen by phase cross-validation on the WPI training file in the
    study before the hysteresis terms (docs/identification.md, git history); not re-tested since."""
    asymmetric_coulomb: tuple[int, ...] = (2, 3)
    """Coordinates whose Coulomb level may differ between the + and - directions: an extra column
    |s(v)| with coefficient a, so that the levels are Fc + a (v > 0) and Fc - a (v < 0), both
    constrained >= 0. Default insertion and roll (cable/carriage friction that depends on the
    direction of travel): chosen by the phase cross-validation before the hysteresis terms; its
    symmetric alternative is re-scored without hysteresis in :data:`SELECTION_CANDIDATES`."""
    cross_springs: tuple[tuple[int, int], ...] = ()
    """(row, column) pairs: torque on coordinate ``row`` linear in the position of ``column``."""
    hysteresis_coordinates: tuple[int, ...] = (0, 1, 2, 3, 4, 5, 6)
    """Coordinates with Maxwell-slip pre-sliding hysteresis (``friction.maxwell_slip_states``,
    one element per breakaway displacement of :data:`HYSTERESIS_BREAKAWAY_RAD` /
    :data:`HYSTERESIS_BREAKAWAY_M`, levels >= 0): friction that turns over a travel after each
    reversal (cable stretch, pulley and carriage pre-sliding) rather than over a velocity band.
    Default: every coordinate (lowest mean error of the phase cross-validation,
    :data:`SELECTION_CANDIDATES`)."""
    insertion_counterweight: bool = True
    """Moving mass of the insertion stage whose weight is balanced (a counterweight riding the
    insertion axis the other way, or any balancing of the carriage along its stroke): it adds
    inertia, Coriolis and centrifugal torques (yaw and pitch inertia growing with the insertion,
    the carriage's inertia along the stroke) without the weight that a rigid body of that mass
    would put on yaw, pitch and insertion. Without it the insertion body's one mass has to be
    both its weight and its inertia, and the fit keeps a 49 g body 1.24 m behind its frame.
    Modelled as a weightless point mass on the insertion axis: three linear parameters, mass
    (kg) >= 0, first and second moments along the axis (kg m, kg m^2) with m * mzz >= mz^2
    (``dynamics_regressor.counterweight_columns``). Default: it won the phase cross-validation
    (:data:`SELECTION_CANDIDATES`; WPI training file: 0.40 kg, 96 mm behind the insertion frame,
    the insertion body's own weight then 6 g)."""
    wrist_joint_friction: bool = True
    """Extra Coulomb + viscous friction on the dVRK wrist joints (pulleys), mapped to c by T^T."""
    prior_weight: float = 1e-4
    """Weight of the pull towards the URDF inertial prior, relative to the mean data curvature."""
    bounding_ellipsoids: bool = True
    """Constrain the instrument bodies' mass inside ``dynamics_fit.BOUNDING_ELLIPSOIDS`` (geometric
    plausibility); the benchmark prints the fit without them too."""
    gravity: tuple[float, float, float] | None = None
    """Gravity (m/s^2) in the base frame if known; None: identify its direction (|g| =
    ``psmforce.robot.conventions.GRAVITY_MPS2``)."""
    max_iter: int = 3000
    min_samples: int = 1000


_ALL = tuple(range(N_COORD))
_NO_COUNTERWEIGHT = dict(insertion_counterweight=False)
"""The candidates the counterweight was scored against keep the model they were chosen in."""
_GRADUAL_COULOMB = dict(
    **_NO_COUNTERWEIGHT,
    friction_shape=FrictionShape(smooth_sign_velocity=0.1, stribeck_velocity=0.2),
    friction_shape_prismatic=FrictionShape(smooth_sign_velocity=0.05, stribeck_velocity=0.1))
"""The previous default's Coulomb transition (0.1 rad/s, 0.05 m/s): ten (insertion 25) times
more gradual than the default's."""
SELECTION_CANDIDATES = {
    "default": DynamicsFitOptions(),
    "no insertion counterweight (previous default)": DynamicsFitOptions(**_NO_COUNTERWEIGHT),
    "gradual Coulomb": DynamicsFitOptions(**_GRADUAL_COULOMB),
    "gradual Coulomb, springs on all coordinates": DynamicsFitOptions(
        **_GRADUAL_COULOMB, spring_coordinates=_ALL),
    "gradual Coulomb, hysteresis on insertion + roll only": DynamicsFitOptions(
        **_GRADUAL_COULOMB, hysteresis_coordinates=(2, 3), spring_coordinates=_ALL),
    "no hysteresis (previous default)": DynamicsFitOptions(
        **_GRADUAL_COULOMB, hysteresis_coordinates=(), spring_coordinates=_ALL),
    "no hysteresis, symmetric Coulomb": DynamicsFitOptions(
        **_GRADUAL_COULOMB, hysteresis_coordinates=(), spring_coordinates=_ALL,
        asymmetric_coulomb=()),
    "no hysteresis, springs on roll + wrist": DynamicsFitOptions(
        **_GRADUAL_COULOMB, hysteresis_coordinates=()),
}
"""The model variants scored by model selection on training data: the WPI study
(``dynamics_validation.select_by_phase_cross_validation``, ``psmforce fit-dynamics --format wpi
--select``, benchmark ``--selection``) and ``recordings.select_options`` (our layout,
``--select``). The default (Maxwell-slip hysteresis on every coordinate, springs on roll + wrist,
sharp Coulomb transition, the insertion counterweight) is the WPI study's winner; the others are
the choices it was made against: the same without the counterweight (the previous default; the
rest of the list is without it too, as it was scored when those choices were made), the
gradual Coulomb transition, springs on yaw/pitch/insertion, hysteresis on fewer coordinates or
none, symmetric Coulomb."""
