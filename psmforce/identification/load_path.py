"""The load path: the cable differentials a known tip force demands, for the internal-force prior.

The prior's law (:mod:`psmforce.identification.prior_law`) turns wrist torques into pair
differentials ``D = K^-T tau / r`` and tensions. Read from the motor efforts, those torques carry
what tensions no cable at the HEX10: the instrument discs' friction with stiction (several N of
``D`` at 1.5-2 mm pulleys), the arm's disturbance, re-mounting offsets (docs/identification.md
section 2). Where the tip force is known (an ATI during calibration, a hung weight, zero in free
space) the torques the cables must supply are known without them: the tip force's moments about
the wrist axes. This module computes those torques and the tip force's own moment at the HEX10,
so a fit can read the cables from the load instead of the currents.

Frames, units, signs (one place):

* ``f_hex`` (N, 3): the force the environment applies on the tool at the jaw tip, in the HEX10
  frame (the recording's ``ati_fx..ati_fz``), N.
* :func:`wrist_efforts_for_tip_force` (N, 3): dVRK joint-space efforts (wrist_pitch, wrist_yaw,
  jaw), Nm, what the motors apply to hold that force with ideal cables: ``-J^T F`` over the wrist
  columns of the jaw tip's Jacobian (base frame, the velocity of the jaw tip), ``F = R_hex f_hex``.
  Jaw 0: a force at the closed tip is shared by the two blades and opens nothing. This is the
  bench's ideal transmission (docs/simulator.md section 6, tested there against ``-J^T F``).
* :func:`tip_force_moment` (N, 3): the tip force's moment about the HEX10 origin in the HEX10
  frame, Nm, ``(R^T (p_tip - p_hex)) x f_hex``; the HEX10 reads it besides the cables' moments.
* The contact is taken at the jaw tip (``PSM.jaw_length`` from cp): where the paper's fixture and
  the simulated bench load the tool. A load elsewhere along the jaws changes both by its lever.
* **The wrist sags under the load.** The joint positions a recording carries are the motor
  side's (encoders); the cables stretch under the differential the load demands, so the wrist
  stands at ``q_true = q_encoder - sag`` (docs/simulator.md section 6, the bench's elasticity),
  and the tip force's moments are taken there: a bent wrist's moment arm changes with its angle,
  and with it the differential the cables carry and the compression the HEX10 reads (measured
  on hung weights in docs/ati_free.md section 4.1). :func:`wrist_sag` gives it from the
  demanded efforts and a :class:`WristCompliance`, one fixed-point pass as the bench takes: the
  efforts at the encoders' pose, the sag they cause, the efforts at the sagged pose. A first
  fit sags the wrist with the instrument's design values (the law's radii, pretension and
  friction are what it looks for); the selection (:func:`~psmforce.identification.
  prior_selection.fit_identified`) then goes on with the sag the values it found give
  (:meth:`WristCompliance.from_law`), the cable stiffness staying the design's. The cables
  stretch under the section's differential: with friction in the compliance (the capstan and
  the pins, 0 by design) the pulleys' demand crosses the idlers first, with the friction state
  the encoders' motion leaves (an approach turns it one way).

The grip of jaws clenched on an object or on each other is internal to the jaws: no tip force
shows it, yet it loads the blade pairs. Recordings with a clench carry it in the jaw effort only,
which also carries the discs' friction; :func:`clenched` marks those samples (the jaw more than
:data:`CLENCH_TOLERANCE_RAD` below :data:`~psmforce.robot.conventions.JAW_CLOSED_RAD`) and a
load-path fit leaves them out.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from psmforce.identification.errors import IdentificationInputError
from psmforce.identification.prior_law import (KAPPA, friction_direction, pair_differentials,
                                               pair_section, with_pins)
from psmforce.io.recording import JOINT_POSITIONS, TARGETS
from psmforce.robot import PSM
from psmforce.robot.conventions import JAW_CLOSED_RAD, JAW_JOINT, JOINTS
from psmforce.robot.frames import hex10_to_base

CONTACT_FRAME = "jaw_tip"
"""Where the tip force is taken to act (:class:`psmforce.robot.PSM` frame)."""
CLENCH_TOLERANCE_RAD = 1e-5
"""How far below closed (rad) a recorded jaw may read and still be taken as closed, not clenched.
A jaw held at closed reads closed give or take its encoder's resolution, or its floating-point
round-off on a bench (a jaw rebuilt from the blades' coordinates reads +-1e-17 rad); a strict
comparison with closed called half of such holds clenched, at random, and dropped them. 1e-5 rad
is below one count of an EndoWrist motor's encoder (the MRD Lab bench's 4196 x 35 counts per
revolution: 4.3e-5 rad of motor shaft), and a grip that shallow is under 0.01 N of blade-pair
differential at the bench's cable stiffness (``k r_b`` x depth, :func:`psmforce.sim.cables.
jaw_grip_torque`)."""
_WRIST_COLUMNS = (4, 5)
"""Columns of wrist_pitch and wrist_yaw in the arm's 6-joint Jacobian (yaw .. wrist_yaw)."""


def _arm_q(q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] < 6 or not np.isfinite(q[:, :6]).all():
        raise IdentificationInputError(f"joint positions must be finite (N, 6|7), got {q.shape}")
    return q[:, :6]


def _force(f_hex, n: int) -> np.ndarray:
    f = np.asarray(f_hex, dtype=float)
    if f.shape != (n, 3) or not np.isfinite(f).all():
        raise IdentificationInputError(f"tip force must be finite ({n}, 3) N, got {f.shape}")
    return f


def wrist_efforts_for_tip_force(q, f_hex, psm: PSM | None = None) -> np.ndarray:
    """(N, 3) efforts (wrist_pitch, wrist_yaw, jaw), Nm, that hold tip force ``f_hex`` (N, 3,
    HEX10 frame, N) at joint positions ``q`` (N, 6|7): module docstring."""
    psm = psm or PSM()
    q6 = _arm_q(q)
    f = _force(f_hex, len(q6))
    f_base = hex10_to_base(f, q6, psm)
    jac = psm.jacobian(q6, CONTACT_FRAME, "base_at_frame")[:, :3, list(_WRIST_COLUMNS)]
    out = np.zeros((len(q6), 3))
    out[:, :2] = -np.einsum("nji,nj->ni", jac, f_base)
    return out


@dataclass(frozen=True)
class WristCompliance:
    """What sags the wrist under a load: each cable run's axial stiffness (N/m), the pulley
    radii (m) that turn joint angles into cable travel, the pretension (N, the pairs' total over
    the six cables), the pairs' asymmetries (1; the blade pairs' one) and the wrist's friction:
    the idlers' capstan (1, the law's ``capstan_mu``), its growth per rad of |wrist pitch| on the
    blade pairs and of |roll| (1/rad), the pins' coefficient (1). A pair's differential ``D`` at
    the section (its pulleys' demand through the law's friction, :func:`~psmforce.
    identification.prior_law.pair_section`, the pins first) stretches its cables by ``e = D /
    (2 k)`` while both are taut and ``e = sign(D) (|D| - T0) / k`` once the unloaded one is slack
    (``T0`` per cable), slack where the taut loop's sum falls below ``|D|``: the elastic law of
    the pair as the bench takes it (docs/simulator.md section 6). The joints sag by ``G^-1 e``
    with ``G`` the coupling of :mod:`psmforce.identification.prior_law` and these radii. The
    friction is 0 by design (the law's design values): the sag is then the pulleys' differential
    alone."""

    stiffness_n_per_m: float
    pretension_total_n: float
    pulley_radius_pitch_m: float
    pulley_radius_blade_m: float
    asymmetry_pitch: float = 0.0
    asymmetry_blade: float = 0.0
    capstan_mu: float = 0.0
    capstan_pitch_gain: float = 0.0
    capstan_roll_gain: float = 0.0
    pin_friction: float = 0.0

    def __post_init__(self):
        values = (self.stiffness_n_per_m, self.pretension_total_n, self.pulley_radius_pitch_m,
                  self.pulley_radius_blade_m)
        if not all(np.isfinite(v) and v > 0 for v in values):
            raise IdentificationInputError(f"a wrist compliance needs a stiffness, pretension and "
                                           f"radii finite and > 0, got {values}")
        if not all(np.isfinite(a) and abs(a) < 1 for a in (self.asymmetry_pitch,
                                                           self.asymmetry_blade)):
            raise IdentificationInputError(f"a pair's asymmetry must lie in (-1, 1), got "
                                           f"{self.asymmetry_pitch}, {self.asymmetry_blade}")
        friction = (self.capstan_mu, self.capstan_pitch_gain, self.capstan_roll_gain,
                    self.pin_friction)
        if not all(np.isfinite(f) and f >= 0 for f in friction):
            raise IdentificationInputError(f"a wrist compliance's friction terms must be finite "
                                           f"and >= 0, got {friction}")

    @property
    def has_friction(self) -> bool:
        return self.capstan_mu > 0 or self.pin_friction > 0

    @classmethod
    def design(cls) -> "WristCompliance":
        """The instrument's design values (:data:`DESIGN_COMPLIANCE`)."""
        return DESIGN_COMPLIANCE

    @classmethod
    def from_law(cls, values, stiffness_n_per_m: float | None = None) -> "WristCompliance":
        """The compliance a law's values give (``values``: name of :data:`~psmforce.
        identification.prior_law.NAMES` -> SI value, every one of :data:`LAW_TERMS` present):
        the law's pretension, radii, asymmetries and friction, the stiffness the design's
        (:data:`DESIGN_CABLE_STIFFNESS_N_PER_M`) unless given. The law's twist gain and path
        pretension have no place in the sag (it takes the pairs' pretension at the straight,
        unrolled wrist)."""
        missing = [n for n in LAW_TERMS.values() if n not in values]
        if missing:
            raise IdentificationInputError(f"a wrist compliance from a law needs {missing}")
        return cls(DESIGN_CABLE_STIFFNESS_N_PER_M if stiffness_n_per_m is None
                   else stiffness_n_per_m,
                   **{field: float(values[name]) for field, name in LAW_TERMS.items()})

    @classmethod
    def from_dict(cls, d, source: str = "wrist compliance") -> "WristCompliance":
        """The compliance a file wrote (``dataclasses.asdict``), checked as user input: exactly
        the fields, each a finite number, and the values :class:`WristCompliance` accepts;
        ``source`` names it in the refusal."""
        names = [f.name for f in fields(cls)]
        if not isinstance(d, dict) or sorted(d) != sorted(names) or any(
                isinstance(x, bool) or not isinstance(x, (int, float)) for x in d.values()):
            raise IdentificationInputError(f"{source}: a wrist compliance must have exactly the "
                                           f"numbers {', '.join(names)}, got {d!r}")
        return cls(**{n: float(d[n]) for n in names})


DESIGN_CABLE_STIFFNESS_N_PER_M = 2.8e5
"""One cable run's axial stiffness (N/m) the load path's sag assumes: the value calibrated on a
real EndoWrist's transmission (the MRD Lab's Tool_4_Maryland_L_4, docs/simulator.md section 10).
Fixed, not identified: the fit's data see the sag only through the moment arms it bends, too
little to pin the stiffness; a tool whose cables are 20 % stiffer or softer sags 20 % less or
more than it assumes."""
DESIGN_COMPLIANCE = WristCompliance(DESIGN_CABLE_STIFFNESS_N_PER_M, pretension_total_n=6.0,
                                    pulley_radius_pitch_m=2.0e-3, pulley_radius_blade_m=1.5e-3,
                                    asymmetry_pitch=0.30, asymmetry_blade=0.275,
                                    capstan_mu=0.0, capstan_pitch_gain=0.5,
                                    capstan_roll_gain=0.15, pin_friction=0.0)
"""The sag's design values: the stiffness above and the law's datasheet pretension, radii,
asymmetries and friction (none: the capstan and the pins at 0), those of :data:`~psmforce.identification.prior_selection.DESIGN`, written out here
because the selection's layer sits above this one (``tests/identification/test_load_path.py``
holds them equal)."""
LAW_TERMS = {"pretension_total_n": "pretension_total",
             "pulley_radius_pitch_m": "pulley_radius_pitch",
             "pulley_radius_blade_m": "pulley_radius_blade",
             "asymmetry_pitch": "asymmetry_pitch", "asymmetry_blade": "asymmetry_blade",
             "capstan_mu": "capstan_mu", "capstan_pitch_gain": "capstan_pitch_gain",
             "capstan_roll_gain": "capstan_roll_gain", "pin_friction": "pin_friction"}
""":class:`WristCompliance` field -> the law's parameter (:mod:`~psmforce.identification.
prior_law`) it takes (:meth:`WristCompliance.from_law`)."""


def wrist_sag(efforts, compliance: WristCompliance, q=None) -> np.ndarray:
    """(N, 3) sag (wrist_pitch, wrist_yaw, jaw; rad) of a wrist whose cables hold ``efforts``
    (N, 3; dVRK efforts of those joints, Nm): encoder minus true position (module docstring).
    ``q`` (N, 7): the encoders' joint positions in time order, which set the friction's state
    (:func:`~psmforce.identification.prior_law.friction_direction`) and the capstan's growth;
    needed only when ``compliance`` has friction. Signs: an effort the motors apply to hold a
    load stretches the cables that pull against it, and the wrist gives way along the load,
    against the effort."""
    e = np.asarray(efforts, dtype=float)
    c = compliance
    d = pair_differentials(e[:, 0], e[:, 1], e[:, 2], c.pulley_radius_pitch_m,
                           c.pulley_radius_blade_m)
    t0 = c.pretension_total_n / 6.0
    a = (c.asymmetry_pitch, c.asymmetry_blade, c.asymmetry_blade)
    mu_z = (0.0, 0.0, 0.0)
    if c.has_friction:
        if q is None or np.shape(q) != (len(e), 7):
            raise IdentificationInputError("a wrist sag with friction needs the encoders' joint "
                                           f"positions (N, 7) beside the efforts, got "
                                           f"{None if q is None else np.shape(q)}")
        q = np.asarray(q, dtype=float)
        z = friction_direction(q[:, 4:7]).T
        roll = 1.0 + c.capstan_roll_gain * np.abs(q[:, 3])
        blade = roll * (1.0 + c.capstan_pitch_gain * np.abs(q[:, 4]))
        mu_z = (c.capstan_mu * roll * z[0], c.capstan_mu * blade * z[1],
                c.capstan_mu * blade * z[2])
        if c.pin_friction > 0:  # the pins' torque from each pair's section sum, one pass
            d = with_pins(d, [c.pin_friction * pair_section(d[i], 2.0 * t0, a[i], mu_z[i], np)[1]
                              * z[i] for i in range(3)],
                          c.pulley_radius_pitch_m, c.pulley_radius_blade_m)
    section = [pair_section(d[i], 2.0 * t0, a[i], mu_z[i], np) for i in range(3)]
    d_section = np.stack([x[0] for x in section], axis=1)
    taut = np.stack([x[2] >= np.abs(d[i]) for i, x in enumerate(section)], axis=1)
    stretch_m = np.where(taut, 0.5 * d_section,
                         np.sign(d_section) * (np.abs(d_section) - t0)) / c.stiffness_n_per_m
    # distal deflections: G^-1 e with G = diag(r) [[1, 0, 0], [k, 1, 0], [k, 0, 1]]
    pitch = stretch_m[:, 0] / c.pulley_radius_pitch_m
    blade_1 = stretch_m[:, 1] / c.pulley_radius_blade_m - KAPPA * pitch
    blade_2 = stretch_m[:, 2] / c.pulley_radius_blade_m - KAPPA * pitch
    return np.stack([pitch, 0.5 * (blade_1 + blade_2), blade_2 - blade_1], axis=1)


def sagged_positions(q, f_hex, compliance: WristCompliance | None = None,
                     psm: PSM | None = None) -> np.ndarray:
    """(N, 7|6) joint positions ``q`` with the wrist (wrist_pitch, wrist_yaw) where the tip force
    ``f_hex`` (N, 3, HEX10 frame) sags it: ``q - sag`` of :func:`wrist_sag` for the efforts at
    ``q`` (one fixed-point pass); ``compliance`` None: :meth:`WristCompliance.design`. The jaw
    keeps its reading: a force at the closed tip loads both blades alike and opens nothing."""
    psm = psm or PSM()
    q = np.array(q, dtype=float)
    sag = wrist_sag(wrist_efforts_for_tip_force(q, f_hex, psm),
                    compliance or WristCompliance.design(), q if q.shape[1] == 7 else None)
    q[:, 4:6] -= sag[:, :2]
    return q


def tip_force_moment(q, f_hex, psm: PSM | None = None) -> np.ndarray:
    """(N, 3) moment (Nm, HEX10 frame) of tip force ``f_hex`` about the HEX10 origin."""
    psm = psm or PSM()
    q6 = _arm_q(q)
    f = _force(f_hex, len(q6))
    tip = psm.forward_kinematics(q6, CONTACT_FRAME)[:, :3, 3]
    hex10 = psm.forward_kinematics(q6, "hex10")
    lever = np.einsum("nji,nj->ni", hex10[:, :3, :3], tip - hex10[:, :3, 3])
    return np.cross(lever, f)


def clenched(frame) -> np.ndarray:
    """(N,) bool: samples of a recording whose jaw is below closed by more than
    :data:`CLENCH_TOLERANCE_RAD` (the blades pressed on each other, an unknown grip the load path
    does not see)."""
    jaw = frame[JOINT_POSITIONS[_JAW]].to_numpy(dtype=float)
    return jaw < JAW_CLOSED_RAD - CLENCH_TOLERANCE_RAD


_JAW = JOINTS.index(JAW_JOINT)


def load_path_inputs(frame, psm: PSM | None = None,
                     compliance: WristCompliance | None = None) -> tuple[np.ndarray, np.ndarray]:
    """From a recording with its known tip force (``ati_fx..ati_fz``): the wrist efforts the
    load path demands (N, 3) and the tip force's moment at the HEX10 (N, 3), both at the wrist
    the force sags (:func:`sagged_positions`; ``compliance`` None: the design values)."""
    missing = [c for c in TARGETS if c not in frame.columns]
    if missing:
        raise IdentificationInputError(
            f"reading the cables from the load path needs the known tip force; the recording "
            f"has no {', '.join(missing)} (free space: write zeros; a hung weight: its force)")
    q = frame[list(JOINT_POSITIONS)].to_numpy(dtype=float)
    f = frame[list(TARGETS)].to_numpy(dtype=float)
    psm = psm or PSM()
    q_true = sagged_positions(q, f, compliance, psm)
    return wrist_efforts_for_tip_force(q_true, f, psm), tip_force_moment(q_true, f, psm)
