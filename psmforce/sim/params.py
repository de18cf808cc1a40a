"""Parameters of one simulated modified instrument and the switch set of simulated effects.

Units: SI throughout (m, rad, N, Nm, kg, s). Values, their sources and the equations that use
them are listed in docs/simulator.md. "Nominal" is the tool the team's benchmarks use;
:meth:`InstrumentParams.sample` draws "another modified tool" around it (the paper notes that hand
modification makes every tool different).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field, fields

import numpy as np


def _default_crosstalk() -> tuple[tuple[float, ...], ...]:
    # Fixed small off-diagonal couplings (force channels into each other and into moments);
    # about 1-2 % as typical for an uncompensated miniature 6-axis cell.
    c = np.eye(6)
    c[0, 1], c[1, 0] = 0.012, -0.008
    c[2, 0], c[2, 1] = 0.015, -0.010
    c[0, 2], c[1, 2] = 0.006, 0.009
    c[3, 1], c[4, 0] = 0.0004, -0.0003   # N -> Nm leakage (m)
    c[5, 2] = 0.0002
    return tuple(tuple(float(v) for v in row) for row in c)


OMITTED_WHEN_OFF = ("cable_coulomb_n", "cable_coulomb_stretch_share", "hex10_mount_rotation_rad",
                    "roll_backlash_rad", "hex10_thermal_drift_n", "hex10_thermal_time_s",
                    "hex10_readout_lag_s")
"""Fields added with simulator 2.2 and 2.3 (:mod:`psmforce.sim.versions`) and with the
re-mounting model (:mod:`psmforce.sim.mounting`) that :meth:`InstrumentParams.to_dict` leaves out
while they are 0 (off; a tuple when every entry is 0): simulator 2.1's ``metadata.json`` stays
what it was."""


@dataclass(frozen=True)
class InstrumentParams:
    """Physical parameters of the modified Cadiere forceps, its HEX10 and the bench sensors.

    Cable pairs are indexed (pitch, blade_1, blade_2): blade_1 = wrist_yaw - jaw/2,
    blade_2 = wrist_yaw + jaw/2 (dVRK coupling discs 2, 3, 4).
    """

    # --- cable transmission ---
    pretension_total_n: float = 6.0
    """Sum of the six cable tensions crossing the HEX10 section at rest, straight wrist, no roll
    (paper: retensioned to ~8 N, 6 N observed on the HEX10)."""
    pulley_radius_pitch_m: float = 2.0e-3
    pulley_radius_blade_m: float = 1.5e-3
    cable_stiffness_n_per_m: float = 2.8e5
    """Axial stiffness of one cable run (cable + rod) between spool and wrist. Calibrated on a
    real EndoWrist (MRD Lab bench, Tool_4_Maryland_L_4): was 6.0e5 (assumed), which gave 0.47x
    the real transmission's static compliance and 0.49x its loop width; 2.8e5 = 6.0e5 x 0.469
    matches the compliance (psmforce/experiments/cable_law_figures.py; docs/simulator.md, "Cable
    law against a real EndoWrist")."""
    cable_asymmetry: tuple[float, float, float] = (0.30, 0.25, 0.30)
    """(k+ - k-) / (k+ + k-) of each pair: how much the pair's tension sum follows its differential."""
    capstan_mu_wrap_distal: float = 0.30
    """Friction coefficient times wrap angle of each cable over the wrist idlers at pitch 0."""
    capstan_wrap_pitch_gain: float = 0.5
    """Relative growth of the blade cables' wrap per rad of |wrist pitch|."""
    capstan_mu_wrap_proximal: float = 0.15
    """Friction coefficient times wrap angle along the proximal path (spools, shaft guides)."""
    presliding_length_m: float = 4.0e-5
    """Dahl characteristic cable displacement (pre-sliding regime length)."""
    pin_friction_coefficient: float = 0.06
    """Pulley-pin friction torque per (pulley radius x tension sum), wrist joints."""
    twist_tension_gain_per_rad2: float = 0.03
    """Relative pretension increase per rad^2 of roll (cables twisted around each other)."""
    twist_friction_gain_per_rad: float = 0.15
    """Relative capstan friction increase per rad of |roll|."""
    pitch_path_mismatch_m: float = 3.2e-6
    """Blade-cable path length left uncompensated by the coupling: dL = e * (1 - cos pitch).
    Was 1.5e-6; raised with the cable stiffness's calibration (6.0e5 -> 2.8e5) so that the
    assumed extra tension it stands for, k_cable x e x (1 - cos pitch) = +0.4 N per blade cable
    at 1 rad pitch, stays what it was (not itself calibrated on the real EndoWrist)."""
    roll_torsion_nm_per_rad: float = 0.004
    roll_friction_nm: float = 0.0023
    """Roll Coulomb level (Nm): our identification's value on the real WPI arm."""
    roll_presliding_rad: float = 0.02
    # --- distal masses (distal of the HEX10 section) ---
    distal_body_mass_kg: float = 0.004
    """Distal interface half + clevis, lumped on the shaft axis proximal of the pitch axis."""
    distal_body_com_m: float = 0.004
    """How far proximal of the wrist-pitch axis the distal body mass sits."""
    jaw_mass_kg: float = 0.0015
    """Both blades, lumped on the control point's z axis."""
    jaw_com_m: float = 0.007
    """How far beyond the control point the jaw mass sits."""
    # --- HEX10 ---
    hex10_crosstalk: tuple[tuple[float, ...], ...] = field(default_factory=_default_crosstalk)
    hex10_force_noise_n: float = 0.02
    hex10_moment_noise_nm: float = 2.0e-4
    hex10_bias_drift_n_per_sqrt_s: float = 0.004
    hex10_residual_bias_n: tuple[float, float, float] = (0.05, -0.08, 0.10)
    """Force offsets left after the assembly-time tare (tare removes electronics offset and the
    distal gravity at the upright tare pose, not the later cable pretension)."""
    hex10_nominal_range_n: float = 25.0
    hex10_overload_n: float = 100.0
    hex10_nominal_moment_nm: float = 0.25
    hex10_overload_moment_nm: float = 1.0
    hex10_range_gain_error: float = 0.03
    """Extra relative gain error on the part of a force beyond the nominal range."""
    cable_radius_in_section_m: float = 1.2e-3
    """Radius at which the six cables cross the sensor bore (pairs on opposite sides)."""
    # --- dVRK arm ---
    arm_gravity_mass_kg: float = 0.9
    """Uncompensated mass of the pitch links lumped on the shaft line (turns with yaw and pitch,
    does not translate with the insertion)."""
    arm_gravity_com_m: float = -0.09
    """Where it sits on the shaft line, from the RCM (negative: behind it)."""
    insertion_stage_mass_kg: float = 0.1
    """Mass the insertion stage lifts along the shaft (carriage + tool, less its balance): the
    real arm's insertion effort carries little weight (WPI: mean 0.03 N while the pitch sweeps
    +-0.8 rad; our identification finds a 25-35 g equivalent insertion + roll body)."""
    arm_gravity_com_offset_m: float = 0.25
    """The insertion stage's COM lies on the shaft line at (insertion - offset) from the RCM."""
    arm_inertia: tuple[float, float, float] = (0.06, 0.06, 0.6)
    """Effective inertia of yaw, pitch (kg m^2) and insertion (kg)."""
    arm_coulomb: tuple[float, float, float] = (0.056, 0.135, 0.64)
    """Kinetic Coulomb level of yaw, pitch (Nm) and insertion (N): the levels our identification
    finds on the real WPI arm (docs/simulator.md, section 8)."""
    arm_viscous: tuple[float, float, float] = (0.083, 0.149, 0.56)
    """Viscous coefficients (Nm s/rad, N s/m), from the same WPI identification."""
    effort_noise: tuple[float, ...] = (0.006, 0.006, 0.03, 0.0008, 0.0006, 0.0005, 0.0005)
    """Std of the white part of the effort noise per joint (Nm or N); on when ``sensor_noise``."""
    velocity_filter_s: float = 0.01
    # --- dVRK joint-effort channels: drive friction, disturbance, current measurement ---
    # (psmforce/sim/drive.py; joints yaw, pitch, insertion, roll unless said otherwise)
    drive_static_ratio: float = 1.4
    """Static (breakaway) over kinetic Coulomb level (Stribeck peak) of yaw, pitch, insertion and
    roll: **assumed**, typical 1.2-1.5."""
    drive_stribeck_velocity: tuple[float, float, float, float] = (0.02, 0.02, 0.002, 0.05)
    """Velocity over which the static excess decays (rad/s; m/s for insertion), **assumed**."""
    arm_friction_smoothing: tuple[float, float, float, float] = (0.1, 0.1, 0.05, 0.1)
    """Velocity (rad/s, m/s) over which the friction of yaw, pitch, insertion and roll changes sign,
    ``tanh(v / v_eps)``: the compliance of their cable / belt drives spreads each reversal. The
    smooth-sign widths our identification selects on the real WPI arm; sharper transitions
    leave a residual the real arm does not show (docs/simulator.md, section 8)."""
    drive_stick_velocity: tuple[float, float, float, float] = (2e-3, 2e-3, 2e-4, 5e-3)
    """Below this speed a joint sticks: its effort then follows the load only beyond the static
    level (the deadband); **assumed**, about a tenth of the Stribeck velocity."""
    disc_coulomb: tuple[float, float, float] = (0.0081, 0.0063, 0.0067)
    """Coulomb level (Nm) of the wrist-pitch, blade 1 and blade 2 instrument discs (motor side:
    sterile adapter, disc bearings): our identification's values on the real WPI arm, whose
    wrist coordinates are these discs (docs/simulator.md, section 8)."""
    disc_viscous: tuple[float, float, float] = (0.0059, 0.0052, 0.0075)
    """Their viscous coefficients (Nm s/rad), same source."""
    disc_presliding_rad: float = 0.02
    """Dahl pre-sliding length of the discs (their cables' hysteresis), **assumed** like the roll's."""
    disc_stribeck_velocity: float = 0.05
    disc_stick_velocity: float = 5e-3
    """Stribeck and sticking speeds of the discs (rad/s), **assumed** like the roll's."""
    drive_position_friction: float = 0.15
    """Relative ripple of the friction levels with position (bearing preload, cable routing)."""
    drive_position_wavelength: tuple[float, float, float, float] = (0.7, 0.7, 0.05, 2.0)
    """Period of that ripple in joint position (rad; m for insertion), **assumed**."""
    drive_load_friction_gain: float = 0.05
    """Extra friction level per unit of the joint's external load (bearings / guides pressed by
    the load): the deadband grows with the load, **assumed** (a friction coefficient)."""
    effort_band_noise: tuple[float, ...] = (0.057, 0.086, 0.170, 0.00044, 0.0054, 0.0039, 0.0031)
    """Std of the coloured effort disturbance per joint (Nm or N): what our identification leaves
    unexplained on the real arm beyond what the simulated effects leave; white noise through a
    second-order resonator (``effort_band_hz``, ``effort_band_damping``). Derived from the WPI
    residual by ``studies/sim_calibration.py --derive`` (docs/simulator.md, section 8)."""
    effort_band_hz: tuple[float, ...] = (1.67, 1.89, 2.14, 2.14, 1.89, 1.89, 1.67)
    """Natural frequency of each joint's resonator (Hz), derived with it."""
    effort_band_damping: tuple[float, ...] = (0.20, 0.77, 0.29, 0.20, 0.77, 2.47, 0.77)
    """Damping ratio of each joint's resonator (over 1: a low-pass band), derived with it."""
    insertion_resonance_hz: float = 12.0
    """The insertion stage's lightly damped mode (belt / cable drive of the carriage): a narrow
    peak of the WPI insertion residual, at the same frequency whatever the insertion speed."""
    insertion_resonance_damping: float = 0.14
    insertion_resonance_n: float = 0.227
    """Stationary std of the insertion-stage mode (N); frequency, damping and std derived from
    the WPI residual's 5-25 Hz band by the same script."""
    current_quantum_a: float = 1.907e-4
    """Motor-current step of the dVRK controller: the WPI efforts move in steps of 0.472 mNm
    (yaw, pitch), 2.812 mN (insertion), 62.6 uNm (roll) = 0.1907 mA x torque constant x gear."""
    torque_constant_nm_per_a: float = 0.0438
    gear_ratios: tuple[float, ...] = (56.5, 56.5, 336.6, 11.71, 11.71, 11.71, 11.71)
    """Motor rad per joint rad (per m for insertion); instrument discs 11.71 (psm_facts)."""
    remount_effort_offset: tuple[float, float, float, float] = (0.0005, 0.004, 0.0015, 0.001)
    """Std of the constant effort offset of roll, wrist pitch, wrist yaw, jaw (Nm) drawn per
    recording: each trial mounts the tool anew on the sterile adapter (disc engagement, cable
    preload); order of the WPI test residual's mean on those joints, **assumed**."""
    # --- ATI Nano17 ---
    ati_force_noise_n: float = 0.004
    ati_moment_noise_nm: float = 3.0e-5
    # --- added after the fields above (keep new fields at the end) ---
    cable_crossing_angle_rad: float = 0.0
    """Angle between each cable and the shaft axis where it crosses the HEX10 section, tilted
    tangentially (a helical lay, every cable the same hand): each cable then also pulls the
    distal body sideways by T sin(angle) along (-sin phi, cos phi, 0) at its angle phi. 0: the
    cables run along the shaft (the nominal bench; the prior does not model this force)."""
    pair_law: str = "linear"
    """The law of each antagonistic cable pair (:mod:`psmforce.sim.cable_laws`): ``"linear"``
    (linear cables, ``S = 2 T0 + alpha D`` taut; the nominal bench) or ``"quadratic"``
    (strain-stiffening cables, ``S = 2 T0 + D^2 / (8 T0)`` taut, slack smoothly at
    ``|D| = 4 T0``; outside the prior's family, for docs/identification.md section 2.1)."""
    cable_coulomb_n: float = 0.0
    """Load-independent (Coulomb) friction force of each cable pair's path proximal of the HEX10
    section (spool bearings, housing idlers, the shaft's cable guides and seal), N of pair
    differential, in the direction of the pair's motion (Dahl state ``z``): the motor pays it,
    the section does not see it (:func:`psmforce.sim.cables.transmission`). 0 (simulator 2.1 and
    before): off. Simulator 2.2 (:mod:`psmforce.sim.versions`) calibrates it on a real
    EndoWrist's friction at zero load (docs/simulator.md section 12b)."""
    cable_coulomb_stretch_share: float = 0.0
    """Share (0..1) of ``cable_coulomb_n`` that the stretching cable run carries (the friction
    acts part-way along it): adds ``share x cable_coulomb_n x z`` to the differential that
    stretches the cables, so it widens the loop of motion lost at each reversal by a
    load-independent amount."""
    hex10_mount_rotation_rad: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """Small misalignment left by mounting the instrument (:mod:`psmforce.sim.mounting`): angles
    (about x, y, z of the HEX10 frame; z = the shaft) of the frame the HEX10 measures in against
    the frame the bench computes the section wrench in, ``R = Rz(c) Ry(b) Rx(a)``; the sensor
    reads ``R^T`` of the section's force and moment (:func:`psmforce.sim.sensors.hex10_reading`).
    All 0 (the nominal bench): the reading is the section wrench's, bit for bit."""
    roll_backlash_rad: float = 0.0
    """Width (rad of roll) of the dead band of the roll drive between the roll encoder (motor
    side) and the shaft (:func:`psmforce.sim.shaft.distal_roll`): after a reversal the motor turns
    this far before the shaft, the HEX10 and everything distal follow, so the shaft lags the
    encoder by up to half of it, on the side of the last motion. The HEX10 then measures in a
    frame turned about the shaft against the one the encoders give (the frame the targets are
    expressed in). 0 (simulator 2.2 and before): off, the shaft turns with the encoder."""
    hex10_thermal_drift_n: float = 0.0
    """Std (N, each force axis) of the offset the HEX10 builds up after a recording starts, as a
    sensor zeroed warm (handled at the re-mount) settles to the bench's temperature:
    ``A (1 - exp(-t / hex10_thermal_time_s))``, ``A`` drawn per recording and axis
    (:func:`psmforce.sim.sensors.hex10_reading`). 0 (simulator 2.2 and before): off."""
    hex10_thermal_time_s: float = 0.0
    """Time constant (s) of that settling; used only while ``hex10_thermal_drift_n`` > 0."""
    hex10_readout_lag_s: float = 0.0
    """Time constant (s) of a first-order low-pass the HEX10's readout puts on all six channels
    (strain-gauge electronics' anti-alias filtering) before the recorder samples them, so the
    sensor trails the ATI in time (:func:`psmforce.sim.sensors.readout_lag`). 0 (simulator 2.2
    and before): off, the reading is instantaneous."""

    def __post_init__(self):
        from psmforce.sim.cable_laws import PAIR_LAWS
        if self.pair_law not in PAIR_LAWS:
            raise ValueError(f"pair_law must be one of {PAIR_LAWS}, got {self.pair_law!r}")

    def to_dict(self) -> dict:
        """Every field, except those of :data:`OMITTED_WHEN_OFF` at 0 (so that a bench without
        them writes the metadata it wrote before they existed; :meth:`from_dict` restores 0)."""
        return {f.name: _jsonable(getattr(self, f.name)) for f in fields(self)
                if not (f.name in OMITTED_WHEN_OFF and _is_off(getattr(self, f.name)))
                and not (f.name == "pair_law" and self.pair_law == "linear")}  # the default law

    @classmethod
    def from_dict(cls, d: dict) -> "InstrumentParams":
        """Inverse of :meth:`to_dict` (a dataset's ``metadata["instrument"]``); a field the
        dict lacks (written by an older simulator) keeps its nominal value."""
        return cls(**{f.name: _tupled(d[f.name]) for f in fields(cls) if f.name in d})

    def sample(self, seed: int, spread: float = 1.0) -> "InstrumentParams":
        """Another modified tool: each parameter drawn around this one (seeded, lognormal or
        normal spreads from docs/simulator.md, scaled by ``spread``)."""
        if spread < 0:
            raise ValueError(f"spread must be >= 0, got {spread}")
        rng = np.random.default_rng(seed)

        def ln(v, s):
            return float(v * np.exp(spread * s * rng.standard_normal()))

        xt = np.array(self.hex10_crosstalk)
        block = ~np.eye(3, dtype=bool)
        xt[:3, :3] += block * spread * 0.006 * rng.standard_normal((3, 3))      # N -> N
        xt[3:, :3] += spread * 0.0003 * rng.standard_normal((3, 3))            # N -> Nm (m)
        return dataclasses.replace(
            self,
            pretension_total_n=ln(self.pretension_total_n, 0.15),
            pulley_radius_pitch_m=ln(self.pulley_radius_pitch_m, 0.08),
            pulley_radius_blade_m=ln(self.pulley_radius_blade_m, 0.08),
            cable_stiffness_n_per_m=ln(self.cable_stiffness_n_per_m, 0.2),
            cable_asymmetry=tuple(float(np.clip(a + spread * 0.1 * rng.standard_normal(), -0.6, 0.6))
                                  for a in self.cable_asymmetry),
            capstan_mu_wrap_distal=ln(self.capstan_mu_wrap_distal, 0.25),
            capstan_mu_wrap_proximal=ln(self.capstan_mu_wrap_proximal, 0.25),
            pin_friction_coefficient=ln(self.pin_friction_coefficient, 0.25),
            twist_tension_gain_per_rad2=ln(self.twist_tension_gain_per_rad2, 0.3),
            pitch_path_mismatch_m=ln(self.pitch_path_mismatch_m, 0.3),
            hex10_crosstalk=tuple(tuple(float(v) for v in row) for row in xt),
            hex10_residual_bias_n=tuple(float(b + spread * 0.05 * rng.standard_normal())
                                        for b in self.hex10_residual_bias_n),
        )


@dataclass(frozen=True)
class Effects:
    """Which simulated effects are on. Every internal effect can be switched off alone.

    With :meth:`none` the HEX10 reads exactly the external wrench moved to its section (in its
    frame), the joints report ideal rigid-transmission torques and nothing is noisy.
    """

    pretension: bool = True
    """Cable pretension (a constant compression at rest)."""
    slack: bool = True
    """Cables cannot push: beyond the pretension the unloaded side goes slack."""
    cable_asymmetry: bool = True
    elasticity: bool = True
    """Cable stretch deflects the wrist: true angles differ from encoder angles."""
    capstan: bool = True
    """Direction-dependent capstan friction over the wrist idlers and the proximal path."""
    hysteresis: bool = True
    """Dahl pre-sliding memory of the friction direction (off: smooth sign of velocity)."""
    pin_friction: bool = True
    roll_twist: bool = True
    """Roll twists the cables: more pretension and more friction."""
    pitch_path_mismatch: bool = True
    distal_gravity: bool = True
    hex10_crosstalk: bool = True
    hex10_bias: bool = True
    """Constant force offset left after the assembly-time tare."""
    hex10_drift: bool = True
    """Slow random-walk drift of the force channels."""
    hex10_range_error: bool = True
    """Accuracy loss beyond the nominal range (clipping at overload is always applied)."""
    sensor_noise: bool = True
    """HEX10, ATI and effort noise."""
    encoder_quantisation: bool = True
    arm_dynamics: bool = True
    """Arm inertia, gravity and friction in the efforts."""
    contact_friction: bool = True
    """Tangential (stick-slip) friction at palpation and rigid contacts."""
    drive_friction: bool = True
    """Stribeck, stiction with a load- and history-dependent deadband at rest, position-dependent
    friction on yaw, pitch, insertion and roll (off: the smooth Coulomb + viscous law)."""
    coloured_effort_noise: bool = True
    """Low-frequency effort disturbance and the insertion-stage resonance (white part: ``sensor_noise``)."""
    current_quantisation: bool = True
    """Efforts in steps of the motor-current quantum."""
    remount_offsets: bool = True
    """A constant effort offset on the instrument joints per recording (tool re-mounted)."""

    @classmethod
    def none(cls) -> "Effects":
        """Every effect off (ideal instrument, ideal sensors)."""
        return cls(**{f.name: False for f in fields(cls)})

    @classmethod
    def reduced(cls, noise: bool = True) -> "Effects":
        """The reduced model class for identification: pretension + antagonistic-pair tensions
        from the demanded wrist torques with slack + distal gravity + constant HEX10 bias, plus
        the arm's own dynamics in the arm efforts; ``noise`` adds white sensor noise and encoder
        quantisation. No hysteresis, capstan, pin friction, elasticity, asymmetry, roll twist,
        path mismatch, drift, cross-talk or range error (docs/simulator.md, "Reduced class").
        """
        off = cls.none()
        return dataclasses.replace(off, pretension=True, slack=True, distal_gravity=True,
                                   hex10_bias=True, arm_dynamics=True, sensor_noise=noise,
                                   encoder_quantisation=noise)

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}


def _is_off(v) -> bool:
    """A switch-like field at its off value: 0, or a tuple of zeros."""
    return all(x == 0.0 for x in v) if isinstance(v, tuple) else v == 0.0


def _tupled(v):
    if isinstance(v, list):
        return tuple(_tupled(x) for x in v)
    return v


def _jsonable(v):
    if isinstance(v, tuple):
        return [_jsonable(x) for x in v]
    return v
