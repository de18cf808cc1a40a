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
    cable_stiffness_n_per_m: float = 6.0e5
    """Axial stiffness of one cable run (cable + rod) between spool and wrist."""
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
    pitch_path_mismatch_m: float = 1.5e-6
    """Blade-cable path length left uncompensated by the coupling: dL = e * (1 - cos pitch)."""
    roll_torsion_nm_per_rad: float = 0.004
    roll_friction_nm: float = 0.010
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
    """Uncompensated moving mass lumped on the shaft line (carriage + instrument + links)."""
    arm_gravity_com_offset_m: float = 0.25
    """COM lies on the shaft line at (insertion - offset) from the RCM."""
    arm_inertia: tuple[float, float, float] = (0.06, 0.06, 0.6)
    """Effective inertia of yaw, pitch (kg m^2) and insertion (kg)."""
    arm_coulomb: tuple[float, float, float] = (0.06, 0.05, 0.35)
    arm_viscous: tuple[float, float, float] = (0.04, 0.04, 2.0)
    effort_noise: tuple[float, ...] = (0.006, 0.006, 0.03, 0.0008, 0.0006, 0.0005, 0.0005)
    """Std of current-derived effort noise per joint (Nm or N)."""
    velocity_filter_s: float = 0.01
    # --- ATI Nano17 ---
    ati_force_noise_n: float = 0.004
    ati_moment_noise_nm: float = 3.0e-5

    def to_dict(self) -> dict:
        return {f.name: _jsonable(getattr(self, f.name)) for f in fields(self)}

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


def _jsonable(v):
    if isinstance(v, tuple):
        return [_jsonable(x) for x in v]
    return v
