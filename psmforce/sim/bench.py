"""One simulated recording from a commanded joint trajectory: kinematics -> contact -> cables ->
sensors. Everything is computed for the whole recording at once (arrays over time).

Frames: PSM base = RCM (modified-DH frame 0); gravity is given in that frame. HEX10 quantities in
the HEX10 frame. Signs: forces are the external force ON THE TOOL; HEX10 reads what everything
distal of its section applies across it (compression negative); joint efforts are what the
motors apply (so a static external load shows up as -J^T F).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pandas as pd

import psmforce.sim.cables as cables
import psmforce.sim.contacts as contacts
import psmforce.sim.drive as drive
import psmforce.sim.port as port_mod
import psmforce.sim.sensors as sensors
import psmforce.sim.shaft as shaft

from psmforce.robot.conventions import GRAVITY_UPRIGHT_MPS2
from psmforce.robot.frames import ati_force_in_hex10
from psmforce.robot.kinematics import default_psm
from psmforce.io.recording import (ATI_RAW, HEX10, JOINT_EFFORTS, JOINT_POSITIONS, JOINT_VELOCITIES,
                         OVERLOAD, TARGETS, TIME)
from psmforce.sim.params import Effects, InstrumentParams
from psmforce.sim.port import Port


@dataclass
class Contact:
    """What the jaw tip touches. ``kind``: "free", "traction", "surface" or "weight" (a mass
    hung from the jaw tip, at rest: its weight ``mass_kg`` x gravity pulls the tip)."""

    kind: str = "free"
    anchor: np.ndarray | None = None
    """traction: D-ring position (base frame, m)."""
    rest_length: float = 0.0
    """traction: string + unstretched spring length (m)."""
    point: np.ndarray | None = None
    """surface: a point of the contact plane (base frame, m)."""
    normal: np.ndarray | None = None
    """surface: outward normal of the plane (base frame)."""
    material: str = "rigid"
    mass_kg: float = 0.0
    """weight: the hung mass (kg)."""
    ati_origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    """Where the ATI sensing origin is (base frame, m): moments of the raw ATI wrench."""


def kinematics(q: np.ndarray) -> dict[str, np.ndarray]:
    """Positions (N, 3) and rotations (N, 3, 3) of the frames the bench needs, base frame."""
    psm = default_psm()
    q6 = q[:, :6]
    out = {}
    for frame in ("roll", "cp", "jaw_tip", "hex10"):
        t = psm.forward_kinematics(q6, frame=frame)
        out["p_" + frame], out["R_" + frame] = t[:, :3, 3], t[:, :3, :3]
    # Joint axes in the base frame: angular rows of the spatial Jacobian (convention-free).
    axes = np.asarray(psm.spatial_jacobian(q6))[:, 3:, :]
    out["axes"] = np.moveaxis(axes, 2, 1)  # (N, 6 joints, 3)
    return out


def _moment_about(axis, origin, point, force):
    """axis . ((point - origin) x force), row-wise."""
    return np.einsum("ij,ij->i", axis, np.cross(point - origin, force))


def _contact_force(contact: Contact, p_tip, v_tip, effects: Effects, gravity) -> np.ndarray:
    if contact.kind == "free":
        return np.zeros_like(p_tip)
    if contact.kind == "weight":
        return np.broadcast_to(contact.mass_kg * np.asarray(gravity, dtype=float), p_tip.shape).copy()
    if contact.kind == "traction":
        return contacts.traction(p_tip, contact.anchor, contact.rest_length)
    if contact.kind == "surface":
        return contacts.surface(p_tip, v_tip, contact.point, contact.normal,
                                contacts.MATERIALS[contact.material], friction=effects.contact_friction)
    raise ValueError(f"unknown contact kind {contact.kind!r}")


def run_trajectory(q_cmd: np.ndarray, dt: float, contact: Contact, params: InstrumentParams,
                   effects: Effects, rng: np.random.Generator,
                   gravity=GRAVITY_UPRIGHT_MPS2, r_base_ati: np.ndarray | None = None,
                   truth: bool = True, port: Port | None = None) -> pd.DataFrame:
    """Simulate one recording. ``q_cmd`` (N, 7): motor-side joint positions in dVRK order
    (what the position controller tracks and the encoders see); ``port``: the cannula the shaft
    passes through (None: the benchtop, no port). Returns a frame in the recording layout
    (psmforce.io.recording), plus ``sim_*`` truth columns if ``truth``."""
    q_cmd = np.asarray(q_cmd, dtype=float)
    if q_cmd.ndim != 2 or q_cmd.shape[1] != 7 or len(q_cmd) < 2:
        raise ValueError(f"q_cmd must have shape (N, 7) with N >= 2, got {q_cmd.shape}")
    if not np.isfinite(q_cmd).all():
        raise ValueError("q_cmd has non-finite values")
    if not dt > 0:
        raise ValueError(f"dt must be > 0, got {dt}")
    n = len(q_cmd)
    r_base_ati = np.eye(3) if r_base_ati is None else r_base_ati
    # The physical arm and shaft (simulator 2.3: the shaft trails the roll encoder through the
    # roll drive's dead band, shaft.py); the encoders, the cables' motor side and the targets
    # stay on q_cmd. Without roll backlash q_phys is q_cmd itself.
    q_phys = shaft.distal_joints(q_cmd, params)
    kin = kinematics(q_phys)
    axes = kin["axes"]
    a_yaw, a_pitch, a_roll, a_wp, a_wy = axes[:, 0], axes[:, 1], axes[:, 3], axes[:, 4], axes[:, 5]
    d_shaft = kin["R_roll"][:, :, 2]
    p_roll, p_cp, p_tip0, p_hex = kin["p_roll"], kin["p_cp"], kin["p_jaw_tip"], kin["p_hex10"]
    z_cp = kin["R_cp"][:, :, 2]

    g = np.asarray(gravity, dtype=float)
    m_jaw = params.jaw_mass_kg if effects.distal_gravity else 0.0
    m_body = params.distal_body_mass_kg if effects.distal_gravity else 0.0
    p_jaw_com = p_cp + params.jaw_com_m * z_cp
    p_body_com = p_roll - params.distal_body_com_m * d_shaft
    f_jaw, f_body = m_jaw * g[None, :], m_body * g[None, :]

    # Jaw on jaw: commanded past closed, each blade presses on the other with the grip torque
    # the stretched blade cables hold (cables.jaw_grip_torque); the other blade's push opposes
    # each one's closing: blade_1 = yaw - jaw/2 closes towards +, blade_2 towards -.
    t0_blade = cables.pair_pretension(q_cmd[:, 3], q_cmd[:, 4], params, effects)[:, 1]
    grip = cables.jaw_grip_torque(q_cmd[:, 6], t0_blade, params)
    tau_grip = np.stack([np.zeros(n), -grip, grip], axis=1)

    def distal_load(p_tip, f_ext):
        """Generalized torques (pitch, blade_1, blade_2) from the tip force, jaw gravity and the
        grip of a jaw closed on itself."""
        t_pitch = (_moment_about(a_wp, p_roll, p_tip, f_ext)
                   + _moment_about(a_wp, p_roll, p_jaw_com, f_jaw))
        t_yaw = _moment_about(a_wy, p_cp, p_tip, f_ext) + _moment_about(a_wy, p_cp, p_jaw_com, f_jaw)
        # A load on the closed jaw tip is shared by the two blades.
        return np.stack([t_pitch, 0.5 * t_yaw, 0.5 * t_yaw], axis=1) + tau_grip

    p_tip = p_tip0
    f_ext = _contact_force(contact, p_tip, np.gradient(p_tip, dt, axis=0), effects, g)
    trans = cables.transmission(q_cmd, distal_load(p_tip, f_ext), params, effects)
    if effects.elasticity:
        # One fixed-point pass: the loaded wrist deflects (true = encoder - deflection), which
        # moves the tip and changes the contact force.
        dp, dy = trans["deflection"][:, 0], trans["deflection"][:, 1]
        p_tip = (p_tip0 - np.cross(a_wp, p_tip0 - p_roll) * dp[:, None]
                 - np.cross(a_wy, p_tip0 - p_cp) * dy[:, None])
        f_ext = _contact_force(contact, p_tip, np.gradient(p_tip, dt, axis=0), effects, g)
        trans = cables.transmission(q_cmd, distal_load(p_tip, f_ext), params, effects)

    # --- HEX10: wrench across the section, HEX10 frame ---
    r_hex = kin["R_hex10"]
    f_base = f_ext + f_jaw + f_body
    m_base = (np.cross(p_tip - p_hex, f_ext) + np.cross(p_jaw_com - p_hex, f_jaw)
              + np.cross(p_body_com - p_hex, f_body))
    to_hex = lambda v: np.einsum("nji,nj->ni", r_hex, v)  # R^T v
    w_section = np.concatenate([to_hex(f_base), to_hex(m_base)], axis=1)
    w_cables = cables.section_wrench(trans["tensions"], params)
    w_section += w_cables
    hex10, overload = sensors.hex10_reading(w_section, dt, params, effects, rng)

    # --- dVRK joint states ---
    q_meas = sensors.quantise_joints(q_cmd, effects)
    qd_meas = sensors.filtered_velocity(q_meas, dt, params.velocity_filter_s)
    effort = np.zeros((n, 7))
    tau_ext = np.stack([_moment_about(a_yaw, 0.0, p_tip, f_ext),
                        _moment_about(a_pitch, 0.0, p_tip, f_ext),
                        np.einsum("ij,ij->i", d_shaft, f_ext),
                        _moment_about(a_roll, p_roll, p_tip, f_ext)], axis=1)
    seal = None
    if port is not None:
        # The port loads the shaft proximal of the HEX10 (section wrench above unchanged).
        f_port, at = port_mod.lateral_force(port, d_shaft, np.arange(n) * dt)
        if np.any(np.einsum("ij,ij->i", at - p_hex, d_shaft) >= 0.0):
            raise ValueError("the port lies distal of the HEX10 (insertion too small)")
        tau_ext[:, 0] += _moment_about(a_yaw, 0.0, at, f_port)
        tau_ext[:, 1] += _moment_about(a_pitch, 0.0, at, f_port)
        seal = port_mod.seal_levels(port, q_cmd[:, 2], np.gradient(q_cmd[:, 2], dt),
                                    np.linalg.norm(f_port, axis=1))
    effort[:, :4] = -tau_ext
    qd = np.gradient(q_cmd[:, :4], dt, axis=0)
    if effects.arm_dynamics:
        qdd = np.gradient(qd[:, :3], dt, axis=0)
        # Two lumped masses on the shaft line, the pitch links' (fixed distance) and the
        # insertion stage's (moves with q3): the motors supply m (p'' - g) to each, through the
        # columns of its Jacobian (a x p for yaw / pitch about axes through the RCM, d for the
        # insertion, which only the stage's mass loads), so gravity, centripetal and Coriolis
        # loads are exact for them.
        for mass, dist, on_insertion in (
                (params.arm_gravity_mass_kg, np.full(n, params.arm_gravity_com_m), False),
                (params.insertion_stage_mass_kg, q_cmd[:, 2] - params.arm_gravity_com_offset_m, True)):
            com = dist[:, None] * d_shaft
            acc = np.gradient(np.gradient(com, dt, axis=0), dt, axis=0)
            f_arm = mass * (acc - g[None, :])
            effort[:, 0] += _moment_about(a_yaw, 0.0, com, f_arm)
            effort[:, 1] += _moment_about(a_pitch, 0.0, com, f_arm)
            if on_insertion:
                effort[:, 2] += np.einsum("ij,ij->i", d_shaft, f_arm)
        effort[:, :3] += np.asarray(params.arm_inertia) * qdd
        effort[:, 3] += params.roll_torsion_nm_per_rad * q_cmd[:, 3]
        if not effects.drive_friction:
            effort[:, :3] += (np.asarray(params.arm_coulomb) * np.tanh(qd[:, :3] / 0.005)
                              + np.asarray(params.arm_viscous) * qd[:, :3])
            z_roll = cables.dahl_direction(q_cmd[:, 3:4], params.roll_presliding_rad, effects.hysteresis)[:, 0]
            effort[:, 3] += params.roll_friction_nm * z_roll
    # Friction with stiction (drive.py) per joint: the drive's own element (``drive_friction``,
    # with the arm's dynamics; its direction a smooth sign of the velocity: the belt / cable
    # drives' compliance spreads each reversal) and the port's seal along and about the shaft.
    elements: list[list] = [[] for _ in range(4)]
    if effects.arm_dynamics and effects.drive_friction:
        for j, law in enumerate(drive.drive_laws(q_cmd, tau_ext, params)):
            elements[j].append((law, np.tanh(qd[:, j] / params.arm_friction_smoothing[j])))
    if seal is not None:
        kinetic, static = seal
        # Along the shaft on insertion (N); about it on roll the same friction at the shaft's
        # radius r (Nm; the seal slides at r w). A rubber seal reverses sharply (stick-slip).
        for j, r in ((2, 1.0), (3, port.shaft_radius_m)):
            law = drive.FrictionLaw(r * kinetic, r * static, port.seal_stribeck_velocity_mps / r,
                                    r ** 2 * port.seal_viscous_n_s_per_m)
            elements[j].append((law, np.tanh(r * qd[:, j] / port.seal_smoothing_mps)))
    for j, joint_elements in enumerate(elements):
        if joint_elements:
            effort[:, j] = drive.stick_slip_effort(effort[:, j], qd[:, j], joint_elements,
                                                   params.drive_stick_velocity[j])
    effort[:, 4:] = trans["effort"]
    if effects.arm_dynamics and effects.drive_friction:
        effort[:, 4:] = drive.disc_friction_efforts(effort[:, 4:], q_cmd[:, 4:], dt, params, effects.hysteresis)
    if effects.sensor_noise:
        effort += np.asarray(params.effort_noise) * rng.standard_normal((n, 7))
    if effects.coloured_effort_noise:
        effort += drive.coloured_disturbance(n, dt, params, rng)
    if effects.remount_offsets:
        effort += drive.remount_offset(params, rng)[None, :]
    if effects.current_quantisation:
        effort = drive.quantise_currents(effort, params)

    # --- ATI and the paper's eq. 4 target (measured joints, calibrated fixture rotation) ---
    arm = (contact.anchor if contact.kind == "traction" else p_tip) - contact.ati_origin
    raw = sensors.ati_raw(f_ext, np.broadcast_to(arm, p_tip.shape), r_base_ati, params, effects, rng)
    target = ati_force_in_hex10(raw[:, :3], q_meas[:, :6], r_base_ati.T, default_psm(), sign=-1.0)

    cols = {TIME: np.arange(n) * dt}
    for j, names in enumerate(zip(JOINT_POSITIONS, JOINT_VELOCITIES, JOINT_EFFORTS)):
        cols.update(zip(names, (q_meas[:, j], qd_meas[:, j], effort[:, j])))
    cols.update(zip(HEX10, hex10.T))
    cols[OVERLOAD] = overload.astype(np.int8)
    cols.update(zip(TARGETS, target.T))
    cols.update(zip(ATI_RAW, raw.T))
    if truth:
        cols["sim_section_fz"] = w_section[:, 2]
        cols["sim_internal_fz"] = w_section[:, 2] - to_hex(f_ext)[:, 2]
        true_wrist = q_cmd[:, 4:7] - trans["deflection"]
        cols["sim_wrist_pitch_true"] = true_wrist[:, 0]
        cols["sim_wrist_yaw_true"] = true_wrist[:, 1]
        cols["sim_slack_pairs"] = trans["slack"].sum(axis=1).astype(np.int8)
        if q_phys is not q_cmd:
            cols["sim_roll_true"] = q_phys[:, 3]
    return pd.DataFrame(cols)
